//! Finding a shell's defects: outer-layer triangles crossing each other or the base,
//! and inverted cells. One search serves the report (every element, once) and the
//! repair pass (only the elements around directors it just shortened, round after
//! round, on a refitted BVH).

use super::geometry::{prisms, Cell};
use super::intersect::{tri_box, triangles_intersect, TriBvh};
use super::Shell;
use crate::Mesh;
use glam::DVec3;
use rayon::prelude::*;

/// The defects found (indices into [`Checker::tris`] and [`Checker::cells`]).
#[derive(Debug, Default)]
pub(crate) struct Findings {
    /// Intersecting outer-layer triangles that share no vertex.
    pub self_pairs: Vec<(u32, u32)>,
    /// (outer triangle, base triangle) pairs that intersect, ignoring pairs that share
    /// a vertex whose outer point coincides with its base point.
    pub base_pairs: Vec<(u32, u32)>,
    /// Inverted cells.
    pub inverted: Vec<u32>,
}

/// What the search needs of a mesh, built once and used for any number of shells.
pub(crate) struct Checker {
    pub tris: Vec<[u32; 3]>,
    pub cells: Vec<Cell>,
    pub base: Vec<[DVec3; 3]>,
    pub base_bvh: TriBvh,
    /// Triangles and cells around each vertex (CSR).
    tri_start: Vec<u32>,
    tri_of: Vec<u32>,
    cell_start: Vec<u32>,
    cell_of: Vec<u32>,
}

/// Which elements to check: all, or those flagged.
pub(crate) struct Dirty {
    pub tris: Vec<bool>,
    pub cells: Vec<bool>,
}

fn incidence(n: usize, items: impl Iterator<Item = impl IntoIterator<Item = u32>> + Clone) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; n + 1];
    for v in items.clone().flatten() {
        start[v as usize + 1] += 1;
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut of = vec![0u32; start[n] as usize];
    for (k, it) in items.enumerate() {
        for v in it {
            of[fill[v as usize] as usize] = k as u32;
            fill[v as usize] += 1;
        }
    }
    (start, of)
}

impl Checker {
    pub fn new(mesh: &Mesh) -> Self {
        let p = mesh.positions();
        let tris = mesh.triangulate().triangles;
        let base: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|i| p[i as usize].as_dvec3())).collect();
        let cells = prisms(mesh);
        let (tri_start, tri_of) = incidence(p.len(), tris.iter().copied());
        let (cell_start, cell_of) = incidence(p.len(), cells.iter().map(|c| c.base().to_vec()));
        Self { base_bvh: TriBvh::build(&base), base, tris, cells, tri_start, tri_of, cell_start, cell_of }
    }

    /// Nothing flagged.
    pub fn clean(&self) -> Dirty {
        Dirty { tris: vec![false; self.tris.len()], cells: vec![false; self.cells.len()] }
    }

    /// Flags the triangles and cells around vertex `v`.
    pub fn mark_around(&self, v: usize, dirty: &mut Dirty) {
        for &t in &self.tri_of[self.tri_start[v] as usize..self.tri_start[v + 1] as usize] {
            dirty.tris[t as usize] = true;
        }
        for &c in &self.cell_of[self.cell_start[v] as usize..self.cell_start[v + 1] as usize] {
            dirty.cells[c as usize] = true;
        }
    }

    /// The defects of `shell` among the flagged elements (all for `None`). A pair is
    /// found when either triangle is flagged. `outer_bvh` is built on the first call
    /// and refitted on the next ones (the shell's topology never changes).
    pub fn find(&self, mesh: &Mesh, shell: &Shell, dirty: Option<&Dirty>, outer_bvh: &mut Option<TriBvh>) -> Findings {
        let p = mesh.positions();
        let top: Vec<DVec3> = (0..p.len()).map(|v| shell.point(p, v, 1.0).as_dvec3()).collect();
        let outer: Vec<[DVec3; 3]> = self.tris.iter().map(|t| t.map(|i| top[i as usize])).collect();
        match outer_bvh {
            Some(b) => b.refit(&outer),
            None => *outer_bvh = Some(TriBvh::build(&outer)),
        }
        let outer_bvh = outer_bvh.as_ref().expect("built above");
        let diag = mesh.bbox_diagonal() as f64;
        let coincide = |v: u32| (top[v as usize] - p[v as usize].as_dvec3()).length() <= 1e-6 * diag;
        let tris = &self.tris;
        let shares = |a: &[u32; 3], b: &[u32; 3]| a.iter().any(|v| b.contains(v));
        let tri_flagged = |i: usize| dirty.is_none_or(|d| d.tris[i]);
        // Per outer triangle: (is it a self pair?, other index).
        let hits: Vec<(bool, u32, u32)> = (0..tris.len())
            .into_par_iter()
            .filter(|&i| tri_flagged(i))
            .flat_map_iter(|i| {
                let (lo, hi) = tri_box(&outer[i]);
                let mut hits = Vec::new();
                outer_bvh.query(lo, hi, |j| {
                    let ju = j as usize;
                    // Each pair once: by the lower index, unless only the higher is flagged.
                    let first = j as usize > i || !tri_flagged(ju);
                    if first && !shares(&tris[i], &tris[ju]) && triangles_intersect(&outer[i], &outer[ju]) {
                        hits.push((true, i as u32, j));
                    }
                });
                self.base_bvh.query(lo, hi, |j| {
                    let touching = tris[i].iter().any(|v| tris[j as usize].contains(v) && coincide(*v));
                    if !touching && triangles_intersect(&outer[i], &self.base[j as usize]) {
                        hits.push((false, i as u32, j));
                    }
                });
                hits
            })
            .collect();
        let (self_hits, base_hits): (Vec<_>, Vec<_>) = hits.into_iter().partition(|h| h.0);
        let inverted = (0..self.cells.len() as u32)
            .into_par_iter()
            .filter(|&c| dirty.is_none_or(|d| d.cells[c as usize]) && self.cells[c as usize].is_inverted(p, shell))
            .collect();
        Findings {
            self_pairs: self_hits.into_iter().map(|h| (h.1, h.2)).collect(),
            base_pairs: base_hits.into_iter().map(|h| (h.1, h.2)).collect(),
            inverted,
        }
    }

    /// The vertices of every defect, as a mask.
    pub fn defect_vertices(&self, f: &Findings, n: usize) -> Vec<bool> {
        let mut bad = vec![false; n];
        let mut mark = |vs: &[u32]| vs.iter().for_each(|v| bad[*v as usize] = true);
        for &(i, j) in &f.self_pairs {
            mark(&self.tris[i as usize]);
            mark(&self.tris[j as usize]);
        }
        for &(i, _) in &f.base_pairs {
            mark(&self.tris[i as usize]);
        }
        for &c in &f.inverted {
            mark(self.cells[c as usize].base());
        }
        bad
    }
}
