//! Multiresolution surfaces (Velho, Perlin, Ying and Biermann, section 2 and Figure 1): a
//! coarse mesh and, per level, detail offsets added to the subdivided coarser level, each
//! stored in the local frame (normal + tangent, [`super::detail::Frame`]) of that subdivided level, so the
//! details follow the surface when the base is edited. [`synthesize`] rebuilds the fine mesh;
//! [`analyze`] splits a fine mesh with the connectivity of subdivided base topology back
//! into a coarse mesh and details.
//!
//! The coarse level of each analysis step is the least-squares fit `min |S P - P_fine|`
//! (section 2 lists "quasi-interpolation or fitting"): `S` the Catmull-Clark step,
//! solved by conjugate gradients on the normal equations. It inverts a plain subdivision
//! exactly at every valence (so such a mesh has zero details), where inverting the vertex
//! rule locally, `v = (n v' - (4 sum E - sum F) / n) / (n - 3)`, is singular at valence 3.

use super::detail::frames::all_frames;
use super::detail::{self, Offsets, State};
use super::topology::{Level, NONE};
use crate::progress::Progress;
use crate::spatial::Bvh;
use crate::{Error, Mesh, Result};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// A multiresolution surface: the coarsest mesh and `details[l - 1]`, one offset per vertex
/// of level `l`, in the frame (t, b, n) of that vertex on the subdivided level `l - 1`
/// (before its details are added).
#[derive(Debug, Clone, PartialEq)]
pub struct Multires {
    pub base: Mesh,
    pub details: Vec<Vec<DVec3>>,
}

/// The vertex count of each level 1..=`levels` of `base`'s subdivision.
pub fn level_vertex_counts(base: &Mesh, levels: u32) -> Result<Vec<usize>> {
    let level = Level::base(base)?;
    let (mut v, mut e, mut f, mut c) = (level.positions.len(), level.edges.len(), level.face_count(), level.corners.len());
    Ok((0..levels)
        .map(|_| {
            (v, e, f, c) = (v + e + f, 2 * e + c, c, 4 * c);
            v
        })
        .collect())
}

/// Checks `details` against the vertex counts of `base`'s levels, and that they are finite.
pub(crate) fn validate_details(base: &Mesh, details: &[Vec<DVec3>]) -> Result<()> {
    if details.len() > super::MAX_LEVELS as usize {
        return Err(Error::InvalidParameter(format!("at most {} detail levels, not {}", super::MAX_LEVELS, details.len())));
    }
    // Detail up to MAX_DETAIL diagonals at up to MAX_LEVELS levels stays far inside f32.
    let diagonal = base.bbox_diagonal();
    if !(diagonal.is_finite() && diagonal <= 1e30) {
        return Err(Error::InvalidParameter(format!("the base is {diagonal} across: too large for detail in f32")));
    }
    let counts = level_vertex_counts(base, details.len() as u32)?;
    for (l, (d, &n)) in details.iter().zip(&counts).enumerate() {
        if d.len() != n {
            return Err(Error::InvalidParameter(format!("level {} has {} details, but that level of the base has {n} vertices", l + 1, d.len())));
        }
        let most = MAX_DETAIL * base.bbox_diagonal() as f64;
        if let Some(v) = d.iter().position(|x| !(x.is_finite() && x.length() <= most)) {
            return Err(Error::InvalidParameter(format!(
                "detail of vertex {v} at level {} is not finite or longer than {MAX_DETAIL} times the base's size: {}",
                l + 1,
                d[v]
            )));
        }
    }
    Ok(())
}

/// Details longer than this many times the base's bounding-box diagonal are refused (an
/// analysed sculpt's are a small fraction of it).
pub const MAX_DETAIL: f64 = 1e3;

/// The world-space offsets of `local` details in the frames of `mesh` (normals `normals`).
pub(crate) fn to_world(mesh: &Mesh, normals: &[Vec3], local: &[DVec3]) -> Vec<DVec3> {
    all_frames(mesh, normals).par_iter().zip(local).map(|(f, &d)| f.to_world(d)).collect()
}

