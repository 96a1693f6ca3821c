//! Incremental shell update after local edits (section 7.1): the field is local
//! (4.3.1), so after moving some vertices only the directors whose trajectories the
//! changed triangles can reach are traced again.
//!
//! Which ones, is decided per trajectory from a few of its points and the field's
//! strength there ([`influence`](super::influence)): a change of the surface beyond
//! the support ball changes nothing; a change within it is bounded by its distance,
//! and when that bound relative to the field's own strength stays below
//! [`IncrementalShell::tolerance`] the director is kept. The bounds a kept trajectory
//! was spared add up over updates, so many small edits retrace it in the end.
//! Tolerance 0 retraces every trajectory within reach (the locality rule alone).
//!
//! The work of an update is in proportion to the edit: the triangulation, normals,
//! first steps and boundary faces are redone only around moved vertices, the patch
//! tree and the defect checker's trees are refitted, not rebuilt, and the repair pass
//! starts from the retraced directors.

use super::defects::Checker;
use super::directors::{
    assemble, check_inputs, min_edge_at, piece_max_edge, piece_size, piece_sizes, side_lengths, trace_vertices, watched_steps, Trace, Tracer,
    FIELD_PIECES_BUDGET, TRACE_SAMPLES,
};
use super::influence::ChangeBound;
use super::intersect::{tri_box, TriBvh};
use super::lp_distance::{extension_faces, PatchTree};
use super::repair::Repair;
use super::{Shell, ShellParams, Side, Thickness};
use crate::mesh::{face_triangles, vertex_normal, Crowding, Weld};
use crate::progress::Progress;
use crate::{Error, Mesh, Result};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Default of [`IncrementalShell::tolerance`]: a trajectory is kept when the change
/// of the surface can turn the field along it by at most this (radians, relative
/// speed); measured director changes stay two orders of magnitude below the
/// thickness (`shell_bench`).
pub const DEFAULT_TOLERANCE: f64 = 3e-2;

/// When more than this fraction of the vertices changed, the update is a rebuild (not
/// from the thesis: past a third, `shell_bench`'s updates cost as much as a rebuild).
const REBUILD_FRACTION: usize = 3;

/// How many rings of repaired directors around the retraced ones an update resets
/// and repairs again; beyond them, repaired directors keep their length and the
/// repair rounds shorten the reset ones instead where they share a defect
/// ([`Repair::held`]). Not from the thesis: connected repaired regions span whole
/// compressed shells (the twice-subdivided comb inside at 5%: 10.3k of 24.8k vertices
/// reset for a 248-vertex edit, its update all repair), and Suzanne's edit in the
/// Python suite needs 5 rings to stay within 3 vertices of a rebuild's.
const RESET_RINGS: u32 = 6;

/// What one update did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct UpdateStats {
    /// Vertices whose position or thickness changed.
    pub changed: usize,
    /// Directors traced again.
    pub retraced: usize,
    /// Directors within reach of the change that the tolerance let keep their value.
    pub kept: usize,
    /// Directors repaired again from their traced value: the retraced ones and the
    /// repaired ones connected to them.
    pub resettled: usize,
    /// Whether the update rebuilt the whole shell (topology or most vertices changed).
    pub rebuilt: bool,
    /// Whether the field's patch tree was built anew over the whole mesh (a cost in
    /// proportion to the mesh, not to the edit): in a local update, because the moved
    /// triangles could not be refitted in it; always in a rebuild.
    pub field_rebuilt: bool,
}

impl UpdateStats {
    /// A rebuild of all `n` vertices after `changed` changed.
    fn rebuilt(changed: usize, n: usize) -> Self {
        Self { changed, retraced: n, kept: 0, resettled: n, rebuilt: true, field_rebuilt: true }
    }
}

/// The updated shell of a mesh without coincident vertices (the welded mesh of an
/// [`IncrementalShell`] whose base has split seams).
struct Tracked {
    mesh: Mesh,
    thickness: Vec<f32>,
    lengths: Vec<f32>,
    side: Side,
    params: ShellParams,
    tracer: Tracer,
    /// First triangle of each face (and the total at the end).
    face_tris: Vec<u32>,
    on_boundary: Vec<bool>,
    /// Integration triangles: the mesh's, then the boundary extension's.
    tris: Vec<[DVec3; 3]>,
    traces: Vec<(Trace, Trace)>,
    /// Bound on the relative field change each kept trajectory has been spared since
    /// it was traced (summed over updates).
    drifted: Vec<f32>,
    shell: Shell,
    checker: Checker,
    outer_bvh: Option<TriBvh>,
}

