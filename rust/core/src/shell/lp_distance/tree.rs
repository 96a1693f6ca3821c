//! Barnes–Hut patch tree over the integration triangles (section 4.4.2): a BVH whose
//! nodes store the patch area, the area-weighted centroid, the second moment of area
//! about it and a bounding sphere. Far patches are replaced by a point mass at their
//! centroid with, for p = 3, a quadrupole correction (the thesis uses the point mass
//! alone; the correction's error falls with the cube of size over distance instead
//! of the square, so patches can be accepted from nearer at the same accuracy; for
//! larger p the kernel's higher terms grow and the correction can do worse, so other
//! p keep the point mass alone); near single
//! faces are integrated exactly (Appendix A, p = 3) or by quadrature (other p).
//! Localization (section 4.3.1): only faces whose centroid lies within a ball around
//! `x` count.

use super::exact::triangle_p3;
use super::quadrature::Quadrature;
use crate::shell::intersect::{segment_crosses_triangle, segment_meets_box};
use glam::DVec3;

/// Triangles per leaf of the patch tree (not from the thesis; `shell_bench`).
const LEAF: usize = 4;

/// The soft localization ball has full weight up to `TAPER` times its radius. The
/// thesis cuts sharply (4.3.1); the taper and its width are ours, chosen with
/// `shell_bench` (a sharp cut opened every node on the ball's rim).
pub const TAPER: f64 = 0.8;

/// Localization weight of a patch whose centroid is `d` from the evaluation point:
/// 1 for `d <= TAPER * radius`, a smoothstep down to 0 at `radius`.
#[inline]
pub fn taper(d: f64, radius: f64) -> f64 {
    if d <= TAPER * radius {
        return 1.0;
    }
    let s = ((radius - d) / ((1.0 - TAPER) * radius)).clamp(0.0, 1.0);
    s * s * (3.0 - 2.0 * s)
}

/// A symmetric 3x3 matrix: xx, yy, zz, xy, xz, yz.
type Sym = [f64; 6];

/// `w v vᵀ`.
fn outer(v: DVec3, w: f64) -> Sym {
    [w * v.x * v.x, w * v.y * v.y, w * v.z * v.z, w * v.x * v.y, w * v.x * v.z, w * v.y * v.z]
}

fn add_sym(a: Sym, b: Sym) -> Sym {
    std::array::from_fn(|i| a[i] + b[i])
}

fn sym_times(q: &Sym, d: DVec3) -> DVec3 {
    DVec3::new(q[0] * d.x + q[3] * d.y + q[4] * d.z, q[3] * d.x + q[1] * d.y + q[5] * d.z, q[4] * d.x + q[5] * d.y + q[2] * d.z)
}

/// Second moment of a triangle's area about its centroid `c`: `A/12 Σ (v_i - c)(v_i - c)ᵀ`.
fn tri_second(t: &[DVec3; 3], area: f64, c: DVec3) -> Sym {
    t.iter().fold([0.0; 6], |q, v| add_sym(q, outer(*v - c, area / 12.0)))
}

#[derive(Debug, Clone, Copy, Default)]
struct Node {
    centroid: DVec3,
    area: f64,
    /// Second moment of area about the centroid, `∫ (y-c)(y-c)ᵀ dy`.
    second: Sym,
    radius: f64,
    /// Leaf: first triangle; internal: index of the second child (the first is `self + 1`).
    index: u32,
    /// Number of triangles of a leaf; 0 for internal nodes.
    count: u32,
}

/// Sum of contributions at one point.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FieldEval {
    /// `∫ |x-y|^-p dy` over the localized surface.
    pub value: f64,
    /// `-∇_x value = p ∫ (x-y)|x-y|^{-p-2} dy`: where the field pushes `x`.
    pub push: DVec3,
    /// `Σ |push_i · ref|` over the individual contributions, for the compression ratio.
    pub abs_along: f64,
    /// A lower bound on the distance from `x` to every triangle of the tree (within
    /// the localization ball or not), from the spheres of the nodes and triangles the
    /// walk closed: a segment from `x` shorter than this crosses none of them.
    pub clearance: f64,
}

/// How a field is integrated.
#[derive(Debug, Clone)]
pub struct Kernel {
    /// Exponent p of the averaged distance (p > 1; 3 uses the exact formulas).
    pub p: f64,
    /// Opening criterion: a patch is a point mass when `radius < theta * distance`.
    pub theta: f64,
    quad: Quadrature,
}

impl Kernel {
    pub fn new(p: f64, theta: f64) -> Self {
        Self { p, theta, quad: Quadrature::new(6, 1.0, 6) }
    }
    fn is_exact(&self) -> bool {
        self.p == 3.0
    }
    /// A patch of `area` and second moment `second` about its centroid, at distance
    /// vector `d = x - c` (`r2 = |d|²`, `r = |d|`): the point mass and (p = 3) its
    /// quadrupole term, `½ Σ Q_ij ∂_i ∂_j` of the kernels `r^-p` and `p d r^-(p+2)` (the dipole
    /// term vanishes about the centroid).
    #[inline]
    fn point(&self, area: f64, second: &Sym, d: DVec3, r2: f64, r: f64) -> (f64, DVec3) {
        let p = self.p;
        if !self.is_exact() {
            let k = area * r2.powf(-0.5 * p);
            return (k, d * (p * k / r2));
        }
        // One division for all the inverse powers: this runs for every accepted patch.
        let inv_r = 1.0 / r;
        let inv_r2 = inv_r * inv_r;
        let rp = inv_r2 * inv_r;
        let (qd, trace) = (sym_times(second, d), second[0] + second[1] + second[2]);
        let dqd = d.dot(qd) * inv_r2;
        let value = rp * (area + 0.5 * p * ((p + 2.0) * dqd - trace) * inv_r2);
        let q = p + 2.0;
        let push = d * (p * rp * inv_r2) * (area + 0.5 * q * ((q + 2.0) * dqd - trace) * inv_r2) - qd * (p * q * rp * inv_r2 * inv_r2);
        (value, push)
    }
    #[inline]
    fn face(&self, t: &[DVec3; 3], x: DVec3) -> (f64, DVec3) {
        if self.is_exact() {
            let r = triangle_p3(t[0], t[1], t[2], x);
            (r.value, -r.gradient)
        } else {
            self.quad.integrate(*t, x, self.p)
        }
    }
}

