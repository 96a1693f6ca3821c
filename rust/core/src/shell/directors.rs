//! Shell directors by integrating the averaged-distance gradient field (chapter 4.3,
//! equation 4.5) with the adaptive explicit Euler scheme of section 4.4: the step is
//! halved while the field direction turns by more than a threshold, and the trajectory
//! stops when the parameter `t` reaches the target thickness. The director is the
//! straight segment from start to end (chapter 3.1); its length is the achieved
//! thickness.
//!
//! Speed along the field. The paper integrates `g_p`, whose magnitude "decays close to
//! the medial axis" (4.3). We move along the unit field direction `ĝ` with speed
//! `min(1, σ / onset)` where `σ = (Σ c_i·ĝ) / (Σ |c_i·ĝ|)` in `[0, 1]`, where `c_i` are the contributions of the
//! individual patches to `-∇∫|x-y|^-p`: σ = 1 where all surface nearby pushes the
//! same way (planes, convex parts, concave corners up to 90°), and σ → 0 where surface
//! parts push against each other (near the medial axis); `onset`
//! ([`ShellParams::compression_onset`]) lets shallow concavities keep full speed. Trajectories therefore slow
//! down exponentially instead of crossing the medial axis, which is the compression
//! behaviour of figures 4.7 and 4.8.

use super::lp_distance::{extension_faces, FieldEval, Kernel, PatchTree};
use super::repair::{Repair, ShellCheck};
use crate::mesh::{boundary_edges, vertex_normals, Incidence};
use crate::progress::Progress;
use crate::{Error, Mesh, Result};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Which side of the base surface the shell occupies (chapter 3.1, figure 3.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// Outside the surface (along the normals).
    Exterior,
    /// Inside the surface.
    Interior,
    /// Both sides: half of the thickness outside, half inside.
    Envelope,
}

impl Side {
    /// `"exterior"`, `"interior"` or `"envelope"` (case-insensitive).
    pub fn parse(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "exterior" => Ok(Side::Exterior),
            "interior" => Ok(Side::Interior),
            "envelope" => Ok(Side::Envelope),
            _ => Err(Error::InvalidParameter(format!("shell side must be \"exterior\", \"interior\" or \"envelope\", got {s:?}"))),
        }
    }
    /// +1 when layer parameter r grows outward (exterior, envelope), -1 for interior.
    pub fn orientation(self) -> f32 {
        if self == Side::Interior {
            -1.0
        } else {
            1.0
        }
    }
}

/// Tuning of the field and of the integrator.
#[derive(Debug, Clone, PartialEq)]
pub struct ShellParams {
    /// Exponent p of the averaged distance (4.3); 3 uses exact integration (Appendix A).
    pub p: f64,
    /// Barnes–Hut opening criterion: a patch counts as a point mass (with its
    /// quadrupole term) when its bounding radius is below `theta` times its distance.
    /// 0.65 keeps the traced directors as close to exact integration as the point
    /// mass alone did at 0.6, with fewer patches opened.
    pub theta: f64,
    /// Localization (4.3.1): the surface within `support * thickness` of a point counts.
    pub support: f64,
    /// Initial step `Δ0 = thickness / steps` (4.4).
    pub steps: u32,
    /// Adaptivity threshold ε on the turn of the field direction per step, radians.
    pub max_turn: f64,
    /// Most halvings of one step.
    pub max_halvings: u32,
    /// Most field evaluations for one trajectory (never hang).
    pub max_evaluations: u32,
    /// Artificial faces along open boundaries (4.3.2).
    pub boundary_faces: bool,
    /// Rounds of local director shortening where chords still tangle
    /// ([`repair::untangle`](super::repair::untangle)), before its final check
    /// removes whatever is left; 0 disables both and the restore pass after them
    /// (`restore`), leaving the traced directors (which may fold). Clean inputs
    /// settle in fewer (the 29k bunny in 28).
    pub repair_rounds: u32,
    /// The shell moves at full speed while the agreement `σ` of the surface pushes
    /// (module docs) is at least this; below it the speed is `σ / onset`. 1 slows down
    /// as soon as any surface pushes back; lower values keep the full thickness in
    /// shallow concavities and compress only nearer the medial axis. Where normal
    /// displacement has room and nothing folds, the restore pass gives compressed
    /// directors their full thickness back.
    pub compression_onset: f64,
    /// Bound each traced director by the room along its chord before the repair
    /// ([`room`](super::room): the medial stop), so that opposing sheets stop short of
    /// each other instead of crossing and being repaired. Only with `repair_rounds`.
    pub medial_stop: bool,
}