impl Tracked {
    fn new(mesh: Mesh, thickness: Vec<f32>, side: Side, params: ShellParams) -> Result<Self> {
        Self::new_watched(mesh, thickness, side, params, None)
    }

    fn new_watched(mesh: Mesh, thickness: Vec<f32>, side: Side, params: ShellParams, progress: Option<&Progress>) -> Result<Self> {
        check_inputs(&mesh, &thickness, &params)?;
        let (steps, settle) = watched_steps(mesh.vertex_count(), params.repair_rounds > 0 && mesh.vertex_count() > 0);
        progress.inspect(|p| p.start(steps));
        let lengths = side_lengths(&thickness, side);
        let (tracer, tris) = Tracer::new(&mesh, &lengths, &params);
        // A face of k corners splits into k - 2 triangles (`face_triangles`).
        let face_tris: Vec<u32> = std::iter::once(0)
            .chain(mesh.faces().scan(0u32, |n, f| {
                *n += f.len().saturating_sub(2) as u32;
                Some(*n)
            }))
            .collect();
        let mut on_boundary = vec![false; mesh.vertex_count()];
        tracer.boundary.iter().for_each(|&(a, b)| (on_boundary[a as usize], on_boundary[b as usize]) = (true, true));
        let all: Vec<u32> = (0..mesh.vertex_count() as u32).collect();
        let traces = trace_vertices(&tracer, &mesh, &lengths, side, &params, &all, progress)?;
        let mut shell = assemble(&mesh, &thickness, side, &traces);
        let checker = Checker::new(&mesh);
        let mut outer_bvh = None;
        if params.medial_stop && params.repair_rounds > 0 {
            super::room::stop_at_room(&checker, &mesh, &mut shell, None);
        }
        let repair = Repair::for_build(&checker, &mesh, &tracer.normals, params.repair_rounds, progress);
        shell.check = repair.settle(&mut outer_bvh, &mut shell, None);
        if let Some(p) = progress {
            p.check()?;
            p.advance(settle);
        }
        Ok(Self {
            mesh,
            thickness,
            lengths,
            side,
            params,
            tracer,
            face_tris,
            on_boundary,
            tris,
            drifted: vec![0.0; traces.len()],
            traces,
            shell,
            checker,
            outer_bvh,
        })
    }

    fn traced_directors(&self) -> Vec<Vec3> {
        assemble(&self.mesh, &self.thickness, self.side, &self.traces).directors
    }

