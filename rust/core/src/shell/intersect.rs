//! Triangle intersection tests for shell reports: an AABB tree over triangles (the
//! shared [`crate::spatial::Bvh`]) and a tri–tri test built from orientation
//! determinants (two triangles intersect when an edge of one properly crosses the
//! other). Their signs are exact for the given f64 coordinates absent underflow
//! (always, for coordinates from f32 positions: their nonzero differences are at
//! least 1.4e-45; Shewchuk's adaptive predicates, the `robust` crate, assume the
//! same): nearly coplanar triangles, whose naive
//! determinants are rounding noise, are told apart exactly. Pairs that merely touch,
//! and coplanar pairs (overlapping or not: every determinant is zero), are not counted
//! by [`triangles_intersect`]; [`triangles_meet`] counts touching and overlapping pairs
//! too, from point-triangle and segment-segment distances. A [`Prepared`] triangle
//! keeps its plane for a search's many tests, and tells the search which tree boxes
//! lie wholly beyond that plane (none of their triangles can cross it).

use glam::DVec3;
use robust::{orient2d, orient3d, Coord, Coord3D};

use crate::spatial::Bvh;

/// Sides of points against the plane of a triangle `t`: the sign of
/// `(t1 - t0) × (t2 - t0) · (p - t0)`, exact for the given coordinates. The normal is
/// computed once for all points; a point's naive determinant is taken when it exceeds
/// Shewchuk's forward error bound for this very evaluation (the orient3d filter,
/// `(7 + 56ε) ε` times the permanent, here 8ε), and Shewchuk's adaptive `orient3d`
/// decides the rest (nearly coplanar points) exactly.
#[derive(Debug, Clone)]
struct Plane {
    t: [DVec3; 3],
    normal: DVec3,
    /// The permanent's factors: the absolute values of the normal's products, summed.
    permanent: DVec3,
}

/// The orient3d filter's relative error bound, `(7 + 56ε) ε` with `ε = 2^-53`,
/// rounded up.
const ORIENT_BOUND: f64 = 8.0 * (f64::EPSILON / 2.0);

impl Plane {
    #[inline]
    fn new(t: &[DVec3; 3]) -> Self {
        let (u, v) = (t[1] - t[0], t[2] - t[0]);
        let permanent = DVec3::new((u.y * v.z).abs() + (v.y * u.z).abs(), (u.z * v.x).abs() + (v.z * u.x).abs(), (u.x * v.y).abs() + (v.x * u.y).abs());
        Self { t: *t, normal: u.cross(v), permanent }
    }

    /// Positive when `p` lies on the side the normal points to (`t` counterclockwise
    /// seen from `p`), negative on the other, zero exactly when `p` is in the plane
    /// (or `t` is degenerate). The magnitude approximates the determinant's.
    #[inline]
    fn side(&self, p: DVec3) -> f64 {
        let w = p - self.t[0];
        let det = self.normal.dot(w);
        let bound = ORIENT_BOUND * self.permanent.dot(w.abs());
        if det > bound || -det > bound {
            det
        } else if bound == 0.0 {
            // Every product is zero, so is every exact term (a difference rounds to
            // zero only when exactly zero, and no product underflowed: see the module
            // docs).
            0.0
        } else if !bound.is_finite() {
            det // infinite or NaN coordinates: the naive value
        } else {
            let c = |v: DVec3| Coord3D { x: v.x, y: v.y, z: v.z };
            // Shewchuk's orient3d is positive for `p` below the plane (the opposite sign).
            -orient3d(c(self.t[0]), c(self.t[1]), c(self.t[2]), c(p))
        }
    }
}

/// The sign of `(b - a) × (c - a) · (d - a)`, exact ([`Plane::side`]).
#[inline]
fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    Plane::new(&[a, b, c]).side(d)
}

/// Whether triangle `t`'s corners are collinear (or coincide), exactly: each of its
/// three axis-aligned projections is.
fn degenerate(t: &[DVec3; 3]) -> bool {
    let collinear = |f: fn(DVec3) -> Coord<f64>| orient2d(f(t[0]), f(t[1]), f(t[2])) == 0.0;
    collinear(|p| Coord { x: p.x, y: p.y }) && collinear(|p| Coord { x: p.y, y: p.z }) && collinear(|p| Coord { x: p.z, y: p.x })
}

/// Whether segment `p q` properly crosses triangle `t` (its plane strictly, inside the
/// closed triangle).
pub fn segment_crosses_triangle(p: DVec3, q: DVec3, t: &[DVec3; 3]) -> bool {
    let plane = Plane::new(t);
    crosses_inside(p, q, plane.side(p), plane.side(q), t)
}

