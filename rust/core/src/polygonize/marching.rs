//! One prism of marching prisms, and where an iso-vertex goes on a lattice edge: the
//! steps every lattice (a bake's shell cells, a grid of cubes) shares.

use super::prism_table::{self, EDGES};

/// How close to an edge's ends an iso-vertex may be, as a share of the edge, and how
/// far lattices keep their samples off the iso-level (in their own units, [`off_level`]):
/// values on the level (a bake's blends of a region, holes or the base slab give
/// exactly 0.5 midway between weights 1 and 0) would put iso-vertices on lattice
/// points, making coincident vertices and triangles around one lattice point that
/// touch without sharing a vertex. Not from a paper: small enough to move the surface
/// by at most 1% of a lattice step, large enough for single precision.
pub const OFF_ISO: f32 = 0.01;

/// Emits the iso-surface triangles of one prism with corner values `values` (corners
/// `0, 1, 2` the bottom triangle counter-clockwise seen from above, `3, 4, 5` above
/// them; inside where `>= level`) into `out`, facing from inside to outside (reversed
/// with `flip`, for a prism whose frame reverses orientation). `vertex(a, b)` gives
/// the iso-vertex on the edge from corner `a` to corner `b`; it is asked once per edge
/// of this prism, and must give every prism sharing that edge the same vertex (its
/// place is the lattice's business: [`crossing`]). Every loop is triangulated between
/// its own vertices, as the table chose (the choice keeps neighbouring prisms from
/// drawing the same chord: it is not arbitrary).
#[inline]
pub fn march_prism(values: &[f32; 6], level: f32, flip: bool, mut vertex: impl FnMut(usize, usize) -> u32, out: &mut Vec<[u32; 3]>) {
    type NoCentre = fn(&mut (), &[(usize, usize, u32)]) -> u32;
    march(values, level, flip, &mut (), |_, a, b| vertex(a, b), None::<NoCentre>, out);
}

/// [`march_prism`], except that a loop of at least [`prism_table::CENTRE_LOOP`]
/// iso-vertices is fanned from a vertex inside the prism, which `centre(ctx, ring)`
/// makes from the loop, given as `(a, b, vertex)` per iso-vertex in winding order (its
/// place: [`centre_weights`]); it belongs to this prism alone (no other prism's
/// triangle has it, and the fan draws no chord between loop vertices, so neighbours
/// meet only along the loop's segments on the prism's faces, as before). `vertex`
/// and `centre` share the lattice's state through `ctx`. Other loops are triangulated
/// exactly as [`march_prism`] does.
#[inline]
pub fn march_prism_centred<C>(
    values: &[f32; 6],
    level: f32,
    flip: bool,
    ctx: &mut C,
    vertex: impl FnMut(&mut C, usize, usize) -> u32,
    centre: impl FnMut(&mut C, &[(usize, usize, u32)]) -> u32,
    out: &mut Vec<[u32; 3]>,
) {
    march(values, level, flip, ctx, vertex, Some(centre), out);
}

/// Both of the above: the long loop is fanned from its centre where `centre` is given.
#[inline]
fn march<C, V, F>(values: &[f32; 6], level: f32, flip: bool, ctx: &mut C, mut vertex: V, centre: Option<F>, out: &mut Vec<[u32; 3]>)
where
    V: FnMut(&mut C, usize, usize) -> u32,
    F: FnMut(&mut C, &[(usize, usize, u32)]) -> u32,
{
    let case = prism_table::classify(values, level);
    if case.count == 0 {
        return;
    }
    let mut verts = [u32::MAX; 9];
    let mut at = |ctx: &mut C, e: u8| {
        let e = e as usize;
        if verts[e] == u32::MAX {
            verts[e] = vertex(ctx, EDGES[e][0], EDGES[e][1]);
        }
        verts[e]
    };
    let mut push = |t: [u32; 3]| out.push(if flip { [t[0], t[2], t[1]] } else { t });
    let (fanned, ring) = if centre.is_some() { (case.ring_tris(), case.ring()) } else { (0..0, &[][..]) };
    for (k, tri) in case.tris[..case.count as usize].iter().enumerate() {
        if !fanned.contains(&k) {
            push(tri.map(|e| at(ctx, e)));
        }
    }
    if let (Some(mut centre), false) = (centre, ring.is_empty()) {
        let mut loop_ = [(0, 0, 0); 9];
        for (k, &e) in ring.iter().enumerate() {
            loop_[k] = (EDGES[e as usize][0], EDGES[e as usize][1], at(ctx, e));
        }
        let loop_ = &loop_[..ring.len()];
        let c = centre(ctx, loop_);
        for k in 0..loop_.len() {
            push([c, loop_[k].2, loop_[(k + 1) % loop_.len()].2]);
        }
    }
}