    /// [`IncrementalShell::update`] on this mesh's vertices (checked there), keeping
    /// trajectories within `tolerance` (module docs).
    fn update(&mut self, positions: &[Vec3], thickness: &[f32], tolerance: f64) -> Result<UpdateStats> {
        let n = self.mesh.vertex_count();
        let moved: Vec<u32> = (0..n as u32).filter(|&v| positions[v as usize] != self.mesh.positions()[v as usize]).collect();
        let thicker: Vec<u32> = (0..n as u32).filter(|&v| thickness[v as usize] != self.thickness[v as usize]).collect();
        let changed = moved.iter().chain(&thicker).collect::<std::collections::BTreeSet<_>>().len();
        if changed == 0 {
            return Ok(UpdateStats::default());
        }
        for &v in &moved {
            self.mesh.set_position(v as usize, positions[v as usize])?;
        }
        self.thickness.copy_from_slice(thickness);
        self.lengths = side_lengths(&self.thickness, self.side);
        if changed * REBUILD_FRACTION > n {
            return self.rebuild(changed);
        }

        let (touched_face, around) = self.refresh_around(&moved);
        let Some((changes, retriangulated, field_rebuilt)) = self.changed_triangles(&touched_face, &around, &thicker) else {
            return self.rebuild(changed);
        };
        let mut must = vec![false; n];
        around.iter().chain(&thicker).chain(&moved).for_each(|&u| must[u as usize] = true);
        let (dirty, kept) = self.choose_retraced(&changes, &must, tolerance);
        let fresh = trace_vertices(&self.tracer, &self.mesh, &self.lengths, self.side, &self.params, &dirty, None)?;
        for (&v, t) in dirty.iter().zip(fresh) {
            self.traces[v as usize] = t;
        }
        let (mut seeds, held, traced) = self.reset_repaired(&dirty);
        let resettled = seeds.len();
        let reset = seeds.clone();
        let flipped = if retriangulated {
            self.checker = Checker::new(&self.mesh);
            self.outer_bvh = None;
            // Crossings and probes are found anew: the parts that cross are looked
            // for near their (maybe new) probes, as after flipped flags.
            self.checker.own_tris()
        } else {
            let flipped = self.checker.refit_base(&self.mesh, &moved);
            self.seed_pierced_outer(&changes, &flipped, &mut seeds);
            flipped
        };
        // A part that moved may now lie inside another part's cells, which did not
        // change: those cells are checked again.
        let reach = self.shell.base_offset.iter().zip(&self.shell.directors).map(|(b, d)| (b.length() + d.length()) as f64).fold(0.0, f64::max);
        seeds.extend(self.checker.cells_near_probes(&self.mesh, &moved, &flipped, reach));
        if self.params.medial_stop && self.params.repair_rounds > 0 {
            // The reset directors are bounded as a build bounds them, the facing
            // sides' reach measured on their traced directors (the others keep their
            // bound or repair).
            super::room::stop_at_room(&self.checker, &self.mesh, &mut self.shell, Some((&reset, &traced)));
        }
        let repair = Repair { held: Some(&held), ..Repair::for_build(&self.checker, &self.mesh, &self.tracer.normals, self.params.repair_rounds, None) };
        self.shell.check = repair.settle(&mut self.outer_bvh, &mut self.shell, Some(&seeds));
        Ok(UpdateStats { changed, retraced: dirty.len(), kept, resettled, rebuilt: false, field_rebuilt })
    }

    /// The faces around moved vertices, and the vertices of those faces, whose normal
    /// and first step are recomputed here.
    fn refresh_around(&mut self, moved: &[u32]) -> (Vec<bool>, Vec<u32>) {
        let n = self.mesh.vertex_count();
        let mut touched_face = vec![false; self.mesh.face_count()];
        let mut around = vec![false; n];
        for &v in moved {
            for &f in self.tracer.faces_around.of(v as usize) {
                if !std::mem::replace(&mut touched_face[f as usize], true) {
                    self.mesh.face(f as usize).iter().for_each(|&u| around[u as usize] = true);
                }
            }
        }
        let around: Vec<u32> = (0..n as u32).filter(|&u| around[u as usize]).collect();
        for &u in &around {
            let faces = self.tracer.faces_around.of(u as usize);
            self.tracer.normals[u as usize] = vertex_normal(&self.mesh, u, faces);
            self.tracer.min_edge[u as usize] = min_edge_at(&self.mesh, u, faces);
        }
        (touched_face, around)
    }