/// Multiresolution synthesis (section 2, Figure 1): subdivide the coarser level, add its
/// details in the local frames, repeat. Levels past the details are not made.
pub fn synthesize(m: &Multires) -> Result<Mesh> {
    validate_details(&m.base, &m.details)?;
    if m.details.is_empty() {
        return Ok(m.base.clone());
    }
    let out = detail::synthesize(&m.base, m.details.len() as u32, State::default(), |level, mesh, normals, _| {
        Offsets::World(to_world(mesh, normals, &m.details[level as usize - 1]))
    })?;
    Ok(out.mesh)
}

/// Multiresolution analysis (section 2, Figure 1): `fine` must be `levels` Catmull-Clark
/// subdivisions of `base_topology` (its faces; its positions are not read) in
/// [`super::subdivide`]'s vertex numbering (its faces in any order, each from any first
/// corner, winding kept). Each coarser level is the least-squares fit of the
/// finer one (see the module's note); the details are then taken level by level against
/// the subdivision of the rebuilt coarser level, exactly as [`synthesize`] adds them, so
/// rounding does not build up: `synthesize(&analyze(..))` is `fine` to float precision.
pub fn analyze(fine: &Mesh, base_topology: &Mesh, levels: u32) -> Result<Multires> {
    analyze_watched(fine, base_topology, levels, None)
}

/// [`analyze`] reporting to `progress` (see [`Stages`]) and stopping with
/// [`Error::Cancelled`] at its next check once cancelling was asked for.
pub fn analyze_watched(fine: &Mesh, base_topology: &Mesh, levels: u32, progress: Option<&Progress>) -> Result<Multires> {
    if !(1..=super::MAX_LEVELS).contains(&levels) {
        return Err(Error::InvalidParameter(format!("analysis levels must be 1 to {}, not {levels}", super::MAX_LEVELS)));
    }
    if let Some(v) = fine.positions().iter().position(|p| !p.is_finite()) {
        return Err(Error::NonFinite { index: v, value: fine.positions()[v].to_array() });
    }
    let stages = Stages::start(progress, base_topology, levels)?;
    let topology = levels_of_watched(base_topology, levels, &stages)?;
    let finest = &topology[levels as usize];
    let not_ours = |why: String| {
        Err(Error::InvalidMesh(format!(
            "the fine mesh ({} vertices, {} faces) is not {levels} Catmull-Clark subdivisions of the base ({} vertices, {} faces) in Thicket's numbering: {why}",
            fine.vertex_count(),
            fine.face_count(),
            finest.vertex_count(),
            finest.face_count()
        )))
    };
    if fine.vertex_count() != finest.vertex_count() {
        return not_ours(format!("those have {} vertices", finest.vertex_count()));
    }
    if let Some(f) = fine.faces().position(|face| face.len() != 4) {
        return not_ours(format!("its face {f} has {} corners, where those are all quads", fine.face(f).len()));
    }
    if fine.face_count() != finest.face_count() {
        return not_ours(format!("those have {} quads", finest.face_count()));
    }
    // The analysis reads positions by vertex number alone: the faces may come in any
    // order and from any first corner (Blender's renumbered sculpt does), not otherwise.
    let ours = oriented_quads(finest.corners());
    if oriented_quads(fine.corners()) != ours {
        let why = match fine.faces().position(|q| ours.binary_search(&oriented_quad(q)).is_err()) {
            Some(f) => format!("its face {f} {:?} is none of theirs", fine.face(f)),
            None => "it repeats a face".to_string(),
        };
        return not_ours(format!("{why} (a mesh numbered otherwise, such as Blender's: match_subdivision gives the order)"));
    }
    analyze_on(fine.positions(), &topology, base_topology, levels, &stages)
}

/// Vectors per parallel part of the fit's dot products (a fixed split: deterministic).
const DOT_CHUNK: usize = 4096;

/// A quad's corners from its least vertex, its winding kept.
fn oriented_quad(q: &[u32]) -> [u32; 4] {
    let k = (0..4).min_by_key(|&i| q[i]).expect("four corners");
    [q[k], q[(k + 1) % 4], q[(k + 2) % 4], q[(k + 3) % 4]]
}