/// The tree. Triangles are stored in leaf order.
#[derive(Debug, Clone, Default)]
pub struct PatchTree {
    tris: Vec<[DVec3; 3]>,
    tri_area: Vec<f64>,
    tri_centroid: Vec<DVec3>,
    tri_radius: Vec<f64>,
    tri_second: Vec<Sym>,
    /// Original index of each stored piece, and the stored place of each piece
    /// (`u32::MAX`: dropped as degenerate).
    order: Vec<u32>,
    place: Vec<u32>,
    /// The pieces each given triangle was split into ([`PatchTree::build_refined`]):
    /// triangle `i` is pieces `first[i]..first[i + 1]`, each piece its corners'
    /// barycentric coordinates in the triangle (so a refit moves them with it).
    first: Vec<u32>,
    pieces: Vec<[DVec3; 3]>,
    /// The longest edge each triangle's pieces may have, as asked (infinite: not
    /// split), and the factor the budget multiplied them by.
    asked: Vec<f64>,
    scale: f64,
    /// The most pieces the budget allows (the triangles and the budget), and each
    /// triangle's piece count at half the scale (empty when the scale is 1 or
    /// infinite), with their sum.
    limit: usize,
    finer: Vec<u32>,
    finer_total: usize,
    /// Leaf of each stored triangle and parent of each node, for [`refit_triangles`].
    ///
    /// [`refit_triangles`]: PatchTree::refit_triangles
    leaf_of: Vec<u32>,
    parent: Vec<u32>,
    nodes: Vec<Node>,
    /// Each node's bounding box (only for refits: it tightens the bounding sphere).
    boxes: Vec<(DVec3, DVec3)>,
    total_area: f64,
}

/// Area, centroid and bounding radius about the centroid of a triangle.
pub(crate) fn tri_props(t: &[DVec3; 3]) -> (f64, DVec3, f64) {
    let area = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
    let c = (t[0] + t[1] + t[2]) / 3.0;
    let r = t.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
    (area, c, r)
}

/// Lexicographic order of points (ties broken the same way whatever the input order).
fn lex(a: DVec3, b: DVec3) -> std::cmp::Ordering {
    a.to_array().iter().zip(b.to_array()).map(|(x, y)| x.total_cmp(&y)).find(|o| o.is_ne()).unwrap_or(std::cmp::Ordering::Equal)
}

/// Splits `t` by longest-edge bisection until no edge is longer than `max_edge` (or
/// `depth` runs out), pushing each piece as barycentric corners in `t`. A sliver
/// becomes a row of pieces (linear in its length), a fat triangle a grid (quadratic).
fn bisect(t: &[DVec3; 3], bary: [DVec3; 3], max_edge: f64, depth: u32, out: &mut Vec<[DVec3; 3]>) {
    let at = |b: DVec3| t[0] * b.x + t[1] * b.y + t[2] * b.z;
    let q = bary.map(at);
    let edge = |k: usize| (q[(k + 1) % 3] - q[k]).length_squared();
    // Ties (equilateral triangles) go by the edges' end points, so the pieces do not
    // depend on which corner a triangulation lists first.
    let ends = |k: usize| {
        let (a, b) = (q[k], q[(k + 1) % 3]);
        if lex(a, b).is_le() {
            (a, b)
        } else {
            (b, a)
        }
    };
    let k = (0..3)
        .max_by(|&a, &b| {
            let (ea, eb) = (ends(a), ends(b));
            edge(a).total_cmp(&edge(b)).then_with(|| lex(ea.0, eb.0)).then_with(|| lex(ea.1, eb.1))
        })
        .unwrap_or(0);
    if depth == 0 || edge(k) <= max_edge * max_edge || edge(k).is_nan() {
        out.push(bary);
        return;
    }
    // Corners k, k+1 (the longest edge) and the one opposite; both halves keep the
    // triangle's orientation.
    let (a, b, c) = (bary[k], bary[(k + 1) % 3], bary[(k + 2) % 3]);
    let m = 0.5 * (a + b);
    bisect(t, [a, m, c], max_edge, depth - 1, out);
    bisect(t, [m, b, c], max_edge, depth - 1, out);
}

/// Most halvings of one triangle (2^20 pieces at most; a budget applies first).
const MAX_DEPTH: u32 = 20;

/// `t` turned to start at its lexicographically least corner (the same triangle,
/// the same orientation), so its pieces do not depend on which corner a
/// triangulation lists first: a rounding apart, near-equal edges would split
/// differently.
fn canonical(t: &[DVec3; 3]) -> [DVec3; 3] {
    let k = (0..3).min_by(|&a, &b| lex(t[a], t[b])).unwrap_or(0);
    [t[k], t[(k + 1) % 3], t[(k + 2) % 3]]
}