    /// The integration triangles that changed, as (index, old, new), written into
    /// `tris` and the patch tree, and whether a face other than a quad was split
    /// anew (the checker, which holds the triangulation, is then rebuilt), and whether
    /// the patch tree was built anew rather than refitted. `None`: a face's triangle
    /// count changed, an edited size splits a triangle into other pieces, or the
    /// rebuilt tree took another scale; rebuild.
    #[allow(clippy::type_complexity)]
    fn changed_triangles(&mut self, touched_face: &[bool], around: &[u32], thicker: &[u32]) -> Option<(Vec<(usize, [DVec3; 3], [DVec3; 3])>, bool, bool)> {
        let p = self.mesh.positions();
        let mut changes: Vec<(usize, [DVec3; 3])> = Vec::new();
        let mut scratch = Vec::new();
        let mut retriangulated = false;
        for f in (0..touched_face.len()).filter(|&f| touched_face[f]) {
            let range = self.face_tris[f] as usize..self.face_tris[f + 1] as usize;
            scratch.clear();
            face_triangles(p, self.mesh.face(f), &mut scratch);
            if scratch.len() != range.len() {
                return None;
            }
            // The checker holds both splits of every quad (and its cells are the
            // quads themselves): only another split of a larger face changes it.
            let quad = self.mesh.face(f).len() == 4;
            for (i, t) in range.zip(&scratch) {
                retriangulated |= !quad && self.checker.tris[i] != *t;
                changes.push((i, t.map(|k| p[k as usize].as_dvec3())));
            }
        }
        if !self.tracer.boundary.is_empty() && around.iter().chain(thicker).any(|&u| self.on_boundary[u as usize]) {
            let first = *self.face_tris.last().unwrap() as usize;
            let ext = extension_faces(&self.tracer.boundary, p, &self.tracer.normals, &self.lengths);
            changes.extend(ext.into_iter().enumerate().map(|(k, t)| (first + k, t)));
        }
        let changes: Vec<(usize, [DVec3; 3], [DVec3; 3])> =
            changes.into_iter().filter(|(i, t)| self.tris[*i] != *t).map(|(i, t)| (i, self.tris[i], t)).collect();
        // The pieces the field integrates are sized by the median thickness
        // (`piece_size`) and split only slivers: where an edit moves the median past a
        // power of two, or turns a triangle into a sliver or back, so that it splits
        // into other pieces, the field changes beyond what the moved triangles bound,
        // and the shell is rebuilt.
        let base_count = *self.face_tris.last().unwrap_or(&0) as usize;
        let size = piece_size(&self.lengths);
        let mut sizes = piece_sizes(size, &self.tris, base_count);
        for &(i, _, t) in changes.iter().filter(|c| c.0 < base_count) {
            sizes[i] = piece_max_edge(&t, size);
        }
        if !self.tracer.tree.adopt_sizes(&self.tris, &sizes) {
            return None;
        }
        for &(i, _, t) in &changes {
            self.tris[i] = t;
        }
        let moved_tris: Vec<_> = changes.iter().map(|&(i, _, t)| (i, t)).collect();
        let field_rebuilt = !self.tracer.tree.refit_triangles(&moved_tris);
        if field_rebuilt {
            let tree = PatchTree::build_refined(&self.tris, &sizes, self.tris.len() * FIELD_PIECES_BUDGET);
            // Another scale splits every sliver otherwise, not only the moved ones.
            if tree.scale() != self.tracer.tree.scale() {
                return None;
            }
            self.tracer.tree = tree;
        }
        Some((changes, retriangulated, field_rebuilt))
    }

    /// The trajectories to trace again: the `must` ones, and those within reach of the
    /// change whose summed drift passes the tolerance (module docs). Returns them and
    /// how many within reach were kept.
    fn choose_retraced(&mut self, changes: &[(usize, [DVec3; 3], [DVec3; 3])], must: &[bool], tolerance: f64) -> (Vec<u32>, usize) {
        let n = self.mesh.vertex_count();
        let pairs: Vec<_> = changes.iter().map(|(_, old, new)| (*old, *new)).collect();
        let mean_reach = self.params.support * self.lengths.iter().map(|&l| l as f64).sum::<f64>() / n as f64;
        let bound = ChangeBound::new(&pairs, (mean_reach / 10.0).max(f64::MIN_POSITIVE), self.params.p);
        let (support, lengths, drifted) = (self.params.support, &self.lengths, &self.drifted);
        // (vertex, its trajectories' drift so far with this update's, retrace?)
        let verdicts: Vec<(u32, f64, bool)> = (0..n as u32)
            .into_par_iter()
            .filter_map(|v| {
                if must[v as usize] {
                    return Some((v, 0.0, true));
                }
                let (o, i) = &self.traces[v as usize];
                let reach = support * lengths[v as usize] as f64;
                let within = |t: &Trace| t.radius > 0.0 && bound.reaches(t.center.as_dvec3(), t.center.as_dvec3(), reach + t.radius as f64);
                if !(within(o) || within(i)) {
                    return None;
                }
                // Kept trajectories add up the changes they were spared, edit after
                // edit: the tolerance bounds the sum since they were traced.
                let d = [o, i].iter().filter(|t| t.radius > 0.0).map(|t| drift(&bound, t, reach)).fold(0.0, f64::max);
                let total = drifted[v as usize] as f64 + d;
                Some((v, total, total > tolerance))
            })
            .collect();
        for &(v, total, retrace) in &verdicts {
            self.drifted[v as usize] = if retrace { 0.0 } else { total as f32 };
        }
        let dirty: Vec<u32> = verdicts.iter().filter(|(_, _, r)| *r).map(|(v, _, _)| *v).collect();
        let kept = verdicts.len() - dirty.len();
        (dirty, kept)
    }

