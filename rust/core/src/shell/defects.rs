//! Finding a shell's defects: outer-layer triangles crossing each other or the base,
//! and inverted cells. One search serves the report (every element, once) and the
//! repair pass (only the elements around directors it just shortened, round after
//! round, on a refitted BVH).

use super::geometry::{prisms, Cell};
use super::intersect::{segment_crosses_triangle, tri_box, triangles_intersect, TriBvh};
use super::Shell;
use crate::mesh::Incidence;
use crate::Mesh;
use glam::DVec3;
use rayon::prelude::*;
use std::borrow::Cow;

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
    /// The base mesh's bounding-box diagonal (the scale of "coincide").
    diag: f64,
    /// Triangles and cells around each vertex (CSR).
    tris_around: Incidence,
    cells_around: Incidence,
}

/// Which elements to check: those flagged (mask and list).
pub(crate) struct Dirty {
    pub tris: Vec<bool>,
    pub cells: Vec<bool>,
    pub tri_list: Vec<u32>,
    pub cell_list: Vec<u32>,
}

impl Dirty {
    /// Flags nothing again, in time proportional to what was flagged.
    pub fn clear(&mut self) {
        self.tri_list.drain(..).for_each(|t| self.tris[t as usize] = false);
        self.cell_list.drain(..).for_each(|c| self.cells[c as usize] = false);
    }
}