/// [`segment_crosses_triangle`] given the sides `dp`, `dq` of `p` and `q` of the
/// plane of `t`. Signs are compared, not their product (which could underflow).
#[inline]
fn crosses_inside(p: DVec3, q: DVec3, dp: f64, dq: f64, t: &[DVec3; 3]) -> bool {
    if !((dp > 0.0 && dq < 0.0) || (dp < 0.0 && dq > 0.0)) {
        return false;
    }
    let s1 = orient(p, q, t[0], t[1]);
    let s2 = orient(p, q, t[1], t[2]);
    let s3 = orient(p, q, t[2], t[0]);
    (s1 >= 0.0 && s2 >= 0.0 && s3 >= 0.0) || (s1 <= 0.0 && s2 <= 0.0 && s3 <= 0.0)
}

/// Whether all three sides are strictly positive or all strictly negative.
#[inline]
fn one_side(s: [f64; 3]) -> bool {
    (s[0] > 0.0 && s[1] > 0.0 && s[2] > 0.0) || (s[0] < 0.0 && s[1] < 0.0 && s[2] < 0.0)
}

/// Whether two triangles intersect (an edge of either properly crosses the other).
/// Each corner's side of the other's plane is computed once (an edge test used to
/// compute both its ends', every corner twice), with the signs
/// [`segment_crosses_triangle`] uses: the answer is its answer. As the signs are
/// exact, a triangle strictly on one side of the other's plane, or in the plane of a
/// proper triangle, has no crossing either way, and the pair ends after three
/// determinants: most pairs, and coplanar ones, which do not count.
pub fn triangles_intersect(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    super::timing::exact_test();
    let plane_b = Plane::new(b);
    let of_a = a.map(|p| plane_b.side(p));
    if one_side(of_a) || (of_a == [0.0; 3] && !degenerate(b)) {
        return false;
    }
    let plane_a = Plane::new(a);
    let of_b = b.map(|p| plane_a.side(p));
    if one_side(of_b) {
        return false;
    }
    crossing_edges(a, b, of_a, of_b)
}

/// [`triangles_intersect`]'s last step: whether an edge of either triangle properly
/// crosses the other, given each corner's side of the other's plane.
#[inline]
fn crossing_edges(a: &[DVec3; 3], b: &[DVec3; 3], of_a: [f64; 3], of_b: [f64; 3]) -> bool {
    (0..3).any(|i| crosses_inside(a[i], a[(i + 1) % 3], of_a[i], of_a[(i + 1) % 3], b))
        || (0..3).any(|i| crosses_inside(b[i], b[(i + 1) % 3], of_b[i], of_b[(i + 1) % 3], a))
}

/// A triangle with its plane (normal and the filter's permanent) computed once, for
/// tests against many others: a search's query triangle against its candidates, a
/// fixed base triangle against every skin triangle near it (issue 14: the searches'
/// exact tests are most of a build). [`Prepared::crosses`] answers exactly as
/// [`triangles_intersect`] with this triangle first: the signs are the same exact
/// signs, and only the order of the early exits differs (the other triangle's
/// corners against this plane first: most candidates lie on one side of it and end
/// there, without their own plane).
#[derive(Debug, Clone)]
pub struct Prepared {
    plane: Plane,
}

impl Prepared {
    #[inline]
    pub fn new(t: &[DVec3; 3]) -> Self {
        Self { plane: Plane::new(t) }
    }

    /// The triangle's corners.
    #[inline]
    pub fn corners(&self) -> &[DVec3; 3] {
        &self.plane.t
    }

    /// Whether the box `[lo, hi]` may hold a point on this triangle's plane or on
    /// both sides of it; false only where every point of the box lies strictly on one
    /// side, by exact signs: then no triangle inside the box crosses this one (its
    /// corners' sides are all of one sign, [`crosses`](Self::crosses)' first exit),
    /// and a search skips it, and any node of its tree whose box does the same,
    /// before computing it (issue 14: most of a skin triangle's box neighbours lie
    /// beyond its plane). The least and greatest of `n · (p - t0)` over the box are
    /// taken at corners chosen per axis by the normal's signs; the rounding of those
    /// sums and of the normal itself is below `8 u` times the permanent times the
    /// box's reach from `t0` (`u = 2^-53`), the same terms that bound
    /// [`Plane::side`]'s filter; 64 of them are the guard band. A degenerate
    /// triangle (all its exact sides zero) is never separated; NaN neither.
    #[inline]
    pub fn box_straddles(&self, lo: DVec3, hi: DVec3) -> bool {
        let Plane { t, normal: n, permanent } = &self.plane;
        let (a, b) = (lo - t[0], hi - t[0]);
        let positive = n.cmpge(DVec3::ZERO);
        let least = n.dot(DVec3::select(positive, a, b));
        let most = n.dot(DVec3::select(positive, b, a));
        let margin = 8.0 * ORIENT_BOUND * permanent.dot(a.abs().max(b.abs()));
        !(least > margin || most < -margin)
    }

