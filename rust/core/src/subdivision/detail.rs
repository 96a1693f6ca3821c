//! Procedural shape detail on multiresolution Catmull-Clark surfaces (Velho, Perlin, Ying
//! and Biermann, section 4): a procedure `F(p, l)` gives every vertex of level `l` a
//! displacement along that level's normal, added before the next level is subdivided, so
//! the subdivision filter reconstructs it (section 3: each scale-limited component
//! modifies its own level; section 4.2: "it is only necessary to specify a random value at
//! every control point"). Each model is deterministic for a seed.

mod fold_guard;
pub(crate) mod frames;
mod gaps;
mod growth;
mod growth_guard;
mod overhang;

pub use fold_guard::{Tally, FOCAL_SHARE, FOLD_SLOPE};
pub use frames::Frame;

use super::topology::Level;
use super::Boundary;
#[cfg(test)]
use super::{subdivide, Options};
use crate::mesh::newell_normal;
#[cfg(test)]
use crate::mesh::vertex_normals;
use crate::{Error, Mesh, Result};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// A procedural detail model (section 4.2). Lengths are in the mesh's units.
#[derive(Debug, Clone, PartialEq)]
pub enum Model {
    /// Fractal ("rock", 4.2): at level `l` (1 for the first subdivision) each control
    /// point moves by `amplitude * 2^(1-l)` times a random value in [-1, 1] of its own
    /// (hashed from the seed, the level and the vertex, whose index every finer level
    /// keeps: the paper's (u, v, level) coordinates), and the subdivision of the levels
    /// after it reconstructs the random values into a smooth 1/f surface ("it is only
    /// necessary to specify a random value at every control point").
    Rock { amplitude: f64 },
    /// Hybrid surface/volume fractal ("berry"): spherical domes `R_l (1 - r^2/R_l^2)^(1/2)`
    /// along the evolving normal around seed points, `r` the Euclidean distance to the
    /// nearest seed, `R_l = radius * 2^(1-l)`. Level 1's seeds are `seeds` (vertex
    /// indices of the base mesh) or, if empty, Poisson-disk points `2 radius` apart; at
    /// each finer level every seed of the last one grows a cluster of up to `children`
    /// seeds within its radius, `2 R_l` from every other seed of the level, each only where
    /// its whole dome stands on the surface (`clusters`). A dome that would lean a face
    /// past vertical against the base is flattened as a whole (see [`overhang`]). A dome reads as round where `R_l` spans
    /// several edges of level `l` (the subdivision then reconstructs it); one or two
    /// edges across, its steep rim makes a spike.
    Berry { radius: f64, seeds: Vec<u32>, children: u32 },
    /// Morphogenic growth ("tentacle", 4.2): at level `l` every seed vertex moves by
    /// `length * l * (±sin(theta + p), ±cos(theta + p), 1)` in its local frame (t, b, n),
    /// `p = l pi/3`, the tangential part negated on even levels, and the levels after it
    /// smooth the pulled vertex into a tentacle that lengthens, thins and twists (see
    /// [`growth`]). Seeds: `seeds` (base vertex indices) or Poisson-disk vertices of level 1
    /// `spacing` apart.
    Tentacle { length: f64, theta: f64, seeds: Vec<u32>, spacing: f64 },
    /// The tentacle's growth without the turn (the "spur" of 5.1, Figure 9): at level `l`
    /// every seed vertex moves `length * l` along its normal, a straight spike.
    Spur { length: f64, seeds: Vec<u32>, spacing: f64 },
    /// Hybrid surface/volume growth ("mushroom cloud", 4.2): around each seed a rising
    /// vortex ring of `radius`, a 3D flow fixed at level 1 (see [`growth`]), carries the
    /// vertices of level `l` for a time `length * l`: a stem rises, its top spreads into a
    /// cap whose rim rolls over and down. Seeds as the tentacle's, `2 radius` apart.
    Mushroom { radius: f64, length: f64, seeds: Vec<u32> },
    /// Surface of revolution with the fuse profile of 6.1, `sin(sum_i 2^-i sin(t^(2^i)))`:
    /// level `l` moves every vertex away from the axis through `center` along `axis` by
    /// `amplitude` times the profile's change when its term `i = l - 1` is added, `t` the
    /// vertex's axial coordinate scaled so the base's farthest vertex is at `|t| = span`
    /// (see [`growth`]).
    Fuse { amplitude: f64, span: f64, center: DVec3, axis: DVec3 },
}

impl Model {
    pub(crate) fn validate(&self, base: &Mesh) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidParameter(m));
        let diag = base.bbox_diagonal() as f64;
        let length = |name: &str, x: f64| match x.is_finite() && x.abs() <= MAX_SHARE * diag {
            true => Ok(()),
            false => bad(format!("{name} must be finite and at most {MAX_SHARE} times the mesh's size, not {x}")),
        };
        let spacing = |name: &str, x: f64| match x.is_finite() && x > 0.0 && x >= MIN_SHARE * diag && x <= MAX_SHARE * diag {
            true => Ok(()),
            false => bad(format!("{name} must be between {MIN_SHARE} and {MAX_SHARE} times the mesh's size, not {x}")),
        };
        let seeds_in = |name: &str, seeds: &[u32]| match seeds.iter().find(|&&s| s as usize >= base.vertex_count()) {
            None => Ok(()),
            Some(s) => bad(format!("{name} seed {s} is not a vertex of the mesh ({} vertices)", base.vertex_count())),
        };
        match self {
            Model::Rock { amplitude } => {
                length("rock amplitude", *amplitude)?;
            }
            Model::Berry { radius, seeds, children } => {
                spacing("berry radius", *radius)?;
                seeds_in("berry", seeds)?;
                if *children > MAX_CHILDREN {
                    return bad(format!("berry children must be at most {MAX_CHILDREN}, not {children}"));
                }
            }
            Model::Tentacle { length: l, theta, seeds, spacing: s } => {
                length("tentacle length", *l)?;
                if !(theta.is_finite() && theta.abs() <= MAX_ANGLE) {
                    return bad(format!("tentacle theta must be finite and at most {MAX_ANGLE} radians in size, not {theta}"));
                }
                seeds_in("tentacle", seeds)?;
                spacing("tentacle spacing", *s)?;
            }
            Model::Spur { length: l, seeds, spacing: s } => {
                length("spur length", *l)?;
                seeds_in("spur", seeds)?;
                spacing("spur spacing", *s)?;
            }
            Model::Mushroom { radius, length: l, seeds } => {
                spacing("mushroom radius", *radius)?;
                length("mushroom length", *l)?;
                seeds_in("mushroom", seeds)?;
            }
            Model::Fuse { amplitude, span, center, axis } => {
                length("fuse amplitude", *amplitude)?;
                if !(span.is_finite() && *span > 0.0 && *span <= MAX_SPAN) {
                    return bad(format!("fuse span must be above 0 and at most {MAX_SPAN}, not {span}"));
                }
                if !(center.is_finite() && axis.is_finite() && axis.length() > 0.0) {
                    return bad(format!("fuse center must be finite and axis finite and not zero, not {center} and {axis}"));
                }
                if growth::half_extent(base.positions(), *center, axis.normalize()) <= MIN_SHARE * diag {
                    return bad(format!("the mesh has no extent along the fuse axis {axis}"));
                }
            }
        }
        Ok(())
    }
}

