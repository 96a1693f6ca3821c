//! Local thickness reduction where the traced shell is still tangled: the field
//! trajectories never cross, but their straight chords (chapter 3.1, "virtual
//! trajectories") can, in sharp concave corners and where trajectories converge.
//! The thesis accepts this (4.6); we shorten directors around each defect — an
//! inverted cell, or an outer-layer triangle crossing another one or the base —
//! towards their base point, so thickness is reduced only there.
//! After the first round only the triangles and cells touching a shortened director
//! are checked again, so later rounds cost in proportion to the defects left.

use super::geometry::{prisms, Cell};
use super::intersect::{tri_box, triangles_intersect, TriBvh};
use super::Shell;
use crate::mesh::vertex_normals;
use crate::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Shortest director the repair leaves, as a fraction of the target.
pub const FLOOR: f32 = 0.05;

/// One defect and the vertices whose directors it may shorten.
enum Defect {
    /// An inverted cell or an outer triangle through the base: all its vertices.
    Whole(Vec<u32>),
    /// Two outer-layer triangles crossing: the one whose directors bend more from
    /// the normals is shortened (both when they bend alike). A chord that keeps to
    /// the normal is what normal displacement would have given; where a far,
    /// strongly bent chord reaches over it, the bent one is at fault.
    Crossing([u32; 3], [u32; 3]),
}

/// How far each director bends away from its vertex normal: `1 - cos` of the angle.
fn bends(normals: &[Vec3], shell: &Shell) -> Vec<f32> {
    let s = shell.side.orientation();
    shell
        .directors
        .iter()
        .zip(normals)
        .map(|(d, n)| if *d == Vec3::ZERO || *n == Vec3::ZERO { 0.0 } else { 1.0 - d.normalize().dot(*n * s) })
        .collect()
}

/// What the repair checks, built once per shell.
struct Checker {
    tris: Vec<[u32; 3]>,
    base_bvh: TriBvh,
    base: Vec<[DVec3; 3]>,
    cells: Vec<Cell>,
    /// Triangles and cells around each vertex (CSR).
    tri_start: Vec<u32>,
    tri_of: Vec<u32>,
    cell_start: Vec<u32>,
    cell_of: Vec<u32>,
}

fn incidence(n: usize, items: impl Iterator<Item = impl IntoIterator<Item = u32>> + Clone) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; n + 1];
    for it in items.clone() {
        for v in it {
            start[v as usize + 1] += 1;
        }
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
    fn new(mesh: &Mesh) -> Self {
        let p = mesh.positions();
        let tris = mesh.triangulate().triangles;
        let base: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|i| p[i as usize].as_dvec3())).collect();
        let cells = prisms(mesh);
        let (tri_start, tri_of) = incidence(p.len(), tris.iter().copied());
        let (cell_start, cell_of) = incidence(p.len(), cells.iter().map(|c| c.base().to_vec()));
        Self { base_bvh: TriBvh::build(&base), base, tris, cells, tri_start, tri_of, cell_start, cell_of }
    }

    /// Defects among the triangles and cells flagged in `tri_dirty` / `cell_dirty`,
    /// each as the list of vertices involved.
    /// `outer_bvh` is built on the first call and refitted on the next ones.
    fn defects(
        &self,
        mesh: &Mesh,
        shell: &Shell,
        tri_dirty: &[bool],
        cell_dirty: &[bool],
        outer_bvh: &mut Option<TriBvh>,
    ) -> Vec<Defect> {
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
        let mut out: Vec<Defect> = (0..tris.len())
            .into_par_iter()
            .filter(|&i| tri_dirty[i])
            .flat_map_iter(|i| {
                let (lo, hi) = tri_box(&outer[i]);
                let mut hits = Vec::new();
                outer_bvh.query(lo, hi, |j| {
                    let j = j as usize;
                    if j != i && !shares(&tris[i], &tris[j]) && triangles_intersect(&outer[i], &outer[j]) {
                        hits.push(Defect::Crossing(tris[i], tris[j]));
                    }
                });
                self.base_bvh.query(lo, hi, |j| {
                    let j = j as usize;
                    let touching = tris[i].iter().any(|v| tris[j].contains(v) && coincide(*v));
                    if !touching && triangles_intersect(&outer[i], &self.base[j]) {
                        hits.push(Defect::Whole(tris[i].to_vec()));
                    }
                });
                hits
            })
            .collect();
        out.extend(
            (0..self.cells.len())
                .into_par_iter()
                .filter(|&c| cell_dirty[c] && self.cells[c].is_inverted(p, shell))
                .map(|c| Defect::Whole(self.cells[c].base().to_vec()))
                .collect::<Vec<_>>(),
        );
        out
    }

    fn mark_around(&self, v: usize, tri_dirty: &mut [bool], cell_dirty: &mut [bool]) {
        for &t in &self.tri_of[self.tri_start[v] as usize..self.tri_start[v + 1] as usize] {
            tri_dirty[t as usize] = true;
        }
        for &c in &self.cell_of[self.cell_start[v] as usize..self.cell_start[v + 1] as usize] {
            cell_dirty[c as usize] = true;
        }
    }
}