/// Per-round shortening of the repair pass. Not from the thesis: small enough steps
/// that untangled directors keep most of their length, large enough that the bunny
/// settles within `repair_rounds` (`shell_bench`, `bench_shell.py`).
pub(crate) const REPAIR_FACTOR: f32 = 0.92;

/// None of these values is in the thesis, which gives the algorithm (4.3-4.4) but not
/// its constants: `p = 3` is its choice for exact integration (Appendix A); `theta`,
/// `support`, `steps`, `max_turn`, `max_halvings`, `repair_rounds` and
/// `compression_onset` were chosen on the hard meshes of `make bench` (`bench_shell.py`:
/// crossings, thickness ratios, time) and `shell_bench` (29k-vertex bunny); each
/// field says what it trades.
impl Default for ShellParams {
    fn default() -> Self {
        Self {
            p: 3.0,
            theta: 0.65,
            support: 2.2,
            steps: 6,
            max_turn: 0.15,
            max_halvings: 5,
            max_evaluations: 120,
            boundary_faces: true,
            repair_rounds: 80,
            compression_onset: 0.7,
            medial_stop: true,
        }
    }
}

impl ShellParams {
    fn validate(&self) -> Result<()> {
        let bad = |m: &str| Err(Error::InvalidParameter(m.into()));
        if !(self.p > 1.0 && self.p.is_finite()) {
            return bad("p must be a finite number greater than 1");
        }
        if !(self.theta >= 0.0 && self.theta < 2.0) {
            return bad("theta must be in [0, 2)");
        }
        if !(self.support >= 1.0 && self.support.is_finite()) {
            return bad("support must be at least 1 (times the thickness)");
        }
        if !(self.compression_onset > 0.0 && self.compression_onset <= 1.0) {
            return bad("compression_onset must be in (0, 1]");
        }
        if self.steps == 0 || self.max_evaluations == 0 || !(self.max_turn > 0.0) {
            return bad("steps, max_evaluations and max_turn must be positive");
        }
        Ok(())
    }
}

/// A shell: layer `r ∈ [0, 1]` of vertex `v` lies at
/// `position[v] + base_offset[v] + r * directors[v]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Shell {
    pub side: Side,
    /// Zero for exterior and interior shells; the inner end for envelopes.
    pub base_offset: Vec<Vec3>,
    pub directors: Vec<Vec3>,
    /// Length of each director: the thickness reached.
    pub achieved: Vec<f32>,
    /// The thickness asked for (magnitude of the input).
    pub target: Vec<f32>,
    /// What the repair and its final check did (all zero for shells not built here).
    pub check: ShellCheck,
}

impl Shell {
    /// A shell given by its base offsets and directors (read back from Blender, or
    /// built by hand): the thickness reached is each director's length, and is taken
    /// as the target too.
    pub fn from_directors(base_offset: Vec<Vec3>, directors: Vec<Vec3>) -> Self {
        let achieved: Vec<f32> = directors.iter().map(|d| d.length()).collect();
        Self { side: Side::Exterior, base_offset, directors, target: achieved.clone(), achieved, check: ShellCheck::default() }
    }

    /// The shell of the mesh whose vertex `order[i]` is this shell's vertex `i`.
    fn renumbered(self, order: &[u32]) -> Self {
        fn back<T: Copy>(order: &[u32], values: Vec<T>) -> Vec<T> {
            let mut out = values.clone();
            order.iter().zip(values).for_each(|(&v, x)| out[v as usize] = x);
            out
        }
        let Shell { side, base_offset, directors, achieved, target, check } = self;
        Shell {
            side,
            base_offset: back(order, base_offset),
            directors: back(order, directors),
            achieved: back(order, achieved),
            target: back(order, target),
            check,
        }
    }