    /// The repair shortens the directors of a tangle together, round by round, so its
    /// result depends on the whole group. The repaired directors connected to the
    /// retraced ones go back to their traced value with them; the repair then runs
    /// again from these seeds: the rounds a rebuild would run on these groups.
    /// Repaired groups the update did not retrace keep their repair, and so do the
    /// repaired directors more than [`RESET_RINGS`] rings from the retraced ones:
    /// returned as held, they are shortened again only by defects no reset director
    /// touches. (Resetting three rings while letting the repair shorten the directors
    /// beyond them cut an edit of 2 vertices of the twice-subdivided comb inside at 5%
    /// from 130 to 14-19 ms, but left Suzanne and bunny updates 6-7 vertices more than
    /// a quarter of the thickness from a rebuild's in the Python suite, where 3 are
    /// allowed.)
    fn reset_repaired(&mut self, retraced: &[u32]) -> (Vec<u32>, Vec<bool>, Vec<Vec3>) {
        let raw = assemble(&self.mesh, &self.thickness, self.side, &self.traces);
        let repaired = |v: usize| self.shell.directors[v] != raw.directors[v] || self.shell.base_offset[v] != raw.base_offset[v];
        let mut reset = vec![false; self.mesh.vertex_count()];
        let mut held = vec![false; self.mesh.vertex_count()];
        let mut ring: Vec<u32> = retraced.to_vec();
        ring.iter().for_each(|&v| reset[v as usize] = true);
        let mut seeds = Vec::with_capacity(ring.len());
        let mut depth = 0;
        while !ring.is_empty() {
            seeds.extend_from_slice(&ring);
            let mut next = Vec::new();
            for &v in &ring {
                for &f in self.tracer.faces_around.of(v as usize) {
                    for &u in self.mesh.face(f as usize) {
                        if !reset[u as usize] && !held[u as usize] && repaired(u as usize) {
                            if depth < RESET_RINGS {
                                reset[u as usize] = true;
                                next.push(u);
                            } else {
                                held[u as usize] = true;
                            }
                        }
                    }
                }
            }
            ring = next;
            depth += 1;
        }
        // Every repaired director not reset is held, not only the ring just beyond:
        // a defect between a reset director and one further out must not shorten the
        // far one (a far change from a local edit).
        for (v, h) in held.iter_mut().enumerate() {
            *h = !reset[v] && repaired(v);
        }
        for &v in &seeds {
            let v = v as usize;
            self.shell.base_offset[v] = raw.base_offset[v];
            self.shell.directors[v] = raw.directors[v];
            self.shell.achieved[v] = raw.achieved[v];
        }
        self.shell.target = raw.target;
        (seeds, held, raw.directors)
    }

    /// Moved base triangles can cross skin triangles no retraced director touches:
    /// the vertices of the skin triangles near them, and their own, join the repair's
    /// seeds (their directors keep their value). A crossing is inherited only where
    /// its two base triangles cross each other, and a base pair starts or stops
    /// crossing only where one of its triangles moved, whose vertices are seeds
    /// already; base triangles that began or stopped crossing the base (`flipped`) are
    /// seeded too, as they change which parts the probes of crossing parts answer for.
    fn seed_pierced_outer(&self, changes: &[(usize, [DVec3; 3], [DVec3; 3])], flipped: &[u32], seeds: &mut Vec<u32>) {
        let Some(outer) = &self.outer_bvh else { return };
        let mut near = vec![false; self.mesh.vertex_count()];
        seeds.iter().for_each(|&v| near[v as usize] = true);
        let mut seed = |t: u32, seeds: &mut Vec<u32>| {
            for &v in &self.checker.tris[t as usize] {
                if !std::mem::replace(&mut near[v as usize], true) {
                    seeds.push(v);
                }
            }
        };
        let base_count = *self.face_tris.last().unwrap() as usize;
        let moved = changes.iter().filter(|c| c.0 < base_count).map(|c| c.2);
        for t in flipped {
            seed(*t, seeds);
        }
        for tri in moved.chain(flipped.iter().map(|&t| self.checker.base[t as usize])) {
            let (lo, hi) = tri_box(&tri);
            outer.query(lo, hi, |i| seed(self.checker.item_tri(i), seeds));
        }
    }