impl Checker {
    pub fn new(mesh: &Mesh) -> Self {
        let p = mesh.positions();
        let tris = mesh.triangulate().triangles;
        let base: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|i| p[i as usize].as_dvec3())).collect();
        let cells = prisms(mesh);
        let tris_around = Incidence::new(p.len(), tris.iter().copied());
        let cells_around = Incidence::new(p.len(), cells.iter().map(|c| c.base().to_vec()));
        Self { base_bvh: TriBvh::build(&base), diag: mesh.bbox_diagonal() as f64, base, tris, cells, tris_around, cells_around }
    }

    /// After the vertices `moved` moved (same topology and triangulation): the base
    /// triangles around them and the tree follow.
    pub fn refit_base(&mut self, mesh: &Mesh, moved: &[u32]) {
        let p = mesh.positions();
        let mut touched: Vec<u32> = moved.iter().flat_map(|&v| self.tris_around.of(v as usize)).copied().collect();
        touched.sort_unstable();
        touched.dedup();
        for &t in &touched {
            self.base[t as usize] = self.tris[t as usize].map(|i| p[i as usize].as_dvec3());
        }
        self.base_bvh.refit_items(touched.iter().map(|&t| (t, tri_box(&self.base[t as usize]))));
        self.diag = mesh.bbox_diagonal() as f64;
    }

    /// Nothing flagged.
    pub fn clean(&self) -> Dirty {
        Dirty { tris: vec![false; self.tris.len()], cells: vec![false; self.cells.len()], tri_list: Vec::new(), cell_list: Vec::new() }
    }

    /// Flags the triangles and cells around each of `vertices`, after clearing `dirty`
    /// (in time proportional to what it held).
    pub fn mark_anew(&self, vertices: impl Iterator<Item = u32>, dirty: &mut Dirty) {
        dirty.clear();
        vertices.for_each(|v| self.mark_around(v as usize, dirty));
    }

    /// Flags the triangles and cells around vertex `v`.
    pub fn mark_around(&self, v: usize, dirty: &mut Dirty) {
        for &t in self.tris_around.of(v) {
            if !std::mem::replace(&mut dirty.tris[t as usize], true) {
                dirty.tri_list.push(t);
            }
        }
        for &c in self.cells_around.of(v) {
            if !std::mem::replace(&mut dirty.cells[c as usize], true) {
                dirty.cell_list.push(c);
            }
        }
    }

    /// Whether outer-layer triangle `t` of `shell` crosses another one that shares no
    /// vertex with it (`tree` holds the outer layer); after the first crossing the
    /// remaining candidates are skipped untested.
    pub fn outer_crosses(&self, mesh: &Mesh, shell: &Shell, t: u32, tree: &TriBvh) -> bool {
        let top = |v: &u32| shell.point(mesh.positions(), *v as usize, 1.0).as_dvec3();
        let mine = self.tris[t as usize].map(|v| top(&v));
        let (lo, hi) = tri_box(&mine);
        let mut hit = false;
        tree.query(lo, hi, |j| {
            let other = &self.tris[j as usize];
            hit = hit || (!other.iter().any(|v| self.tris[t as usize].contains(v)) && triangles_intersect(&mine, &other.map(|v| top(&v))));
        });
        hit
    }

    /// The triangles around vertex `v`.
    pub fn tris_of(&self, v: usize) -> &[u32] {
        self.tris_around.of(v)
    }

    /// Whether segment `a`-`b` of vertex `v` crosses a triangle away from `v`: of the
    /// base, or of `outer`'s outer layer (with its tree).
    pub fn segment_crosses(&self, mesh: &Mesh, v: u32, a: DVec3, b: DVec3, outer: Option<(&Shell, &TriBvh)>) -> bool {
        let mut hit = false;
        let mut test =
            |j: u32, t: &dyn Fn() -> [DVec3; 3]| hit = hit || (!self.tris[j as usize].contains(&v) && segment_crosses_triangle(a, b, &t()));
        match outer {
            None => self.base_bvh.query_segment(a, b, |j| test(j, &|| self.base[j as usize])),
            Some((shell, tree)) => {
                let top = |i: u32| shell.point(mesh.positions(), i as usize, 1.0).as_dvec3();
                tree.query_segment(a, b, |j| test(j, &|| self.tris[j as usize].map(top)))
            }
        }
        hit
    }

    /// The cells around vertex `v`.
    pub fn cells_of(&self, v: usize) -> &[u32] {
        self.cells_around.of(v)
    }

    /// The corners of the cells around vertex `v` (`v` among them, others repeated).
    pub fn cell_corners_around(&self, v: usize) -> impl Iterator<Item = u32> + '_ {
        self.cells_around.of(v).iter().flat_map(|&c| self.cells[c as usize].base().iter().copied())
    }

    /// A tree over the outer-layer triangles' boxes, refitting `reuse` when given
    /// (the shell's topology never changes).
    pub fn outer_tree(&self, mesh: &Mesh, shell: &Shell, reuse: Option<TriBvh>) -> TriBvh {
        let boxes = (0..self.tris.len() as u32).into_par_iter().map(|t| self.outer_box(mesh, shell, t));
        match reuse {
            Some(mut tree) => {
                tree.refit_boxes(boxes.collect::<Vec<_>>().into_iter());
                tree
            }
            None => TriBvh::from_boxes(boxes.collect()),
        }
    }

    /// The box of outer-layer triangle `t`.
    pub fn outer_box(&self, mesh: &Mesh, shell: &Shell, t: u32) -> (DVec3, DVec3) {
        tri_box(&self.tris[t as usize].map(|v| shell.point(mesh.positions(), v as usize, 1.0).as_dvec3()))
    }

    /// The defects of `shell` among the flagged elements (all for `None`). A pair is
    /// found when either triangle is flagged. `outer_tree` holds every outer-layer
    /// triangle of `shell` ([`outer_tree`](Self::outer_tree)); without it the outer
    /// layer is not checked against itself.
    pub fn find(&self, mesh: &Mesh, shell: &Shell, dirty: Option<&Dirty>, outer_tree: Option<&TriBvh>) -> Findings {
        let p = mesh.positions();
        let top = |v: u32| shell.point(p, v as usize, 1.0).as_dvec3();
        let outer = |i: usize| self.tris[i].map(top);
        let coincide = |v: u32| (top(v) - p[v as usize].as_dvec3()).length() <= 1e-6 * self.diag;
        let tris = &self.tris;
        let shares = |a: &[u32; 3], b: &[u32; 3]| a.iter().any(|v| b.contains(v));
        let tri_flagged = |i: usize| dirty.is_none_or(|d| d.tris[i]);

        // Per outer triangle: (is it a self pair?, other index).
        let every = |n: usize| Cow::Owned((0..n as u32).collect());
        let (tri_list, cell_list): (Cow<[u32]>, Cow<[u32]>) = match dirty {
            Some(d) => (Cow::Borrowed(&d.tri_list), Cow::Borrowed(&d.cell_list)),
            None => (every(tris.len()), every(self.cells.len())),
        };
        let hits: Vec<(bool, u32, u32)> = tri_list
            .par_iter()
            .flat_map_iter(|&i| {
                let i = i as usize;
                let mine = outer(i);
                let (lo, hi) = tri_box(&mine);
                let mut hits = Vec::new();
                if let Some(tree) = outer_tree {
                    tree.query(lo, hi, |j| {
                        let ju = j as usize;
                        // Each pair once: by the lower index, unless only the higher is flagged.
                        let first = j as usize > i || !tri_flagged(ju);
                        if first && !shares(&tris[i], &tris[ju]) && triangles_intersect(&mine, &outer(ju)) {
                            hits.push((true, i as u32, j));
                        }
                    });
                }
                self.base_bvh.query(lo, hi, |j| {
                    let touching = tris[i].iter().any(|v| tris[j as usize].contains(v) && coincide(*v));
                    if !touching && triangles_intersect(&mine, &self.base[j as usize]) {
                        hits.push((false, i as u32, j));
                    }
                });
                hits
            })
            .collect();
        let (self_hits, base_hits): (Vec<_>, Vec<_>) = hits.into_iter().partition(|h| h.0);
        let inverted = cell_list.par_iter().copied().filter(|&c| self.cells[c as usize].is_inverted(p, shell)).collect();
        Findings {
            self_pairs: self_hits.into_iter().map(|h| (h.1, h.2)).collect(),
            base_pairs: base_hits.into_iter().map(|h| (h.1, h.2)).collect(),
            inverted,
        }
    }

    /// The vertices of every defect, sorted, each once.
    pub fn defect_vertex_list(&self, f: &Findings) -> Vec<u32> {
        let mut bad = Vec::new();
        for &(i, j) in &f.self_pairs {
            bad.extend(self.tris[i as usize]);
            bad.extend(self.tris[j as usize]);
        }
        for &(i, _) in &f.base_pairs {
            bad.extend(self.tris[i as usize]);
        }
        for &c in &f.inverted {
            bad.extend(self.cells[c as usize].base());
        }
        bad.sort_unstable();
        bad.dedup();
        bad
    }
}