    /// The shell of a mesh welded by `weld` ([`Mesh::weld_coincident`]), given back
    /// to the original vertices: coincident vertices share their welded vertex's
    /// director, thickness and target (the least asked for among them).
    pub fn expanded(self, weld: &crate::mesh::Weld) -> Self {
        let Shell { side, base_offset, directors, achieved, target, check } = self;
        Shell {
            side,
            base_offset: weld.expand(&base_offset),
            directors: weld.expand(&directors),
            achieved: weld.expand(&achieved),
            target: weld.expand(&target),
            check,
        }
    }

    /// The shell on a mesh welded by `weld`, where coincident vertices have one
    /// director and base offset (as [`Shell::expanded`] gives them), else `None`.
    pub fn welded(&self, weld: &crate::mesh::Weld) -> Option<Self> {
        let leads = weld.leads();
        if !weld.copies_agree(&leads, |v, lead| (self.directors[v], self.base_offset[v]) == (self.directors[lead], self.base_offset[lead])) {
            return None;
        }
        let pick = |values: &[Vec3]| leads.iter().map(|&v| values[v as usize]).collect();
        let achieved: Vec<f32> = leads.iter().map(|&v| self.achieved[v as usize]).collect();
        Some(Shell {
            side: self.side,
            base_offset: pick(&self.base_offset),
            directors: pick(&self.directors),
            achieved,
            target: weld.least(&self.target),
            check: self.check,
        })
    }

    /// Position of layer `r` of vertex `v`.
    pub fn point(&self, positions: &[Vec3], v: usize, r: f32) -> Vec3 {
        positions[v] + self.base_offset[v] + self.directors[v] * r
    }
}

/// Everything the tracer needs, shared by full and incremental builds.
pub(crate) struct Tracer {
    pub tree: PatchTree,
    pub kernel: Kernel,
    pub normals: Vec<Vec3>,
    /// Shortest edge at each vertex (first step size).
    pub min_edge: Vec<f32>,
    /// [`ShellParams::compression_onset`].
    pub onset: f64,
    /// Directed open-boundary edges with artificial faces (none when disabled).
    pub boundary: Vec<(u32, u32)>,
    /// The faces around each vertex.
    pub faces_around: Incidence,
}

/// One traced trajectory: its end, the bounding sphere of the points evaluated, and
/// a few of those points with the field's strength there (for the incremental
/// update's bound on how much a surface change can move the trajectory).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Trace {
    pub end: Vec3,
    pub center: Vec3,
    pub radius: f32,
    /// The first point evaluated, the first ones at parameters past 1/3 and 2/3 of
    /// the thickness, and the end; `push` is `|∇∫|x-y|^-p|` there (0: no sample).
    pub samples: [Sample; TRACE_SAMPLES],
}

pub(crate) const TRACE_SAMPLES: usize = 4;

/// A step moving less than this share of the thickness is accepted without checking
/// the turn of the field direction. Not from the thesis: halving such steps only spent
/// evaluations near the medial axis (`shell_bench`: fewer evaluations, same shells).
const STALL: f64 = 1e-3;

#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Sample {
    pub at: Vec3,
    pub push: f32,
}

impl Trace {
    /// A trajectory that did not move from `x`.
    pub fn still(x: Vec3) -> Self {
        Self { end: x, center: x, radius: 0.0, samples: [Sample { at: x, push: 0.0 }; TRACE_SAMPLES] }
    }
}

/// The triangles the field integrates: the mesh's, then the artificial faces along
/// its open `boundary` edges (4.3.2).
/// Also the longest edge of each one's pieces for the patch tree ([`piece_sizes`]).
fn integration_triangles(mesh: &Mesh, normals: &[Vec3], reach: &[f32], boundary: &[(u32, u32)]) -> (Vec<[DVec3; 3]>, Vec<f64>) {
    let mut tris = super::lp_distance::mesh_triangles(mesh);
    let mesh_count = tris.len();
    tris.extend(extension_faces(boundary, mesh.positions(), normals, reach));
    let sizes = piece_sizes(piece_size(reach), &tris, mesh_count);
    (tris, sizes)
}