/// Lengths are refused beyond this many times the base's bounding-box diagonal (a rock
/// larger than the object), and a berry radius under [`MIN_SHARE`] of it (domes no level
/// could show, whose seed grid would put every vertex in one cell).
pub const MAX_SHARE: f64 = 10.0;
pub const MIN_SHARE: f64 = 1e-4;

/// The most seeds a berry seed grows at the next level.
pub const MAX_CHILDREN: u32 = 64;

/// The largest tentacle turn `theta` taken, in radians (an animated angle may wind up).
pub const MAX_ANGLE: f64 = 1e6;

/// The largest fuse `span`: the profile's term `i` has `t^(2^i)` radians, past 4 far more
/// waves than any level has vertices.
pub const MAX_SPAN: f64 = 4.0;

/// A detailed surface: the finest level's mesh (all quads), the base face each face lies
/// in, and per vertex the displacements the levels added (signed, along their normals;
/// carried to finer levels by linear interpolation), for shading.
#[derive(Debug, Clone, PartialEq)]
pub struct Detailed {
    pub mesh: Mesh,
    pub source_face: Vec<u32>,
    pub scalar: Vec<f32>,
}

/// Subdivides `base` by `levels` Catmull-Clark levels (Blender's default boundary rule, no
/// limit projection) adding `model`'s detail at each (multiresolution synthesis, section
/// 2). `seed` picks the random values.
pub fn procedural_detail(base: &Mesh, levels: u32, model: &Model, seed: u64) -> Result<Detailed> {
    model.validate(base)?;
    synthesize(base, levels, model.initial_state(base), |level, mesh, normals, state| model.displacements(level, mesh, normals, seed, state))
}

impl Model {
    /// What the model carries into level 1: the fuse's axial reach on the base.
    pub(crate) fn initial_state(&self, base: &Mesh) -> State {
        let mut state = State::default();
        if let Model::Fuse { center, axis, .. } = self {
            state.reach = growth::half_extent(base.positions(), *center, axis.normalize());
        }
        if let Model::Berry { .. } | Model::Tentacle { .. } | Model::Spur { .. } = self {
            state.clearance = Some(fold_guard::Clearance::of(base));
        }
        // How far each base face is from another part, searched as far as any level's
        // rock could be limited by it (see `gaps`).
        if let Model::Rock { amplitude } = self {
            state.gaps = gaps::Gaps::of(base, |edge| gaps::rock_reach(*amplitude, edge));
        }
        state
    }
}

/// What a model carries from one level to the next: its seeds (vertex indices, which every
/// finer level keeps), a mushroom's rings, the fuse's axial reach on the base.
#[derive(Debug, Default)]
pub(crate) struct State {
    seeds: Vec<u32>,
    rings: Vec<growth::Ring>,
    reach: f64,
    /// What the fold guard reduced.
    pub tally: Tally,
    /// The base, for the room domes have before meeting another part of it.
    clearance: Option<fold_guard::Clearance>,
    /// The distances to other parts of the base, for the rock.
    gaps: Option<gaps::Gaps>,
    /// The base's normals at the level's vertices, for domes' overhangs.
    reference: Vec<Vec3>,
    /// Per-vertex factors on the level's detail before the guard (a local modification's
    /// gain above 1, section 5), so an enhancement stays within the guard's limits; empty
    /// for 1.
    pub gain: Vec<f64>,
    /// Painted per-vertex weights (a blend's alpha), carried to each level.
    pub painted: Vec<f32>,
    /// A second model's state (a blend's), carried along.
    pub second: Option<Box<State>>,
}

impl State {
    /// Vertex `v`'s factor from [`State::gain`].
    fn gain(&self, v: usize) -> f64 {
        self.gain.get(v).copied().unwrap_or(1.0)
    }

    /// Carries the per-vertex values the state keeps to `parent`'s child level (see
    /// [`carried`]).
    fn carry(&mut self, parent: &Level) {
        for values in [&mut self.painted] {
            if !values.is_empty() {
                *values = carried(parent, values);
            }
        }
        if !self.reference.is_empty() {
            self.reference = carried(parent, &self.reference);
        }
        if let Some(gaps) = &mut self.gaps {
            gaps.carry(parent);
        }
        if let Some(second) = &mut self.second {
            second.carry(parent);
        }
    }
}

impl State {
    /// The growth models' fold guard ([`growth_guard`]) on a level's offsets.
    fn guard_growth(&mut self, level: u32, mesh: &Mesh, normals: &[Vec3], group: &[u32], offsets: &mut [DVec3]) {
        if let Some(clearance) = &self.clearance {
            let limits = fold_guard::Limits::of(mesh, normals);
            growth_guard::guard(offsets, group, mesh.positions(), normals, &limits, clearance, level, &mut self.tally);
        }
    }
}

/// A level's detail: displacements along the vertex normals, or world-space offsets.
pub(crate) enum Offsets {
    Normal(Vec<f64>),
    World(Vec<DVec3>),
}

/// The synthesis loop: subdivide one level, displace by `detail(level, mesh, normals,
/// state)`, repeat. `scalar` sums the displacements' components along the normals.
///
/// One level's connectivity is derived from the last's ([`Level::child_as_base`]: no edge
/// sorting or hashing, no manifold checks past the base) and the positions carried in it
/// (rounded to f32 at every level, as the meshes the models see hold them); the finest
/// level gets its quads alone ([`child_quads`]), no edges for a level after it. Each level's
/// vertices and edges are numbered as [`subdivide`](super::subdivide) by one level would
/// number them from the last level's mesh, and the arithmetic is the same, so the result
/// is bit for bit what subdividing one level at a time makes (the vertex indices the
/// rock's random values and the seeds hang on included).
pub(crate) fn synthesize(base: &Mesh, levels: u32, mut state: State, detail: impl FnMut(u32, &Mesh, &[Vec3], &mut State) -> Offsets) -> Result<Detailed> {
    synthesize_in(base, levels, &mut state, detail)
}