/// Where the centre of a loop of iso-vertices goes, as weights of the prism's six
/// corners (non-negative, summing to 1; the lattice maps corners to its own space,
/// where a prism is a triangle times an interval): the mean of the loop's vertices in
/// the prism's coordinates, `(a, b, f)` each (on the edge from corner `a` to `b`, at
/// `f` from `a`), then one Newton step onto `level` of the values' interpolation
/// (linear across, linear up) along its gradient, shortened to keep it `margin`
/// inside the prism, in the prism's own coordinates (barycentric across, the layer's
/// share up): it must not meet the surface of the prism beside it, which a curved
/// lattice bends by as much as its iso-vertices keep off the lattice points (the
/// bake's `Margins`: 0.05 of a step, up to 0.25 in twisted cells). A mean already
/// closer to a face than `margin` is not moved closer.
pub fn centre_weights(values: &[f32; 6], level: f32, ring: impl Iterator<Item = (usize, usize, f32)>, margin: f32) -> [f32; 6] {
    // Coordinates (w1, w2, t): w0 = 1 - w1 - w2.
    let local = |c: usize| glam::Vec3::new(f32::from(c % 3 == 1), f32::from(c % 3 == 2), (c / 3) as f32);
    let (mut sum, mut n) = (glam::Vec3::ZERO, 0.0f32);
    for (a, b, f) in ring {
        sum += local(a).lerp(local(b), f);
        n += 1.0;
    }
    let x = sum / n.max(1.0);
    let v = values;
    let (t, w) = (x.z, [1.0 - x.x - x.y, x.x, x.y]);
    let value = (0..3).map(|k| w[k] * ((1.0 - t) * v[k] + t * v[k + 3])).sum::<f32>();
    let g = glam::Vec3::new(
        (1.0 - t) * (v[1] - v[0]) + t * (v[4] - v[3]),
        (1.0 - t) * (v[2] - v[0]) + t * (v[5] - v[3]),
        (0..3).map(|k| w[k] * (v[k + 3] - v[k])).sum::<f32>(),
    );
    let x = step_inside(x, -(value - level) * g / g.length_squared(), margin);
    let (t, w) = (x.z, [1.0 - x.x - x.y, x.x, x.y]);
    [w[0] * (1.0 - t), w[1] * (1.0 - t), w[2] * (1.0 - t), w[0] * t, w[1] * t, w[2] * t]
}

/// `x + s step` in a prism's coordinates `(w1, w2, t)` ([`centre_weights`]) for the
/// largest `s` in `[0, 1]` that keeps `w0 = 1 - w1 - w2`, `w1`, `w2`, `t` and `1 - t`
/// above `margin` (or not lower, where they start below it); `x` where the step is
/// not a number.
fn step_inside(x: glam::Vec3, step: glam::Vec3, margin: f32) -> glam::Vec3 {
    if !step.is_finite() {
        return x;
    }
    let limits = [(1.0 - x.x - x.y, -step.x - step.y), (x.x, step.x), (x.y, step.y), (x.z, step.z), (1.0 - x.z, -step.z)];
    let s = limits.iter().fold(1.0f32, |s, &(room, rate)| if rate < 0.0 { s.min(((room - margin) / -rate).max(0.0)) } else { s });
    x + s * step
}