/// The longest edge of the pieces the field integrates, as a share of the typical
/// thickness: triangles longer than this are split for the patch tree
/// ([`PatchTree::build_refined`]). Not from the thesis, whose meshes are finer than
/// their shells; chosen on CAD parts from STL files (long slivers across whole
/// faces), where the tree otherwise integrated most triangles exactly at every
/// evaluation (a 3.7k-vertex part took 40 s) and the localization (4.3.1) weighed
/// each sliver by a centroid far from most of its area. A quarter of the thickness
/// gave the same shells on 15 CAD parts and 6 scans, no faster, and a Barnes-Hut
/// error twice as large on a fine plane (2.3 degrees off the normal against 1.3).
const FIELD_PIECE: f32 = 1.0;

/// The pieces may add at most this many times the triangles (the split's length
/// doubles until they fit): memory stays proportional to the mesh.
pub(crate) const FIELD_PIECES_BUDGET: usize = 8;

/// A triangle is split only when it is a sliver: its height under its longest edge
/// is less than this share of that edge. Fat triangles larger than the thickness
/// (open cards a few thicknesses wide) kept their shells as unsplit; split, the
/// localization moved enough to squeeze some interior cells to a sixth of a target
/// they had room for, and to stack compressed cells whose bakes crossed.
const SLIVER: f64 = 0.25;

/// The longest edge of the field's pieces: [`FIELD_PIECE`] times the median
/// thickness `reach`, rounded down to a power of two (infinite: none given).
///
/// One size from the median, rounded, so that the pieces do not follow the
/// thickness: painting it, or moving a few vertices, leaves every piece where it was
/// and the incremental update (7.1) refits the tree instead of building it anew
/// (sized per face, every thickness edit split its faces otherwise, and the field
/// changed beyond what the edit's triangles bound).
pub(crate) fn piece_size(reach: &[f32]) -> f64 {
    let mut r: Vec<f32> = reach.iter().copied().filter(|r| r.is_finite() && *r > 0.0).collect();
    if r.is_empty() {
        return f64::INFINITY;
    }
    let mid = r.len() / 2;
    let median = *r.select_nth_unstable_by(mid, f32::total_cmp).1;
    (FIELD_PIECE as f64 * median as f64).log2().floor().exp2()
}

/// The longest edge of `t`'s pieces: `size` for a [`SLIVER`] longer than it,
/// infinite (not split) otherwise.
pub(crate) fn piece_max_edge(t: &[DVec3; 3], size: f64) -> f64 {
    let longest = (0..3).map(|k| (t[(k + 1) % 3] - t[k]).length_squared()).fold(0.0, f64::max);
    let twice_area = (t[1] - t[0]).cross(t[2] - t[0]).length();
    // height = twice_area / longest < SLIVER longest
    if longest > size * size && twice_area < SLIVER * longest {
        size
    } else {
        f64::INFINITY
    }
}

/// [`piece_max_edge`] of each of `tris` at `size`: the mesh's first `mesh_triangles`,
/// then the extension faces (4.3.2), not split (they are as long as the thickness).
pub(crate) fn piece_sizes(size: f64, tris: &[[DVec3; 3]], mesh_triangles: usize) -> Vec<f64> {
    tris.iter().enumerate().map(|(i, t)| if i < mesh_triangles { piece_max_edge(t, size) } else { f64::INFINITY }).collect()
}

/// Shortest edge at `v` among its `faces` (the first step of its trajectory).
pub(crate) fn min_edge_at(mesh: &Mesh, v: u32, faces: &[u32]) -> f32 {
    let p = mesh.positions();
    let mut m = f32::INFINITY;
    for &f in faces {
        let face = mesh.face(f as usize);
        let k = face.len();
        if let Some(i) = face.iter().position(|&u| u == v) {
            for u in [face[(i + 1) % k], face[(i + k - 1) % k]] {
                let l = (p[u as usize] - p[v as usize]).length();
                if l > 0.0 {
                    m = m.min(l);
                }
            }
        }
    }
    m
}

impl Tracer {
    /// The tracer, and the integration triangles its tree was built from (in their
    /// original order, for later refits).
    pub fn new(mesh: &Mesh, reach: &[f32], params: &ShellParams) -> (Self, Vec<[DVec3; 3]>) {
        let normals = vertex_normals(mesh);
        let boundary = if params.boundary_faces { boundary_edges(mesh) } else { Vec::new() };
        let (tris, sizes) = integration_triangles(mesh, &normals, reach, &boundary);
        let tree = PatchTree::build_refined(&tris, &sizes, tris.len() * FIELD_PIECES_BUDGET);
        let faces_around = Incidence::faces(mesh);
        let min_edge = (0..mesh.vertex_count()).map(|v| min_edge_at(mesh, v as u32, faces_around.of(v))).collect();
        let kernel = Kernel::new(params.p, params.theta);
        (Self { tree, kernel, normals, min_edge, onset: params.compression_onset, boundary, faces_around }, tris)
    }

