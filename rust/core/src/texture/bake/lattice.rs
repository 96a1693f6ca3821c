//! The bake's sample lattice: every cell (a triangle of the triangulated base) gets
//! `n` steps per base edge, and lattice points are numbered globally — a mesh vertex,
//! a point on a mesh edge, or one inside a face — so neighbouring cells share the
//! samples on their common faces (no cracks).

use super::super::mapping::{TextureCoordinates, TriangleCells};
use crate::Mesh;
use glam::Vec2;
use std::collections::HashMap;

pub(super) struct Lattice {
    pub n: u32,
    pub tris: Vec<[u32; 3]>,
    /// Corner `(s, t)` of each triangle.
    pub st: Vec<[Vec2; 3]>,
    edges: HashMap<(u32, u32), u32>,
    vertex_count: u32,
    /// Points on the shell's side walls (open boundary edges and their vertices).
    pub boundary: Vec<bool>,
}

impl Lattice {
    pub fn new(mesh: &Mesh, coords: &TextureCoordinates, n: u32) -> Self {
        let cells = TriangleCells::new(mesh, coords);
        let mut edges = HashMap::new();
        let mut uses: Vec<u32> = Vec::new();
        for t in &cells.triangles {
            for k in 0..3 {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                let next = edges.len() as u32;
                let e = *edges.entry((a, b)).or_insert(next);
                if e as usize == uses.len() {
                    uses.push(0);
                }
                uses[e as usize] += 1;
            }
        }
        let mut me = Self { n, tris: cells.triangles, st: cells.st, edges, vertex_count: mesh.vertex_count() as u32, boundary: Vec::new() };
        let mut boundary = vec![false; me.key_count()];
        for (&(a, b), &e) in &me.edges {
            if uses[e as usize] == 1 {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
                for k in 1..n {
                    boundary[me.edge_key(a, b, k)] = true;
                }
            }
        }
        me.boundary = boundary;
        me
    }

    fn interior_per_face(&self) -> usize {
        let n = self.n as usize;
        if n < 3 {
            0
        } else {
            (n - 1) * (n - 2) / 2
        }
    }

    /// Number of lattice points (without the layer index).
    pub fn key_count(&self) -> usize {
        self.vertex_count as usize + self.edges.len() * (self.n as usize - 1) + self.tris.len() * self.interior_per_face()
    }

    /// Point `k` steps from `a` on edge `a-b`.
    fn edge_key(&self, a: u32, b: u32, k: u32) -> usize {
        let (lo, hi, k) = if a < b { (a, b, k) } else { (b, a, self.n - k) };
        let e = self.edges[&(lo, hi)] as usize;
        self.vertex_count as usize + e * (self.n as usize - 1) + (k as usize - 1)
    }

    /// Global key of local point `(i, j)` of triangle `t` (corner a at (0,0), b at
    /// (n,0), c at (0,n)).
    pub fn key(&self, t: usize, i: u32, j: u32) -> usize {
        let [a, b, c] = self.tris[t];
        let n = self.n;
        match (i, j) {
            (0, 0) => a as usize,
            _ if i == n => b as usize,
            _ if j == n => c as usize,
            (_, 0) => self.edge_key(a, b, i),
            (0, _) => self.edge_key(a, c, j),
            _ if i + j == n => self.edge_key(b, c, j),
            _ => {
                let (i, j, n) = (i as usize, j as usize, n as usize);
                let base = self.vertex_count as usize + self.edges.len() * (n - 1) + t * self.interior_per_face();
                base + (i - 1) * (n - 1) - (i - 1) * i / 2 + (j - 1)
            }
        }
    }

    /// Local points `(i, j)` of a triangle in a fixed order (`i` major).
    pub fn local_points(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        (0..=self.n).flat_map(move |i| (0..=self.n - i).map(move |j| (i, j)))
    }

    /// Index of local point `(i, j)` in [`Self::local_points`] order.
    #[inline]
    pub fn local_index(&self, i: u32, j: u32) -> usize {
        let (i, j, n) = (i as usize, j as usize, self.n as usize);
        i * (n + 1) - i * (i.saturating_sub(1)) / 2 + j
    }

    /// The small triangles of a cell's lattice (`n^2` of them, counter-clockwise),
    /// as indices of their corners in [`Self::local_points`] order; each is the base of
    /// one column of prisms.
    pub fn small_triangles(&self) -> impl Iterator<Item = [usize; 3]> + '_ {
        let n = self.n;
        (0..n)
            .flat_map(move |i| {
                (0..n - i).flat_map(move |j| {
                    let up = [(i, j), (i + 1, j), (i, j + 1)];
                    let down = [(i + 1, j), (i + 1, j + 1), (i, j + 1)];
                    [up, down].into_iter().take(if i + j + 2 <= n { 2 } else { 1 })
                })
            })
            .map(|t| t.map(|(i, j)| self.local_index(i, j)))
    }

    /// For every lattice point, the first cell containing it and its local `(i, j)`
    /// there: where its samples are computed, so shared points get one value.
    pub fn owners(&self) -> Vec<(u32, u16, u16)> {
        let mut owner = vec![(u32::MAX, 0u16, 0u16); self.key_count()];
        for t in 0..self.tris.len() {
            for (i, j) in self.local_points() {
                let k = self.key(t, i, j);
                if owner[k].0 == u32::MAX {
                    owner[k] = (t as u32, i as u16, j as u16);
                }
            }
        }
        owner
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_indices_follow_the_point_order() {
        let m = crate::testmeshes::icosphere(0);
        let coords = TextureCoordinates::of(&m, 1.0);
        for n in 1..6 {
            let l = Lattice::new(&m, &coords, n);
            for (k, (i, j)) in l.local_points().enumerate() {
                assert_eq!(l.local_index(i, j), k, "n {n} ({i},{j})");
            }
            // n^2 small triangles, each counter-clockwise in (i, j), covering the cell.
            let pts: Vec<(u32, u32)> = l.local_points().collect();
            let area2: i64 = l
                .small_triangles()
                .map(|t| {
                    let [a, b, c] = t.map(|k| (pts[k].0 as i64, pts[k].1 as i64));
                    let cross = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
                    assert_eq!(cross, 1, "n {n}: {t:?}");
                    cross
                })
                .sum();
            assert_eq!(area2, (n * n) as i64);
            // Closed icosphere: every key is owned, none on a boundary.
            assert!(l.owners().iter().all(|o| o.0 != u32::MAX));
            assert!(!l.boundary.iter().any(|b| *b));
        }
    }
}