/// [`synthesize`] with a state the caller keeps (for its tally), carried level by level
/// ([`State::carry`]).
pub(crate) fn synthesize_in(
    base: &Mesh,
    levels: u32,
    state: &mut State,
    mut detail: impl FnMut(u32, &Mesh, &[Vec3], &mut State) -> Offsets,
) -> Result<Detailed> {
    if !(1..=super::MAX_LEVELS).contains(&levels) {
        return Err(Error::InvalidParameter(format!("detail levels must be 1 to {}, not {levels}", super::MAX_LEVELS)));
    }
    super::check_levels(base, levels)?;
    let boundary = Boundary::SmoothAll;
    let mut parent = Level::base(base)?;
    let mut source_face: Vec<u32> = (0..base.face_count() as u32).collect();
    let mut scalar: Vec<f32> = vec![0.0; base.vertex_count()];
    for level in 1..=levels {
        let points = parent.points(boundary);
        let positions: Vec<Vec3> = points.par_iter().map(|p| p.as_vec3()).collect();
        // The finest level needs its quads alone: no edges or faces for a level after it.
        let (mut child, corners) = match level < levels {
            true => {
                let mut child = parent.child_as_base(points);
                let corners = std::mem::take(&mut child.corners);
                (Some(child), corners)
            }
            false => {
                drop(points);
                (None, child_quads(&parent))
            }
        };
        scalar = carried(&parent, &scalar);
        state.carry(&parent);
        source_face = parent.corner_face.par_iter().map(|&f| source_face[f as usize]).collect();
        drop(parent);
        let faces = corners.len() / 4;
        let mesh = Mesh::new(positions, &vec![4u32; faces], corners, None)?;
        let normals = quad_normals(&mesh);
        let offsets = detail(level, &mesh, &normals, state);
        let (mut moved, corners) = mesh.into_parts();
        match offsets {
            Offsets::Normal(d) => {
                scalar.par_iter_mut().zip(&d).for_each(|(s, &d)| *s += d as f32);
                moved.par_iter_mut().zip(&normals).zip(&d).for_each(|((p, &n), &d)| *p += n * d as f32);
            }
            Offsets::World(w) => {
                scalar.par_iter_mut().zip(&w).zip(&normals).for_each(|((s, w), n)| *s += w.dot(n.as_dvec3()) as f32);
                moved.par_iter_mut().zip(&w).for_each(|(p, w)| *p = (p.as_dvec3() + w).as_vec3());
            }
        }
        drop(normals);
        let Some(mut next) = child.take() else {
            let mesh = Mesh::new(moved, &vec![4u32; faces], corners, None)?;
            return Ok(Detailed { mesh, source_face, scalar });
        };
        next.positions.par_iter_mut().zip(&moved).for_each(|(p, m)| *p = m.as_dvec3());
        next.corners = corners;
        parent = next;
    }
    unreachable!("the finest level returns")
}

/// The quads of `parent`'s child level as [`Level::child_as_base`] numbers them, without
/// the edges and faces a level after it would need: corner `c` at vertex `v` of face `f`
/// becomes quad `c`, (v, edge point after v, face point of f, edge point before v).
fn child_quads(parent: &Level) -> Vec<u32> {
    let (nv, ne) = (parent.positions.len() as u32, parent.edges.len() as u32);
    let quads: Vec<[u32; 4]> = (0..parent.corners.len())
        .into_par_iter()
        .map(|c| [parent.corners[c], nv + parent.corner_edge[c], nv + ne + parent.corner_face[c], nv + parent.corner_edge[parent.prev(c)]])
        .collect();
    quads.into_flattened()
}

/// A per-vertex value carried from level to level linearly.
pub(crate) trait Carried: Copy + Send + Sync {
    /// The mean of `values` (`n` of them).
    fn mean(values: impl Iterator<Item = Self>, n: usize) -> Self;
    /// The mean of `a` and `b`.
    fn midpoint(a: Self, b: Self) -> Self {
        Self::mean([a, b].into_iter(), 2)
    }
}

impl Carried for f32 {
    fn mean(values: impl Iterator<Item = f32>, n: usize) -> f32 {
        values.sum::<f32>() / n as f32
    }
    fn midpoint(a: f32, b: f32) -> f32 {
        0.5 * (a + b)
    }
}

/// Unit vectors (normals): the mean's direction, summed in f64 and normalized.
impl Carried for Vec3 {
    fn mean(values: impl Iterator<Item = Vec3>, n: usize) -> Vec3 {
        (values.map(|v| v.as_dvec3()).sum::<DVec3>() / n as f64).normalize_or_zero().as_vec3()
    }
}

/// Per-vertex values of `parent` carried to its child level linearly: a vertex keeps its
/// value, edge point `nv + e` takes the mean of edge `e`'s ends, face point `nv + ne + f`
/// the mean of face `f`'s corners (the scalar, a berry's reference normals, painted
/// weights).
fn carried<T: Carried>(parent: &Level, values: &[T]) -> Vec<T> {
    let face_means = (0..parent.face_count()).into_par_iter().map(|f| {
        let face = parent.face(f);
        T::mean(face.iter().map(|&v| values[v as usize]), face.len())
    });
    let edge_means = parent.edges.par_iter().map(|&[a, b]| T::midpoint(values[a as usize], values[b as usize]));
    let mut out = Vec::with_capacity(values.len() + parent.edges.len() + parent.face_count());
    out.extend_from_slice(values);
    out.par_extend(edge_means);
    out.par_extend(face_means);
    out
}

/// [`vertex_normals`](crate::mesh::vertex_normals) of an all-quad mesh, bit for bit, the
/// costly part in parallel: block by block of faces, each corner's angle-weighted unit face
/// normal is computed in parallel, then added to its vertex's sum in corner order, as
/// `vertex_normals` adds them ([`scatter`], in parallel; no buffer the size of the mesh).
fn quad_normals(mesh: &Mesh) -> Vec<Vec3> {
    const BLOCK: usize = 1 << 14; // faces: 768 KiB of weights
    let (p, corners) = (mesh.positions(), mesh.corners());
    let mut n = vec![Vec3::ZERO; p.len()];
    let mut weights: Vec<[Vec3; 4]> = Vec::with_capacity(BLOCK);
    for block in corners.chunks(4 * BLOCK) {
        // NaN: a corner the sum skips (a degenerate face, an undefined angle).
        block
            .par_chunks_exact(4)
            .map(|quad| {
                let pts: [Vec3; 4] = std::array::from_fn(|i| p[quad[i] as usize]);
                let fnorm = newell_normal(&pts).normalize_or_zero();
                std::array::from_fn(|i| {
                    let angle = (pts[(i + 3) % 4] - pts[i]).angle_between(pts[(i + 1) % 4] - pts[i]);
                    if fnorm == Vec3::ZERO || !angle.is_finite() {
                        Vec3::NAN
                    } else {
                        fnorm * angle
                    }
                })
            })
            .collect_into_vec(&mut weights);
        scatter(&mut n, block, weights.as_flattened(), |n, w| {
            if !w.x.is_nan() {
                *n += *w;
            }
        });
    }
    n.par_iter_mut().for_each(|v| *v = v.normalize_or_zero());
    n
}

/// Adds each corner's value into its vertex's record, `add(record, value)`, in parallel
/// and without atomics, at every vertex in corner order (so bit for bit what one pass over
/// the corners gives): each thread owns one range of the vertices and walks all of
/// `corners`, updating its own.
fn scatter<T: Send, R: Sync>(records: &mut [T], corners: &[u32], values: &[R], add: impl Fn(&mut T, &R) + Sync) {
    let size = records.len().div_ceil(rayon::current_num_threads()).max(1);
    records.par_chunks_mut(size).enumerate().for_each(|(i, mine)| {
        let lo = i * size;
        for (&v, x) in corners.iter().zip(values) {
            if let Some(r) = (v as usize).checked_sub(lo).and_then(|j| mine.get_mut(j)) {
                add(r, x);
            }
        }
    });
}