    /// The unit field direction at `x`, the speed along it (module docs), `|push|` and
    /// a lower bound on the distance from `x` to the integration triangles.
    fn sample(&self, x: DVec3, radius: f64, reference: DVec3) -> Option<(DVec3, f64, f64, f64)> {
        let FieldEval { push, abs_along, clearance, .. } = self.tree.eval(x, radius, reference, &self.kernel);
        let len = push.length();
        if !(len > 0.0 && len.is_finite() && abs_along > 0.0) {
            return None;
        }
        let dir = push / len;
        Some((dir, (push.dot(reference) / (abs_along * self.onset)).clamp(0.0, 1.0), len, clearance))
    }

    /// Traces the trajectory of vertex `v` towards side `sign` (+1 outward, -1 inward)
    /// over parameter length `h` (section 4.4's algorithm with bounded work).
    pub fn trace(&self, x0: Vec3, v: usize, sign: f32, h: f32, params: &ShellParams) -> Trace {
        let n = self.normals[v] * sign;
        if !(h > 0.0) || n == Vec3::ZERO {
            return Trace::still(x0);
        }
        let (h, radius) = (h as f64, params.support * h as f64);
        let start = x0.as_dvec3();
        // The field is singular on the surface: leave it along the normal (the direction
        // of g_p at smooth surface points, 4.3) by a small fraction of the local edge.
        let first = (0.02 * h).min(0.05 * self.min_edge[v] as f64);
        let mut t = first;
        let mut x = start + n.as_dvec3() * first;
        let (mut lo, mut hi) = (start.min(x), start.max(x));
        let mut samples = [Sample { at: x.as_vec3(), push: 0.0 }; TRACE_SAMPLES];
        let finish = |x: DVec3, lo: DVec3, hi: DVec3, mut samples: [Sample; TRACE_SAMPLES], push: f64| {
            // Slots not reached (short trajectories) repeat the end.
            samples[TRACE_SAMPLES - 1] = Sample { at: x.as_vec3(), push: push as f32 };
            for k in (1..TRACE_SAMPLES - 1).rev() {
                if samples[k].push == 0.0 {
                    samples[k] = samples[k + 1];
                }
            }
            Trace { end: x.as_vec3(), center: ((lo + hi) * 0.5).as_vec3(), radius: ((hi - lo).length() * 0.5) as f32, samples }
        };
        let mut evals = 1u32;
        let Some((mut g, mut speed, mut push, mut clearance)) = self.sample(x, radius, n.as_dvec3()) else {
            return finish(x, lo, hi, samples, 0.0);
        };
        samples[0].push = push as f32;
        let mut slot = 1;
        let cos_eps = params.max_turn.cos();
        let step0 = h / params.steps as f64;
        // The step grows back by a factor of two only after a step that turned by
        // less than half the threshold: a trajectory bending through a concavity
        // would otherwise retry the longer step (and halve it again, an evaluation
        // each time) at every step.
        let cos_half = (0.5 * params.max_turn).cos();
        let mut next = step0;
        'outer: while t < h * (1.0 - 1e-7) && evals < params.max_evaluations {
            let mut delta = (h - t).min(step0).min(next);
            let mut halvings = 0;
            loop {
                let xn = x + g * (speed * delta);
                // Steps shorter than the clearance the evaluation at `x` found cannot
                // reach a triangle; past the first steps most are.
                if speed * delta >= CLEAR_SHARE * clearance && self.tree.segment_crosses(x, xn) {
                    // The step jumped over a thin part (the field is singular on the
                    // surface, so the trajectory itself never crosses it).
                    if halvings >= params.max_halvings {
                        break 'outer;
                    }
                    delta *= 0.5;
                    halvings += 1;
                    continue;
                }
                evals += 1;
                lo = lo.min(xn);
                hi = hi.max(xn);
                let Some((gn, sn, pn, cn)) = self.sample(xn, radius, g) else { break 'outer };
                // A step that hardly moves (a trajectory stalled near the medial axis,
                // where the direction swings) is accepted whatever the turn: halving it
                // would only spend evaluations on no motion.
                let still = speed * delta <= STALL * h;
                let turn = gn.dot(g);
                if turn >= cos_eps || still || halvings >= params.max_halvings || evals >= params.max_evaluations {
                    t += delta;
                    next = if turn >= cos_half { 2.0 * delta } else { delta };
                    (x, g, speed, push, clearance) = (xn, gn, sn, pn, cn);
                    if slot < TRACE_SAMPLES - 1 && t >= h * slot as f64 / (TRACE_SAMPLES - 1) as f64 {
                        samples[slot] = Sample { at: x.as_vec3(), push: push as f32 };
                        slot += 1;
                    }
                    break;
                }
                delta *= 0.5;
                halvings += 1;
            }
        }
        finish(x, lo, hi, samples, push)
    }
}

