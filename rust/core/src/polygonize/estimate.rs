//! A field mesh's size before it is made, a memory limit, and the watch that long
//! meshings report to (issue 17: "resolutions whose output would not fit in memory: a
//! clear message, nothing changed").
//!
//! [`estimate`] counts the crossings of the same field on a coarser lattice of the
//! same box ([`ESTIMATE_RESOLUTION`] cells along the longest side: the interval-culled
//! descent's blocks sampled, nothing meshed) and scales each edge direction's count to
//! the lattice asked for: a surface of area `A` crosses a family of parallel edges
//! `e` (one per cell of volume `V`) about `A |e| / V` times, times the mean of its
//! normal's cosine to them, which the coarse count measures. Dual contouring makes one
//! quad per crossing edge along x, y or z and about as many vertices (Euler: `V = F +
//! χ` for a closed quad mesh); marching prisms one vertex per crossing edge of the
//! prisms (x, y, z and the cubes' `+x+y` diagonal) and about two triangles per vertex.
//! Detail finer than the coarse lattice is not seen, so the meshers also check the
//! limit as they go ([`Watch`]) and stop before holding much more than it.

use crate::field::ScalarField;
use crate::polygonize::dual::count_crossings;
use crate::progress::Progress;
use crate::{Error, Result};
use glam::{UVec3, Vec3};

/// The two meshers of fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mesher {
    /// [`crate::polygonize::dual`]: quads on the interval-culled octree.
    Dual,
    /// [`crate::polygonize::grid`]: triangles by marching prisms on the whole grid.
    Grid,
}

/// The memory limit of a field mesh when the caller gives none: 4 GB, what a
/// workstation running Blender can spare without swapping.
pub const DEFAULT_MAX_BYTES: u64 = 4_000_000_000;

/// Cells along the longest side of the lattice [`estimate`] counts on (fewer where the
/// mesh asked for has fewer; then the count is exact). Not from a paper: on the
/// estimate tests' trees, 64 sees features down to a few hundredths of the box and
/// costs a few milliseconds; 32 missed the 20-node tree's thinnest segments.
pub const ESTIMATE_RESOLUTION: u32 = 64;

/// Bytes a live block of the dual mesher holds however little surface it has (its
/// cells' first vertex and corner signs, the block itself, its place in the lists and
/// the contouring's index): the descent stops when the blocks it kept would pass the
/// limit.
pub(crate) const BYTES_PER_BLOCK: u64 = 600;

/// Bytes per output vertex and per face at the mesher's peak (the binding's arrays
/// made from the mesh take less). Measured with a counting allocator on a sphere, a
/// torus, the 20-node tree and a displaced sphere at 64 to 512 cells: the dual mesher
/// held 183-230 bytes per quad with its blocks, the grid mesher 141-203 per vertex
/// with its planes; rounded up (`tests/estimate_memory.rs` keeps the model within
/// 0.8x-2x of the measured peak).
const DUAL_BYTES_PER_VERTEX: u64 = 110;
const DUAL_BYTES_PER_QUAD: u64 = 90;
const GRID_BYTES_PER_VERTEX: u64 = 110;
const GRID_BYTES_PER_TRIANGLE: u64 = 20;
/// Bytes per lattice point of a plane that a slab of the grid mesher holds while
/// marching (two planes of values, two of vertex slots, the points, the culling's
/// flags); one slab per thread is in flight.
const GRID_BYTES_PER_PLANE_POINT: u64 = 64;

/// What a long meshing checks as it goes: the progress it reports to and whose cancel
/// it obeys, and the most bytes it may hold.
#[derive(Debug, Clone, Copy, Default)]
pub struct Watch<'a> {
    pub progress: Option<&'a Progress>,
    /// Past this many bytes (by [`Estimate`]'s model, from what was made so far) the
    /// build stops with an error naming the limit; `None`: no limit.
    pub max_bytes: Option<u64>,
}

