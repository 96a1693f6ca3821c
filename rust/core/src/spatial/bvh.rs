//! A bounding volume hierarchy over axis-aligned boxes, one per item: median splits
//! on the longest axis of the node's box, leaves of at most four items,
//! children stored depth first (the left child right after its parent). Queries walk
//! it with a fixed stack; two trees (or one with itself) are joined by a simultaneous
//! descent (Ericson, *Real-Time Collision Detection*, 6.3.2), in parallel near the
//! roots.
//!
//! Boxes are `f64`: the shell's geometry is `f64` (its boxes must hold exactly what
//! its exact predicates test), and `f32` boxes widen to `f64` exactly, so the
//! renderers' `f32` data loses nothing; their rays are `f64` already.

use glam::DVec3;
use rayon::prelude::*;

/// Most items in a leaf.
const LEAF_SIZE: usize = 4;

/// Möller–Trumbore: the ray parameter `h > 0` where `o + h d` meets triangle `t`, if
/// it does.
pub fn ray_triangle(o: DVec3, d: DVec3, t: &[DVec3; 3]) -> Option<f64> {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let s = o - t[0];
    let u = s.dot(pv) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let h = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && h > 0.0).then_some(h)
}

/// The box of a triangle.
#[inline]
pub fn tri_box(t: &[DVec3; 3]) -> (DVec3, DVec3) {
    (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
}

/// Whether segment `a`-`b` meets the box `[lo, hi]` (slab test; `inv` is
/// `1 / (b - a)`). An axis the segment runs parallel to is decided by `a` alone; a
/// little slack keeps a segment grazing a face from being lost to rounding.
#[inline]
pub fn segment_meets_box(a: DVec3, b: DVec3, inv: DVec3, lo: DVec3, hi: DVec3) -> bool {
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

/// The span `[t0, t1]` of the ray `origin + t dir`, `t ∈ [0, t_far]`, inside the box
/// `[lo, hi]` (slab test; `inv` is `1 / dir`), if it meets it. An axis the ray runs
/// parallel to is decided by the origin alone, as in [`segment_meets_box`]: the slab
/// formula's `0 · ∞` would be NaN there, and a ray in a box's face plane (axis-aligned
/// meshes) would miss the box.
#[inline]
fn ray_span(origin: DVec3, inv: DVec3, t_far: f64, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, t_far);
    for k in 0..3 {
        if inv[k].is_infinite() {
            if origin[k] < lo[k] || origin[k] > hi[k] {
                return None;
            }
        } else {
            let (a, b) = ((lo[k] - origin[k]) * inv[k], (hi[k] - origin[k]) * inv[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

#[inline]
fn boxes_meet(a: &(DVec3, DVec3), b: &(DVec3, DVec3)) -> bool {
    !(a.0.cmpgt(b.1).any() || a.1.cmplt(b.0).any())
}

#[derive(Debug, Clone, Copy)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: first slot; internal: second child.
    index: u32,
    /// Leaf: its items; internal: 0.
    count: u32,
}

/// A bounding volume hierarchy over the boxes of items `0..n`.
#[derive(Debug, Clone, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
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

impl Bvh {
    /// A tree over `boxes`, item `i` having `boxes[i]` (`lo <= hi`).
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

    /// A tree over the boxes of triangles ([`tri_box`]).
    pub fn from_triangles(tris: &[[DVec3; 3]]) -> Self {
        Self::from_boxes(tris.iter().map(tri_box).collect())
    }

    /// The number of items.
    pub fn len(&self) -> usize {
        self.boxes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty()
    }

    /// Builds node `items` (slots from `first` on) and those below it; returns it.
    fn split(&mut self, items: &mut [u32], first: usize) -> usize {
        let (lo, hi) = items.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), &i| {
            let b = self.boxes[i as usize];
            (l.min(b.0), h.max(b.1))
        });
        let me = self.nodes.len();
        self.nodes.push(Node { lo, hi, index: first as u32, count: items.len() as u32 });
        if items.len() <= LEAF_SIZE {
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

    /// Moves some items to new boxes and refits only the nodes above them: work in
    /// proportion to the items times the depth.
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

    /// Moves every item to a new box (same count and order as built) and recomputes
    /// the nodes bottom-up, keeping the tree's topology: O(n).
    pub fn refit_boxes(&mut self, boxes: impl Iterator<Item = (DVec3, DVec3)>) {
        boxes.zip(&self.slot_of).for_each(|(b, &slot)| self.boxes[slot as usize] = b);
        // Children always follow their parent: refit in reverse order.
        for n in (0..self.nodes.len()).rev() {
            (self.nodes[n].lo, self.nodes[n].hi) = self.node_box(n);
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

    /// Calls `f` with every item whose box overlaps `[lo, hi]`.
    pub fn query(&self, lo: DVec3, hi: DVec3, mut f: impl FnMut(u32)) {
        self.any(lo, hi, |i| {
            f(i);
            false
        });
    }

    /// Whether `found` holds for an item whose box overlaps `[lo, hi]`; stops at the
    /// first.
    pub fn any(&self, lo: DVec3, hi: DVec3, mut found: impl FnMut(u32) -> bool) -> bool {
        let meets = |l: DVec3, h: DVec3| !(l.cmpgt(hi).any() || h.cmplt(lo).any());
        self.walk(meets, |i, b| meets(b.0, b.1) && found(i))
    }

    /// Whether `found` holds for an item whose box `meets` accepts; stops at the
    /// first. `meets` prunes whole nodes, so it must accept every box that contains
    /// a box it accepts (a box overlap, a plane the box straddles).
    pub fn any_where(&self, meets: impl Fn(DVec3, DVec3) -> bool, mut found: impl FnMut(u32) -> bool) -> bool {
        self.walk(&meets, |i, b| meets(b.0, b.1) && found(i))
    }

    /// Calls `f` with every item whose box `meets` accepts ([`any_where`](Self::any_where)).
    pub fn query_where(&self, meets: impl Fn(DVec3, DVec3) -> bool, mut f: impl FnMut(u32)) {
        self.any_where(meets, |i| {
            f(i);
            false
        });
    }

    /// Calls `f` with every item whose box the segment `a`-`b` meets
    /// ([`segment_meets_box`] per node: a long slanted segment visits far fewer nodes
    /// than its box would).
    pub fn query_segment(&self, a: DVec3, b: DVec3, mut f: impl FnMut(u32)) {
        self.any_on_segment(a, b, |i| {
            f(i);
            false
        });
    }

    /// Whether `found` holds for an item whose box the segment `a`-`b` meets; stops
    /// at the first.
    pub fn any_on_segment(&self, a: DVec3, b: DVec3, mut found: impl FnMut(u32) -> bool) -> bool {
        let inv = DVec3::ONE / (b - a);
        let meets = |lo: DVec3, hi: DVec3| segment_meets_box(a, b, inv, lo, hi);
        self.walk(meets, |i, bx| meets(bx.0, bx.1) && found(i))
    }

    /// Calls `f(item, t0, t1)` with every item whose box the ray `origin + t dir`,
    /// `t ∈ [0, t_far]`, crosses, `[t0, t1]` being the ray's span inside the box.
    pub fn query_ray(&self, origin: DVec3, dir: DVec3, t_far: f64, mut f: impl FnMut(u32, f64, f64)) {
        self.any_on_ray(origin, dir, t_far, |i, t0, t1| {
            f(i, t0, t1);
            false
        });
    }

    /// Whether `found(item, t0, t1)` holds for an item whose box the ray crosses (as
    /// [`query_ray`](Self::query_ray)); stops at the first.
    pub fn any_on_ray(&self, origin: DVec3, dir: DVec3, t_far: f64, mut found: impl FnMut(u32, f64, f64) -> bool) -> bool {
        let inv = dir.recip();
        self.walk(
            |lo, hi| ray_span(origin, inv, t_far, lo, hi).is_some(),
            |i, b| ray_span(origin, inv, t_far, b.0, b.1).is_some_and(|(t0, t1)| found(i, t0, t1)),
        )
    }

    /// The nearest hit along the ray `origin + t dir`, `t ∈ [0, t_far]`: the least
    /// `hit(item)` (the ray parameter where it meets the item, `None` where it does
    /// not) over the items whose boxes the ray crosses, boxes beyond the best hit so
    /// far skipped. `None` when no item is hit.
    pub fn first_on_ray(&self, origin: DVec3, dir: DVec3, t_far: f64, mut hit: impl FnMut(u32) -> Option<f64>) -> Option<(u32, f64)> {
        let inv = dir.recip();
        let best = std::cell::Cell::new((u32::MAX, t_far));
        self.walk(
            |lo, hi| ray_span(origin, inv, best.get().1, lo, hi).is_some(),
            |i, b| {
                if ray_span(origin, inv, best.get().1, b.0, b.1).is_some() {
                    if let Some(t) = hit(i).filter(|&t| t <= best.get().1) {
                        best.set((i, t));
                    }
                }
                false
            },
        );
        Some(best.get()).filter(|b| b.0 != u32::MAX)
    }

    /// The item nearest to `p` and its distance, by `distance(item)` (the exact
    /// distance to the item, at least the distance to its box), among those nearer
    /// than `max`: nodes are visited nearest box first and skipped once their box is
    /// no nearer than the best found. `None` when no item is nearer than `max`.
    pub fn closest(&self, p: DVec3, max: f64, mut distance: impl FnMut(u32) -> f64) -> Option<(u32, f64)> {
        let to_box = |lo: DVec3, hi: DVec3| (lo - p).max(p - hi).max(DVec3::ZERO).length();
        let mut best: Option<(u32, f64)> = None;
        let mut bound = max;
        if self.nodes.is_empty() {
            return None;
        }
        let mut stack = [(0u32, 0.0f64); 64];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let (n, near) = stack[sp];
            if near >= bound {
                continue;
            }
            let node = self.nodes[n as usize];
            if node.count > 0 {
                let range = node.index as usize..(node.index + node.count) as usize;
                for (&i, b) in self.items[range.clone()].iter().zip(&self.boxes[range]) {
                    if to_box(b.0, b.1) < bound {
                        let d = distance(i);
                        if d < bound {
                            (best, bound) = (Some((i, d)), d);
                        }
                    }
                }
            } else if sp + 2 <= stack.len() {
                // The nearer child on top, visited first.
                let (a, b) = (n + 1, node.index);
                let (da, db) = (to_box(self.nodes[a as usize].lo, self.nodes[a as usize].hi), to_box(self.nodes[b as usize].lo, self.nodes[b as usize].hi));
                let (first, second) = if da <= db { ((a, da), (b, db)) } else { ((b, db), (a, da)) };
                stack[sp] = second;
                stack[sp + 1] = first;
                sp += 2;
            }
        }
        best
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
    pub fn overlapping_pairs_with(&self, other: &Bvh, keep: &(impl Fn(u32, u32) -> bool + Sync)) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        if !self.nodes.is_empty() && !other.nodes.is_empty() {
            Join { a: self, b: other, keep, same: false }.across(0, 0, 0, &mut out);
        }
        out
    }

    /// Descends the nodes that pass `meets`, calling `found(item, box)` for the items
    /// of the leaves reached, until it returns true (then returns true).
    #[inline]
    fn walk(&self, meets: impl Fn(DVec3, DVec3) -> bool, mut found: impl FnMut(u32, &(DVec3, DVec3)) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        // Median splits keep the depth near log2(n / LEAF_SIZE): 64 is never reached.
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
                    if found(i, b) {
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
    a: &'t Bvh,
    b: &'t Bvh,
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
        let size = |n: &Node| (n.hi - n.lo).length_squared();
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
        if !boxes_meet(&self.a.boxes[x], &self.b.boxes[y]) {
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

    /// The nearest triangle to random points against every triangle measured, also
    /// after a refit, and nothing nearer than a bound that no triangle meets.
    #[test]
    fn closest_finds_the_nearest_item_as_brute_force_does() {
        use crate::shell::intersect::point_triangle_distance2;
        let mut rng = crate::test_rng::Rng(0x9e37_79b9);
        let mut rand = || rng.uniform();
        let mut tris: Vec<[DVec3; 3]> = (0..300)
            .map(|_| {
                let c = DVec3::new(rand(), rand(), rand()) * 10.0;
                [c, c + DVec3::new(rand(), rand(), rand()), c + DVec3::new(rand(), rand(), rand())]
            })
            .collect();
        let mut tree = Bvh::from_triangles(&tris);
        for round in 0..2 {
            for _ in 0..200 {
                let p = DVec3::new(rand(), rand(), rand()) * 12.0 - 1.0;
                let d = |i: u32| point_triangle_distance2(p, &tris[i as usize]).sqrt();
                let want = (0..tris.len() as u32).map(|i| (i, d(i))).min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
                let got = tree.closest(p, f64::INFINITY, d).unwrap();
                assert!((got.1 - want.1).abs() < 1e-12, "round {round}: {got:?} vs {want:?}");
                assert_eq!(tree.closest(p, want.1 * 0.999, d), None);
            }
            // Move some triangles and refit.
            let moved: Vec<u32> = (0..tris.len() as u32).step_by(7).collect();
            for &i in &moved {
                let shift = DVec3::new(rand(), rand(), rand()) * 3.0;
                tris[i as usize] = tris[i as usize].map(|v| v + shift);
            }
            tree.refit_items(moved.iter().map(|&i| (i, tri_box(&tris[i as usize]))));
        }
        assert_eq!(Bvh::from_boxes(Vec::new()).closest(DVec3::ZERO, f64::INFINITY, |_| 0.0), None);
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
        boxes_meet(a, b)
    }

    #[test]
    fn tree_joins_find_every_overlapping_pair_once() {
        // Enough items for the parallel part of the traversal and for deep leaves.
        let (a, b) = (random_boxes(3000, 1), random_boxes(2000, 2));
        let keep = |i: u32, j: u32| !(i + j).is_multiple_of(3); // the filter is applied
        let (ta, tb) = (Bvh::from_boxes(a.clone()), Bvh::from_boxes(b.clone()));
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
        let brute: Vec<(u32, u32)> = (0..a.len())
            .flat_map(|i| (0..b.len()).map(move |j| (i, j)))
            .filter(|&(i, j)| meets(&shifted[i], &b[j]))
            .map(|(i, j)| (i as u32, j as u32))
            .collect();
        assert_eq!(across, brute);
        // Moving some items one by one (their slots in leaf order) gives the same
        // joins as moving all.
        let mut partly = ta.clone();
        partly.refit_items((0..a.len() as u32).step_by(3).map(|i| (i, shifted[i as usize])));
        let now: Vec<_> = (0..a.len()).map(|i| if i % 3 == 0 { shifted[i] } else { a[i] }).collect();
        let mut within = partly.overlapping_pairs(&|_, _| true);
        within.sort_unstable();
        let brute: Vec<(u32, u32)> = (0..a.len())
            .flat_map(|i| (i + 1..a.len()).map(move |j| (i, j)))
            .filter(|&(i, j)| meets(&now[i], &now[j]))
            .map(|(i, j)| (i as u32, j as u32))
            .collect();
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

    #[test]
    fn box_queries_agree_with_brute_force_after_refits() {
        let boxes = random_boxes(2000, 3);
        let mut tree = Bvh::from_boxes(boxes.clone());
        assert_eq!(tree.len(), 2000);
        let probes = random_boxes(50, 4).into_iter().map(|(l, h)| (l, l + (h - l) * 3.0));
        let check = |tree: &Bvh, boxes: &[(DVec3, DVec3)]| {
            for probe in probes.clone() {
                let mut found = Vec::new();
                tree.query(probe.0, probe.1, |i| found.push(i));
                found.sort_unstable();
                let brute: Vec<u32> = (0..boxes.len() as u32).filter(|&i| meets(&boxes[i as usize], &probe)).collect();
                assert_eq!(found, brute);
            }
        };
        check(&tree, &boxes);
        // Every other box moved, then half of those back, item by item.
        let moved: Vec<_> = boxes.iter().enumerate().map(|(i, b)| if i % 2 == 0 { (b.0 * 0.5, b.1 * 0.5) } else { *b }).collect();
        tree.refit_boxes(moved.iter().copied());
        check(&tree, &moved);
        let back: Vec<_> = moved.iter().zip(&boxes).enumerate().map(|(i, (m, b))| if i % 4 == 0 { *b } else { *m }).collect();
        tree.refit_items((0..boxes.len() as u32).step_by(4).map(|i| (i, boxes[i as usize])));
        check(&tree, &back);
        let empty = Bvh::from_boxes(Vec::new());
        assert!(empty.is_empty() && !empty.any(DVec3::ZERO, DVec3::ONE, |_| true));
        assert!(!empty.any_on_ray(DVec3::ZERO, DVec3::X, 1.0, |_, _, _| true));
    }

    #[test]
    fn a_ray_in_a_box_face_plane_meets_the_box() {
        // Boxes with a face in the plane x = 1 (an axis-aligned mesh's face; one box on
        // each side of it): a ray along z in that plane crosses both.
        let tris = [
            [DVec3::new(1.0, -1.0, 2.0), DVec3::new(1.0, 1.0, 2.0), DVec3::new(2.0, 0.0, 3.0)],
            [DVec3::new(1.0, -1.0, 5.0), DVec3::new(1.0, 1.0, 5.0), DVec3::new(0.0, 0.0, 6.0)],
        ];
        let boxes: Vec<_> = tris.iter().map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))).collect();
        let tree = Bvh::from_boxes(boxes);
        let (o, d) = (DVec3::new(1.0, 0.0, 0.0), DVec3::Z);
        let mut found = Vec::new();
        tree.query_ray(o, d, 10.0, |i, t0, t1| found.push((i, t0, t1)));
        found.sort_by_key(|f| f.0);
        assert_eq!(found, vec![(0, 2.0, 3.0), (1, 5.0, 6.0)]);
        // Beside both boxes, nothing.
        assert!(!tree.any_on_ray(DVec3::new(2.0 + 1e-6, 0.0, 0.0), d, 10.0, |_, _, _| true));
        // The nearest hit: the ray enters triangle 0's box at t = 2 (a crossing on its edge).
        let first = tree.first_on_ray(o, d, 10.0, |j| Some([2.0, 5.0][j as usize]));
        assert_eq!(first, Some((0, 2.0)));
    }

    #[test]
    fn rays_and_segments_find_every_crossed_box_with_its_span() {
        // Boxes on a grid (rays along the grid's axes and diagonals graze their faces)
        // and random ones.
        let grid: Vec<(DVec3, DVec3)> = (0..1000)
            .map(|i| {
                let p = DVec3::new((i % 10) as f64, ((i / 10) % 10) as f64, (i / 100) as f64);
                (p, p + DVec3::splat(0.7))
            })
            .collect();
        let random: Vec<_> = random_boxes(1500, 5).into_iter().map(|(l, h)| (l * 10.0, h * 10.0)).collect();
        for boxes in [grid, random] {
            let mut tree = Bvh::from_boxes(boxes.clone());
            for round in 0..2 {
                let boxes: Vec<_> = boxes.iter().map(|(l, h)| (*l + DVec3::Y * round as f64, *h + DVec3::Y * round as f64)).collect();
                if round > 0 {
                    tree.refit_boxes(boxes.iter().copied());
                }
                let mut crossed = 0;
                for (o, d, t_far) in [
                    (DVec3::new(-1.0, 0.3, 0.2), DVec3::new(1.0, 0.5, 0.3), 100.0),
                    (DVec3::new(4.3, 4.2, -2.0), DVec3::Z, 100.0),
                    (DVec3::new(12.0, 12.0, 12.0), DVec3::NEG_ONE, 100.0),
                    (DVec3::new(3.0, 3.0, 3.0), DVec3::new(0.2, -1.0, 0.4), 2.5),
                ] {
                    let d = d.normalize();
                    let mut found = Vec::new();
                    tree.query_ray(o, d, t_far, |i, t0, t1| found.push((i, t0, t1)));
                    found.sort_by_key(|f| f.0);
                    let inv = d.recip();
                    let brute: Vec<(u32, f64, f64)> = (0..boxes.len() as u32)
                        .filter_map(|i| {
                            let (lo, hi) = boxes[i as usize];
                            let (a, b) = ((lo - o) * inv, (hi - o) * inv);
                            let (t0, t1) = (a.min(b).max_element().max(0.0), a.max(b).min_element().min(t_far));
                            (t0 <= t1).then_some((i, t0, t1))
                        })
                        .collect();
                    assert_eq!(found, brute);
                    for &(i, t0, t1) in &found {
                        // The span's ends lie on the box (up to rounding).
                        let (lo, hi) = boxes[i as usize];
                        for t in [t0, t1] {
                            let p = o + d * t;
                            assert!(p.cmpge(lo - 1e-9).all() && p.cmple(hi + 1e-9).all());
                        }
                    }
                    crossed += found.len();
                    // Segments: the same boxes as the ray cut at `t_far` (up to a
                    // grazing slack).
                    let mut on_segment = Vec::new();
                    tree.query_segment(o, o + d * t_far, |i| on_segment.push(i));
                    on_segment.sort_unstable();
                    let brute: Vec<u32> = (0..boxes.len() as u32)
                        .filter(|&i| segment_meets_box(o, o + d * t_far, DVec3::ONE / (d * t_far), boxes[i as usize].0, boxes[i as usize].1))
                        .collect();
                    assert_eq!(on_segment, brute);
                    assert!(found.iter().all(|f| on_segment.binary_search(&f.0).is_ok()));
                }
                assert!(crossed > 10, "the rays must cross boxes: {crossed}");
            }
        }
    }
}