/// All quads of `corners` as [`oriented_quad`]s, sorted: equal for the same oriented
/// faces in any order and from any first corner.
fn oriented_quads(corners: &[u32]) -> Vec<[u32; 4]> {
    let mut quads: Vec<[u32; 4]> = corners.par_chunks_exact(4).map(oriented_quad).collect();
    quads.par_sort_unstable();
    quads
}

/// [`analyze`] once the fine positions are known to be those of `topology` (the plain
/// levels 0..=`levels` of `base_topology`, from [`levels_of`]).
fn analyze_on(fine: &[Vec3], topology: &[Mesh], base_topology: &Mesh, levels: u32, stages: &Stages) -> Result<Multires> {
    // Coarse targets, finest first.
    let mut targets: Vec<Vec<DVec3>> = vec![fine.iter().map(|p| p.as_dvec3()).collect()];
    for l in (0..levels as usize).rev() {
        let step = Step::of(&topology[l], &topology[l + 1])?;
        let n = topology[l + 1].vertex_count();
        stages.advance(STEP_WEIGHT * n)?;
        targets.push(step.fit(targets.last().expect("a finer level"), stages, FIT_WEIGHT * n)?);
    }
    targets.reverse();
    let base = Mesh::new(targets[0].iter().map(|p| p.as_vec3()).collect(), &base_topology.face_sizes(), base_topology.corners().to_vec(), None)?;
    let mut details = Vec::with_capacity(levels as usize);
    detail::synthesize(&base, levels, State::default(), |level, mesh, normals, _| {
        let target = &targets[level as usize];
        let w: Vec<DVec3> = mesh.positions().iter().zip(target).map(|(p, t)| *t - p.as_dvec3()).collect();
        if stages.advance(mesh.vertex_count()).is_ok() {
            // Once cancelled the remaining levels only subdivide (checked below).
            details.push(all_frames(mesh, normals).iter().zip(&w).map(|(f, &w)| f.to_local(w)).collect());
        }
        Offsets::World(w)
    })?;
    stages.check()?;
    Ok(Multires { base, details })
}

/// The plain subdivisions of `base` at levels 0..=`levels`, numbered as [`synthesize`]
/// numbers them (they come from the same loop).
fn levels_of(base: &Mesh, levels: u32) -> Result<Vec<Mesh>> {
    levels_of_watched(base, levels, &Stages::default())
}

/// [`levels_of`], each level counted in `stages` (stopping at a cancel).
fn levels_of_watched(base: &Mesh, levels: u32, stages: &Stages) -> Result<Vec<Mesh>> {
    let mut out = vec![base.clone()];
    detail::synthesize(base, levels, State::default(), |_, mesh, _, _| {
        if stages.advance(mesh.vertex_count()).is_ok() {
            out.push(mesh.clone());
        }
        Offsets::Normal(vec![0.0; mesh.vertex_count()])
    })?;
    stages.check()?;
    Ok(out)
}

/// Weights of an analysis' stages in [`Stages`], per vertex of the finer level of a step
/// (the subdivisions and the synthesis of the details count one per vertex): building
/// the step's matrix, and its least-squares fit (timed on a 126k-vertex sculpt: plain
/// levels 0.1 s, matrices 0.3 s, fits 0.55 s, details 0.05 s).
const STEP_WEIGHT: usize = 3;
const FIT_WEIGHT: usize = 6;

/// An analysis' progress: the plain levels, each level's step and fit, the details'
/// synthesis, weighted by vertex counts ([`STEP_WEIGHT`], [`FIT_WEIGHT`]); nothing
/// reported without a [`Progress`].
#[derive(Default)]
struct Stages<'a> {
    progress: Option<&'a Progress>,
}