impl Model {
    /// The displacement of each vertex of `mesh` (level `level`, vertex normals `normals`).
    pub(crate) fn displacements(&self, level: u32, mesh: &Mesh, normals: &[Vec3], seed: u64, state: &mut State) -> Offsets {
        let octave = 0.5f64.powi(level as i32 - 1);
        let p = mesh.positions();
        // Level 1's seeds: `given`, or Poisson-disk vertices `spacing` apart.
        let first_seeds = |given: &[u32], spacing: f64| match given.is_empty() {
            false => given.to_vec(),
            true => poisson_disk(p, (0..p.len() as u32).collect(), spacing, seed),
        };
        match self {
            Model::Rock { amplitude } => {
                let key = mix(seed ^ (level as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                let mut limits = fold_guard::Limits::of(mesh, normals);
                if let Some(gaps) = &state.gaps {
                    limits.near(gaps.rock_room(level, mesh));
                }
                let size = amplitude * octave;
                let gain = &state.gain;
                let size = |v: usize| size * gain.get(v).copied().unwrap_or(1.0);
                Offsets::Normal(limits.random(size, |v| unit_random(mix(key ^ mix(v as u64))), &mut state.tally))
            }
            Model::Berry { radius, seeds: given, children } => {
                let r = radius * octave;
                let mut limits = fold_guard::Limits::of(mesh, normals);
                state.seeds = match level {
                    1 => first_seeds(given, 2.0 * r),
                    _ => {
                        // A child where its dome stands whole: under the focal limits, no face
                        // tipped over (no overhang test to prepare where no child grows). Its
                        // own top, `r` high, is checked before its dome is built.
                        let stand = (*children > 0).then(|| overhang::Stand::new(mesh, normals, &state.reference));
                        let room = |v: u32| r <= limits.out(v as usize);
                        let fits =
                            |dome: &[(u32, f64)]| dome.iter().all(|&(v, h)| h <= limits.out(v as usize)) && stand.as_ref().is_some_and(|s| s.stands(dome));
                        clusters(p, &state.seeds, 2.0 * r, *children, mix(seed ^ level as u64), room, fits)
                    }
                };
                let mut heights = domes(p, &state.seeds, r);
                if !state.gain.is_empty() {
                    heights.iter_mut().enumerate().for_each(|(v, (_, h))| *h *= state.gain(v));
                }
                if let Some(clearance) = &state.clearance {
                    limits.clear_of(clearance, level, p, normals, |v| heights[v].1 > 0.0);
                }
                let (dome, full): (Vec<u32>, Vec<f64>) = heights.into_iter().unzip();
                // Each dome flattened as a whole to fit under its vertices' limits.
                let factor = fold_guard::scale_groups(&dome, |v| if full[v] > 0.0 { limits.out(v) / full[v] } else { 1.0 });
                let mut d: Vec<f64> = full.par_iter().zip(&dome).map(|(&h, &k)| if k == u32::MAX { 0.0 } else { h * factor[k as usize] }).collect();
                if level == 1 {
                    state.reference = normals.to_vec(); // carried to finer levels by the synthesis
                }
                overhang::upright(p, normals, mesh.corners(), &state.reference, &dome, &mut d);
                state.tally.count(&full, &d);
                Offsets::Normal(d)
            }
            Model::Tentacle { seeds: given, spacing, .. } | Model::Spur { seeds: given, spacing, .. } => {
                if level == 1 {
                    state.seeds = first_seeds(given, *spacing);
                }
                let local = match *self {
                    Model::Tentacle { length, theta, .. } => growth::tentacle_local(level, length, theta),
                    Model::Spur { length, .. } => growth::spur_local(level, length),
                    _ => unreachable!("a growth model"),
                };
                let mut offsets = growth::at_seeds(mesh, normals, &state.seeds, local);
                state.seeds.iter().for_each(|&s| offsets[s as usize] *= state.gain(s as usize));
                let mut group = vec![u32::MAX; p.len()];
                state.seeds.iter().enumerate().for_each(|(i, &s)| group[s as usize] = i as u32);
                state.guard_growth(level, mesh, normals, &group, &mut offsets);
                Offsets::World(offsets)
            }
            Model::Mushroom { radius, length, seeds: given } => {
                if level == 1 {
                    state.seeds = first_seeds(given, 2.0 * radius);
                    state.rings = state.seeds.iter().map(|&s| growth::Ring::over(p[s as usize], normals[s as usize], *radius)).collect();
                }
                let mut offsets = growth::advect(p, &state.rings, length * level as f64);
                if !state.gain.is_empty() {
                    offsets.par_iter_mut().zip(&state.gain).for_each(|(w, g)| *w *= *g);
                }
                Offsets::World(offsets)
            }
            Model::Fuse { amplitude, span, center, axis } => {
                Offsets::World(growth::fuse(p, level, *amplitude, &state.gain, *span, *center, axis.normalize(), state.reach, &mut state.tally))
            }
        }
    }
}

/// Dome heights `R (1 - r^2/R^2)^(1/2)` of every point over its nearest seed within `R`,
/// with that seed's position in `seeds` (`u32::MAX` beyond every dome).
fn domes(p: &[Vec3], seeds: &[u32], radius: f64) -> Vec<(u32, f64)> {
    let grid = Grid::new(seeds.iter().map(|&s| p[s as usize].as_dvec3()), radius);
    p.par_iter()
        .map(|q| match grid.nearest(q.as_dvec3()) {
            Some((k, nearest)) if nearest < radius => (k as u32, radius * (1.0 - nearest * nearest / (radius * radius)).sqrt()),
            _ => (u32::MAX, 0.0),
        })
        .collect()
}

/// Seeds of the next level (the paper's "cluster of seed points" defined by a volume
/// texture around each seed of the previous level, whose domes grow on the evolving
/// surface, Velho et al. 4.2): around each seed of the last, up to `children` vertices
/// within `spacing` (`2 R_l`, the last level's radius) of it, at least `spacing` apart
/// from every other seed of the level, its own cluster's or a neighbouring one's (domes
/// of one radius `R_l` then never overlap; clusters drawn apart only within each came as
/// close as they liked across, and their domes crossed), each where its whole dome
/// stands on the parent's: `fits` of its (vertex, height) pairs, sorted by vertex. A
/// child anywhere within the parent's radius mostly landed on the parent's steep wall,
/// where the guards halved its dome (91% of the berry preset's dome vertices on the UV
/// sphere); those places are now passed over for the next candidate. A candidate without
/// `room` for its own top is passed over before its dome is built, and a cluster gives up
/// after [`TRIES_PER_CHILD`] domes per child asked (the berry preset on a 10k-vertex
/// sphere, where no child fits, built every member's dome: 8.5-10.7 s for level 4, now
/// 4.3-5.1 s; the same output on the hard meshes and the bunny).
fn clusters(p: &[Vec3], parents: &[u32], spacing: f64, children: u32, seed: u64, room: impl Fn(u32) -> bool, fits: impl Fn(&[(u32, f64)]) -> bool) -> Vec<u32> {
    let radius = 0.5 * spacing; // R_l
    let reach = spacing; // the parent's radius: 2 R_l = R_(l-1)
    let near = Grid::new(parents.iter().map(|&s| p[s as usize].as_dvec3()), reach + radius);
    // Each vertex goes to the cluster of its nearest parent within reach; the vertices a
    // child's dome may cover, to the cluster's footprint.
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); parents.len()];
    let mut under = Vec::new();
    for (v, q) in p.iter().enumerate() {
        if let Some((k, d)) = near.nearest(q.as_dvec3()) {
            if d < reach {
                members[k].push(v as u32);
            }
            if d < reach + radius {
                under.push(v as u32);
            }
        }
    }
    let footprint = Grid::new(under.iter().map(|&v| p[v as usize].as_dvec3()), radius);
    let stands = |q: DVec3| {
        let mut dome: Vec<(u32, f64)> = footprint.within(q, radius).map(|(i, d)| (under[i], radius * (1.0 - d * d / (radius * radius)).sqrt())).collect();
        dome.sort_unstable_by_key(|&(v, _)| v);
        fits(&dome)
    };
    // Dart throwing over each cluster's candidates in a seeded random order against the
    // seeds kept in every cluster, so no two domes of the level overlap.
    let mut kept = Grid { cell: spacing, cells: HashMap::new(), points: Vec::new() };
    let mut out = Vec::new();
    for (k, mut m) in members.into_iter().enumerate() {
        let key = mix(seed ^ k as u64);
        m.sort_unstable_by_key(|&v| (mix(key ^ v as u64), v));
        let (mut grown, mut tried) = (0, 0);
        for v in m {
            if grown == children || tried == TRIES_PER_CHILD * children {
                break;
            }
            let q = p[v as usize].as_dvec3();
            // The cheap tests first: room for its top (`room`, the one of `fits` at the
            // dome's centre, so nothing changes), clear of the kept seeds; then its dome.
            if room(v) && kept.nearest(q).is_none_or(|(_, d)| d >= spacing) {
                tried += 1;
                if stands(q) {
                    kept.insert(q);
                    out.push(v);
                    grown += 1;
                }
            }
        }
    }
    out.sort_unstable();
    out
}