impl Watch<'_> {
    pub fn is_cancelled(&self) -> bool {
        self.progress.is_some_and(Progress::is_cancelled)
    }
    /// `Err(Cancelled)` once cancelling was asked for.
    pub fn check(&self) -> Result<()> {
        self.progress.map_or(Ok(()), Progress::check)
    }
    pub(crate) fn start(&self, total: usize) {
        if let Some(p) = self.progress {
            p.start(total);
        }
    }
    pub(crate) fn advance(&self, n: usize) {
        if let Some(p) = self.progress {
            p.advance(n);
        }
    }
}

/// A field mesh's size, estimated before meshing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub mesher: Mesher,
    pub resolution: u32,
    /// The cells of the mesh asked for, and of the lattice counted.
    pub cells: UVec3,
    pub counted_cells: UVec3,
    pub vertices: u64,
    /// Quads ([`Mesher::Dual`]) or triangles ([`Mesher::Grid`]).
    pub faces: u64,
    pub triangles: u64,
    /// The most bytes the mesher is expected to hold at once, output included.
    pub peak_bytes: u64,
}

/// Estimates the mesh of `field` in `bounds` at `resolution` cells along the longest
/// side by `mesher` (see the [module docs](self)): bad boxes and resolutions are the
/// meshers' own errors, a field that is not a number where sampled too.
pub fn estimate<F: ScalarField + ?Sized>(field: &F, bounds: (Vec3, Vec3), resolution: u32, mesher: Mesher) -> Result<Estimate> {
    let (step, cells, _) = crate::polygonize::grid::cells_for(bounds, resolution)?;
    let coarse = count_crossings(field, bounds, resolution.min(ESTIMATE_RESOLUTION), &Watch::default())?;
    // Crossings of a family of parallel edges `e`, one per cell: about `A |e| / V`.
    let density = |step: Vec3, e: UVec3| f64::from((e.as_vec3() * step).length()) / f64::from(step.x * step.y * step.z);
    let scaled: Vec<f64> =
        coarse.edges.iter().zip(super::dual::Crossings::DIRECTIONS).map(|(&n, e)| n as f64 * density(step, e) / density(coarse.step, e)).collect();
    let area_ratio = f64::from(cells.max_element()) / f64::from(coarse.cells.max_element());
    let live_blocks = (coarse.live_blocks as f64 * area_ratio * area_ratio).round() as u64;
    let (vertices, faces, triangles) = match mesher {
        Mesher::Dual => {
            let quads = (scaled[0] + scaled[1] + scaled[2]).round() as u64;
            (quads, quads, 2 * quads)
        }
        Mesher::Grid => {
            let vertices = scaled.iter().sum::<f64>().round() as u64;
            (vertices, 2 * vertices, 2 * vertices)
        }
    };
    let peak_bytes = peak_bytes(mesher, cells, live_blocks, vertices, faces);
    Ok(Estimate { mesher, resolution, cells, counted_cells: coarse.cells, vertices, faces, triangles, peak_bytes })
}

/// Refuses a build whose estimate passes `max_bytes` (see [`Estimate::check`]) before
/// anything big is made. Skips the estimate, returning `None`, where even a surface
/// through every cell of the lattice would fit.
pub fn check_fits<F: ScalarField + ?Sized>(field: &F, bounds: (Vec3, Vec3), resolution: u32, mesher: Mesher, max_bytes: u64) -> Result<Option<Estimate>> {
    let (_, cells, _) = crate::polygonize::grid::cells_for(bounds, resolution)?;
    let every_cell = u64::from(cells.x) * u64::from(cells.y) * u64::from(cells.z);
    let every_block = every_cell.div_ceil(u64::from(crate::polygonize::dual::BLOCK).pow(3));
    // Every cell crossed along all its x, y and z (and diagonal) edges.
    let worst = match mesher {
        Mesher::Dual => peak_bytes(mesher, cells, every_block, 3 * every_cell, 3 * every_cell),
        Mesher::Grid => peak_bytes(mesher, cells, 0, 4 * every_cell, 8 * every_cell),
    };
    if worst <= max_bytes {
        return Ok(None);
    }
    let e = estimate(field, bounds, resolution, mesher)?;
    e.check(max_bytes)?;
    Ok(Some(e))
}