impl<'a> Stages<'a> {
    fn start(progress: Option<&'a Progress>, base: &Mesh, levels: u32) -> Result<Self> {
        if let Some(p) = progress {
            let counts = level_vertex_counts(base, levels)?;
            let each: usize = counts.iter().sum();
            p.start(2 * each + (STEP_WEIGHT + FIT_WEIGHT) * each);
            p.check()?;
        }
        Ok(Stages { progress })
    }

    /// `n` more units done, then [`Self::check`].
    fn advance(&self, n: usize) -> Result<()> {
        if let Some(p) = self.progress {
            p.advance(n);
        }
        self.check()
    }

    fn check(&self) -> Result<()> {
        self.progress.map_or(Ok(()), Progress::check)
    }
}

/// [`analyze`] of the fine positions `fine` alone, the fine mesh's faces being those of
/// `levels` subdivisions of `base_topology` (in [`synthesize`]'s numbering).
pub fn analyze_positions(fine: Vec<Vec3>, base_topology: &Mesh, levels: u32) -> Result<Multires> {
    analyze_positions_watched(fine, base_topology, levels, None)
}

/// [`analyze_positions`] reporting to `progress`, as [`analyze_watched`].
pub fn analyze_positions_watched(fine: Vec<Vec3>, base_topology: &Mesh, levels: u32, progress: Option<&Progress>) -> Result<Multires> {
    if !(1..=super::MAX_LEVELS).contains(&levels) {
        return Err(Error::InvalidParameter(format!("analysis levels must be 1 to {}, not {levels}", super::MAX_LEVELS)));
    }
    let want = *level_vertex_counts(base_topology, levels)?.last().expect("one level or more");
    if fine.len() != want {
        return Err(Error::InvalidMesh(format!("the fine mesh has {} vertices; {levels} subdivisions of the base have {want}", fine.len())));
    }
    if let Some(v) = fine.iter().position(|p| !p.is_finite()) {
        return Err(Error::NonFinite { index: v, value: fine[v].to_array() });
    }
    // The levels are made once, here, not again by `analyze`.
    let stages = Stages::start(progress, base_topology, levels)?;
    analyze_on(&fine, &levels_of_watched(base_topology, levels, &stages)?, base_topology, levels, &stages)
}

/// The limit positions (Halstead, Kass and DeRose 1993) of the vertices of `levels` plain
/// subdivisions of `base`, in [`synthesize`]'s numbering: where Blender's Subdivision
/// Surface modifier with Use Limit Surface puts the same vertices, numbered its own way, so
/// [`match_points`] finds its numbering.
pub fn limit_positions(base: &Mesh, levels: u32) -> Result<Vec<Vec3>> {
    let finest = levels_of(base, levels)?.pop().expect("the finest level");
    Ok(Level::base(&finest)?.limit_positions(super::Boundary::SmoothAll).iter().map(|p| p.as_vec3()).collect())
}

/// The permutation that matches `query` to `reference` by position: `order[k]` is the
/// reference point nearest to query point `k` (a search of a [`Bvh`] of the reference
/// points). Refuses point sets of different sizes, a query point with no reference point
/// within `tolerance`, and two query points with the same nearest reference point.
pub fn match_points(reference: &[Vec3], query: &[Vec3], tolerance: f64) -> Result<Vec<u32>> {
    if reference.len() != query.len() {
        return Err(Error::InvalidMesh(format!("{} points cannot be matched one to one with {}", query.len(), reference.len())));
    }
    let points: Vec<DVec3> = reference.iter().map(|p| p.as_dvec3()).collect();
    let bvh = Bvh::from_boxes(points.iter().map(|&p| (p, p)).collect());
    let order: Vec<Option<u32>> =
        query.par_iter().map(|q| bvh.closest(q.as_dvec3(), tolerance, |i| points[i as usize].distance(q.as_dvec3())).map(|(i, _)| i)).collect();
    let mut taken = vec![u32::MAX; reference.len()];
    for (k, o) in order.iter().enumerate() {
        let Some(i) = *o else {
            return Err(Error::InvalidMesh(format!("point {k} at {} has no match within {tolerance}", query[k])));
        };
        if taken[i as usize] != u32::MAX {
            return Err(Error::InvalidMesh(format!(
                "points {} and {k} both match point {i} (at {}): the meshes differ",
                taken[i as usize], reference[i as usize]
            )));
        }
        taken[i as usize] = k as u32;
    }
    Ok(order.into_iter().map(|o| o.expect("checked")).collect())
}