/// The most domes [`clusters`] builds per child asked before it gives up on a cluster:
/// a cluster with no place for a child (a parent on a thin part, under a low curvature
/// limit) otherwise built the dome of every vertex within its reach. The children the
/// hard meshes and the bunny grow at level 3 took at most 270 domes for 3 children.
const TRIES_PER_CHILD: u32 = 128;

/// Dart throwing over `candidates` in a seeded random order: a candidate is kept when no
/// kept one lies within `spacing` (a Poisson-disk set of the vertices).
fn poisson_disk(p: &[Vec3], mut candidates: Vec<u32>, spacing: f64, seed: u64) -> Vec<u32> {
    candidates.sort_unstable_by_key(|&v| (mix(seed ^ v as u64), v));
    let mut grid = Grid { cell: spacing, cells: HashMap::new(), points: Vec::new() };
    let mut kept = Vec::new();
    for v in candidates {
        let q = p[v as usize].as_dvec3();
        if grid.nearest(q).is_none_or(|(_, d)| d >= spacing) {
            grid.insert(q);
            kept.push(v);
        }
    }
    kept
}

/// Points hashed into cubes of side `cell`: nearest-point queries within one cell.
struct Grid {
    cell: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
    points: Vec<DVec3>,
}

impl Grid {
    fn new(points: impl Iterator<Item = DVec3>, cell: f64) -> Self {
        let mut grid = Grid { cell, cells: HashMap::new(), points: Vec::new() };
        points.for_each(|q| grid.insert(q));
        grid
    }

    fn key(&self, q: DVec3) -> [i64; 3] {
        (q / self.cell).floor().as_i64vec3().to_array()
    }

    fn insert(&mut self, q: DVec3) {
        let k = self.key(q);
        self.cells.entry(k).or_default().push(self.points.len() as u32);
        self.points.push(q);
    }

    /// The points (index, distance) within one cell of `q`'s cell: every point closer
    /// than `cell` is among them.
    fn around(&self, q: DVec3) -> impl Iterator<Item = (usize, f64)> + '_ {
        let k = self.key(q);
        (0..27).flat_map(move |c| {
            let cell = [k[0].wrapping_add(c / 9 - 1), k[1].wrapping_add(c / 3 % 3 - 1), k[2].wrapping_add(c % 3 - 1)];
            self.cells.get(&cell).map_or(&[][..], |v| &v[..]).iter().map(move |&i| (i as usize, self.points[i as usize].distance(q)))
        })
    }

    /// The points closer to `q` than `reach`, at most `cell`.
    fn within(&self, q: DVec3, reach: f64) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.around(q).filter(move |&(_, d)| d < reach)
    }

    /// The nearest point (index, distance) among those of [`Grid::around`].
    fn nearest(&self, q: DVec3) -> Option<(usize, f64)> {
        self.around(q).fold(None, |best, (i, d)| if best.is_none_or(|(_, b)| d < b) { Some((i, d)) } else { best })
    }
}