    /// [`triangles_intersect`]`(self, b)`.
    #[inline]
    pub fn crosses(&self, b: &[DVec3; 3]) -> bool {
        self.crosses_with(b, None)
    }

    /// [`triangles_intersect`]`(self, b)` with `b` prepared too (neither plane is
    /// computed again).
    #[inline]
    pub fn crosses_prepared(&self, b: &Prepared) -> bool {
        self.crosses_with(&b.plane.t, Some(&b.plane))
    }

    /// Why the answers are [`triangles_intersect`]'s: that test returns true only at
    /// its last step, [`crossing_edges`], given the same exact sides; every exit here
    /// returns false where it does. `b` on one side of this plane: its exit. `b` in
    /// the plane of this proper triangle: every corner of `b` has side zero, so no
    /// edge of `b` crosses, and an edge of this triangle crosses only with corners
    /// strictly on either side of `b`'s plane, which is this plane (`b` proper) or
    /// gives every point side zero (`b` degenerate: `orient3d` of collinear points);
    /// so `crossing_edges` is false. (A degenerate triangle gives every point side
    /// zero, and may still pierce `b`: it goes on.)
    #[inline]
    fn crosses_with(&self, b: &[DVec3; 3], plane_b: Option<&Plane>) -> bool {
        super::timing::exact_test();
        let a = &self.plane.t;
        let of_b = b.map(|p| self.plane.side(p));
        if one_side(of_b) || (of_b == [0.0; 3] && !degenerate(a)) {
            return false;
        }
        let made;
        let plane_b = match plane_b {
            Some(p) => p,
            None => {
                made = Plane::new(b);
                &made
            }
        };
        let of_a = a.map(|p| plane_b.side(p));
        if one_side(of_a) || (of_a == [0.0; 3] && !degenerate(b)) {
            return false;
        }
        crossing_edges(a, b, of_a, of_b)
    }
}

/// Squared distance from `p` to the closed triangle `t` (closest point by Voronoi
/// regions, Ericson, *Real-Time Collision Detection*, 5.1.5).
pub fn point_triangle_distance2(p: DVec3, t: &[DVec3; 3]) -> f64 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (p - (a + ab * (d1 / (d1 - d3)))).length_squared();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (p - (a + ac * (d2 / (d2 - d6)))).length_squared();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).length_squared();
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        // A degenerate triangle: its edges.
        return [(a, b), (b, c), (c, a)].iter().map(|&(u, v)| segment_segment_distance2(p, p, u, v)).fold(f64::MAX, f64::min);
    }
    (p - (a + ab * (vb / denom) + ac * (vc / denom))).length_squared()
}

/// Squared distance between segments `p1 q1` and `p2 q2` (Ericson 5.1.9).
pub fn segment_segment_distance2(p1: DVec3, q1: DVec3, p2: DVec3, q2: DVec3) -> f64 {
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.length_squared(), d2.length_squared(), d2.dot(r));
    let tiny = f64::MIN_POSITIVE;
    let (s, t) = if a <= tiny && e <= tiny {
        (0.0, 0.0)
    } else if a <= tiny {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= tiny {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > 0.0 { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p1 + d1 * s) - (p2 + d2 * t)).length_squared()
}

/// Whether two triangles cross, touch or come within `eps` of each other: an edge of
/// either properly crosses the other, or the least distance between them (from the
/// vertex-triangle and edge-edge pairs, exact for triangles that do not cross) is at
/// most `eps`. Unlike [`triangles_intersect`] this sees touching and coplanar
/// overlapping pairs, which a closed mesh's non-adjacent triangles must not have either.
pub fn triangles_meet(a: &[DVec3; 3], b: &[DVec3; 3], eps: f64) -> bool {
    // Most pairs whose boxes overlap lie apart on either side of a plane: no crossing,
    // no contact, and none of the fifteen distances below needed.
    if beyond_plane(a, b, eps) || beyond_plane(b, a, eps) {
        return false;
    }
    if triangles_intersect(a, b) {
        return true;
    }
    let e2 = eps * eps;
    (0..3).any(|i| point_triangle_distance2(a[i], b) <= e2 || point_triangle_distance2(b[i], a) <= e2)
        || (0..3).any(|i| (0..3).any(|j| segment_segment_distance2(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]) <= e2))
}