/// One Catmull-Clark step of a level's topology as a sparse matrix `S` (rows: the finer
/// level's vertex points, edge points, face points; Blender's default boundary rule), and
/// its transpose.
struct Step {
    rows: Sparse,
    cols: Sparse,
}

/// Compressed rows: row `r` is `(index[k], weight[k])` for `k` in `start[r]..start[r + 1]`.
struct Sparse {
    start: Vec<usize>,
    index: Vec<u32>,
    weight: Vec<f64>,
}

impl Sparse {
    fn from_triplets(rows: usize, mut t: Vec<(u32, u32, f64)>) -> Self {
        t.par_sort_unstable_by_key(|&(r, c, _)| (r, c));
        let mut start = vec![0usize; rows + 1];
        let (mut index, mut weight) = (Vec::with_capacity(t.len()), Vec::with_capacity(t.len()));
        for group in t.chunk_by(|a, b| (a.0, a.1) == (b.0, b.1)) {
            start[group[0].0 as usize + 1] += 1;
            index.push(group[0].1);
            weight.push(group.iter().map(|x| x.2).sum());
        }
        for r in 0..rows {
            start[r + 1] += start[r];
        }
        Sparse { start, index, weight }
    }

    fn apply(&self, x: &[DVec3]) -> Vec<DVec3> {
        (0..self.start.len() - 1)
            .into_par_iter()
            .map(|r| (self.start[r]..self.start[r + 1]).map(|k| x[self.index[k] as usize] * self.weight[k]).sum())
            .collect()
    }
}

impl Step {
    /// The stencils of [`Level::refine`] with [`super::Boundary::SmoothAll`], from `coarse`
    /// to `fine`, its subdivision. The fine vertices are found from the quads, not from an
    /// edge numbering: corner `c` of the coarse mesh became quad `c`, (vertex, edge point
    /// after it, face point, edge point before it).
    fn of(coarse: &Mesh, fine: &Mesh) -> Result<Self> {
        let level = Level::base(coarse)?;
        let quads = fine.corners();
        let nv = level.positions.len();
        if quads.len() != 4 * level.corners.len() {
            return Err(Error::InvalidMesh(format!("a level of {} quads is not the subdivision of one of {} corners", quads.len() / 4, level.corners.len())));
        }
        let mut edge_row = vec![0u32; level.edges.len()];
        level.corner_edge.iter().enumerate().for_each(|(c, &e)| edge_row[e as usize] = quads[4 * c + 1]);
        let face_row = |f: usize| quads[4 * level.offsets[f] as usize + 2];
        let mut valence = vec![0u32; nv];
        let mut boundary = vec![false; nv];
        level.corners.iter().for_each(|&v| valence[v as usize] += 1);
        for (e, &[a, b]) in level.edges.iter().enumerate() {
            if level.edge_faces[e][1] == NONE {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
            }
        }
        let mut t: Vec<(u32, u32, f64)> = Vec::new();
        let face_point = |t: &mut Vec<(u32, u32, f64)>, row: u32, f: usize, w: f64| {
            let face = level.face(f);
            face.iter().for_each(|&u| t.push((row, u, w / face.len() as f64)));
        };
        // Vertex points: (n-2)/n v + sum(e_i)/n^2 + sum(f_i)/n^2 inside, (e1 + 6 v + e2)/8
        // on a boundary.
        for v in 0..nv {
            let n = valence[v] as f64;
            t.push((v as u32, v as u32, if boundary[v] { 0.75 } else { (n - 2.0) / n }));
        }
        for (c, &v) in level.corners.iter().enumerate() {
            if !boundary[v as usize] {
                let n = valence[v as usize] as f64;
                face_point(&mut t, v, level.corner_face[c] as usize, 1.0 / (n * n));
            }
        }
        for (e, &[a, b]) in level.edges.iter().enumerate() {
            let on_boundary = level.edge_faces[e][1] == NONE;
            for (x, y) in [(a, b), (b, a)] {
                let n = valence[x as usize] as f64;
                if !boundary[x as usize] {
                    t.push((x, y, 1.0 / (n * n)));
                } else if on_boundary {
                    t.push((x, y, 0.125));
                }
            }
            // Edge points: the mean of the ends and the two face points; the midpoint on a
            // boundary.
            let row = edge_row[e];
            if on_boundary {
                t.extend([(row, a, 0.5), (row, b, 0.5)]);
            } else {
                t.extend([(row, a, 0.25), (row, b, 0.25)]);
                level.edge_faces[e].iter().for_each(|&f| face_point(&mut t, row, f as usize, 0.25));
            }
        }
        // Face points: the centroids.
        for f in 0..level.face_count() {
            face_point(&mut t, face_row(f), f, 1.0);
        }
        let transposed = t.iter().map(|&(r, c, w)| (c, r, w)).collect();
        Ok(Step { rows: Sparse::from_triplets(fine.vertex_count(), t), cols: Sparse::from_triplets(nv, transposed) })
    }