    fn rebuild(&mut self, changed: usize) -> Result<UpdateStats> {
        *self = Self::new(self.mesh.clone(), self.thickness.clone(), self.side, self.params.clone())?;
        Ok(UpdateStats::rebuilt(changed, self.mesh.vertex_count()))
    }
}

/// A shell kept up to date while its base mesh is edited. A base with split seams
/// (vertices at one position, [`Mesh::weld_coincident`]) is tracked welded, as
/// [`build_shell`](super::build_shell) builds it; an edit that pulls welded vertices
/// apart rebuilds it with the new seams.
pub struct IncrementalShell {
    tracked: Tracked,
    seams: Option<Seams>,
    /// Who shares a position with whom in the base as given: an edit that moves no
    /// vertex onto or off a shared position keeps the seams, unsorted.
    crowding: Crowding,
    /// Bound on the relative field change a kept trajectory may see (module docs).
    pub tolerance: f64,
}

/// The base as given, beside its welded copy in [`Tracked`].
struct Seams {
    weld: Weld,
    mesh: Mesh,
    thickness: Vec<f32>,
    /// The tracked shell given back to every original vertex.
    shell: Shell,
}

impl IncrementalShell {
    pub fn new(mesh: Mesh, thickness: Vec<f32>, side: Side, params: ShellParams) -> Result<Self> {
        Self::new_watched(mesh, thickness, side, params, None)
    }

    /// [`IncrementalShell::new`] watched through `progress`, as
    /// [`build_shell_watched`](super::directors::build_shell_watched).
    pub fn new_watched(mesh: Mesh, thickness: Vec<f32>, side: Side, params: ShellParams, progress: Option<&Progress>) -> Result<Self> {
        check_inputs(&mesh, &thickness, &params)?;
        let crowding = Crowding::new(mesh.positions());
        let Some(weld) = mesh.weld_coincident() else {
            let tracked = Tracked::new_watched(mesh, thickness, side, params, progress)?;
            return Ok(Self { tracked, seams: None, crowding, tolerance: DEFAULT_TOLERANCE });
        };
        let tracked = Tracked::new_watched(weld.mesh.clone(), weld.least(&thickness), side, params, progress)?;
        let shell = tracked.shell.clone().expanded(&weld);
        Ok(Self { tracked, seams: Some(Seams { weld, mesh, thickness, shell }), crowding, tolerance: DEFAULT_TOLERANCE })
    }

    pub fn shell(&self) -> &Shell {
        self.seams.as_ref().map_or(&self.tracked.shell, |s| &s.shell)
    }
    pub fn mesh(&self) -> &Mesh {
        self.seams.as_ref().map_or(&self.tracked.mesh, |s| &s.mesh)
    }
    pub fn thickness(&self) -> &[f32] {
        self.seams.as_ref().map_or(&self.tracked.thickness, |s| &s.thickness)
    }
    /// The directors as traced, before the repair pass shortened any.
    pub fn traced_directors(&self) -> Vec<Vec3> {
        let traced = self.tracked.traced_directors();
        match &self.seams {
            Some(s) => s.weld.expand(&traced),
            None => traced,
        }
    }

    /// Moves vertices to new positions and updates the shell; returns how many
    /// directors were traced again.
    pub fn move_vertices(&mut self, moved: &[(u32, Vec3)]) -> Result<usize> {
        let mut positions = self.mesh().positions().to_vec();
        for &(v, p) in moved {
            *positions.get_mut(v as usize).ok_or_else(|| Error::InvalidParameter(format!("vertex {v} does not exist")))? = p;
        }
        let thickness = self.thickness().to_vec();
        Ok(self.update(&positions, &thickness)?.retraced)
    }

