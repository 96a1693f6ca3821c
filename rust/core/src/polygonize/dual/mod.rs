//! Adaptive dual contouring of fields with analytic gradients: the polygonizer that
//! the implicit features share. Quads, sharp where the field has creases and corners,
//! a closed 2-manifold for every field (the box cuts the solid, as
//! [`crate::polygonize::mesh_field`] does), and work that follows the surface.
//!
//! - [`lattice`]: the cells over the box, and the field cut by it.
//! - [`octree`]: sparse descent by the field's interval bound to the blocks of finest
//!   cells that may hold the surface.
//! - [`cases`]: the pieces of the surface in a cell (manifold dual contouring,
//!   Schaefer, Ju and Warren 2007).
//! - [`qef`]: a piece's vertex from its crossings' tangent planes (Ju, Losasso,
//!   Schaefer and Warren 2002).
//! - [`project`]: vertices far off the zero set pulled onto it.
//! - [`block`]: one block sampled, its crossings and vertices.
//! - [`contour`]: quads around crossing edges, fold fallback, quad splits.
//! - [`count`]: the crossings of a lattice counted without meshing, for
//!   [`crate::polygonize::estimate`].
//!
//! The output does not depend on the number of threads: blocks come in a fixed order
//! and each crossing and vertex is computed alone (a batch's go to the field together,
//! each point evaluated on its own).

mod block;
mod cases;
mod contour;
mod count;
mod lattice;
mod octree;
mod project;
mod qef;

#[cfg(test)]
mod tests;

pub use count::{count_crossings, Crossings};
pub use lattice::BLOCK;

use crate::field::ScalarField;
use crate::polygonize::estimate::{over_limit, peak_bytes, Mesher, Watch};
use crate::Result;
use glam::{UVec3, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// What [`mesh_dual`] meshes, and how finely.
#[derive(Debug, Clone, PartialEq)]
pub struct DualParams {
    /// The box meshed: lowest and highest corner.
    pub bounds: (Vec3, Vec3),
    /// Cells along the box's longest side (2 to [`crate::polygonize::grid::MAX_RESOLUTION`]).
    pub resolution: u32,
}

/// Where the time went, in milliseconds (wall clock), and how many field evaluations.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Profile {
    /// The octree descent (interval bounds).
    pub descent_ms: f64,
    /// Sampling the live blocks, crossings and QEF vertices.
    pub cells_ms: f64,
    /// Quads, fold fallback and splits.
    pub contour_ms: f64,
    /// Normals and attributes at the vertices.
    pub attributes_ms: f64,
    pub live_blocks: usize,
    /// Point evaluations (values or gradients) in the blocks.
    pub evaluations: usize,
}

/// A meshed field: a closed, consistently oriented 2-manifold of quads
/// (counter-clockwise seen from outside, where `f > 0`).
#[derive(Debug, Clone, Default)]
pub struct DualMesh {
    pub positions: Vec<Vec3>,
    /// The cut field's unit gradient at each vertex (the box face's normal where the
    /// box cut the solid; zero where the gradient is not a number).
    pub normals: Vec<Vec3>,
    /// Quads whose split along `0-2` is the better one.
    pub quads: Vec<[u32; 4]>,
    /// [`ScalarField::attribute_count`] values per vertex, the field's at the vertex.
    pub attributes: Vec<f32>,
    pub attribute_count: usize,
    /// Cells along x, y and z.
    pub cells: UVec3,
    pub profile: Profile,
}

impl DualMesh {
    /// The quads split along their `0-2` diagonal.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        self.quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect()
    }
}

/// Meshes the zero set of `field` inside `params.bounds` (inside is `f <= 0`) by
/// manifold dual contouring at the finest level of an interval-culled octree.
/// A field that is not a number at a sample is an error.
pub fn mesh_dual<F: ScalarField + ?Sized>(field: &F, params: &DualParams) -> Result<DualMesh> {
    mesh_dual_watched(field, params, &Watch::default())
}

/// Live blocks sampled between two looks at the watch. Not from a paper: a few
/// milliseconds of work on two cores, and few enough joins not to be seen in the time.
const BLOCKS_PER_LOOK: usize = 256;

