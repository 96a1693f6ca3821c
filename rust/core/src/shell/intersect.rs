//! Triangle intersection tests for shell reports: an AABB tree over triangles and a
//! tri–tri test built from orientation determinants in f64 (two triangles intersect
//! when an edge of one properly crosses the other). Pairs that merely touch, and
//! coplanar overlaps, are not counted by [`triangles_intersect`]; [`triangles_meet`]
//! counts them too, from exact point-triangle and segment-segment distances.

use glam::DVec3;
use rayon::prelude::*;

#[inline]
fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (b - a).cross(c - a).dot(d - a)
}

/// Whether segment `p q` properly crosses triangle `t` (its plane strictly, inside the
/// closed triangle).
pub fn segment_crosses_triangle(p: DVec3, q: DVec3, t: &[DVec3; 3]) -> bool {
    let (dp, dq) = (orient(t[0], t[1], t[2], p), orient(t[0], t[1], t[2], q));
    if !(dp * dq < 0.0) {
        return false;
    }
    let s1 = orient(p, q, t[0], t[1]);
    let s2 = orient(p, q, t[1], t[2]);
    let s3 = orient(p, q, t[2], t[0]);
    (s1 >= 0.0 && s2 >= 0.0 && s3 >= 0.0) || (s1 <= 0.0 && s2 <= 0.0 && s3 <= 0.0)
}

/// Whether two triangles intersect (an edge of either properly crosses the other).
pub fn triangles_intersect(a: &[DVec3; 3], b: &[DVec3; 3]) -> bool {
    (0..3).any(|i| segment_crosses_triangle(a[i], a[(i + 1) % 3], b)) || (0..3).any(|i| segment_crosses_triangle(b[i], b[(i + 1) % 3], a))
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
    if triangles_intersect(a, b) {
        return true;
    }
    let e2 = eps * eps;
    (0..3).any(|i| point_triangle_distance2(a[i], b) <= e2 || point_triangle_distance2(b[i], a) <= e2)
        || (0..3).any(|i| (0..3).any(|j| segment_segment_distance2(a[i], a[(i + 1) % 3], b[j], b[(j + 1) % 3]) <= e2))
}

/// Whether segment `a`-`b` meets the box `[lo, hi]` (slab test; `inv` is
/// `1 / (b - a)`). An axis the segment runs parallel to is decided by `a` alone; a
/// little slack keeps a segment grazing a face from being lost to rounding.
#[inline]
pub(crate) fn segment_meets_box(a: DVec3, b: DVec3, inv: DVec3, lo: DVec3, hi: DVec3) -> bool {
    let d = b - a;
    let (t0, t1) = ((lo - a) * inv, (hi - a) * inv);
    let (mut enter, mut exit) = (0.0f64, 1.0f64);
    for k in 0..3 {
        if d[k] == 0.0 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return false;
            }
        } else {
            enter = enter.max(t0[k].min(t1[k]));
            exit = exit.min(t0[k].max(t1[k]));
        }
    }
    enter <= exit + 1e-9
}

#[derive(Debug, Clone, Copy)]
struct BoxNode {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first item; internal: second child.
    index: u32,
    count: u32,
}

/// AABB tree over triangles for overlap queries.
#[derive(Debug, Clone, Default)]
pub struct TriBvh {
    nodes: Vec<BoxNode>,
    /// Items in leaf order, and their boxes in the same order (a leaf's boxes are
    /// read in one sweep).
    items: Vec<u32>,
    boxes: Vec<(DVec3, DVec3)>,
    /// Where each item sits in `items` (and its box in `boxes`), for refits.
    slot_of: Vec<u32>,
    /// Parent of each node (the root's is itself) and leaf of each item, for
    /// [`refit_items`](Self::refit_items).
    parent: Vec<u32>,
    leaf_of: Vec<u32>,
}