/// The share of an evaluation's clearance a step may take without a crossing test
/// (a margin for rounding: the bound and the test are both in double precision).
const CLEAR_SHARE: f64 = 0.99;

/// Per-side parameter length at each vertex for the requested side.
pub(crate) fn side_lengths(thickness: &[f32], side: Side) -> Vec<f32> {
    let f = if side == Side::Envelope { 0.5 } else { 1.0 };
    thickness.iter().map(|t| t.abs() * f).collect()
}

pub(crate) fn check_inputs(mesh: &Mesh, thickness: &[f32], params: &ShellParams) -> Result<()> {
    mesh.require_faces()?;
    params.validate()?;
    if thickness.len() != mesh.vertex_count() {
        return Err(Error::InvalidParameter(format!("{} thickness values given for {} vertices", thickness.len(), mesh.vertex_count())));
    }
    if let Some(i) = thickness.iter().position(|t| !t.is_finite()) {
        return Err(Error::InvalidParameter(format!("thickness of vertex {i} is not finite")));
    }
    Ok(())
}

/// Traces the vertices in `which`; returns per-vertex traces for the sides needed:
/// `(outward, inward)`, each present when the side uses it. Each traced vertex is a
/// step of `progress`; once it is cancelled the vertices not yet started are skipped
/// and the result is [`Error::Cancelled`].
pub(crate) fn trace_vertices(
    tracer: &Tracer,
    mesh: &Mesh,
    lengths: &[f32],
    side: Side,
    params: &ShellParams,
    which: &[u32],
    progress: Option<&Progress>,
) -> Result<Vec<(Trace, Trace)>> {
    let p = mesh.positions();
    let traces = which
        .par_iter()
        .with_min_len(16)
        .map(|&v| {
            let v = v as usize;
            let none = Trace::still(p[v]);
            if progress.is_some_and(Progress::is_cancelled) {
                return (none, none);
            }
            let out = if side != Side::Interior { tracer.trace(p[v], v, 1.0, lengths[v], params) } else { none };
            let inn = if side != Side::Exterior { tracer.trace(p[v], v, -1.0, lengths[v], params) } else { none };
            progress.inspect(|p| p.step());
            (out, inn)
        })
        .collect();
    progress.map_or(Ok(()), Progress::check)?;
    Ok(traces)
}

/// The steps a watched build counts, all of them and those of the repair and restore
/// passes: one per traced vertex, then one per [`SETTLE_SHARE`] vertices for the
/// passes, counted when they are done.
pub(crate) fn watched_steps(vertices: usize, repair: bool) -> (usize, usize) {
    let settle = if repair { vertices.div_ceil(SETTLE_SHARE) } else { 0 };
    (vertices + settle, settle)
}

/// The repair and restore took a third of a build at 10% exterior (bunny, comb and a
/// bumpy sphere of 2-10k vertices: 25-40%), so they count as half the tracing.
const SETTLE_SHARE: usize = 2;

/// Base offset and director of one vertex from its traces.
pub(crate) fn director_of(x0: Vec3, side: Side, out: &Trace, inn: &Trace) -> (Vec3, Vec3) {
    match side {
        Side::Exterior => (Vec3::ZERO, out.end - x0),
        Side::Interior => (Vec3::ZERO, inn.end - x0),
        Side::Envelope => (inn.end - x0, out.end - inn.end),
    }
}