/// Scales past this split nothing (see [`PatchTree::build_refined`]).
const MAX_SCALE: f64 = (1u64 << 40) as f64;

/// How many pieces [`split_into`] makes of `t` at `max_edge`.
fn count_pieces(t: &[DVec3; 3], max_edge: f64) -> u32 {
    let mut out = Vec::new();
    split_into(t, max_edge, &mut out);
    out.len() as u32
}

/// `t`'s pieces (barycentric in [`canonical`]`(t)`) no longer than `max_edge` (not
/// split when it is infinite, zero or NaN).
fn split_into(t: &[DVec3; 3], max_edge: f64, out: &mut Vec<[DVec3; 3]>) {
    let split = max_edge > 0.0 && max_edge.is_finite();
    bisect(&canonical(t), [DVec3::X, DVec3::Y, DVec3::Z], max_edge, if split { MAX_DEPTH } else { 0 }, out);
}

/// The corners of a piece (barycentric `b`) of triangle `t`.
fn piece_of(t: &[DVec3; 3], b: &[DVec3; 3]) -> [DVec3; 3] {
    let t = canonical(t);
    b.map(|b| t[0] * b.x + t[1] * b.y + t[2] * b.z)
}

impl PatchTree {
    /// Builds the tree; zero-area triangles are dropped (they contribute nothing).
    pub fn build(tris: &[[DVec3; 3]]) -> Self {
        Self::build_refined(tris, &vec![f64::INFINITY; tris.len()], 0)
    }

    /// Builds the tree over `tris`, each split into pieces no longer than its
    /// `max_edge` (by longest-edge bisection), all doubled until at most `budget`
    /// pieces more than the triangles are made. The integral over a triangle is the sum
    /// over its pieces, so this changes no exact value; it lets the Barnes-Hut walk
    /// (4.4.2) accept the far parts of triangles much larger than the distance at
    /// which the field is evaluated (a CAD part's STL: long slivers spanning a whole
    /// face, every one opened and integrated exactly at every evaluation near it),
    /// and the localization (4.3.1), which weighs a patch by its centroid's
    /// distance, sees where a large triangle's area actually lies.
    pub fn build_refined(tris: &[[DVec3; 3]], max_edge: &[f64], budget: usize) -> Self {
        assert_eq!(tris.len(), max_edge.len(), "one piece size per triangle");
        let limit = tris.len() + budget;
        let mut scale = 1.0;
        let (mut first, mut pieces) = (Vec::with_capacity(tris.len() + 1), Vec::with_capacity(tris.len()));
        loop {
            // Past 2^40 the sizes asked are absurdly small for the triangles: none is
            // split (an infinite scale), which always fits.
            if scale > MAX_SCALE {
                scale = f64::INFINITY;
            }
            first.clear();
            pieces.clear();
            let mut over = false;
            for (t, &e) in tris.iter().zip(max_edge) {
                first.push(pieces.len() as u32);
                split_into(t, e * scale, &mut pieces);
                if pieces.len() > limit {
                    over = true;
                    break;
                }
            }
            if !over {
                break;
            }
            scale *= 2.0;
        }
        first.push(pieces.len() as u32);
        let split: Vec<[DVec3; 3]> =
            (0..tris.len()).flat_map(|i| pieces[first[i] as usize..first[i + 1] as usize].iter().map(move |b| piece_of(&tris[i], b))).collect();
        let mut tree = Self::build_pieces(&split);
        (tree.first, tree.pieces, tree.asked, tree.scale, tree.limit) = (first, pieces, max_edge.to_vec(), scale, limit);
        // How many pieces half this scale would make: where an edit brings that
        // within the budget, a build would split finer, and a refit must not keep these.
        if scale > 1.0 && scale.is_finite() {
            tree.finer = tris.iter().zip(max_edge).map(|(t, &e)| count_pieces(t, e * scale * 0.5)).collect();
            tree.finer_total = tree.finer.iter().map(|&c| c as usize).sum();
        }
        tree
    }

    /// Whether, with `changed` triangles (index, new corners, new size asked) in place
    /// of theirs, half the scale would fit the budget (a build would then split finer);
    /// the new counts at half the scale where it does not.
    fn finer_fits(&self, changed: impl Iterator<Item = (usize, [DVec3; 3], f64)>) -> (bool, Vec<(usize, u32)>) {
        if self.finer.is_empty() {
            return (false, Vec::new());
        }
        let mut total = self.finer_total;
        let counts: Vec<(usize, u32)> = changed.map(|(i, t, e)| (i, count_pieces(&t, e * self.scale * 0.5))).collect();
        for &(i, c) in &counts {
            total = total - self.finer[i] as usize + c as usize;
        }
        (total <= self.limit, counts)
    }

    fn take_finer(&mut self, counts: Vec<(usize, u32)>) {
        for (i, c) in counts {
            self.finer_total = self.finer_total - self.finer[i] as usize + c as usize;
            self.finer[i] = c;
        }
    }