    /// The coarse positions `P` minimising `|S P - fine|^2`: conjugate gradients on
    /// `S^T S P = S^T fine`, from the fine level's own base vertices (which `S` keeps in
    /// place and index). Counts `weight` units in `stages` as it goes (the larger of the
    /// share of steps taken and of the residual's way down to the tolerance, on a log
    /// scale), checking for a cancel at every step.
    fn fit(&self, fine: &[DVec3], stages: &Stages, weight: usize) -> Result<Vec<DVec3>> {
        let nv = self.cols.start.len() - 1;
        let normal = |x: &[DVec3]| self.cols.apply(&self.rows.apply(x));
        // Fixed chunks summed in order: the same sums, so the same fit, at any load
        // (rayon's `sum` adds in whatever split work stealing made).
        let dot = |a: &[DVec3], b: &[DVec3]| -> f64 {
            let parts: Vec<f64> = a.par_chunks(DOT_CHUNK).zip(b.par_chunks(DOT_CHUNK)).map(|(a, b)| a.iter().zip(b).map(|(a, b)| a.dot(*b)).sum()).collect();
            parts.iter().sum()
        };
        let rhs = self.cols.apply(fine);
        let mut x = fine[..nv].to_vec();
        let ax = normal(&x);
        let mut r: Vec<DVec3> = rhs.iter().zip(&ax).map(|(b, a)| *b - *a).collect();
        let mut p = r.clone();
        let mut rr = dot(&r, &r);
        let stop = (FIT_TOLERANCE * FIT_TOLERANCE) * dot(&rhs, &rhs);
        let (first, mut given) = (rr, 0usize);
        for step in 0..FIT_ITERATIONS {
            if rr <= stop {
                break;
            }
            let converged = if first > stop { (first / rr).ln() / (first / stop).ln() } else { 1.0 };
            let share = converged.max(step as f64 / FIT_ITERATIONS as f64).clamp(0.0, 1.0);
            let due = ((share * weight as f64) as usize).max(given);
            stages.advance(due - given)?;
            given = due;
            let ap = normal(&p);
            let alpha = rr / dot(&p, &ap);
            x.par_iter_mut().zip(&p).for_each(|(x, p)| *x += *p * alpha);
            r.par_iter_mut().zip(&ap).for_each(|(r, a)| *r -= *a * alpha);
            let next = dot(&r, &r);
            let beta = next / rr;
            rr = next;
            p.par_iter_mut().zip(&r).for_each(|(p, r)| *p = *r + *p * beta);
        }
        stages.advance(weight - given)?;
        Ok(x)
    }
}

/// Conjugate gradients stop at this residual relative to the right-hand side, or after
/// this many steps (the details take up whatever the fit leaves).
const FIT_TOLERANCE: f64 = 1e-12;
const FIT_ITERATIONS: usize = 500;

#[cfg(test)]
mod tests;