/// Builds a shell of the given side and per-vertex target thickness (its magnitude is
/// used; as produced by [`Thickness::per_vertex`](super::Thickness::per_vertex)).
/// Quads and n-gons are triangulated for integration only. Zero-area faces are
/// skipped, loose vertices get zero directors; where the surface leaves no room the
/// shell gets thinner (see [`Shell::achieved`]).
///
/// The work runs on the mesh in spatial order ([`Mesh::spatially_ordered`]): on
/// meshes stored in random order (scattered parts) that makes it several times faster.
pub fn build_shell(mesh: &Mesh, thickness: &[f32], side: Side, params: &ShellParams) -> Result<Shell> {
    build_shell_watched(mesh, thickness, side, params, None)
}

/// [`build_shell`] watched through `progress`: it counts the vertices traced (and the
/// repair, see [`watched_steps`]) and reaches 1 when the shell is done; once it is
/// cancelled the tracing stops within a few vertices per thread, the repair at its
/// next round and the restore at its next batch, with [`Error::Cancelled`].
pub fn build_shell_watched(mesh: &Mesh, thickness: &[f32], side: Side, params: &ShellParams, progress: Option<&Progress>) -> Result<Shell> {
    check_inputs(mesh, thickness, params)?;
    if let Some(weld) = mesh.weld_coincident() {
        // Split seams are one surface: built welded, given back to every copy.
        return Ok(build_shell_watched(&weld.mesh, &weld.least(thickness), side, params, progress)?.expanded(&weld));
    }
    let (sorted, order) = mesh.spatially_ordered();
    let thickness: Vec<f32> = order.iter().map(|&v| thickness[v as usize]).collect();
    Ok(build_in_order(&sorted, &thickness, side, params, progress)?.renumbered(&order))
}

fn build_in_order(mesh: &Mesh, thickness: &[f32], side: Side, params: &ShellParams, progress: Option<&Progress>) -> Result<Shell> {
    let repairs = params.repair_rounds > 0 && mesh.vertex_count() > 0;
    let (steps, settle) = watched_steps(mesh.vertex_count(), repairs);
    progress.inspect(|p| p.start(steps));
    let lengths = side_lengths(thickness, side);
    // The defect checker depends on the mesh alone: it is built while the tracing
    // runs (its serial parts would leave a core idle after it).
    let (traced, checker) = rayon::join(
        || -> Result<_> {
            let _t = super::timing::Stage::start("trace");
            let (tracer, _) = Tracer::new(mesh, &lengths, params);
            let all: Vec<u32> = (0..mesh.vertex_count() as u32).collect();
            let traces = trace_vertices(&tracer, mesh, &lengths, side, params, &all, progress)?;
            Ok((tracer, traces))
        },
        || {
            let _t = super::timing::Stage::start("checker");
            repairs.then(|| super::defects::Checker::new(mesh))
        },
    );
    let (tracer, traces) = traced?;
    let mut shell = assemble(mesh, thickness, side, &traces);
    if let Some(checker) = checker {
        if params.medial_stop {
            super::room::stop_at_room(&checker, mesh, &mut shell, None);
        }
        let repair = Repair::for_build(&checker, mesh, &tracer.normals, params.repair_rounds, progress);
        shell.check = repair.settle(&mut None, &mut shell, None);
    }
    if let Some(p) = progress {
        p.check()?;
        p.advance(settle);
    }
    Ok(shell)
}

pub(crate) fn assemble(mesh: &Mesh, thickness: &[f32], side: Side, traces: &[(Trace, Trace)]) -> Shell {
    let p = mesh.positions();
    let (mut base_offset, mut directors) = (Vec::with_capacity(p.len()), Vec::with_capacity(p.len()));
    for (v, (o, i)) in traces.iter().enumerate() {
        let (b, d) = director_of(p[v], side, o, i);
        base_offset.push(b);
        directors.push(d);
    }
    let achieved = directors.iter().map(|d| d.length()).collect();
    Shell { side, base_offset, directors, achieved, target: thickness.iter().map(|t| t.abs()).collect(), check: ShellCheck::default() }
}