pub fn tri_box(t: &[DVec3; 3]) -> (DVec3, DVec3) {
    (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
}

impl TriBvh {
    pub fn build(tris: &[[DVec3; 3]]) -> Self {
        Self::from_boxes(tris.iter().map(tri_box).collect())
    }

    /// The number of items.
    pub fn len(&self) -> usize {
        self.boxes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty()
    }

    /// A tree over boxes (one per item) rather than triangles.
    pub fn from_boxes(boxes: Vec<(DVec3, DVec3)>) -> Self {
        let mut items: Vec<u32> = (0..boxes.len() as u32).collect();
        let mut me = Self { nodes: Vec::new(), items: Vec::new(), boxes, slot_of: Vec::new(), parent: Vec::new(), leaf_of: Vec::new() };
        if !items.is_empty() {
            me.split(&mut items, 0);
        }
        me.boxes = items.iter().map(|&i| me.boxes[i as usize]).collect();
        me.slot_of = vec![0; items.len()];
        items.iter().enumerate().for_each(|(slot, &i)| me.slot_of[i as usize] = slot as u32);
        me.items = items;
        me.parent = vec![0; me.nodes.len()];
        me.leaf_of = vec![0; me.boxes.len()];
        for (n, node) in me.nodes.iter().enumerate() {
            if node.count > 0 {
                me.items[node.index as usize..(node.index + node.count) as usize].iter().for_each(|&i| me.leaf_of[i as usize] = n as u32);
            } else {
                me.parent[n + 1] = n as u32;
                me.parent[node.index as usize] = n as u32;
            }
        }
        me
    }

    /// Moves some items to new boxes and refits only the nodes above them: work in
    /// proportion to the items times the depth (the repair's later rounds).
    pub fn refit_items(&mut self, moved: impl Iterator<Item = (u32, (DVec3, DVec3))>) {
        for (i, b) in moved {
            self.boxes[self.slot_of[i as usize] as usize] = b;
            let mut n = self.leaf_of[i as usize] as usize;
            loop {
                let (lo, hi) = self.node_box(n);
                let node = &mut self.nodes[n];
                if node.lo == lo && node.hi == hi {
                    break; // unchanged here, so unchanged above
                }
                (node.lo, node.hi) = (lo, hi);
                if n == 0 {
                    break;
                }
                n = self.parent[n] as usize;
            }
        }
    }

    /// A node's box from its items (leaf) or children.
    fn node_box(&self, n: usize) -> (DVec3, DVec3) {
        let node = self.nodes[n];
        if node.count > 0 {
            self.boxes[node.index as usize..(node.index + node.count) as usize]
                .iter()
                .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), b| (l.min(b.0), h.max(b.1)))
        } else {
            let (a, b) = (self.nodes[n + 1], self.nodes[node.index as usize]);
            (a.lo.min(b.lo), a.hi.max(b.hi))
        }
    }

    fn split(&mut self, items: &mut [u32], first: usize) -> usize {
        let (lo, hi) = items.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &i| {
            let b = self.boxes[i as usize];
            (l.min(b.0), h.max(b.1))
        });
        let me = self.nodes.len();
        self.nodes.push(BoxNode { lo, hi, index: first as u32, count: items.len() as u32 });
        if items.len() <= 4 {
            return me;
        }
        let e = hi - lo;
        let axis = if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        };
        let mid = items.len() / 2;
        let key = |i: &u32| {
            let b = self.boxes[*i as usize];
            b.0[axis] + b.1[axis]
        };
        items.select_nth_unstable_by(mid, |a, b| key(a).total_cmp(&key(b)));
        let (l, r) = items.split_at_mut(mid);
        self.split(l, first);
        let right = self.split(r, first + mid);
        self.nodes[me].index = right as u32;
        self.nodes[me].count = 0;
        me
    }

    /// Moves every item to a new box (same count and order as built) and recomputes
    /// the nodes bottom-up, keeping the tree's topology: O(n).
    pub fn refit_boxes(&mut self, boxes: impl Iterator<Item = (DVec3, DVec3)>) {
        boxes.zip(&self.slot_of).for_each(|(b, &slot)| self.boxes[slot as usize] = b);
        // Children always follow their parent: refit in reverse order.
        for n in (0..self.nodes.len()).rev() {
            (self.nodes[n].lo, self.nodes[n].hi) = self.node_box(n);
        }
    }

    /// Calls `f` with every triangle whose box the segment `a`-`b` meets (slab test
    /// per node: a long slanted segment visits far fewer nodes than its box would).
    pub fn query_segment(&self, a: DVec3, b: DVec3, mut f: impl FnMut(u32)) {
        self.any_on_segment(a, b, |i| {
            f(i);
            false
        });
    }

    /// Whether `found` holds for a triangle whose box the segment `a`-`b` meets;
    /// stops at the first.
    pub fn any_on_segment(&self, a: DVec3, b: DVec3, found: impl FnMut(u32) -> bool) -> bool {
        let inv = DVec3::ONE / (b - a);
        self.walk(|lo, hi| segment_meets_box(a, b, inv, lo, hi), found)
    }

    /// Calls `f` with every triangle whose box overlaps `[lo, hi]`.
    pub fn query(&self, lo: DVec3, hi: DVec3, mut f: impl FnMut(u32)) {
        self.any(lo, hi, |i| {
            f(i);
            false
        });
    }

    /// Whether `found` holds for a triangle whose box overlaps `[lo, hi]`; stops at
    /// the first.
    pub fn any(&self, lo: DVec3, hi: DVec3, found: impl FnMut(u32) -> bool) -> bool {
        self.walk(|l, h| !(l.cmpgt(hi).any() || h.cmplt(lo).any()), found)
    }

    /// The pairs `(i, j)`, `i < j`, whose boxes overlap and that `keep` accepts, in
    /// no particular order: one traversal of the tree against itself (each pair of
    /// overlapping nodes visited once), in parallel, rather than one query per item.
    pub fn overlapping_pairs(&self, keep: &(impl Fn(u32, u32) -> bool + Sync)) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        if !self.nodes.is_empty() {
            Join { a: self, b: self, keep, same: true }.within(0, 0, &mut out);
        }
        out
    }

    /// The pairs (item of `self`, item of `other`) whose boxes overlap and that
    /// `keep` accepts, in no particular order: one traversal of both trees.
    pub fn overlapping_pairs_with(&self, other: &TriBvh, keep: &(impl Fn(u32, u32) -> bool + Sync)) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        if !self.nodes.is_empty() && !other.nodes.is_empty() {
            Join { a: self, b: other, keep, same: false }.across(0, 0, 0, &mut out);
        }
        out
    }

    /// Calls `found` with every item whose box, and every ancestor's, passes `meets`,
    /// until it returns true (then returns true).
    fn walk(&self, meets: impl Fn(DVec3, DVec3) -> bool, mut found: impl FnMut(u32) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack = [0u32; 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let n = stack[sp];
            let node = self.nodes[n as usize];
            if !meets(node.lo, node.hi) {
                continue;
            }
            if node.count > 0 {
                let range = node.index as usize..(node.index + node.count) as usize;
                for (&i, b) in self.items[range.clone()].iter().zip(&self.boxes[range]) {
                    if meets(b.0, b.1) && found(i) {
                        return true;
                    }
                }
            } else if sp + 2 <= stack.len() {
                stack[sp] = n + 1;
                stack[sp + 1] = node.index;
                sp += 2;
            }
        }
        false
    }
}