/// Shrinks directors around defects by `factor` per round, for at most `rounds`
/// rounds; returns the number of rounds that changed something. A director is never
/// shortened below [`FLOOR`] of its target: a cell of vanishing height is degenerate,
/// no better than a folded one.
pub fn untangle(mesh: &Mesh, shell: &mut Shell, rounds: u32, factor: f32) -> u32 {
    untangle_around(mesh, shell, rounds, factor, None)
}

/// [`untangle`], checking at first only the triangles and cells around `seeds` (all
/// of them for `None`): after a local edit the rest of the shell is known clean.
pub fn untangle_around(mesh: &Mesh, shell: &mut Shell, rounds: u32, factor: f32, seeds: Option<&[u32]>) -> u32 {
    if rounds == 0 || mesh.vertex_count() == 0 {
        return 0;
    }
    let checker = Checker::new(mesh);
    let normals = vertex_normals(mesh);
    let mut tri_dirty = vec![seeds.is_none(); checker.tris.len()];
    let mut cell_dirty = vec![seeds.is_none(); checker.cells.len()];
    for &v in seeds.unwrap_or(&[]) {
        checker.mark_around(v as usize, &mut tri_dirty, &mut cell_dirty);
    }
    let mut changed = 0;
    let mut outer_bvh = None;
    for _ in 0..rounds {
        let defects = checker.defects(mesh, shell, &tri_dirty, &cell_dirty, &mut outer_bvh);
        if defects.is_empty() {
            break;
        }
        changed += 1;
        let bend = bends(&normals, shell);
        let mut shrink = vec![false; mesh.vertex_count()];
        let mut mark = |vs: &[u32]| vs.iter().for_each(|v| shrink[*v as usize] = true);
        for d in &defects {
            match d {
                Defect::Whole(vs) => mark(vs),
                Defect::Crossing(a, b) => {
                    let most = |t: &[u32; 3]| t.iter().map(|v| bend[*v as usize]).fold(0.0f32, f32::max);
                    let (ba, bb) = (most(a), most(b));
                    if ba >= 0.5 * bb {
                        mark(a);
                    }
                    if bb >= 0.5 * ba {
                        mark(b);
                    }
                }
            }
        }
        tri_dirty.fill(false);
        cell_dirty.fill(false);
        for (v, &s) in shrink.iter().enumerate() {
            let f = factor.max(FLOOR * shell.target[v] / shell.achieved[v].max(f32::MIN_POSITIVE));
            if s && f < 1.0 {
                shell.base_offset[v] *= f;
                shell.directors[v] *= f;
                shell.achieved[v] = shell.directors[v].length();
                checker.mark_around(v, &mut tri_dirty, &mut cell_dirty);
            }
        }
    }
    changed
}