/// [`mesh_dual`] under a [`Watch`]: progress counted over the live blocks (then the
/// contouring and attributes), a cancel obeyed between batches of blocks, and the
/// memory limit checked against what the blocks sampled so far will take
/// ([`peak_bytes`]): past it the build stops with an error naming the limit.
pub fn mesh_dual_watched<F: ScalarField + ?Sized>(field: &F, params: &DualParams, watch: &Watch<'_>) -> Result<DualMesh> {
    let lattice = lattice::Lattice::new(params.bounds, params.resolution)?;
    watch.check()?;
    let mut profile = Profile::default();
    let start = Instant::now();
    let live = octree::live_blocks(field, &lattice, watch)?;
    profile.descent_ms = ms(start);
    profile.live_blocks = live.len();
    let start = Instant::now();
    // The blocks are most of the work; contouring and attributes the last fifth.
    let tail = live.len() / 4 + 1;
    watch.start(live.len() + tail);
    let mut blocks: Vec<block::Block> = Vec::with_capacity(live.len());
    let (mut vertices, mut quads) = (0u64, 0u64);
    for batch in live.chunks(BLOCKS_PER_LOOK) {
        watch.check()?;
        let origins: Vec<UVec3> = batch.iter().map(|&b| b * lattice::BLOCK).collect();
        let shared = block::Shared::of(field, &lattice, &origins)?;
        profile.evaluations += shared.evaluated();
        let (done, evaluations) = block::process(field, &lattice, &origins, &shared);
        profile.evaluations += evaluations;
        vertices += done.iter().map(|b| b.qef.len() as u64).sum::<u64>();
        quads += done.iter().map(|b| b.edges.len() as u64).sum::<u64>();
        blocks.extend(done);
        watch.advance(batch.len());
        if let Some(limit) = watch.max_bytes {
            let held = peak_bytes(Mesher::Dual, lattice.cells, live.len() as u64, vertices, quads);
            if held > limit {
                return Err(over_limit(limit, &format!("{} of {} blocks sampled already make {vertices} vertices", blocks.len(), live.len())));
            }
        }
    }
    drop(live);
    profile.cells_ms = ms(start);
    watch.check()?;
    let start = Instant::now();
    let mut offsets = Vec::with_capacity(blocks.len());
    let mut total = 0u32;
    for b in &blocks {
        offsets.push(total);
        total += b.qef.len() as u32;
    }
    let mut quads = contour::quads(&blocks, &offsets)?;
    let mut qef = Vec::with_capacity(total as usize);
    let mut mass = Vec::with_capacity(total as usize);
    let mut cells = Vec::with_capacity(total as usize);
    for b in blocks {
        qef.extend(b.qef);
        mass.extend(b.mass);
        cells.extend(b.cell);
    }
    let (mut positions, fallen) = contour::place(qef, &mass, &mut quads);
    drop(mass);
    // Mass points of curved pieces sit inside their chord: pulled onto the surface.
    let (mut moved, at): (Vec<Vec3>, Vec<UVec3>) = fallen.iter().map(|&v| (positions[v as usize], cells[v as usize])).unzip();
    project::project(field, &lattice, &mut moved, &at, None);
    for (&v, p) in fallen.iter().zip(moved) {
        positions[v as usize] = p;
    }
    profile.contour_ms = ms(start);
    watch.check()?;
    watch.advance(tail / 2);
    let start = Instant::now();
    let normals = vertex_normals(field, &lattice, &positions);
    let count = field.attribute_count();
    let mut attributes = vec![0.0; positions.len() * count];
    if count > 0 {
        const CHUNK: usize = 4096;
        attributes.par_chunks_mut(CHUNK * count).zip(positions.par_chunks(CHUNK)).for_each(|(out, points)| field.attributes(points, out));
    }
    profile.attributes_ms = ms(start);
    watch.advance(tail - tail / 2);
    Ok(DualMesh { positions, normals, quads: quads.into_iter().map(|(q, _)| q).collect(), attributes, attribute_count: count, cells: lattice.cells, profile })
}

fn ms(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// The cut field's unit gradient at each vertex.
fn vertex_normals<F: ScalarField + ?Sized>(field: &F, lattice: &lattice::Lattice, positions: &[Vec3]) -> Vec<Vec3> {
    const CHUNK: usize = 4096;
    let mut normals = vec![Vec3::ZERO; positions.len()];
    normals.par_chunks_mut(CHUNK).zip(positions.par_chunks(CHUNK)).for_each(|(out, points)| {
        field.gradients(points, out);
        let edge = lattice.step.length();
        let near: Vec<usize> = (0..points.len()).filter(|&v| lattice.to_box(points[v]).0 > -edge).collect();
        if !near.is_empty() {
            let near_points: Vec<Vec3> = near.iter().map(|&v| points[v]).collect();
            let mut f = vec![0.0; near.len()];
            field.values(&near_points, &mut f);
            for (&v, f) in near.iter().zip(f) {
                let (d, face) = lattice.to_box(points[v]);
                if d >= f {
                    out[v] = face;
                }
            }
        }
        for g in out.iter_mut() {
            *g = if g.is_finite() { g.normalize_or_zero() } else { Vec3::ZERO };
        }
    });
    normals
}