    /// The scale the budget multiplied the sizes asked by (1: as asked; infinite: no
    /// triangle split).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Takes `max_edge` as the sizes asked for `tris` (the triangles as last given)
    /// where they split into the same pieces as before; false, changing nothing,
    /// where one would split into others (build anew then).
    pub fn adopt_sizes(&mut self, tris: &[[DVec3; 3]], max_edge: &[f64]) -> bool {
        if max_edge.len() != self.asked.len() || tris.len() != self.asked.len() {
            return false;
        }
        let mut split = Vec::new();
        let changed: Vec<usize> = (0..tris.len()).filter(|&i| max_edge[i].to_bits() != self.asked[i].to_bits()).collect();
        for &i in &changed {
            split.clear();
            split_into(&tris[i], max_edge[i] * self.scale, &mut split);
            if split[..] != self.pieces[self.first[i] as usize..self.first[i + 1] as usize] {
                return false;
            }
        }
        let (fits, counts) = self.finer_fits(changed.iter().map(|&i| (i, tris[i], max_edge[i])));
        if fits {
            return false;
        }
        self.take_finer(counts);
        self.asked.copy_from_slice(max_edge);
        true
    }

    /// Pieces stored (triangles after [`build_refined`](Self::build_refined)'s split).
    pub fn piece_count(&self) -> usize {
        self.pieces.len()
    }

    fn build_pieces(tris: &[[DVec3; 3]]) -> Self {
        let mut idx: Vec<u32> = Vec::with_capacity(tris.len());
        let mut props = Vec::with_capacity(tris.len());
        for (i, t) in tris.iter().enumerate() {
            let pr = tri_props(t);
            props.push(pr);
            if pr.0 > 0.0 && pr.0.is_finite() {
                idx.push(i as u32);
            }
        }
        let mut tree = Self::default();
        if !idx.is_empty() {
            tree.nodes.reserve(2 * idx.len() / LEAF + 2);
            tree.split(&mut idx, &props, 0);
        }
        tree.order = idx;
        tree.tris = tree.order.iter().map(|&i| tris[i as usize]).collect();
        tree.place = vec![u32::MAX; tris.len()];
        tree.order.iter().enumerate().for_each(|(k, &i)| tree.place[i as usize] = k as u32);
        tree.leaf_of = vec![0; tree.tris.len()];
        tree.parent = vec![0; tree.nodes.len()];
        tree.boxes = vec![(DVec3::ZERO, DVec3::ZERO); tree.nodes.len()];
        for (n, node) in tree.nodes.iter().enumerate() {
            if node.count > 0 {
                (node.index..node.index + node.count).for_each(|k| tree.leaf_of[k as usize] = n as u32);
            } else {
                tree.parent[n + 1] = n as u32;
                tree.parent[node.index as usize] = n as u32;
            }
        }
        tree.refit_all();
        tree
    }

    /// Moves some triangles (original indices, as given to [`build`]) and refits the
    /// nodes above them only. Returns false, changing nothing, when one of them was
    /// left out of the tree as degenerate and now has an area, or now splits into
    /// another number of pieces: rebuild then.
    ///
    /// [`build`]: PatchTree::build
    pub fn refit_triangles(&mut self, moved: &[(usize, [DVec3; 3])]) -> bool {
        // A moved triangle splits as a build would split it: into as many pieces as
        // before (their leaves are refitted), or the tree is built again. The same
        // count may come in other pieces, where the move changed which edge is longest
        // (the bisection's order): those take the old ones' leaves.
        let mut splits = Vec::with_capacity(moved.len());
        for (i, t) in moved {
            let mut split = Vec::new();
            split_into(t, self.asked[*i] * self.scale, &mut split);
            if split.len() != (self.first[*i + 1] - self.first[*i]) as usize {
                return false;
            }
            splits.push(split);
        }
        let (fits, counts) = self.finer_fits(moved.iter().map(|&(i, t)| (i, t, self.asked[i])));
        if fits {
            return false;
        }
        let triangles: Vec<usize> = moved.iter().map(|m| m.0).collect();
        let moved: Vec<(usize, [DVec3; 3])> =
            moved.iter().zip(&splits).flat_map(|((i, t), split)| (self.first[*i] as usize..).zip(split.iter().map(|b| piece_of(t, b)))).collect();
        if moved.iter().any(|(k, piece)| self.place[*k] == u32::MAX && tri_props(piece).0 > 0.0) {
            return false;
        }
        self.take_finer(counts);
        for (i, split) in triangles.into_iter().zip(splits) {
            let start = self.first[i] as usize;
            self.pieces[start..start + split.len()].copy_from_slice(&split);
        }
        let mut nodes: Vec<u32> = Vec::with_capacity(moved.len());
        for (i, t) in &moved {
            let k = self.place[*i];
            if k == u32::MAX {
                continue;
            }
            let k = k as usize;
            self.tris[k] = *t;
            (self.tri_area[k], self.tri_centroid[k], self.tri_radius[k]) = tri_props(t);
            self.tri_second[k] = tri_second(t, self.tri_area[k], self.tri_centroid[k]);
            nodes.push(self.leaf_of[k]);
        }
        // Every ancestor once, children before parents (they have larger indices).
        let mut n = 0;
        while n < nodes.len() {
            let p = self.parent[nodes[n] as usize];
            if nodes[n] != 0 {
                nodes.push(p);
            }
            n += 1;
        }
        nodes.sort_unstable_by(|a, b| b.cmp(a));
        nodes.dedup();
        for n in nodes {
            self.refit_node(n as usize);
        }
        self.total_area = self.nodes.first().map_or(0.0, |r| r.area);
        true
    }