    /// Brings the shell to new vertex positions and target thickness (same vertex
    /// count and faces): only what changed is recomputed.
    pub fn update(&mut self, positions: &[Vec3], thickness: &[f32]) -> Result<UpdateStats> {
        let n = self.mesh().vertex_count();
        if positions.len() != n || thickness.len() != n {
            return Err(Error::InvalidParameter(format!(
                "{} positions and {} thickness values given for a shell of {n} vertices",
                positions.len(),
                thickness.len()
            )));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::NonFinite { index: i, value: positions[i].to_array() });
        }
        if let Some(i) = thickness.iter().position(|t| !t.is_finite()) {
            return Err(Error::InvalidParameter(format!("thickness of vertex {i} is not finite")));
        }
        let old = self.mesh().positions();
        let moved: Vec<u32> = (0..n as u32).filter(|&v| positions[v as usize] != old[v as usize]).collect();
        let changed = (0..n).filter(|&v| positions[v] != old[v] || thickness[v] != self.thickness()[v]).count();
        if changed == 0 {
            return Ok(UpdateStats::default());
        }
        let moves: Vec<(Vec3, Vec3)> = moved.iter().map(|&v| (old[v as usize], positions[v as usize])).collect();
        if !self.crowding.moves_alone(&moves) {
            // The seams as `build_shell` would weld them now: copies pulled apart, or
            // vertices moved onto others, make new seams, and the shell is built anew.
            let mut edited = self.mesh().clone();
            moved.iter().try_for_each(|&v| edited.set_position(v as usize, positions[v as usize]))?;
            if edited.weld_coincident().as_ref().map(|w| &w.of) != self.seams.as_ref().map(|s| &s.weld.of) {
                let (side, params, tolerance) = (self.tracked.side, self.tracked.params.clone(), self.tolerance);
                *self = Self::new(edited, thickness.to_vec(), side, params)?;
                self.tolerance = tolerance;
                return Ok(UpdateStats::rebuilt(changed, n));
            }
        }
        let stats = match self.seams.as_mut() {
            None => self.tracked.update(positions, thickness, self.tolerance),
            Some(seams) => {
                let welded = seams.weld.positions(positions).expect("the same seams: copies share their positions");
                // Traced, kept and resettled count directors (a seam's copies share one).
                self.tracked.update(&welded, &seams.weld.least(thickness), self.tolerance).and_then(|stats| {
                    moved.iter().try_for_each(|&v| seams.mesh.set_position(v as usize, positions[v as usize]))?;
                    seams.thickness.copy_from_slice(thickness);
                    seams.shell = self.tracked.shell.clone().expanded(&seams.weld);
                    Ok(UpdateStats { changed, ..stats })
                })
            }
        };
        match stats {
            Ok(_) => self.crowding.apply(&moves),
            // The tracked mesh may hold some of the new positions: counted anew.
            Err(_) => self.crowding = Crowding::new(self.mesh().positions()),
        }
        stats
    }

    /// [`update`](Self::update) with the thickness given by its rule (and per-vertex
    /// factors), resolved on the new positions: relative thickness follows the
    /// edited mesh's size.
    pub fn update_with(&mut self, positions: &[Vec3], rule: &Thickness, factors: Option<&[f32]>) -> Result<UpdateStats> {
        let n = self.mesh().vertex_count();
        if positions.len() != n {
            return Err(Error::InvalidParameter(format!("{} positions given for a shell of {n} vertices", positions.len())));
        }
        let thickness = rule.per_vertex_at(self.mesh(), positions, factors)?;
        self.update(positions, &thickness)
    }
}

/// Largest relative change of the field the surface change can cause along a
/// trajectory (between consecutive samples, against the weaker field of the two).
fn drift(bound: &ChangeBound, t: &Trace, reach: f64) -> f64 {
    let mut worst = 0.0f64;
    for k in 0..TRACE_SAMPLES - 1 {
        let (a, b) = (t.samples[k], t.samples[k + 1]);
        let change = bound.on_segment(a.at.as_dvec3(), b.at.as_dvec3(), reach);
        if change > 0.0 {
            worst = worst.max(change / a.push.min(b.push) as f64);
        }
    }
    worst
}