/// The bytes a mesher holds at its peak for an output of `vertices` and `faces`, on
/// a lattice of `cells` with `live_blocks` blocks kept by the dual mesher's descent.
pub(crate) fn peak_bytes(mesher: Mesher, cells: UVec3, live_blocks: u64, vertices: u64, faces: u64) -> u64 {
    match mesher {
        Mesher::Dual => live_blocks * BYTES_PER_BLOCK + vertices * DUAL_BYTES_PER_VERTEX + faces * DUAL_BYTES_PER_QUAD,
        Mesher::Grid => {
            let plane = u64::from(cells.x + 1) * u64::from(cells.y + 1);
            let slabs = u64::from(cells.z.div_ceil(crate::polygonize::grid::SLAB));
            let in_flight = slabs.min(rayon::current_num_threads() as u64);
            in_flight * plane * GRID_BYTES_PER_PLANE_POINT + vertices * GRID_BYTES_PER_VERTEX + faces * GRID_BYTES_PER_TRIANGLE
        }
    }
}

/// `n` in a short form: 950, 12.3 k, 4.56 M.
fn count(n: u64) -> String {
    match n {
        0..1_000 => n.to_string(),
        1_000..1_000_000 => format!("{:.1} k", n as f64 / 1e3),
        _ => format!("{:.2} M", n as f64 / 1e6),
    }
}

fn gigabytes(bytes: u64) -> String {
    format!("{:.2} GB", bytes as f64 / 1e9)
}

/// The error of a build stopped at the memory limit `limit`; `what` says what it had
/// seen.
pub(crate) fn over_limit(limit: u64, what: &str) -> Error {
    Error::OverLimit(format!("the field mesh would pass the memory limit of {} ({what}, more than the estimate saw): use fewer cells", gigabytes(limit)))
}

impl Estimate {
    /// About the most cells along the longest side whose mesh fits in `max_bytes`, by
    /// this estimate (memory grows about as the square of the resolution; a tenth
    /// kept in hand): at least 2, at most [`MAX_RESOLUTION`](crate::polygonize::grid::MAX_RESOLUTION),
    /// and not below this resolution where it fits.
    pub fn resolution_within(&self, max_bytes: u64) -> u32 {
        let r = f64::from(self.resolution) * (max_bytes as f64 / self.peak_bytes.max(1) as f64).sqrt() * 0.9;
        let r = (r.floor() as u32).clamp(2, crate::polygonize::grid::MAX_RESOLUTION);
        if self.peak_bytes <= max_bytes {
            r.max(self.resolution)
        } else {
            r
        }
    }

    /// `Ok` where the peak fits in `max_bytes`, else an error naming the estimate, the
    /// limit and a resolution that fits.
    pub fn check(&self, max_bytes: u64) -> Result<()> {
        if self.peak_bytes <= max_bytes {
            return Ok(());
        }
        let (faces, what) = match self.mesher {
            Mesher::Dual => (self.faces, "quads"),
            Mesher::Grid => (self.faces, "triangles"),
        };
        Err(Error::OverLimit(format!(
            "resolution {} ({}x{}x{} cells) would make about {} vertices and {} {what} and need about {} at its peak, over the memory limit of {}: use about {} cells or fewer",
            self.resolution,
            self.cells.x,
            self.cells.y,
            self.cells.z,
            count(self.vertices),
            count(faces),
            gigabytes(self.peak_bytes),
            gigabytes(max_bytes),
            self.resolution_within(max_bytes)
        )))
    }
}

#[cfg(test)]
#[path = "estimate_tests.rs"]
mod tests;