    fn split(&mut self, idx: &mut [u32], props: &[(f64, DVec3, f64)], first: usize) -> usize {
        let me = self.nodes.len();
        self.nodes.push(Node::default());
        if idx.len() <= LEAF {
            self.nodes[me].index = first as u32;
            self.nodes[me].count = idx.len() as u32;
            return me;
        }
        let (lo, hi) = idx.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &i| {
            let c = props[i as usize].1;
            (lo.min(c), hi.max(c))
        });
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let mid = idx.len() / 2;
        // Ties (the pieces of a split triangle often share a coordinate) go by the
        // rest of the centroid, area and size: the tree does not depend on the order
        // the triangles came in (a build in spatial order equals one in mesh order).
        let key = |i: u32| {
            let (area, c, r) = props[i as usize];
            [c[axis], c[(axis + 1) % 3], c[(axis + 2) % 3], area, r]
        };
        idx.select_nth_unstable_by(mid, |&a, &b| {
            key(a).iter().zip(key(b)).map(|(x, y)| x.total_cmp(&y)).find(|o| o.is_ne()).unwrap_or(std::cmp::Ordering::Equal)
        });
        let (l, r) = idx.split_at_mut(mid);
        self.split(l, props, first);
        let right = self.split(r, props, first + mid);
        self.nodes[me].index = right as u32;
        me
    }

    /// Recomputes areas, centroids and bounding spheres bottom-up (after vertices moved;
    /// the topology of the tree is kept).
    fn refit_all(&mut self) {
        let props: Vec<_> = self.tris.iter().map(tri_props).collect();
        self.tri_area = props.iter().map(|p| p.0).collect();
        self.tri_centroid = props.iter().map(|p| p.1).collect();
        self.tri_radius = props.iter().map(|p| p.2).collect();
        self.tri_second = self.tris.iter().zip(&props).map(|(t, p)| tri_second(t, p.0, p.1)).collect();
        self.total_area = self.tri_area.iter().sum();
        // Children have larger indices than parents: refit in reverse order.
        for n in (0..self.nodes.len()).rev() {
            self.refit_node(n);
        }
    }

    /// Area, centroid, second moment and bounding sphere of node `n` from its
    /// triangles or children (moments move to the new centroid by the parallel-axis rule).
    fn refit_node(&mut self, n: usize) {
        let node = self.nodes[n];
        let shifted = |c: DVec3, parts: &mut dyn Iterator<Item = (f64, DVec3, Sym)>| {
            parts.fold([0.0; 6], |q, (area, centroid, second)| add_sym(q, add_sym(second, outer(centroid - c, area))))
        };
        let (area, centroid, second, radius) = if node.count > 0 {
            let r = node.index as usize..(node.index + node.count) as usize;
            let area: f64 = self.tri_area[r.clone()].iter().sum();
            let c = if area > 0.0 { r.clone().map(|i| self.tri_centroid[i] * self.tri_area[i]).sum::<DVec3>() / area } else { self.tri_centroid[r.start] };
            let second = shifted(c, &mut r.clone().map(|i| (self.tri_area[i], self.tri_centroid[i], self.tri_second[i])));
            self.boxes[n] = self.tris[r.clone()].iter().flatten().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), p| (l.min(*p), h.max(*p)));
            let rad = self.tris[r].iter().flatten().map(|p| (*p - c).length()).fold(0.0, f64::max);
            (area, c, second, rad)
        } else {
            let (a, b) = (self.nodes[n + 1], self.nodes[node.index as usize]);
            let area = a.area + b.area;
            let c = if area > 0.0 { (a.centroid * a.area + b.centroid * b.area) / area } else { a.centroid };
            let second = shifted(c, &mut [(a.area, a.centroid, a.second), (b.area, b.centroid, b.second)].into_iter());
            let (ba, bb) = (self.boxes[n + 1], self.boxes[node.index as usize]);
            let (lo, hi) = (ba.0.min(bb.0), ba.1.max(bb.1));
            self.boxes[n] = (lo, hi);
            // The farther of the children's spheres, or of the box's corners: the box
            // is the tighter bound for compact nodes, the spheres for long thin ones.
            let spheres = (a.radius + (a.centroid - c).length()).max(b.radius + (b.centroid - c).length());
            let corner = (c - lo).abs().max((hi - c).abs()).length();
            let rad = spheres.min(corner);
            (area, c, second, rad)
        };
        self.nodes[n].area = area;
        self.nodes[n].centroid = centroid;
        self.nodes[n].second = second;
        self.nodes[n].radius = radius;
    }

    /// Whether segment `a`-`b` properly crosses one of the triangles. The field is
    /// singular on every one of them, so a trajectory (4.4) never crosses them; a
    /// step that would is too long.
    pub fn segment_crosses(&self, a: DVec3, b: DVec3) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let inv = DVec3::ONE / (b - a);
        let mut stack = [0u32; 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let n = stack[sp] as usize;
            let (lo, hi) = self.boxes[n];
            if !segment_meets_box(a, b, inv, lo, hi) {
                continue;
            }
            let node = self.nodes[n];
            if node.count > 0 {
                let r = node.index as usize..(node.index + node.count) as usize;
                if self.tris[r].iter().any(|t| segment_crosses_triangle(a, b, t)) {
                    return true;
                }
            } else {
                stack[sp] = n as u32 + 1;
                stack[sp + 1] = node.index;
                sp += 2;
            }
        }
        false
    }

    pub fn total_area(&self) -> f64 {
        self.total_area
    }
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Sums the contributions of the surface within `radius` of `x` (all of it for
    /// `f64::INFINITY`). `reference` is the direction `abs_along` is measured along.
    ///
    /// Localization (4.3.1) is soft: a patch counts with weight [`taper`] of its
    /// centroid's distance, 1 inside `TAPER * radius` and falling smoothly to 0 at
    /// `radius`; nothing beyond `radius` contributes. A sharp cut would force every node straddling the ball's
    /// boundary open down to its faces — most of the work of an evaluation, for
    /// contributions that are the smallest ones (`|x-y|^{-p-1}` at the ball's rim).
    pub fn eval(&self, x: DVec3, radius: f64, reference: DVec3, kernel: &Kernel) -> FieldEval {
        let mut out = FieldEval { clearance: f64::INFINITY, ..Default::default() };
        if self.nodes.is_empty() {
            return out;
        }
        let add = |w: f64, (v, push): (f64, DVec3), out: &mut FieldEval| {
            let push = push * w;
            out.value += v * w;
            out.push += push;
            out.abs_along += push.dot(reference).abs();
        };
        let theta2 = kernel.theta * kernel.theta;
        let mut stack = [0u32; 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let ni = stack[sp];
            let node = &self.nodes[ni as usize];
            let d = x - node.centroid;
            let r2 = d.length_squared();
            let reach = radius + node.radius;
            if r2 > reach * reach {
                out.clearance = out.clearance.min(radius);
                continue;
            }
            // Squared forms of `d - node.radius > radius` and `node.radius < theta d`.
            if node.radius * node.radius < theta2 * r2 {
                let r = r2.sqrt();
                out.clearance = out.clearance.min(r - node.radius);
                let w = taper(r, radius);
                if w > 0.0 {
                    add(w, kernel.point(node.area, &node.second, d, r2, r), &mut out);
                }
                continue;
            }
            if node.count > 0 {
                for i in node.index as usize..(node.index + node.count) as usize {
                    let d = x - self.tri_centroid[i];
                    let r2 = d.length_squared();
                    out.clearance = out.clearance.min(r2.sqrt() - self.tri_radius[i]);
                    if r2 >= radius * radius {
                        continue;
                    }
                    let r = r2.sqrt();
                    let w = taper(r, radius);
                    if w <= 0.0 {
                        continue;
                    }
                    if self.tri_area[i] == 0.0 {
                        continue; // degenerate since a refit: no area, no contribution
                    }
                    let tr = self.tri_radius[i];
                    if tr * tr < theta2 * r2 {
                        add(w, kernel.point(self.tri_area[i], &self.tri_second[i], d, r2, r), &mut out);
                    } else {
                        add(w, kernel.face(&self.tris[i], x), &mut out);
                    }
                }
            } else if sp + 2 <= stack.len() {
                stack[sp] = node.index;
                stack[sp + 1] = ni + 1;
                sp += 2;
            } else {
                out.clearance = 0.0; // a subtree left out: nothing is known of it
            }
        }
        out.clearance = out.clearance.max(0.0);
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sheet(n: usize, lift: impl Fn(usize) -> f64) -> Vec<[DVec3; 3]> {
        let p = |i: usize, j: usize| DVec3::new(i as f64, j as f64, lift(i * (n + 1) + j));
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..n {
                tris.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
                tris.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
            }
        }
        tris
    }

    /// One patch (a curved sheet) summed as the root's point mass, with and without its
    /// quadrupole term, against every face integrated exactly.
    #[test]
    fn quadrupole_term_cuts_the_far_field_error_by_an_order_and_is_a_gradient() {
        let tris = sheet(6, |k| 0.05 * ((k % 7) as f64) + 0.02 * ((k / 7) as f64).powi(2));
        let tree = PatchTree::build(&tris);
        let root = tree.nodes[0];
        let exact = Kernel::new(3.0, 0.0);
        let mut worst = [0.0f64; 2];
        for (k, dir) in [DVec3::new(0.3, 0.2, 1.0), DVec3::new(1.0, -0.4, 0.5), DVec3::new(-0.7, 0.9, -0.2)].iter().enumerate() {
            let x = root.centroid + dir.normalize() * root.radius * (3.0 + k as f64);
            let want = tree.eval(x, f64::INFINITY, DVec3::Z, &exact);
            let d = x - root.centroid;
            let (r2, r) = (d.length_squared(), d.length());
            for (slot, second) in [[0.0; 6], root.second].iter().enumerate() {
                let (value, push) = exact.point(root.area, second, d, r2, r);
                let err = ((value - want.value).abs() / want.value).max((push - want.push).length() / want.push.length());
                worst[slot] = worst[slot].max(err);
            }
            // The corrected push is minus the gradient of the corrected value.
            let h = 1e-5 * r;
            let value_at = |x: DVec3| {
                let d = x - root.centroid;
                exact.point(root.area, &root.second, d, d.length_squared(), d.length()).0
            };
            let (_, push) = exact.point(root.area, &root.second, d, r2, r);
            for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
                let fd = -(value_at(x + axis * h) - value_at(x - axis * h)) / (2.0 * h);
                assert!((fd - push.dot(axis)).abs() <= 1e-6 * push.length(), "{fd} vs {}", push.dot(axis));
            }
        }
        let [monopole, quadrupole] = worst;
        assert!(monopole > 1e-3, "the test patch must be far from a point: {monopole}");
        assert!(quadrupole < 0.1 * monopole, "monopole {monopole:.2e}, quadrupole {quadrupole:.2e}");
    }

    #[test]
    fn refitting_some_triangles_matches_a_rebuilt_tree() {
        let flat = sheet(12, |_| 0.0);
        let bumped = sheet(12, |k| if (40..60).contains(&k) { 0.3 } else { 0.0 });
        let moved: Vec<(usize, [DVec3; 3])> = flat.iter().zip(&bumped).enumerate().filter(|(_, (a, b))| a != b).map(|(i, (_, b))| (i, *b)).collect();
        assert!(!moved.is_empty() && moved.len() < flat.len() / 4);
        let mut tree = PatchTree::build(&flat);
        assert!(tree.refit_triangles(&moved));
        let rebuilt = PatchTree::build(&bumped);
        let exact = Kernel::new(3.0, 0.0);
        for x in [DVec3::new(3.0, 4.0, 1.0), DVec3::new(6.5, 2.2, -0.7), DVec3::new(11.0, 11.0, 2.0)] {
            let (a, b) = (tree.eval(x, 5.0, DVec3::Z, &exact), rebuilt.eval(x, 5.0, DVec3::Z, &exact));
            assert!((a.push - b.push).length() <= 1e-9 * b.push.length() && (a.value - b.value).abs() <= 1e-9 * b.value, "{a:?} vs {b:?}");
        }
        assert!((tree.total_area() - rebuilt.total_area()).abs() < 1e-9);
        // The whole surface's second moment does not depend on how the tree groups it.
        let (a, b) = (tree.nodes[0].second, rebuilt.nodes[0].second);
        assert!(a.iter().zip(&b).all(|(a, b)| (a - b).abs() <= 1e-9 * b.abs().max(1.0)), "{a:?} vs {b:?}");
        // Every node's sphere holds its triangles after the refit (and after the build).
        for t in [&tree, &rebuilt] {
            for (k, tri) in t.tris.iter().enumerate() {
                let mut n = t.leaf_of[k] as usize;
                loop {
                    let node = t.nodes[n];
                    assert!(tri.iter().all(|q| (*q - node.centroid).length() <= node.radius + 1e-9), "node {n}");
                    if n == 0 {
                        break;
                    }
                    n = t.parent[n] as usize;
                }
            }
        }
    }

    /// The clearance an evaluation reports never exceeds the distance to the nearest
    /// triangle (brute force), with a localization ball or without, and is not
    /// uselessly small: near a sheet it is within its faces' size of the distance.
    #[test]
    fn clearance_is_a_lower_bound_on_the_distance_to_the_surface() {
        use crate::shell::intersect::point_triangle_distance2;
        let tris = sheet(16, |k| 0.3 * ((k % 5) as f64).sin() + 0.01 * (k as f64));
        let tree = PatchTree::build(&tris);
        let kernel = Kernel::new(3.0, 0.65);
        let mut rng = crate::test_rng::Rng(0x2545_f491);
        let mut rand = || rng.uniform();
        let mut useful = 0;
        for k in 0..400 {
            let x = DVec3::new(20.0 * rand() - 2.0, 20.0 * rand() - 2.0, 6.0 * rand() - 2.0);
            let radius = if k % 2 == 0 { f64::INFINITY } else { 1.0 + 4.0 * rand() };
            let e = tree.eval(x, radius, DVec3::Z, &kernel);
            let nearest = tris.iter().map(|t| point_triangle_distance2(x, t).sqrt()).fold(f64::INFINITY, f64::min);
            assert!(e.clearance <= nearest * (1.0 + 1e-12), "clearance {} beyond the nearest triangle at {nearest}", e.clearance);
            useful += usize::from(e.clearance >= nearest - 1.5);
        }
        assert!(useful > 300, "clearance within a face size of the distance at only {useful} of 400 points");
    }

    #[test]
    fn a_degenerate_triangle_gaining_area_asks_for_a_rebuild() {
        let mut tris = sheet(3, |_| 0.0);
        let c = tris[4][0];
        let flat = tris[4];
        tris[4] = [c, c, c];
        let mut tree = PatchTree::build(&tris);
        assert_eq!(tree.triangle_count(), tris.len() - 1);
        assert!(!tree.refit_triangles(&[(4, flat)]));
        // Collapsing a triangle is fine: it stops contributing.
        assert!(tree.refit_triangles(&[(5, [c, c, c])]));
        let e = tree.eval(DVec3::new(1.5, 1.5, 0.5), f64::INFINITY, DVec3::Z, &Kernel::new(3.0, 0.0));
        assert!(e.value.is_finite() && e.push.is_finite());
    }

    /// A fan of slivers (a CAD face from an STL file: every triangle from one corner
    /// across the face), then one of them moved.
    fn fan(n: usize, lift: f64) -> Vec<[DVec3; 3]> {
        let apex = DVec3::new(0.0, 0.0, 0.0);
        let rim = |k: usize| DVec3::new(10.0, k as f64 * 10.0 / n as f64, lift * (k % 3) as f64);
        (0..n).map(|k| [apex, rim(k), rim(k + 1)]).collect()
    }

    /// Splitting changes no exact value (the integral over a triangle is the sum over
    /// its pieces), keeps within the piece size and the budget, and a refit moves the
    /// pieces with their triangle.
    #[test]
    fn refined_tree_integrates_the_same_surface_in_pieces_within_its_budget() {
        let tris = fan(40, 0.05);
        let exact = Kernel::new(3.0, 0.0);
        let whole = PatchTree::build(&tris);
        let split = PatchTree::build_refined(&tris, &[1.0; 40], 40 * 100);
        assert!(split.piece_count() > 8 * tris.len() && split.piece_count() <= tris.len() + 40 * 100, "{}", split.piece_count());
        assert_eq!((split.scale, &split.asked[..]), (1.0, &[1.0; 40][..]));
        assert!(split.tris.iter().all(|t| (0..3).all(|k| (t[(k + 1) % 3] - t[k]).length() <= 1.0 + 1e-12)));
        assert!((split.total_area() - whole.total_area()).abs() <= 1e-9 * whole.total_area());
        let check = |a: &PatchTree, b: &PatchTree| {
            for x in [DVec3::new(3.0, 4.0, 1.0), DVec3::new(9.5, 2.2, -0.3), DVec3::new(0.2, 0.1, 0.05), DVec3::new(12.0, 11.0, 2.0)] {
                let (a, b) = (a.eval(x, f64::INFINITY, DVec3::Z, &exact), b.eval(x, f64::INFINITY, DVec3::Z, &exact));
                assert!((a.push - b.push).length() <= 1e-8 * b.push.length() && (a.value - b.value).abs() <= 1e-8 * b.value, "{a:?} vs {b:?}");
            }
        };
        check(&split, &whole);
        // A tight budget doubles the piece size until the pieces fit.
        let capped = PatchTree::build_refined(&tris, &[1.0; 40], 200);
        assert!(capped.scale > 1.0 && capped.piece_count() <= tris.len() + 200, "{} pieces at {}", capped.piece_count(), capped.scale);
        check(&capped, &whole);
        // Moving a sliver a little moves its pieces: the same field as the moved
        // triangles whole. Moved so far that it splits otherwise, it asks for a build.
        let mut moved = tris.clone();
        moved[7][2] += DVec3::new(0.0, 0.0, 0.01);
        let mut refit = split.clone();
        assert!(refit.refit_triangles(&[(7, moved[7])]));
        check(&refit, &PatchTree::build(&moved));
        // Moved so that its other long edge is the longest, the sliver splits into as
        // many pieces but other ones: refitted, it holds the pieces a build makes (an
        // update rebuilt the whole tree here before).
        let mut swapped = tris.clone();
        swapped[7][1] += DVec3::new(0.1, 0.0, 0.0);
        let built = PatchTree::build_refined(&swapped, &[1.0; 40], 40 * 100);
        let pieces = |t: &PatchTree| t.pieces[t.first[7] as usize..t.first[8] as usize].to_vec();
        assert_ne!(pieces(&split), pieces(&built));
        let mut refit_swapped = split.clone();
        assert!(refit_swapped.refit_triangles(&[(7, swapped[7])]));
        assert_eq!(pieces(&refit_swapped), pieces(&built));
        check(&refit_swapped, &PatchTree::build(&swapped));
        moved[7][2] += DVec3::new(0.5, -0.2, 1.5);
        assert!(!refit.refit_triangles(&[(7, moved[7])]));
    }

    /// The far pieces of a split sliver are accepted as patches by the Barnes-Hut
    /// walk (their moments are the pieces', not the sliver's): the approximated field
    /// stays within 2% of the exact one near the fan's apex and away from it.
    #[test]
    fn refined_tree_keeps_the_approximation_close_to_exact() {
        let tris = fan(60, 0.02);
        let exact = Kernel::new(3.0, 0.0);
        let fast = Kernel::new(3.0, 0.65);
        let split = PatchTree::build_refined(&tris, &[0.5; 60], 60 * 256);
        for x in [DVec3::new(1.0, 0.5, 0.8), DVec3::new(8.0, 3.0, 0.4), DVec3::new(5.0, 9.0, -1.0)] {
            let (a, b) = (split.eval(x, f64::INFINITY, DVec3::Z, &fast), split.eval(x, f64::INFINITY, DVec3::Z, &exact));
            let angle = a.push.angle_between(b.push);
            assert!(angle < 0.02 && (a.value - b.value).abs() < 0.02 * b.value, "at {x}: {a:?} vs {b:?} ({angle} rad)");
        }
    }

    /// Sizes far too small for the triangles (a thickness of 1e-20 against unit
    /// slivers) split nothing rather than running out of memory or indices.
    #[test]
    fn absurdly_small_pieces_split_nothing() {
        let tris = fan(100, 0.05);
        let tree = PatchTree::build_refined(&tris, &[1e-20; 100], 800);
        assert_eq!((tree.piece_count(), tree.scale()), (100, f64::INFINITY));
        assert!((tree.total_area() - PatchTree::build(&tris).total_area()).abs() <= 1e-12 * tree.total_area());
    }

    /// Where the budget doubled the sizes, an edit that would let a build split at
    /// the finer scale again is refused by the refit (a rebuild then makes what a
    /// build would); one that keeps the counts is refitted.
    #[test]
    fn a_refit_refuses_what_a_build_would_split_finer() {
        let tris = fan(40, 0.05);
        let sizes = [1.0; 40];
        let unbounded = PatchTree::build_refined(&tris, &sizes, usize::MAX / 2).piece_count();
        let tight = PatchTree::build_refined(&tris, &sizes, unbounded - 1 - 40);
        assert_eq!(tight.scale(), 2.0);
        let mut lifted = tris[7];
        lifted[2] += DVec3::new(0.0, 0.0, 1e-6);
        assert!(tight.clone().refit_triangles(&[(7, lifted)]));
        // Sliver 7 shrunk to a speck: one piece at any scale, so scale 1 now fits.
        let speck = [tris[7][0], tris[7][0] + DVec3::new(1e-3, 0.0, 0.0), tris[7][0] + DVec3::new(0.0, 1e-3, 0.0)];
        let mut moved = tris.clone();
        moved[7] = speck;
        assert_eq!(PatchTree::build_refined(&moved, &sizes, unbounded - 1 - 40).scale(), 1.0);
        assert!(!tight.clone().refit_triangles(&[(7, speck)]));
    }
}
