//! Local thickness reduction where the traced shell is still tangled: the field
//! trajectories never cross, but their straight chords (chapter 3.1, "virtual
//! trajectories") can, in sharp concave corners and where trajectories converge.
//! The thesis accepts this (4.6); we shorten the directors of every defect — an
//! inverted cell, or an outer-layer triangle crossing another one or the base —
//! towards their base point, so thickness is reduced only there. A director already
//! at the [`FLOOR`] that is still the corner of an inverted cell points away from its
//! side's normal (a trajectory bent by self-intersecting input): no length unfolds
//! that cell, so it turns to the normal, at the same length. After the first round only the triangles and cells touching a
//! changed director are checked again, so later rounds cost in proportion to the
//! defects left.

use super::defects::Checker;
use super::intersect::TriBvh;
use super::report::normal_shape;
use super::Shell;
use crate::mesh::vertex_normals;
use crate::Mesh;
use glam::Vec3;

/// Shortest director the repair leaves, as a fraction of the target: a cell of
/// vanishing height is degenerate, no better than a folded one.
pub const FLOOR: f32 = 0.05;

/// Shrinks directors around defects by `factor` per round, for at most `rounds`
/// rounds; returns the number of rounds that changed something.
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
    Repair { checker: &checker, mesh, normals: &normals, rounds, factor }.untangle(&mut None, shell, seeds)
}

/// What the repair and restore passes use besides the shell: the mesh, its defect
/// checker and vertex normals, and the repair's rounds and per-round factor.
pub(crate) struct Repair<'a> {
    pub checker: &'a Checker,
    pub mesh: &'a Mesh,
    pub normals: &'a [Vec3],
    pub rounds: u32,
    pub factor: f32,
}

impl Repair<'_> {
    /// [`untangle_around`] with an outer-layer tree kept by the caller (the
    /// incremental shell keeps it between edits): a kept tree must match `shell`
    /// except around `seeds`.
    pub fn untangle(&self, outer_bvh: &mut Option<TriBvh>, shell: &mut Shell, seeds: Option<&[u32]>) -> u32 {
        let Repair { checker, mesh, normals, rounds, factor } = *self;
        if rounds == 0 || mesh.vertex_count() == 0 {
            return 0;
        }
        let mut dirty = seeds.map(|s| {
            let mut d = checker.clean();
            s.iter().for_each(|v| checker.mark_around(*v as usize, &mut d));
            d
        });
        // A kept tree is refitted where the seeds' directors changed; otherwise in full.
        let mut outer = match (outer_bvh.take(), &dirty) {
            (Some(mut tree), Some(d)) => {
                tree.refit_items(d.tri_list.iter().map(|&t| (t, checker.outer_box(mesh, shell, t))));
                tree
            }
            (reuse, _) => checker.outer_tree(mesh, shell, reuse),
        };
        let mut changed = 0;
        // Two flag sets, swapped round after round: clearing costs what they held.
        let mut next = checker.clean();
        for _ in 0..rounds {
            let found = checker.find(mesh, shell, dirty.as_ref(), Some(&outer));
            next.clear();
            let mut any = false;
            let mut folded: Vec<u32> = found.inverted.iter().flat_map(|&c| checker.cells[c as usize].base()).copied().collect();
            folded.sort_unstable();
            for v in checker.defect_vertex_list(&found) {
                let folds = folded.binary_search(&v).is_ok();
                let v = v as usize;
                let f = factor.max(FLOOR * shell.target[v] / shell.achieved[v].max(f32::MIN_POSITIVE));
                let length = shell.achieved[v];
                let along = normal_shape(shell.side, normals[v]).1;
                if length <= 0.0 {
                    continue; // nothing to shorten or turn (a zero target)
                } else if f < 1.0 {
                    shell.base_offset[v] *= f;
                    shell.directors[v] *= f;
                    shell.achieved[v] = shell.directors[v].length();
                } else if folds && along != Vec3::ZERO && shell.directors[v].dot(along) < 0.999 * length {
                    (shell.base_offset[v], shell.directors[v]) = normal_shape(shell.side, normals[v] * length);
                } else {
                    continue;
                }
                checker.mark_around(v, &mut next);
                any = true;
            }
            if !any {
                break;
            }
            changed += 1;
            // Only the outer triangles around shortened directors moved.
            outer.refit_items(next.tri_list.iter().map(|&t| (t, checker.outer_box(mesh, shell, t))));
            match dirty.as_mut() {
                Some(d) => std::mem::swap(d, &mut next),
                None => dirty = Some(std::mem::replace(&mut next, checker.clean())),
            }
        }
        *outer_bvh = Some(outer);
        changed
    }
}