/// Refinement of an iso-vertex by [`crossing`]: at most `steps` evaluations, fewer once
/// the field is within `tolerance` of the level.
#[derive(Debug, Clone, Copy)]
pub struct Refine {
    pub steps: usize,
    pub tolerance: f32,
}

/// Where a field `value(f)` crosses `level` on a lattice edge from `f = 0` (sample
/// `a`) to `f = 1` (sample `b`, on the other side): Illinois regula falsi from the
/// linear guess ([`Crossing`]), as [`Refine`] allows. Where the field is curved along
/// the edge (a trilinear texture between columns, any nonlinear implicit), linear
/// interpolation of the end values moves the surface inward and thins features a few
/// lattice steps wide. The result is kept [`OFF_ISO`] of the edge from its ends, and
/// a field that cannot be evaluated leaves the last guess.
pub fn crossing(a: f32, b: f32, level: f32, refine: Refine, mut value: impl FnMut(f32) -> f32) -> f32 {
    let mut c = Crossing::new(a, b, level);
    for _ in 0..refine.steps {
        if !c.step(value(c.at()), refine.tolerance) {
            break;
        }
    }
    c.result()
}

/// The state of one [`crossing`], for callers that evaluate many edges' next points
/// as one batch: [`Crossing::at`] is where to evaluate, [`Crossing::step`] takes the
/// value there.
#[derive(Debug, Clone, Copy)]
pub struct Crossing {
    lo: f32,
    hi: f32,
    fa: f32,
    fb: f32,
    x: f32,
    side: i8,
    level: f32,
}

impl Crossing {
    /// The bracket `[0, 1]` with samples `a` and `b`; the first guess is linear.
    pub fn new(a: f32, b: f32, level: f32) -> Self {
        let (fa, fb) = (a - level, b - level);
        Self { lo: 0.0, hi: 1.0, fa, fb, x: (fa / (fa - fb)).clamp(0.0, 1.0), side: 0, level }
    }
    /// The parameter to evaluate next.
    pub fn at(&self) -> f32 {
        self.x
    }
    /// Takes the field's value at [`Crossing::at`]; false when it is done (within
    /// `tolerance` of the level, or not a number: the guess stays).
    pub fn step(&mut self, value: f32, tolerance: f32) -> bool {
        let fx = value - self.level;
        if !fx.is_finite() || fx.abs() <= tolerance {
            return false;
        }
        if (fx >= 0.0) == (self.fb >= 0.0) {
            (self.hi, self.fb) = (self.x, fx);
            if self.side == 1 {
                self.fa *= 0.5;
            }
            self.side = 1;
        } else {
            (self.lo, self.fa) = (self.x, fx);
            if self.side == -1 {
                self.fb *= 0.5;
            }
            self.side = -1;
        }
        let next = self.lo - self.fa * (self.hi - self.lo) / (self.fb - self.fa);
        self.x = if next.is_finite() && next > self.lo && next < self.hi { next } else { 0.5 * (self.lo + self.hi) };
        true
    }
    /// The crossing found, kept [`OFF_ISO`] of the edge from its ends.
    pub fn result(&self) -> f32 {
        self.x.clamp(OFF_ISO, 1.0 - OFF_ISO)
    }
}

/// Where the straight line through the two samples meets `level`, in `[0, 1]`. Not
/// kept off the ends: a lattice that uses it alone keeps its samples off the level
/// ([`off_level`]) and within a bounded range, which keeps the vertices off them.
#[inline]
pub fn linear(a: f32, b: f32, level: f32) -> f32 {
    ((level - a) / (b - a)).clamp(0.0, 1.0)
}