/// Whether all of `b` lies more than `eps` from the plane of `a`, on one side. The
/// rounding error of `n · (p - a0)` (with `n` the unnormalized normal) is below a few
/// ulps of `|e1| |e2| |p - a0|`; sixteen of them are added to the margin, so rounding
/// never decides a contact, also for needles.
fn beyond_plane(a: &[DVec3; 3], b: &[DVec3; 3], eps: f64) -> bool {
    let (e1, e2) = (a[1] - a[0], a[2] - a[0]);
    let n = e1.cross(e2);
    let length = n.length();
    if !(length > 0.0 && length.is_finite()) {
        return false;
    }
    let scale = 16.0 * f64::EPSILON * e1.length() * e2.length();
    let side = |p: DVec3| {
        let d = n.dot(p - a[0]);
        let margin = eps.max(0.0) * length + scale * p.distance(a[0]);
        if d > margin {
            1
        } else if d < -margin {
            -1
        } else {
            0
        }
    };
    let s = b.map(side);
    s[0] != 0 && s[0] == s[1] && s[1] == s[2]
}

pub(crate) use crate::spatial::segment_meets_box;
pub use crate::spatial::tri_box;

/// The shell's tree over triangles: the shared [`Bvh`] over their boxes
/// ([`tri_box`]), every query and join of which it offers.
#[derive(Debug, Clone, Default)]
pub struct TriBvh(Bvh);

impl TriBvh {
    pub fn build(tris: &[[DVec3; 3]]) -> Self {
        Self(Bvh::from_triangles(tris))
    }

    /// A tree over boxes (one per item) rather than triangles.
    pub fn from_boxes(boxes: Vec<(DVec3, DVec3)>) -> Self {
        Self(Bvh::from_boxes(boxes))
    }
}

impl std::ops::Deref for TriBvh {
    type Target = Bvh;
    fn deref(&self) -> &Bvh {
        &self.0
    }
}

impl std::ops::DerefMut for TriBvh {
    fn deref_mut(&mut self) -> &mut Bvh {
        &mut self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_touching_and_separate() {
        let a = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let crossing = [DVec3::new(0.2, 0.2, -1.0), DVec3::new(0.2, 0.2, 1.0), DVec3::new(2.0, 2.0, 0.5)];
        assert!(triangles_intersect(&a, &crossing));
        let above = crossing.map(|p| p + DVec3::Z * 1.5);
        assert!(!triangles_intersect(&a, &above));
        let touching = [DVec3::new(0.2, 0.2, 0.0), DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.5, 0.0, 1.0)];
        assert!(!triangles_intersect(&a, &touching));
        let mut bvh = TriBvh::build(&[a, above, crossing]);
        let query = |bvh: &TriBvh| {
            let mut hits = Vec::new();
            bvh.query(DVec3::new(0.15, 0.15, -0.1), DVec3::new(0.25, 0.25, 0.1), |i| hits.push(i));
            hits.sort();
            hits
        };
        assert_eq!(query(&bvh), vec![0, 2]);
        // After moving the crossing triangle away and `above` down, a refit finds `above`.
        bvh.refit_boxes([a, above.map(|p| p - DVec3::Z * 1.5), crossing.map(|p| p + DVec3::X * 5.0)].iter().map(tri_box));
        assert_eq!(query(&bvh), vec![0, 1]);
        // Moving items one by one gives the same answers as a full refit.
        let mut partial = TriBvh::build(&[a, above, crossing]);
        partial.refit_items([(1, tri_box(&above.map(|p| p - DVec3::Z * 1.5))), (2, tri_box(&crossing.map(|p| p + DVec3::X * 5.0)))].into_iter());
        assert_eq!(query(&partial), vec![0, 1]);
        partial.refit_items(std::iter::once((2, tri_box(&crossing))));
        assert_eq!(query(&partial), vec![0, 1, 2]);
    }

    /// Least distance between two triangles by dense sampling (a reference: never
    /// below the true distance, and close to it at this density).
    fn sampled_distance(a: &[DVec3; 3], b: &[DVec3; 3]) -> f64 {
        let points = |t: &[DVec3; 3]| {
            let n = 60;
            let mut out = Vec::new();
            for i in 0..=n {
                for j in 0..=n - i {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    out.push(t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v);
                }
            }
            out
        };
        let (pa, pb) = (points(a), points(b));
        pa.iter().flat_map(|p| pb.iter().map(move |q| p.distance(*q))).fold(f64::MAX, f64::min)
    }