/// A value in [-1, 1) from a hash.
fn unit_random(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// SplitMix64's finalizer: a well-mixed 64-bit hash.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testmeshes;

    fn sphere() -> Mesh {
        testmeshes::icosphere(2)
    }

    /// Per-vertex values of `parent` carried to its subdivision (one level, numbered as
    /// [`subdivide`] numbers it) by [`carried`].
    fn linear_child_values<T: Carried>(parent: &Mesh, values: &[T]) -> Vec<T> {
        carried(&Level::base(parent).expect("a mesh that subdivides"), values)
    }

    #[test]
    fn rock_detail_amplitudes_fall_as_one_over_f() {
        // The detail each level adds, measured as the RMS of its displacements, halves
        // from level to level (1/f: the frequency doubles with each level). This checks
        // the generator; the surface's smoothing is the next test's.
        let base = sphere();
        let model = Model::Rock { amplitude: 0.05 };
        let mut rms = Vec::new();
        synthesize(&base, 4, State::default(), |level, mesh, normals, state| {
            let Offsets::Normal(d) = model.displacements(level, mesh, normals, 7, state) else { unreachable!() };
            rms.push((d.iter().map(|d| d * d).sum::<f64>() / d.len() as f64).sqrt());
            Offsets::Normal(d)
        })
        .unwrap();
        for l in 1..rms.len() {
            let ratio = rms[l] / rms[l - 1];
            assert!((ratio - 0.5).abs() < 0.5 * 0.2, "level {} / {}: {ratio} (rms {rms:?})", l + 1, l);
        }
    }

    #[test]
    fn values_carried_linearly_land_on_the_new_points() {
        // On a regular planar grid every new point of a subdivision is the midpoint of its
        // edge or the centroid of its face, so a value linear in x carried linearly equals
        // the new point's x.
        let grid = crate::mesh::fixtures::grid(3);
        let child = subdivide(&grid, &Options { levels: 1, limit: false, boundary: Boundary::SmoothAll }).unwrap().mesh;
        let x: Vec<f32> = grid.positions().iter().map(|p| p.x).collect();
        let carried = linear_child_values(&grid, &x);
        assert_eq!(carried.len(), child.vertex_count());
        for (v, (c, p)) in carried.iter().zip(child.positions()).enumerate().skip(grid.vertex_count()) {
            assert!((c - p.x).abs() < 1e-6, "vertex {v}: {c} against {}", p.x);
        }
        assert_eq!(&carried[..x.len()], &x[..]);
    }

    #[test]
    fn normals_carried_are_the_quad_means_and_near_the_finer_levels_own() {
        // A berry's reference normals: level 1's carried to level 2 equal, bit for bit,
        // each new point's mean over the child quads around it of their first corners'
        // normals (summed in f64, normalized: how they were carried before), and stand
        // within a few degrees of level 2's own normals.
        let base = sphere();
        let options = Options { levels: 1, limit: false, boundary: Boundary::SmoothAll };
        let one = subdivide(&base, &options).unwrap().mesh;
        let two = subdivide(&one, &options).unwrap().mesh;
        let n1 = vertex_normals(&one);
        let carried = linear_child_values(&one, &n1);
        let (mut sum, mut count) = (vec![DVec3::ZERO; two.vertex_count()], vec![0u32; two.vertex_count()]);
        for quad in two.corners().chunks_exact(4) {
            for &c in &quad[1..] {
                sum[c as usize] += n1[quad[0] as usize].as_dvec3();
                count[c as usize] += 1;
            }
        }
        for (v, (c, n)) in carried.iter().zip(vertex_normals(&two)).enumerate() {
            let want = if v < n1.len() { n1[v] } else { (sum[v] / count[v] as f64).normalize().as_vec3() };
            assert_eq!(c.to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "vertex {v}");
            assert!(c.dot(n) > 0.99, "{c} {n}");
        }
    }

    #[test]
    fn rock_values_are_uniform_and_differ_between_neighbours() {
        // One value per control point: over a level's vertices the values spread evenly
        // over [-1, 1) and a vertex's value says nothing of the next one's.
        let values: Vec<f64> = (0..100_000u64).map(|v| unit_random(mix(mix(42) ^ mix(v)))).collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let below = values.iter().filter(|&&x| x < 0.5).count() as f64 / values.len() as f64;
        let lag: f64 = values.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (values.len() - 1) as f64;
        assert!(values.iter().all(|&x| (-1.0..1.0).contains(&x)));
        assert!(mean.abs() < 0.01 && (below - 0.75).abs() < 0.01 && lag.abs() < 0.01, "mean {mean}, below 0.5 {below}, lag-1 {lag}");
    }

    #[test]
    fn rock_surface_is_smoothed_by_the_levels_after_its_detail() {
        // Reconstruction (4.2): the first level's random values, subdivided three more
        // times without detail, leave a surface whose neighbouring vertices differ far
        // less than the raw values do.
        let base = sphere();
        let amplitude = 0.05;
        let rough = |out: &Detailed| {
            let p = out.mesh.positions();
            let normals = vertex_normals(&out.mesh);
            let mut sum = 0.0;
            let mut n = 0;
            for face in out.mesh.faces() {
                for k in 0..face.len() {
                    let (a, b) = (face[k] as usize, face[(k + 1) % face.len()] as usize);
                    sum += ((p[a] - p[b]).dot(normals[a]) as f64).abs();
                    n += 1;
                }
            }
            sum / n as f64
        };
        let rock = |level, mesh: &Mesh, normals: &[Vec3], state: &mut State| match level {
            1 => Model::Rock { amplitude }.displacements(level, mesh, normals, 9, state),
            _ => Offsets::Normal(vec![0.0; mesh.vertex_count()]),
        };
        let once = synthesize(&base, 1, State::default(), rock).unwrap();
        let smoothed = synthesize(&base, 4, State::default(), rock).unwrap();
        let (raw, after) = (rough(&once), rough(&smoothed));
        assert!(after < 0.25 * raw, "edge steps along the normal: {raw} raw, {after} after three smoothing levels");
    }

    #[test]
    fn a_berry_dome_reaches_its_radius_at_the_seed() {
        // One level, one seed: the seed vertex moves by exactly R along its normal from
        // where plain subdivision puts it, and vertices beyond R do not move.
        let base = sphere();
        let radius = 0.3;
        let out = procedural_detail(&base, 1, &Model::Berry { radius, seeds: vec![5], children: 0 }, 1).unwrap();
        let plain = subdivide(&base, &Options { levels: 1, limit: false, boundary: Boundary::SmoothAll }).unwrap().mesh;
        let (p, q) = (plain.positions(), out.mesh.positions());
        let normals = vertex_normals(&plain);
        let moved = (q[5] - p[5]).as_dvec3();
        assert!((moved.length() - radius).abs() < 1e-5 && moved.normalize().dot(normals[5].as_dvec3()) > 0.99999, "{moved}");
        assert!((out.scalar[5] as f64 - radius).abs() < 1e-6);
        let mut far = 0;
        for v in 0..p.len() {
            let r = p[v].distance(p[5]) as f64;
            let want = if r < radius { radius * (1.0 - r * r / (radius * radius)).sqrt() } else { 0.0 };
            assert!(((q[v] - p[v]).length() as f64 - want).abs() < 1e-5, "vertex {v} at {r}");
            far += (r >= radius) as usize;
        }
        assert!(far > p.len() / 2);
    }

    /// Blender's default UV sphere (32 segments, 16 rings, radius 1): triangles at the
    /// poles, quads between, edges short at the poles.
    fn uv_sphere() -> Mesh {
        let (segments, rings) = (32u32, 16u32);
        let mut p = vec![Vec3::Z, -Vec3::Z];
        for r in 1..rings {
            let phi = std::f32::consts::PI * r as f32 / rings as f32;
            p.extend((0..segments).map(|s| {
                let theta = std::f32::consts::TAU * s as f32 / segments as f32;
                Vec3::new(phi.sin() * theta.cos(), phi.sin() * theta.sin(), phi.cos())
            }));
        }
        let at = |r: u32, s: u32| 2 + (r - 1) * segments + s % segments;
        let (mut sizes, mut corners) = (Vec::new(), Vec::new());
        for s in 0..segments {
            sizes.extend([3, 3]);
            corners.extend([0, at(1, s), at(1, s + 1), 1, at(rings - 1, s + 1), at(rings - 1, s)]);
            for r in 1..rings - 1 {
                sizes.push(4);
                corners.extend([at(r, s), at(r + 1, s), at(r + 1, s + 1), at(r, s + 1)]);
            }
        }
        Mesh::new(p, &sizes, corners, None).unwrap()
    }

    #[test]
    fn the_tally_counts_each_reduced_vertex_once_a_level() {
        // The berry preset on the UV sphere: at every level, the domes the seeds ask for
        // (unguarded, from the same seeds on the same mesh) against what the guards left,
        // vertex by vertex; the tally is that count, however many times a dome was halved.
        // The rock likewise, against its unguarded random values.
        let base = uv_sphere();
        for (model, mut want) in
            [(Model::Berry { radius: 0.12, seeds: vec![], children: 3 }, Tally::default()), (Model::Rock { amplitude: 0.05 }, Tally::default())]
        {
            synthesize(&base, 3, model.initial_state(&base), |level, mesh, normals, state| {
                let offsets = model.displacements(level, mesh, normals, 0, state);
                let Offsets::Normal(d) = &offsets else { unreachable!() };
                let octave = 0.5f64.powi(level as i32 - 1);
                let full: Vec<f64> = match &model {
                    Model::Berry { radius, .. } => domes(mesh.positions(), &state.seeds, radius * octave).into_iter().map(|(_, h)| h).collect(),
                    Model::Rock { amplitude } => {
                        let key = mix((level as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                        (0..d.len()).map(|v| amplitude * octave * unit_random(mix(key ^ mix(v as u64)))).collect()
                    }
                    _ => unreachable!(),
                };
                for (f, k) in full.iter().zip(d) {
                    if *f != 0.0 {
                        want.placed += 1;
                        want.limited += (k != f) as u64;
                        want.shrunk += (k.abs() < 0.9 * f.abs()) as u64;
                    }
                    assert!(k.abs() <= f.abs() && k * f >= 0.0, "the guard only lowers detail");
                }
                offsets
            })
            .unwrap();
            let tally = crate::subdivision::recipe::synthesize(&base, 3, &crate::subdivision::recipe::Recipe::of(model.clone(), 0)).unwrap().tally;
            assert_eq!(tally, want, "{model:?}");
            eprintln!("{model:?}: {want:?} share {:.3}, shrunk {:.3}", want.share(), want.shrunk_share());
        }
    }

    #[test]
    fn berry_children_are_placed_where_their_domes_stand() {
        // The berry preset (radius 0.12 of the diagonal) on the UV sphere: children drawn
        // anywhere within their parent's radius mostly landed on its steep wall, where the
        // guards halved their domes (57% of the dome vertices of two levels); placed only
        // where their whole dome stands, none is reduced, and level 2 still has children.
        let base = uv_sphere();
        let model = Model::Berry { radius: 0.12 * base.bbox_diagonal() as f64, seeds: vec![], children: 3 };
        let tally = crate::subdivision::recipe::synthesize(&base, 3, &crate::subdivision::recipe::Recipe::of(model.clone(), 0)).unwrap().tally;
        assert!(tally.placed > 0 && tally.limited == 0, "{tally:?}");
        let mut counts = Vec::new();
        synthesize(&base, 3, model.initial_state(&base), |level, mesh, normals, state| {
            let offsets = model.displacements(level, mesh, normals, 0, state);
            counts.push(state.seeds.len());
            offsets
        })
        .unwrap();
        eprintln!("seeds per level {counts:?}");
        assert!(counts[1] > 0 && counts[2] > 0, "{counts:?}");
    }

    #[test]
    fn a_local_gain_above_one_stays_within_the_guard() {
        // Gain 3 around a vertex of the UV sphere's equator: every level's displacement
        // stays within the guard's limits vertex by vertex (the rock within a quarter of
        // the shortest edge too), the gain raises detail where the guard leaves room, and
        // the result crosses itself no more than at gain 1.
        use crate::mesh::Incidence;
        use crate::subdivision::operations::{Levels, Local};
        use crate::subdivision::recipe::{synthesize as recipe, Recipe};
        let base = uv_sphere();
        let local = Local { center: 2 + 8 * 32, radius: 4.0, gain: 3.0, levels: Levels::ALL };
        for model in [Model::Rock { amplitude: 0.01 }, Model::Berry { radius: 0.12, seeds: vec![], children: 3 }] {
            let (mut raised, mut checked) = (0, 0);
            synthesize(&base, 3, model.initial_state(&base), |level, mesh, normals, state| {
                let plain = match level {
                    1 => model.displacements(level, mesh, normals, 4, &mut model.initial_state(&base)),
                    _ => Offsets::Normal(Vec::new()),
                };
                state.gain = local.weights(level, 3, mesh, &Incidence::faces(mesh));
                let offsets = model.displacements(level, mesh, normals, 4, state);
                let (Offsets::Normal(d), Offsets::Normal(_)) = (&offsets, &plain) else { unreachable!() };
                let limits = fold_guard::Limits::of(mesh, normals);
                for (v, &d) in d.iter().enumerate() {
                    assert!(d <= limits.out(v) * (1.0 + 1e-12) && -d <= limits.inward(v) * (1.0 + 1e-12), "{model:?} level {level} vertex {v}: {d}");
                    if let Model::Rock { .. } = model {
                        assert!(d.abs() <= FOLD_SLOPE * limits.shortest(v) * (1.0 + 1e-12));
                    }
                    checked += (state.gain[v] > 1.0) as usize;
                }
                if level == 1 {
                    let Offsets::Normal(p) = &plain else { unreachable!() };
                    raised += d.iter().zip(p).filter(|(d, p)| d.abs() > p.abs() * 1.5).count();
                }
                offsets
            })
            .unwrap();
            assert!(checked > 100 && raised > 0, "{model:?}: {checked} vertices under the gain, {raised} raised");
            let crossings = |gain| {
                let r = Recipe { local: vec![Local { gain, ..local.clone() }], ..Recipe::of(model.clone(), 4) };
                crate::hard_meshes::self_intersections(&recipe(&base, 3, &r).unwrap().detailed.mesh)
            };
            let (one, three) = (crossings(1.0), crossings(3.0));
            assert!(three <= one, "{model:?}: {three} crossing pairs at gain 3, {one} at gain 1");
        }
    }

    #[test]
    fn berry_seeds_are_a_poisson_disk_set_and_clusters_grow() {
        let base = sphere();
        let mut counts = Vec::new();
        let radius = 0.2;
        synthesize(&base, 3, State::default(), |level, mesh, normals, state| {
            let Offsets::Normal(d) = Model::Berry { radius, seeds: vec![], children: 4 }.displacements(level, mesh, normals, 3, state) else { unreachable!() };
            let seeds = &state.seeds;
            let r = radius * 0.5f64.powi(level as i32 - 1);
            let p = mesh.positions();
            for (i, &a) in seeds.iter().enumerate() {
                for &b in &seeds[i + 1..] {
                    let d = p[a as usize].distance(p[b as usize]) as f64;
                    // 2 R apart at every level, across clusters too, so no two domes of a
                    // level overlap (neighbouring clusters once came closer and crossed).
                    assert!(d >= 2.0 * r - 1e-6, "level {level}: seeds {a}, {b} {d} apart");
                }
            }
            assert!(d.iter().all(|&h| (0.0..=r + 1e-12).contains(&h)));
            counts.push(seeds.len());
            Offsets::Normal(d)
        })
        .unwrap();
        assert!(counts[0] > 3 && counts[1] > counts[0] && counts[2] >= counts[1], "{counts:?}");
    }

    #[test]
    fn same_seed_same_surface_other_seed_other_surface() {
        let base = sphere();
        let rock = Model::Rock { amplitude: 0.05 };
        let a = procedural_detail(&base, 2, &rock, 11).unwrap();
        assert_eq!(a, procedural_detail(&base, 2, &rock, 11).unwrap());
        assert_ne!(a.mesh.positions(), procedural_detail(&base, 2, &rock, 12).unwrap().mesh.positions());
        let berry = Model::Berry { radius: 0.2, seeds: vec![], children: 3 };
        assert_eq!(procedural_detail(&base, 3, &berry, 4).unwrap(), procedural_detail(&base, 3, &berry, 4).unwrap());
    }

    /// The synthesis as it was before its stepper: [`subdivide`] one level at a time (the
    /// connectivity rebuilt from each level's mesh), [`vertex_normals`], a new mesh per level.
    fn one_level_at_a_time(base: &Mesh, levels: u32, model: &Model, seed: u64) -> Detailed {
        let options = Options { levels: 1, limit: false, boundary: Boundary::SmoothAll };
        let (mut mesh, mut state) = (base.clone(), model.initial_state(base));
        let mut source_face: Vec<u32> = (0..base.face_count() as u32).collect();
        let mut scalar: Vec<f32> = vec![0.0; base.vertex_count()];
        for level in 1..=levels {
            let next = subdivide(&mesh, &options).unwrap();
            scalar = linear_child_values(&mesh, &scalar);
            state.carry(&Level::base(&mesh).unwrap());
            source_face = next.source_face.iter().map(|&f| source_face[f as usize]).collect();
            mesh = next.mesh;
            let normals = vertex_normals(&mesh);
            let moved: Vec<Vec3> = match model.displacements(level, &mesh, &normals, seed, &mut state) {
                Offsets::Normal(d) => {
                    scalar.iter_mut().zip(&d).for_each(|(s, &d)| *s += d as f32);
                    mesh.positions().iter().zip(&normals).zip(&d).map(|((&p, &n), &d)| p + n * d as f32).collect()
                }
                Offsets::World(w) => {
                    scalar.iter_mut().zip(&w).zip(&normals).for_each(|((s, w), n)| *s += w.dot(n.as_dvec3()) as f32);
                    mesh.positions().iter().zip(&w).map(|(&p, w)| (p.as_dvec3() + w).as_vec3()).collect()
                }
            };
            mesh = Mesh::new(moved, &mesh.face_sizes(), mesh.corners().to_vec(), None).unwrap();
        }
        Detailed { mesh, source_face, scalar }
    }

    #[test]
    fn the_stepper_is_bit_for_bit_one_level_at_a_time() {
        // Same vertex numbering, positions, normals and values: every model, on closed
        // meshes with triangles, n-gons and open boundaries.
        let models = [
            Model::Rock { amplitude: 0.05 },
            Model::Berry { radius: 0.2, seeds: vec![], children: 3 },
            Model::Tentacle { length: 0.02, theta: 0.3, seeds: vec![], spacing: 0.4 },
            Model::Mushroom { radius: 0.2, length: 0.05, seeds: vec![] },
        ];
        let meshes = [sphere(), crate::mesh::fixtures::grid(3), crate::mesh::fixtures::cube(), crate::hard_meshes::star_prism()];
        for (m, base) in meshes.iter().enumerate() {
            for model in &models {
                for levels in [1, 3] {
                    let want = one_level_at_a_time(base, levels, model, 5);
                    let got = procedural_detail(base, levels, model, 5).unwrap();
                    assert!(got == want, "mesh {m}, {model:?}, {levels} levels");
                }
            }
        }
        // The normals bit for bit, degenerate faces (all corners at one point) included,
        // over more than one block of faces.
        let bits = |n: Vec<Vec3>| n.iter().map(|v| v.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        let quads = subdivide(&sphere(), &Options { levels: 4, limit: false, boundary: Boundary::SmoothAll }).unwrap().mesh;
        assert!(quads.face_count() > 1 << 14);
        assert_eq!(bits(quad_normals(&quads)), bits(vertex_normals(&quads)));
        let (mut p, corners) = quads.into_parts();
        let sizes = vec![4u32; corners.len() / 4];
        corners[4 * 100..4 * 104].iter().for_each(|&v| p[v as usize] = Vec3::ZERO);
        let flattened = Mesh::new(p, &sizes, corners, None).unwrap();
        assert_eq!(bits(quad_normals(&flattened)), bits(vertex_normals(&flattened)));
    }

    #[test]
    fn uvs_on_the_connectivity_alone_are_subdivides() {
        // `subdivide_uvs` (what the detail's UVs are) refines no position: its UVs are
        // those `subdivide_with_uvs` gives without the limit, bit for bit, seams included
        // (every fifth face's corners shifted off their neighbours').
        use crate::subdivision::{subdivide_uvs, subdivide_with_uvs, UvSmooth};
        use glam::Vec2;
        let base = sphere();
        let p = base.positions();
        let uvs: Vec<Vec2> = base
            .faces()
            .enumerate()
            .flat_map(|(f, face)| face.iter().map(move |&v| Vec2::new(p[v as usize].x, p[v as usize].y) + (f % 5 == 0) as u8 as f32 * 0.5))
            .collect();
        let planar: Vec<Vec2> = base.corners().iter().map(|&v| Vec2::new(p[v as usize].y, p[v as usize].z)).collect();
        for smooth in [UvSmooth::PreserveBoundaries, UvSmooth::Linear] {
            for levels in 1..=3 {
                let options = Options { levels, limit: false, boundary: Boundary::SmoothAll };
                let (_, want) = subdivide_with_uvs(&base, &options, smooth, &[&uvs, &planar]).unwrap();
                assert_eq!(subdivide_uvs(&base, levels, smooth, &[&uvs, &planar]).unwrap(), want, "{smooth:?} level {levels}");
            }
        }
        assert!(matches!(subdivide_uvs(&base, 2, UvSmooth::Linear, &[&uvs[1..]]), Err(Error::InvalidParameter(_))));
        assert!(matches!(subdivide_uvs(&base, 0, UvSmooth::Linear, &[&uvs]), Err(Error::InvalidParameter(_))));
    }

    #[test]
    fn bad_parameters_are_refused() {
        let base = sphere();
        let refuse = |m: Model, levels: u32| assert!(matches!(procedural_detail(&base, levels, &m, 0), Err(Error::InvalidParameter(_))), "{m:?}");
        refuse(Model::Rock { amplitude: f64::NAN }, 2);
        refuse(Model::Rock { amplitude: 1e6 }, 2);
        refuse(Model::Rock { amplitude: 0.1 }, 0);
        refuse(Model::Rock { amplitude: 0.1 }, super::super::MAX_LEVELS + 1);
        refuse(Model::Berry { radius: 1e-9, seeds: vec![], children: 2 }, 2);
        // A mesh of one point (zero size): no radius fits, not even zero.
        let point = Mesh::new(vec![Vec3::ZERO; 4], &[4], vec![0, 1, 2, 3], None).unwrap();
        assert!(matches!(procedural_detail(&point, 1, &Model::Berry { radius: 0.0, seeds: vec![], children: 2 }, 0), Err(Error::InvalidParameter(_))));
        refuse(Model::Berry { radius: -1.0, seeds: vec![], children: 2 }, 2);
        refuse(Model::Berry { radius: 0.1, seeds: vec![10_000], children: 2 }, 2);
        refuse(Model::Berry { radius: 0.1, seeds: vec![], children: MAX_CHILDREN + 1 }, 2);
    }
}
