//! The bake's sample lattice: every cell (a triangle of the triangulated base) gets
//! `n` steps per base edge, and lattice points are numbered globally — a mesh vertex,
//! a point on a mesh edge, or one inside a face — so neighbouring cells share the
//! samples on their common faces (no cracks). A point's samples are computed in the
//! cell that owns it (the first cell containing it), so shared points get one value
//! even where the cells' texture coordinates differ (per-face tiles, UV seams).

use super::super::mapping::TriangleCells;
use crate::Mesh;
use glam::Vec2;
use std::collections::HashMap;

/// Where a local point lies on its cell ([`Lattice::place`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Place {
    /// At corner `k` (0, 1, 2: a, b, c).
    Corner(usize),
    /// On the side from corner `a` to corner `b`, `step` lattice steps from `a`.
    Side(usize, usize, u32),
    Inside,
}

impl Place {
    /// The cell's corners the point shares with the neighbours (bit `k`: corner `k`):
    /// one at a corner, the side's two on a side, none inside.
    pub fn corners(self) -> u8 {
        match self {
            Place::Corner(k) => 1 << k,
            Place::Side(a, b, _) => 1 << a | 1 << b,
            Place::Inside => 0,
        }
    }
}

pub(super) struct Lattice {
    pub n: u32,
    pub tris: Vec<[u32; 3]>,
    /// Corner `(s, t)` of each triangle.
    pub st: Vec<[Vec2; 3]>,
    /// The mesh face of each cell.
    pub faces: Vec<u32>,
    edges: HashMap<(u32, u32), u32>,
    vertex_count: u32,
    /// Per mesh vertex and per edge: on the shell's side walls (open boundary edges).
    vertex_on_wall: Vec<bool>,
    edge_on_wall: Vec<bool>,
    /// Per mesh vertex: the first cell containing it and its corner there.
    vertex_owner: Vec<(u32, u8)>,
    /// Per edge: the first cell containing it.
    edge_owner: Vec<u32>,
}

impl Lattice {
    pub fn new(mesh: &Mesh, cells: TriangleCells, n: u32) -> Self {
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
        let mut vertex_on_wall = vec![false; mesh.vertex_count()];
        let mut edge_on_wall = vec![false; edges.len()];
        for (&(a, b), &e) in &edges {
            if uses[e as usize] == 1 {
                (vertex_on_wall[a as usize], vertex_on_wall[b as usize], edge_on_wall[e as usize]) = (true, true, true);
            }
        }
        let mut vertex_owner = vec![(u32::MAX, 0u8); mesh.vertex_count()];
        let mut edge_owner = vec![u32::MAX; edges.len()];
        for (t, tri) in cells.triangles.iter().enumerate().rev() {
            for k in 0..3 {
                vertex_owner[tri[k] as usize] = (t as u32, k as u8);
                let (a, b) = (tri[k].min(tri[(k + 1) % 3]), tri[k].max(tri[(k + 1) % 3]));
                edge_owner[edges[&(a, b)] as usize] = t as u32;
            }
        }
        Self {
            n,
            tris: cells.triangles,
            st: cells.st,
            faces: cells.faces,
            edges,
            vertex_count: mesh.vertex_count() as u32,
            vertex_on_wall,
            edge_on_wall,
            vertex_owner,
            edge_owner,
        }
    }

    /// Local `(i, j)` of corner `k` (a, b, c).
    fn corner(&self, k: usize) -> (u32, u32) {
        [(0, 0), (self.n, 0), (0, self.n)][k.min(2)]
    }

    /// Where local point `(i, j)` lies on its cell: at a corner, on a side, or inside.
    pub fn place(&self, i: u32, j: u32) -> Place {
        let n = self.n;
        match (i, j) {
            (0, 0) => Place::Corner(0),
            _ if i == n => Place::Corner(1),
            _ if j == n => Place::Corner(2),
            (_, 0) => Place::Side(0, 1, i),
            (0, _) => Place::Side(0, 2, j),
            _ if i + j == n => Place::Side(1, 2, j),
            _ => Place::Inside,
        }
    }

    /// Whether local point `(i, j)` of cell `t` lies on the shell's side walls.
    pub fn on_wall(&self, t: usize, i: u32, j: u32) -> bool {
        let tri = self.tris[t];
        match self.place(i, j) {
            Place::Corner(k) => self.vertex_on_wall[tri[k] as usize],
            Place::Side(a, b, _) => {
                let (p, q) = (tri[a], tri[b]);
                self.edge_on_wall[self.edges[&(p.min(q), p.max(q))] as usize]
            }
            Place::Inside => false,
        }
    }

    /// The cell that computes the samples of local point `(i, j)` of cell `t`, and the
    /// point's local coordinates there.
    pub fn owner(&self, t: usize, i: u32, j: u32) -> (usize, u32, u32) {
        let tri = self.tris[t];
        let vertex = |v: u32| {
            let (o, k) = self.vertex_owner[v as usize];
            let (i, j) = self.corner(k as usize);
            (o as usize, i, j)
        };
        // The point `step` lattice steps from corner `from` toward corner `to`.
        let on_edge = |from: usize, to: usize, step: u32| {
            let (p, q) = (tri[from], tri[to]);
            let o = self.edge_owner[self.edges[&(p.min(q), p.max(q))] as usize] as usize;
            if o == t {
                return (t, i, j);
            }
            let other = self.tris[o];
            let at = |v: u32| self.corner(other.iter().position(|c| *c == v).unwrap_or(0));
            let (pa, pb) = (at(p), at(q));
            // Corners sit at 0 or n, so the step moves by exactly `step` per axis.
            let go = |a: u32, b: u32| {
                if b > a {
                    a + step
                } else if b < a {
                    a - step
                } else {
                    a
                }
            };
            (o, go(pa.0, pb.0), go(pa.1, pb.1))
        };
        match self.place(i, j) {
            Place::Corner(k) => vertex(tri[k]),
            Place::Side(a, b, step) => on_edge(a, b, step),
            Place::Inside => (t, i, j),
        }
    }

    fn interior_per_face(&self) -> usize {
        let n = self.n as usize;
        if n < 3 {
            0
        } else {
            (n - 1) * (n - 2) / 2
        }
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
        let tri = self.tris[t];
        match self.place(i, j) {
            Place::Corner(k) => tri[k] as usize,
            Place::Side(a, b, step) => self.edge_key(tri[a], tri[b], step),
            Place::Inside => {
                let (i, j, n) = (i as usize, j as usize, self.n as usize);
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_indices_follow_the_point_order() {
        let m = crate::testmeshes::icosphere(0);
        let coords = crate::texture::TextureCoordinates::of(&m, 1.0);
        for n in 1..6 {
            let l = Lattice::new(&m, TriangleCells::new(&m, &coords), n);
            for (k, (i, j)) in l.local_points().enumerate() {
                assert_eq!(l.local_index(i, j), k, "n {n} ({i},{j})");
            }
            // Closed icosphere: no point on a wall; every point's owner has it at the
            // same global key and is the first cell holding that key.
            for t in 0..l.tris.len() {
                for (i, j) in l.local_points() {
                    assert!(!l.on_wall(t, i, j));
                    let (o, oi, oj) = l.owner(t, i, j);
                    assert_eq!(l.key(o, oi, oj), l.key(t, i, j), "n {n} cell {t} ({i},{j})");
                    assert!(o <= t);
                    let first = (0..l.tris.len()).find(|&u| l.local_points().any(|(a, b)| l.key(u, a, b) == l.key(t, i, j)));
                    assert_eq!(first, Some(o));
                }
            }
        }
    }
}