    /// Numbers uniform in `[-1, 1)` from a linear congruential sequence.
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    #[test]
    fn distances_agree_with_sampling_and_touching_pairs_meet() {
        let mut rnd = uniform(12345);
        for _ in 0..60 {
            let a = [DVec3::new(rnd(), rnd(), rnd()), DVec3::new(rnd(), rnd(), rnd()), DVec3::new(rnd(), rnd(), rnd())];
            let shift = DVec3::new(rnd(), rnd(), rnd()) * 2.0;
            let b = [DVec3::new(rnd(), rnd(), rnd()) + shift, DVec3::new(rnd(), rnd(), rnd()) + shift, DVec3::new(rnd(), rnd(), rnd()) + shift];
            let sampled = sampled_distance(&a, &b);
            if triangles_intersect(&a, &b) {
                assert!(sampled < 0.1, "crossing triangles sampled {sampled} apart");
                continue;
            }
            let exact = (0..3)
                .map(|i| point_triangle_distance2(a[i], &b).min(point_triangle_distance2(b[i], &a)))
                .chain((0..3).flat_map(|i| (0..3).map(move |j| segment_segment_distance2(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]))))
                .fold(f64::MAX, f64::min)
                .sqrt();
            assert!(exact <= sampled + 1e-9 && sampled - exact < 0.06, "exact {exact}, sampled {sampled}");
            assert_eq!(triangles_meet(&a, &b, 0.0), exact == 0.0);
            assert!(triangles_meet(&a, &b, exact * 1.001 + 1e-12));
        }
        // A vertex resting on another triangle, and two coplanar overlapping triangles:
        // no proper crossing, but they meet.
        let a = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let resting = [DVec3::new(0.2, 0.2, 0.0), DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.5, 0.0, 1.0)];
        let coplanar = [DVec3::new(0.1, 0.1, 0.0), DVec3::new(1.0, 0.5, 0.0), DVec3::new(0.5, 1.0, 0.0)];
        for b in [resting, coplanar] {
            assert!(!triangles_intersect(&a, &b) && triangles_meet(&a, &b, 1e-12));
        }
        let apart = coplanar.map(|p| p + DVec3::Z * 0.01);
        assert!(!triangles_meet(&a, &apart, 0.005) && triangles_meet(&a, &apart, 0.0101));
    }

    /// The triangle test with each corner's side computed once answers as six
    /// segment tests do, on random pairs and on pairs made to touch: a corner on the
    /// other's plane or edge, a shared edge, coplanar overlaps, grid points (exact
    /// zeros), needles.
    #[test]
    fn triangles_intersect_is_six_segment_tests() {
        let six = |a: &[DVec3; 3], b: &[DVec3; 3]| {
            (0..3).any(|i| segment_crosses_triangle(a[i], a[(i + 1) % 3], b)) || (0..3).any(|i| segment_crosses_triangle(b[i], b[(i + 1) % 3], a))
        };
        let mut rnd = uniform(7);
        let (mut crossing, mut pairs) = (0, 0);
        for k in 0..20000 {
            let mut point = || match k % 3 {
                // Coarse grid points: many corners exactly on planes and edges.
                0 => DVec3::new((rnd() * 2.0).round(), (rnd() * 2.0).round(), (rnd() * 2.0).round()),
                _ => DVec3::new(rnd(), rnd(), rnd()),
            };
            let a = [point(), point(), point()];
            let mut b = [point(), point(), point()];
            match k % 7 {
                1 => b[0] = a[0].lerp(a[1], 0.5),
                2 => (b[0], b[1]) = (a[1], a[2]),
                3 => b = [a[0], a[1].lerp(a[2], 0.3), a[0].lerp(a[2], 0.7) + (a[1] - a[0]) * 0.2],
                4 => b[1] = b[0] + DVec3::splat(1e-12),
                _ => {}
            }
            for (x, y) in [(a, b), (b, a)] {
                assert_eq!(triangles_intersect(&x, &y), six(&x, &y), "{x:?} {y:?}");
                crossing += usize::from(six(&x, &y));
                pairs += 1;
            }
        }
        assert!(crossing > pairs / 10 && crossing < pairs * 9 / 10, "{crossing} of {pairs}");
    }

    /// A prepared triangle answers as [`triangles_intersect`] does, with the other
    /// triangle plain or prepared, either way round: on random pairs, grid points
    /// (exact zeros), shared corners and edges, coplanar pairs (tilted, so rounded),
    /// and degenerate triangles (collinear, coincident corners, a needle through the
    /// other), of which some cross.
    #[test]
    fn prepared_triangles_answer_as_the_plain_test() {
        let mut rnd = uniform(4242);
        let (mut crossing, mut coplanar, mut degenerate_crossing, mut pairs) = (0, 0, 0, 0);
        for k in 0..30000 {
            let mut point = || match k % 3 {
                0 => DVec3::new((rnd() * 2.0).round(), (rnd() * 2.0).round(), (rnd() * 2.0).round()),
                _ => DVec3::new(rnd(), rnd(), rnd()),
            };
            let a = [point(), point(), point()];
            let mut b = [point(), point(), point()];
            match k % 11 {
                1 => b[0] = a[0].lerp(a[1], 0.5),
                2 => (b[0], b[1]) = (a[1], a[2]),
                // In a's plane (rounded: a tilted plane).
                3 => b = [a[0].lerp(a[1], 0.3), a[1].lerp(a[2], 0.6), a[2] + (a[2] - a[0]) * 0.4],
                4 => b = [a[0], a[1].lerp(a[2], 0.3), a[0].lerp(a[2], 0.7) + (a[1] - a[0]) * 0.2],
                // Collinear and coincident corners (exactly, for grid points).
                5 => b[2] = b[0] + (b[1] - b[0]) * 2.0,
                6 => b[1] = b[0],
                7 => b = [b[0]; 3],
                // A needle through a's centre.
                8 => {
                    let c = (a[0] + a[1] + a[2]) / 3.0;
                    let n = (a[1] - a[0]).cross(a[2] - a[0]);
                    b = [c - n, c + n, c + n * 3.0];
                }
                9 => b[1] = b[0] + DVec3::splat(1e-12),
                _ => {}
            }
            for (x, y) in [(a, b), (b, a)] {
                let plain = triangles_intersect(&x, &y);
                let (px, py) = (Prepared::new(&x), Prepared::new(&y));
                assert_eq!(px.crosses(&y), plain, "{x:?} {y:?}");
                assert_eq!(px.crosses_prepared(&py), plain, "{x:?} {y:?}");
                assert_eq!(px.corners(), &x);
                pairs += 1;
                crossing += usize::from(plain);
                coplanar += usize::from(y.iter().all(|&p| Plane::new(&x).side(p) == 0.0) && !degenerate(&x));
                degenerate_crossing += usize::from(plain && (degenerate(&x) || degenerate(&y)));
            }
        }
        assert!(
            crossing > pairs / 10 && coplanar > 500 && degenerate_crossing > 100,
            "{crossing} crossing, {coplanar} coplanar, {degenerate_crossing} degenerate crossing of {pairs}"
        );
    }

    /// A box is separated from a triangle's plane only where each of its corners
    /// (and so every point in it) lies strictly on one side by the exact sign, and
    /// then no triangle inside it crosses: random boxes around random and tilted
    /// triangles, boxes touching the plane at a corner (exact zeros on grid points)
    /// or lifted off it by 1e-13 .. 1e-3 of their size; many are separated.
    #[test]
    fn boxes_are_separated_from_a_plane_only_by_exact_signs() {
        let mut rnd = uniform(515);
        let c = |v: DVec3| Coord3D { x: v.x, y: v.y, z: v.z };
        let (mut separated, mut near) = (0, 0);
        for k in 0..20000 {
            let (q, origin) = (rotation(&mut rnd), DVec3::new(rnd(), rnd(), rnd()) * 10.0);
            let t = match k % 4 {
                0 => [0, 1, 2].map(|_| DVec3::new((rnd() * 3.0).round(), (rnd() * 3.0).round(), (rnd() * 3.0).round())),
                _ => [0, 1, 2].map(|_| origin + q * DVec3::new(rnd(), rnd(), 0.0)),
            };
            let prepared = Prepared::new(&t);
            // A box around a point at some height over the plane, or with a corner on
            // it (grid triangles: a grid corner).
            let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            let size = DVec3::new(rnd().abs(), rnd().abs(), rnd().abs()) * 0.5;
            let (lo, hi) = match k % 4 {
                0 => {
                    let p = DVec3::new((rnd() * 3.0).round(), (rnd() * 3.0).round(), (rnd() * 3.0).round());
                    (p, p + size)
                }
                _ => {
                    // The box's lowest corner along the normal (or its highest, below
                    // the plane) at `lift` from a point of the plane.
                    let lift = rnd() * 10f64.powi(-(k % 11) - 3);
                    let m = t[0] + (t[1] - t[0]) * rnd() + (t[2] - t[0]) * rnd() + n * lift;
                    let lo = m - size * DVec3::select((n * lift.signum()).cmplt(DVec3::ZERO), DVec3::ONE, DVec3::ZERO);
                    (lo, lo + size)
                }
            };
            if prepared.box_straddles(lo, hi) {
                continue;
            }
            separated += 1;
            let corners: Vec<DVec3> = (0..8).map(|b| DVec3::select(glam::BVec3::new(b & 1 != 0, b & 2 != 0, b & 4 != 0), hi, lo)).collect();
            let sides: Vec<f64> = corners.iter().map(|&p| -orient3d(c(t[0]), c(t[1]), c(t[2]), c(p))).collect();
            assert!(sides.iter().all(|&s| s > 0.0) || sides.iter().all(|&s| s < 0.0), "{t:?} {lo:?} {hi:?} {sides:?}");
            near += usize::from(sides.iter().map(|s| s.abs()).fold(f64::MAX, f64::min) < 1e-6);
            let inside = [0, 1, 2].map(|_| lo + (hi - lo) * DVec3::new((rnd() + 1.0) / 2.0, (rnd() + 1.0) / 2.0, (rnd() + 1.0) / 2.0));
            assert!(!triangles_intersect(&t, &inside) && !prepared.crosses(&inside));
        }
        assert!(separated > 5000 && near > 100, "{separated} separated, {near} within 1e-6");
        // A degenerate triangle separates nothing.
        let needle = Prepared::new(&[DVec3::ZERO, DVec3::X, DVec3::X * 2.0]);
        assert!(needle.box_straddles(DVec3::new(0.0, 1.0, 1.0), DVec3::new(1.0, 2.0, 2.0)));
    }

    /// A uniform random rotation (Shoemake) from three numbers in `[-1, 1)`.
    fn rotation(rnd: &mut impl FnMut() -> f64) -> glam::DQuat {
        let (u1, u2, u3) = ((rnd() + 1.0) / 2.0, std::f64::consts::PI * (rnd() + 1.0), std::f64::consts::PI * (rnd() + 1.0));
        glam::DQuat::from_xyzw((1.0 - u1).sqrt() * u2.sin(), (1.0 - u1).sqrt() * u2.cos(), u1.sqrt() * u3.sin(), u1.sqrt() * u3.cos())
    }

    #[test]
    fn filtered_sides_are_the_exact_signs() {
        // Points near and on tilted planes (a corner's lift of 0, 1e-18 .. 1e-6, on
        // planes through coordinates up to 10): the filter's naive determinant, where
        // taken, has the sign of Shewchuk's orient3d (exact) everywhere.
        let mut rnd = uniform(31);
        let sign = |x: f64| (x > 0.0) as i32 - (x < 0.0) as i32;
        let c = |v: DVec3| Coord3D { x: v.x, y: v.y, z: v.z };
        let (mut filtered, mut zeros) = (0, 0);
        for k in 0..20000 {
            let (q, origin) = (rotation(&mut rnd), DVec3::new(rnd(), rnd(), rnd()) * 10.0);
            let at = |x: f64, y: f64, z: f64| origin + q * DVec3::new(x, y, z);
            let t = [at(rnd(), rnd(), 0.0), at(rnd(), rnd(), 0.0), at(rnd(), rnd(), 0.0)];
            let lift = if k % 5 == 0 { 0.0 } else { rnd() * 10f64.powi(-(k % 13) - 6) };
            let mut p = at(rnd(), rnd(), lift);
            if k % 7 == 0 {
                p = t[0] + (t[1] - t[0]) * 2.0; // exactly coplanar where the sum is exact
            }
            let plane = Plane::new(&t);
            let (side, exact) = (plane.side(p), -orient3d(c(t[0]), c(t[1]), c(t[2]), c(p)));
            assert_eq!(sign(side), sign(exact), "{t:?} {p:?}");
            let w = p - t[0];
            filtered += usize::from(plane.normal.dot(w).abs() > ORIENT_BOUND * plane.permanent.dot(w.abs()));
            zeros += usize::from(exact == 0.0);
        }
        assert!(filtered > 5000 && filtered < 15000 && zeros > 100, "{filtered} filtered, {zeros} zeros");
        // Collinear and coincident corners are degenerate; a sliver is not.
        let (a, b, mid) = (DVec3::new(0.5, 1.0, 1.5), DVec3::new(2.5, -3.0, 4.5), DVec3::new(1.5, -1.0, 3.0));
        assert!(degenerate(&[a, b, mid]) && degenerate(&[a, a, b]) && degenerate(&[a, a, a]));
        assert!(!degenerate(&[a, b, mid + DVec3::Z * 2f64.powi(-50)]));
    }

    #[test]
    fn coplanar_triangles_apart_on_a_tilted_layer_do_not_cross() {
        // Flat caps of a bake: corners on a tilted plane, then lifted to a layer `r`
        // along a common director, each rounded in f64. The triangles lie in one plane
        // up to rounding and do not meet (a gap of 0.2 or 1e-6 between them in that
        // plane, or apart along a shared line). The naive determinants were noise of
        // random sign: 19 of these 30,000 tests reported a crossing.
        let mut rnd = uniform(2024);
        let pairs = [
            ([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)], [(0.6, 0.6), (1.6, 0.6), (0.6, 1.6)]),
            ([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)], [(0.500001, 0.5), (1.5, 0.5), (0.5, 1.5)]),
            ([(0.0, 0.0), (1.0, 0.0), (0.3, 0.7)], [(1.2, 0.0), (3.0, 0.0), (2.0, 0.5)]),
        ];
        let mut reported = 0;
        for _ in 0..2000 {
            let (q, origin) = (rotation(&mut rnd), DVec3::new(rnd(), rnd(), rnd()) * 10.0);
            let director = q * DVec3::new(0.3 * rnd(), 0.3 * rnd(), 1.0);
            let lift = director * (0.37 + 0.1 * rnd());
            let at = |(x, y): (f64, f64)| origin + q * DVec3::new(x, y, 0.0) * 0.01 + lift;
            for (a, b) in pairs {
                let (a, b) = (a.map(at), b.map(at));
                reported += usize::from(triangles_intersect(&a, &b)) + usize::from(triangles_intersect(&b, &a));
                reported += a.iter().zip(a.iter().cycle().skip(1)).filter(|&(p, q)| segment_crosses_triangle(*p, *q, &b)).count();
            }
        }
        assert_eq!(reported, 0);
    }

    #[test]
    fn triangles_crossing_at_a_tiny_angle_cross() {
        // One triangle through another at an angle of 1e-12 (on a tilted plane, far
        // above rounding) and of 1e-200 (axis-aligned, exact coordinates): both cross,
        // and lifted clear of the plane by twice that, neither does.
        let mut rnd = uniform(77);
        for _ in 0..500 {
            let (q, origin) = (rotation(&mut rnd), DVec3::new(rnd(), rnd(), rnd()) * 10.0);
            let at = |x: f64, y: f64, z: f64| origin + q * DVec3::new(x, y, z);
            let a = [at(0.0, 0.0, 0.0), at(1.0, 0.0, 0.0), at(0.0, 1.0, 0.0)];
            let h = 1e-12;
            let b = [at(0.2, 0.2, -h), at(0.6, 0.2, h), at(0.2, 0.6, h)];
            assert!(triangles_intersect(&a, &b) && triangles_intersect(&b, &a), "{a:?} {b:?}");
            let above = [at(0.2, 0.2, h), at(0.6, 0.2, 3.0 * h), at(0.2, 0.6, 3.0 * h)];
            assert!(!triangles_intersect(&a, &above) && !triangles_intersect(&above, &a), "{a:?} {above:?}");
        }
        let a = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let h = 1e-200;
        let b = [DVec3::new(0.2, 0.2, -h), DVec3::new(0.6, 0.2, h), DVec3::new(0.2, 0.6, h)];
        assert!(triangles_intersect(&a, &b) && triangles_intersect(&b, &a));
        assert!(!triangles_intersect(&a, &b.map(|p| p + DVec3::Z * 2.0 * h)));
    }

    #[test]
    fn the_plane_test_only_skips_pairs_that_do_not_meet() {
        // Close random pairs at several tolerances: the answer with the early plane
        // test is the answer of the full test (crossing, then the fifteen distances).
        let mut rnd = uniform(99);
        let full = |a: &[DVec3; 3], b: &[DVec3; 3], eps: f64| {
            triangles_intersect(a, b)
                || (0..3).any(|i| point_triangle_distance2(a[i], b) <= eps * eps || point_triangle_distance2(b[i], a) <= eps * eps)
                || (0..3).any(|i| (0..3).any(|j| segment_segment_distance2(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]) <= eps * eps))
        };
        let (mut skipped, mut met) = (0, 0);
        for _ in 0..3000 {
            let a = [DVec3::new(rnd(), rnd(), rnd()), DVec3::new(rnd(), rnd(), rnd()), DVec3::new(rnd(), rnd(), rnd())];
            let shift = DVec3::new(rnd(), rnd(), rnd()) * 0.6;
            let b = [0, 1, 2].map(|_| DVec3::new(rnd(), rnd(), rnd()) * 0.5 + shift);
            for eps in [0.0, 1e-3, 0.05] {
                let answer = triangles_meet(&a, &b, eps);
                assert_eq!(answer, full(&a, &b, eps), "{a:?} {b:?} {eps}");
                met += usize::from(answer);
                skipped += usize::from(beyond_plane(&a, &b, eps) || beyond_plane(&b, &a, eps));
            }
        }
        assert!(skipped > 1000 && met > 1000, "skipped {skipped}, met {met}");
        // A needle resting on a triangle, and a triangle with a vertex exactly in the
        // other's plane: they meet at zero tolerance, and the plane test keeps them.
        let a = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let needle = [DVec3::new(0.3, 0.3, 0.0), DVec3::new(0.3 + 1e-9, 0.3, 1.0), DVec3::new(0.3, 0.3 + 1e-9, 2.0)];
        let resting = [DVec3::new(0.25, 0.25, 0.0), DVec3::new(0.2, 0.9, 1.0), DVec3::new(0.9, 0.2, 1.0)];
        for b in [needle, resting] {
            assert!(!beyond_plane(&a, &b, 0.0) && !beyond_plane(&b, &a, 0.0));
            assert!(triangles_meet(&a, &b, 0.0) && triangles_meet(&b, &a, 0.0));
        }
    }
}