/// A part of a [`Join`]'s traversal, adding the pairs it finds.
type Part<'a> = &'a (dyn Fn(&mut Vec<(u32, u32)>) + Sync);

/// Two trees (or one tree twice, `same`) traversed against each other for
/// overlapping item pairs.
struct Join<'t, K> {
    a: &'t TriBvh,
    b: &'t TriBvh,
    keep: &'t K,
    same: bool,
}

impl<K: Fn(u32, u32) -> bool + Sync> Join<'_, K> {
    /// Depth below which the traversal stays on one thread.
    const PARALLEL_DEPTH: u32 = 10;

    /// Pairs within node `n` of the one tree (`same`).
    fn within(&self, n: u32, depth: u32, out: &mut Vec<(u32, u32)>) {
        let node = self.a.nodes[n as usize];
        if node.count > 0 {
            let range = node.index as usize..(node.index + node.count) as usize;
            for x in range.clone() {
                for y in x + 1..range.end {
                    self.leaf_pair(x, y, out);
                }
            }
            return;
        }
        let (l, r) = (n + 1, node.index);
        self.fork(depth, out, [&|o| self.within(l, depth + 1, o), &|o| self.within(r, depth + 1, o), &|o| self.across(l, r, depth + 1, o)]);
    }

    /// Pairs between node `x` of `a` and node `y` of `b`.
    fn across(&self, x: u32, y: u32, depth: u32, out: &mut Vec<(u32, u32)>) {
        let (nx, ny) = (self.a.nodes[x as usize], self.b.nodes[y as usize]);
        if nx.lo.cmpgt(ny.hi).any() || nx.hi.cmplt(ny.lo).any() {
            return;
        }
        if nx.count > 0 && ny.count > 0 {
            for i in nx.index as usize..(nx.index + nx.count) as usize {
                for j in ny.index as usize..(ny.index + ny.count) as usize {
                    self.leaf_pair(i, j, out);
                }
            }
            return;
        }
        // Descend the node that is not a leaf, or the bigger one.
        let size = |n: &BoxNode| (n.hi - n.lo).length_squared();
        if ny.count > 0 || (nx.count == 0 && size(&nx) >= size(&ny)) {
            self.fork(depth, out, [&|o| self.across(x + 1, y, depth + 1, o), &|o| self.across(nx.index, y, depth + 1, o)]);
        } else {
            self.fork(depth, out, [&|o| self.across(x, y + 1, depth + 1, o), &|o| self.across(x, ny.index, depth + 1, o)]);
        }
    }

    /// Runs the parts, in parallel near the root.
    fn fork<const N: usize>(&self, depth: u32, out: &mut Vec<(u32, u32)>, parts: [Part<'_>; N]) {
        if depth >= Self::PARALLEL_DEPTH {
            parts.iter().for_each(|part| part(out));
            return;
        }
        let found: Vec<Vec<(u32, u32)>> = parts
            .into_par_iter()
            .map(|part| {
                let mut o = Vec::new();
                part(&mut o);
                o
            })
            .collect();
        found.into_iter().for_each(|f| out.extend(f));
    }

    /// Slots `x` of `a` and `y` of `b`: kept as an item pair (ordered, for one tree)
    /// when their boxes overlap and `keep` accepts it.
    fn leaf_pair(&self, x: usize, y: usize, out: &mut Vec<(u32, u32)>) {
        let (bx, by) = (self.a.boxes[x], self.b.boxes[y]);
        if bx.0.cmpgt(by.1).any() || bx.1.cmplt(by.0).any() {
            return;
        }
        let (mut i, mut j) = (self.a.items[x], self.b.items[y]);
        if self.same && i > j {
            (i, j) = (j, i);
        }
        if (self.keep)(i, j) {
            out.push((i, j));
        }
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
        partial.refit_items(
            [(1, tri_box(&above.map(|p| p - DVec3::Z * 1.5))), (2, tri_box(&crossing.map(|p| p + DVec3::X * 5.0)))].into_iter(),
        );
        assert_eq!(query(&partial), vec![0, 1]);
        partial.refit_items(std::iter::once((2, tri_box(&crossing))));
        assert_eq!(query(&partial), vec![0, 1, 2]);
    }

    /// Random small boxes in a unit cube, overlapping some of their neighbours.
    fn random_boxes(n: usize, seed: u64) -> Vec<(DVec3, DVec3)> {
        let mut state = seed;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let lo = DVec3::new(rnd(), rnd(), rnd());
                (lo, lo + DVec3::new(rnd(), rnd(), rnd()) * 0.1)
            })
            .collect()
    }

    fn meets(a: &(DVec3, DVec3), b: &(DVec3, DVec3)) -> bool {
        !(a.0.cmpgt(b.1).any() || a.1.cmplt(b.0).any())
    }

    #[test]
    fn tree_joins_find_every_overlapping_pair_once() {
        // Enough items for the parallel part of the traversal and for deep leaves.
        let (a, b) = (random_boxes(3000, 1), random_boxes(2000, 2));
        let keep = |i: u32, j: u32| !(i + j).is_multiple_of(3); // the filter is applied
        let (ta, tb) = (TriBvh::from_boxes(a.clone()), TriBvh::from_boxes(b.clone()));
        let mut within = ta.overlapping_pairs(&keep);
        within.sort_unstable();
        let mut brute = Vec::new();
        for i in 0..a.len() {
            for j in i + 1..a.len() {
                if meets(&a[i], &a[j]) && keep(i as u32, j as u32) {
                    brute.push((i as u32, j as u32));
                }
            }
        }
        assert!(brute.len() > 1000, "the test needs many overlaps: {}", brute.len());
        assert_eq!(within, brute);
        let mut across = ta.overlapping_pairs_with(&tb, &keep);
        across.sort_unstable();
        let mut brute = Vec::new();
        for (i, x) in a.iter().enumerate() {
            for (j, y) in b.iter().enumerate() {
                if meets(x, y) && keep(i as u32, j as u32) {
                    brute.push((i as u32, j as u32));
                }
            }
        }
        assert_eq!(across, brute);
        // After a refit the joins see the moved boxes.
        let mut moved = ta.clone();
        let shifted: Vec<_> = a.iter().map(|(l, h)| (*l + DVec3::X * 0.5, *h + DVec3::X * 0.5)).collect();
        moved.refit_boxes(shifted.iter().copied());
        let mut across = moved.overlapping_pairs_with(&tb, &|_, _| true);
        across.sort_unstable();
        let brute: Vec<(u32, u32)> =
            (0..a.len()).flat_map(|i| (0..b.len()).map(move |j| (i, j))).filter(|&(i, j)| meets(&shifted[i], &b[j])).map(|(i, j)| (i as u32, j as u32)).collect();
        assert_eq!(across, brute);
        // Moving some items one by one (their slots in leaf order) gives the same
        // joins as moving all.
        let mut partly = ta.clone();
        partly.refit_items((0..a.len() as u32).step_by(3).map(|i| (i, shifted[i as usize])));
        let now: Vec<_> = (0..a.len()).map(|i| if i % 3 == 0 { shifted[i] } else { a[i] }).collect();
        let mut within = partly.overlapping_pairs(&|_, _| true);
        within.sort_unstable();
        let brute: Vec<(u32, u32)> =
            (0..a.len()).flat_map(|i| (i + 1..a.len()).map(move |j| (i, j))).filter(|&(i, j)| meets(&now[i], &now[j])).map(|(i, j)| (i as u32, j as u32)).collect();
        assert_eq!(within, brute);
        // Early exit: `any` stops at the first accepted item and agrees with `query`.
        let probe = (DVec3::splat(0.4), DVec3::splat(0.6));
        let mut all = Vec::new();
        ta.query(probe.0, probe.1, |i| all.push(i));
        let mut seen = 0;
        assert!(all.len() > 1);
        assert!(ta.any(probe.0, probe.1, |i| {
            seen += 1;
            i == all[0]
        }));
        assert_eq!(seen, 1, "the walk visits items in the same order and stops at the first accepted");
        assert!(!ta.any(probe.0, probe.1, |_| false));
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

    #[test]
    fn distances_agree_with_sampling_and_touching_pairs_meet() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
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
}