/// `v` moved [`OFF_ISO`] times `scale` off `level` where it is nearer, keeping its side:
/// a sample on the level would put iso-vertices on lattice points.
#[inline]
pub fn off_level(v: f32, level: f32, scale: f32) -> f32 {
    let eps = OFF_ISO * scale;
    if (v - level).abs() < eps {
        if v >= level {
            level + eps
        } else {
            level - eps
        }
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const THREE: Refine = Refine { steps: 3, tolerance: 0.0 };

    #[test]
    fn the_crossing_is_found_on_curved_edges_and_kept_off_the_ends() {
        // 1 - 2 f²: 0.5 at f = 0.5, where the linear guess from the ends says 0.25.
        let f = crossing(1.0, -1.0, 0.5, THREE, |f| 1.0 - 2.0 * f * f);
        assert!((f - 0.5).abs() < 5e-3, "{f}");
        // From below, and a steep curve (sqrt: the guess is far off).
        let f = crossing(0.0, 1.0, 0.5, THREE, f32::sqrt);
        assert!((f - 0.25).abs() < 0.02, "{f}");
        // Linear: exact at once, at any level.
        assert!((crossing(0.2, 0.8, 0.5, THREE, |f| 0.2 + 0.6 * f) - 0.5).abs() < 1e-6);
        assert!((crossing(-3.0, 1.0, 0.0, THREE, |f| -3.0 + 4.0 * f) - 0.75).abs() < 1e-6);
        // A crossing at the very end stays OFF_ISO of the edge from it.
        let f = crossing(0.9, 0.1, 0.5, THREE, |f| if f < 1e-4 { 0.9 } else { 0.1 });
        assert!((OFF_ISO..=1.0 - OFF_ISO).contains(&f), "{f}");
        // More steps converge further; a tolerance stops them early.
        let kink = |f: f32| if f < 0.3 { 1.0 - f } else { 0.7 - 4.0 * (f - 0.3) };
        let (three, more) = (crossing(1.0, -2.1, 0.5, THREE, kink), crossing(1.0, -2.1, 0.5, Refine { steps: 12, tolerance: 0.0 }, kink));
        assert!((more - 0.35).abs() < 1e-4 && (more - 0.35).abs() < (three - 0.35).abs(), "{three} {more}");
        let mut calls = 0;
        crossing(0.2, 0.8, 0.5, Refine { steps: 12, tolerance: 1e-3 }, |f| {
            calls += 1;
            0.2 + 0.6 * f
        });
        assert_eq!(calls, 1);
        // A field that cannot be evaluated leaves the linear guess.
        assert!((crossing(0.0, 1.0, 0.5, THREE, |_| f32::NAN) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn samples_on_the_level_move_off_it_and_keep_their_side() {
        assert_eq!(off_level(0.5, 0.5, 1.0), 0.5 + OFF_ISO);
        assert_eq!(off_level(0.499, 0.5, 1.0), 0.5 - OFF_ISO);
        assert_eq!(off_level(0.2, 0.5, 1.0), 0.2);
        assert_eq!(off_level(-1e-9, 0.0, 2.0), -2.0 * OFF_ISO);
    }

    #[test]
    fn a_prism_asks_each_crossed_edge_once_and_flips_on_request() {
        // Corner 0 inside: the three edges at it are crossed, one triangle.
        let values = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut asked = Vec::new();
        let mut tris = Vec::new();
        march_prism(
            &values,
            0.5,
            false,
            |a, b| {
                asked.push((a, b));
                asked.len() as u32 - 1
            },
            &mut tris,
        );
        asked.sort();
        assert_eq!(asked, vec![(0, 1), (0, 3), (2, 0)]);
        assert_eq!(tris.len(), 1);
        let mut again = Vec::new();
        let mut k = 0;
        march_prism(
            &values,
            0.5,
            true,
            |_, _| {
                k += 1;
                k - 1
            },
            &mut again,
        );
        let t = tris[0];
        assert_eq!(again[0], [t[0], t[2], t[1]]);
        // All outside or all inside: nothing.
        let mut none = Vec::new();
        march_prism(&[0.0; 6], 0.5, false, |_, _| 0, &mut none);
        march_prism(&[1.0; 6], 0.5, false, |_, _| 0, &mut none);
        assert!(none.is_empty());
    }
}
