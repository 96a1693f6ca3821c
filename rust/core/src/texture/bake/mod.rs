//! Bake to geometry: the `alpha = 0.5` iso-surface of the texture over the whole shell
//! as one mesh (chapter 3: the thick surface's detailed surface).
//!
//! - [`lattice`]: every cell (a triangle prism; quads and n-gons are triangulated) is
//!   sampled on a lattice numbered globally so neighbouring cells share samples. Its
//!   steps follow the texture (chapter 3.2: the texture is the detail, so the bake
//!   samples it at its own texel spacing), at least `resolution` per base edge and
//!   `depth_steps` along the directors.
//! - [`bounds`]: where the occupancy cannot reach the iso-level, whole blocks of the
//!   lattice are skipped, so sampling that fine costs only where the surface is.
//! - [`occupancy`]: the occupancy sampled there: textures united, then the stack's
//!   [`effects`] (partial regions blended with a base slab, figure 3.3; a moved
//!   region and holes, chapter 7), which the renderers apply alike.
//! - [`polygonize`]: marching prisms, one cell at a time, through the shared prism,
//!   crossing and weld of [`crate::polygonize`] (iso-vertices shared by cells are
//!   joined through their lattice-edge keys).
//! - [`cutter`] and [`uv_mask`]: a closed mesh's inside, and a vertex group in `(s, t)`.
//!
//! Shared samples, conforming splits and edge keys make the result free of cracks and
//! duplicated vertices. The shell's own boundary (base layer, outer layer, walls along
//! open mesh edges) is sampled as outside, so every baked surface is closed. Normals
//! come from the field's gradient carried to world space by each cell's map.

mod bounds;
pub mod cutter;
pub mod effects;
mod hierarchy;
mod lattice;
mod occupancy;
mod polygonize;
mod simplify;
mod split;
mod uv_mask;

use super::mapping::{CellMap, TextureCoordinates, TriangleCells};
use super::TextureLayer;
use crate::mesh::face_windings;
use crate::polygonize::weld::{weld, Piece};
use crate::progress::Progress;
use crate::shell::Shell;
use crate::{Error, Mesh, Result};
use bounds::MaxPyramid;
pub use cutter::Cutter;
pub use effects::{Effects, Site};
use glam::{Vec2, Vec3};
use lattice::Lattice;
use occupancy::Occupancy;
use polygonize::{Cells, Margins, Scratch};
use rayon::prelude::*;
use std::collections::HashMap;

/// Bake settings.
#[derive(Debug, Clone)]
pub struct BakeParams {
    /// Lattice steps along each base edge of a cell, at least (see `follow_texture`).
    pub resolution: u32,
    /// Lattice steps along the directors, at least.
    pub depth_steps: u32,
    /// Refine the lattice to the texture's own texel spacing (up to [`MAX_STEPS`] per
    /// cell edge and across the shell), so features as thin as a texel survive.
    /// Off: exactly `resolution` and `depth_steps` steps (a quick, coarse bake).
    pub follow_texture: bool,
    /// UV tiling factor.
    pub tiling: f32,
    /// Where the texture exists (figure 3.3), per vertex in `[0, 1]`; elsewhere the
    /// base surface shows as a thin slab, blended smoothly in between. `None`: everywhere.
    pub region: Option<Vec<f32>>,
    /// Thickness of that base slab as a fraction of the shell (at least 1.5 layers).
    pub base_layer: f32,
    /// Holes (chapter 7.3): per vertex in `[0, 1]`, the texture is zeroed where 1.
    pub holes: Option<Vec<f32>>,
    /// Holes inside a closed mesh, given in the base mesh's coordinates.
    pub cutter: Option<Cutter>,
    /// A texture region moved along the surface (chapter 7.2).
    pub moved: Option<MovedRegion>,
    /// Counts the cells baked, and stops the bake when cancelled.
    pub progress: Option<std::sync::Arc<Progress>>,
    /// Simplify toward this many triangles (each cell its share), moving the surface
    /// by [`SIMPLIFY_ERROR`] lattice steps, then by the larger [`SIMPLIFY_ERRORS`] where
    /// a cell is still over its share ([`THIN_SIMPLIFY_ERROR`] only, for textures with
    /// thin features); 0: no simplification. A result still over the budget says so
    /// ([`BakedMesh::over_budget`]).
    pub triangle_budget: usize,
    /// The most triangles the lattice may sample before simplification (the bake's
    /// work): a texture-following lattice is coarsened to stay under it (the result
    /// then says the texture is finer than the lattice); a bake over it even at
    /// `resolution` steps is refused.
    pub max_triangles: usize,
}

/// The piece of texture inside `weights` (per vertex in `[0, 1]`) shifted by `offset`
/// in UV units; the trace it leaves shows the base surface. Needs a UV map.
#[derive(Debug, Clone)]
pub struct MovedRegion {
    pub weights: Vec<f32>,
    pub offset: Vec2,
}

impl Default for BakeParams {
    fn default() -> Self {
        Self {
            resolution: 8,
            depth_steps: 16,
            follow_texture: true,
            tiling: 1.0,
            region: None,
            base_layer: 0.1,
            holes: None,
            cutter: None,
            moved: None,
            progress: None,
            triangle_budget: 1_000_000,
            max_triangles: 20_000_000,
        }
    }
}

/// The baked surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BakedMesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub normals: Vec<Vec3>,
    /// `(s, t, r)` of each vertex (where cells meet, the first cell's).
    pub texcoords: Vec<Vec3>,
    /// `(s, t, r)` of each triangle corner, in its own cell: across UV seams and tile
    /// edges each side keeps its own, as a UV map needs.
    pub corner_texcoords: Vec<[Vec3; 3]>,
    /// The base mesh face each triangle grew from (its cell's face).
    pub source_face: Vec<u32>,
    /// True when the mesh had no UVs and each face got its own tile.
    pub per_face_tiles: bool,
    /// Lattice steps used: per cell edge, and across the shell.
    pub lattice: [u32; 2],
    /// True when the lattice is coarser than the texture on many cells (beyond
    /// [`MAX_STEPS`], or coarsened to `max_triangles`): thin features may be lost.
    pub texture_finer_than_lattice: bool,
    /// True when the result has more triangles than the budget (beyond
    /// [`SHARE_TOLERANCE`]): the largest error allowed, `simplify_error`, stopped the
    /// simplification.
    pub over_budget: bool,
    /// The largest error the simplification may use, in lattice steps
    /// ([`simplify_errors`]).
    pub simplify_error: f32,
}

/// How far simplification may move the surface, in lattice steps, at first.
pub const SIMPLIFY_ERROR: f32 = 0.25;

/// The errors, in lattice steps, with which a cell still over its share of the budget
/// is simplified further, in turn ([`simplify_errors`]): the silhouette of textures
/// without thin features (features two texels or more across, a step per texel)
/// survives a step. Not from the paper: chosen with `bake_fidelity` (320-face head, default
/// budget; triangles and IoU close / grazing at a quarter step, then with these):
/// weave 2.16 M, 1.000 / 1.000 to 1.32 M, 1.000 / 1.000; chain mail 1.09 M, 0.989 /
/// 0.991 to 1.03 M, 0.988 / 0.991. Raising the error alone, from the lattice's piece,
/// gave weave 1.68 M at half a step and 1.42 M at one; chain mail's cells still over
/// their share kept the same triangles at every error up to two steps: what they keep
/// are their locked rims.
pub const SIMPLIFY_ERRORS: [f32; 3] = [SIMPLIFY_ERROR, 0.5, 1.0];

/// [`SIMPLIFY_ERROR`] for textures with thin features ([`THIN_SHARE`]). Not from the
/// paper: quadric collapse within a bound shrinks a strand's cross-section toward an
/// inscribed polygon with sides that cut up to the bound inside, so strands one or
/// two lattice steps wide lose width. Chosen with `bake_fidelity` (converged
/// reference, aligned 128-step lattice, default budget), IoU close / grazing and triangles:
/// fur 0.942 / 0.951 and 1.66 M at 0.25, 0.950 / 0.958 and 1.92 M at 0.175,
/// 0.953 / 0.961 and 2.07 M at 0.15, 0.955 / 0.964 and 2.28 M at 0.125 (0.967 / 0.973
/// unsimplified); grass 0.960 / 0.968 and 1.84 M at 0.25, 0.964 / 0.972 and 2.55 M at 0.15.
pub const THIN_SIMPLIFY_ERROR: f32 = 0.15;

/// The most lattice steps the bake refines to, per cell edge and across the shell
/// (one tile per face of a 64-texel texture with thin features asks for 181, and takes
/// the aligned 128, [`aligned_steps`]).
pub const MAX_STEPS: u32 = 192;

/// Share of thin texels ([`bounds::thin_share`]) above which the lattice takes two
/// steps per texel. Not from the paper: chosen between grass (0.14) and chain mail
/// (0.007) with `bake_fidelity` (fur: IoU 0.85 at one step per texel, 0.93 at two; grass 0.93, 0.95;
/// with iso-vertices on the crossing and two layers per slice, fur 0.94, grass 0.97;
/// these against the reference marched at 1% of the shell, which misses thin strands).
const THIN_SHARE: f32 = 0.05;

/// Share of thin texels above which a lattice not aligned with the texel centres
/// ([`aligned_steps`]) takes four steps per texel instead of two: between such
/// points a one-texel strand is cut to a diamond inside its trilinear 0.5 level.
/// Not from the paper: shares at 32 x 32 x 16 and 64 x 64 x 32, fur 0.99 and 0.70,
/// grass 0.57 and 0.14, chain mail 0.093 and 0.007, the others under 0.02; chain mail
/// at 32 (rings a few texels across) stays at two. Spot (5.8 k faces, UV map, tiling 4,
/// fur, IoU close / grazing against the converged reference, the add-on's default
/// budget): 0.927 / 0.929 at two steps per texel, 0.943 / 0.944 at three (measured
/// unsimplified), 0.950 / 0.951 at four (1.25 M triangles).
const STRANDS_SHARE: f32 = 0.12;

/// How close, in lattice steps, a lattice point must come to a texel centre to count
/// as on it ([`aligned_steps`]): far below any feature, far above `f32` rounding.
const ALIGNED_TOLERANCE: f64 = 1e-3;

/// The most lattice samples (points times layers) of one cell: its buffers (values,
/// ids, gradients, eight iso-vertex slots) take about 70 bytes a sample, about
/// 140 MiB per worker thread at most.
const MAX_CELL_SAMPLES: usize = 1 << 21;

impl BakeParams {
    /// The checks every bake and estimate makes before any work: settings in range,
    /// per-vertex weights that fit `mesh`, a shell that belongs to it, a texture.
    pub(crate) fn check(&self, mesh: &Mesh, shell: &Shell, textures: &[TextureLayer]) -> Result<()> {
        mesh.require_faces()?;
        if textures.is_empty() {
            return Err(Error::InvalidParameter("no texture to bake".into()));
        }
        if shell.directors.len() != mesh.vertex_count() {
            return Err(Error::InvalidParameter("the shell does not belong to this mesh".into()));
        }
        if !(1..=64).contains(&self.resolution) || !(2..=256).contains(&self.depth_steps) {
            return Err(Error::InvalidParameter("resolution must be in 1..=64 and depth_steps in 2..=256".into()));
        }
        if !(self.tiling > 0.0 && self.tiling.is_finite()) {
            return Err(Error::InvalidParameter("tiling must be a positive number".into()));
        }
        if !self.base_layer.is_finite() {
            return Err(Error::InvalidParameter("base_layer must be a finite number".into()));
        }
        let n_vertices = mesh.vertex_count();
        let weights = [("region", self.region.as_deref()), ("holes", self.holes.as_deref()), ("moved region", self.moved.as_ref().map(|m| &m.weights[..]))];
        for (what, w) in weights {
            if w.is_some_and(|w| w.len() != n_vertices || w.iter().any(|x| !x.is_finite())) {
                return Err(Error::InvalidParameter(format!("{what} weights: one finite value per vertex")));
            }
        }
        if self.moved.as_ref().is_some_and(|m| !m.offset.is_finite()) {
            return Err(Error::InvalidParameter("the moved region's offset must be finite".into()));
        }
        Ok(())
    }
}

/// What a bake and its estimate share: the checked settings' lattice, the stack's
/// effects and the textures' bounds, from which the [`Occupancy`] is made.
struct Setup {
    coords: TextureCoordinates,
    lattice: Lattice,
    effects: Effects,
    bounds: Vec<MaxPyramid>,
    /// Heights `r` of the lattice's layers (from 0 to 1), and steps per block edge.
    heights: Vec<f32>,
    block: u32,
    texture_finer_than_lattice: bool,
    /// Steps per block: the lattice has `resolution * block` steps per cell edge.
    resolution: u32,
    /// How far simplification may move the surface, in lattice steps: each tried in
    /// turn while a cell is over its share ([`simplify_errors`]).
    simplify_errors: &'static [f32],
    /// Per cell: its triangles are reversed ([`cell_flips`]).
    flips: Vec<bool>,
    /// How far iso-vertices keep off the lattice points ([`Margins`]).
    margins: Margins,
}

/// The lattice of a bake: steps per cell edge, heights, culling blocks.
struct Steps {
    /// Steps per cell edge (`resolution * block`).
    n: u32,
    /// Heights `r` of the layers, from 0 to 1.
    heights: Vec<f32>,
    /// Steps per block edge.
    block: u32,
    /// The texture is finer than the lattice on many cells.
    finer: bool,
    /// A texture has many features one texel wide ([`THIN_SHARE`]).
    thin: bool,
}

/// The lattice for the cells with corner coordinates `st`. Following the texture, a
/// cell edge gets a step per texel it spans, two for textures with thin features (the
/// 90th percentile over cells, so a few huge cells do not inflate every cell), rounded
/// up to a multiple of `resolution`, whose steps become the culling blocks; where a
/// lattice of at most that many steps has a point on every texel centre
/// ([`aligned_steps`]), the finest such instead, and where none is, four steps per
/// texel for strands ([`STRANDS_SHARE`]); the layers lie on the texture's slices
/// ([`texel_layers`]). A cell's lattice stays under [`MAX_CELL_SAMPLES`].
fn lattice_steps(st: &[[Vec2; 3]], textures: &[TextureLayer], params: &BakeParams) -> Steps {
    let (n0, m0) = (params.resolution, params.depth_steps);
    let uniform = |m: u32| (0..=m).map(|l| l as f32 / m as f32).collect::<Vec<f32>>();
    if !params.follow_texture || st.is_empty() {
        return Steps { n: n0, heights: uniform(m0), block: 1, finer: false, thin: false };
    }
    // Steps per texel: two where a texture has many features one texel wide, four
    // for strands off an aligned lattice.
    let (span, share) = texel_span(st, textures);
    let thin = share > THIN_SHARE;
    let heights = texel_layers(textures, m0, if thin { 2 } else { 1 });
    let points = |n: u32| (n as usize + 1) * (n as usize + 2) / 2;
    let blocks = |span: f32| ((span / n0 as f32).ceil() as u32).clamp(1, (MAX_STEPS / n0).max(1));
    let mut block = blocks(span);
    if let Some(period) = aligned_steps(st, textures, n0, n0 * block) {
        block = period * (n0 * block / period) / n0;
    } else if share > STRANDS_SHARE {
        block = blocks(span * 2.0);
    }
    while block > 1 && points(n0 * block) * heights.len() > MAX_CELL_SAMPLES {
        block -= 1;
    }
    let finer = span > (n0 * block) as f32 * 1.5;
    Steps { n: n0 * block, heights, block, finer, thin }
}

/// The steps per edge a texture-following lattice wants on the cells with corner
/// coordinates `st` before [`aligned_steps`] ([`lattice_steps`]: the 90th percentile of
/// the texels a cell's longest edge spans, times the steps per texel of a texture with
/// thin features), and the textures' share of thin texels ([`bounds::thin_share`]).
fn texel_span(st: &[[Vec2; 3]], textures: &[TextureLayer]) -> (f32, f32) {
    let share = textures.iter().map(|l| bounds::thin_share(&l.texture)).fold(0.0, f32::max);
    let texels = textures.iter().map(|l| l.texture.dims()).fold(Vec2::ZERO, |a, [x, y, _]| a.max(Vec2::new(x as f32, y as f32)));
    let mut spans: Vec<f32> = st.iter().map(|c| (0..3).map(|k| ((c[(k + 1) % 3] - c[k]) * texels).length()).fold(0.0, f32::max)).collect();
    if spans.is_empty() {
        return (0.0, share);
    }
    let at = (spans.len() * 9 / 10).min(spans.len() - 1);
    let (_, span, _) = spans.select_nth_unstable_by(at, f32::total_cmp);
    (if span.is_finite() { *span } else { 0.0 } * if share > THIN_SHARE { 2.0 } else { 1.0 }, share)
}

/// The steps per edge a texture-following lattice wants on the cells of `mesh` (four
/// per texel for strands: a mesh with a UV map has no aligned lattice,
/// [`aligned_steps`]); 0 where a face's lattice never needs more than [`MAX_STEPS`]
/// (one tile per face, or a fixed lattice).
fn wanted_steps(mesh: &Mesh, textures: &[TextureLayer], params: &BakeParams) -> f64 {
    if !params.follow_texture || mesh.uvs().is_none() {
        return 0.0;
    }
    let cells = TriangleCells::new(mesh, &TextureCoordinates::of(mesh, params.tiling));
    let (span, share) = texel_span(&cells.st, textures);
    span as f64 * if share > STRANDS_SHARE { 2.0 } else { 1.0 }
}

/// The base split for a bake of `params` ([`split`]), once they are checked: halved
/// until a cell's lattice of at most [`MAX_STEPS`] per edge takes the steps the
/// texture wants, or as many as `max_triangles` leave room for (the lattice's
/// triangles grow with the square of its steps: the unsplit bake's count says how
/// many more fit). `None` where the lattice needs no split.
fn split_base(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<Option<split::Split>> {
    params.check(mesh, shell, textures)?;
    let wanted = wanted_steps(mesh, textures, params);
    if wanted <= MAX_STEPS as f64 {
        return Ok(None);
    }
    let (setup, sample) = fitted_setup(mesh, shell, textures, params, FULL)?;
    let sampled = sample.sampled();
    let room = setup.lattice.n as f64 * (params.max_triangles as f64 / sampled.max(1) as f64).sqrt();
    let steps = wanted.min(room);
    let levels = (0..8).find(|&k| steps <= (MAX_STEPS << k) as f64).unwrap_or(8);
    split::split(mesh, shell, params, levels)
}

/// The fewest steps per cell edge, a multiple of `n0` up to `most`, with which every
/// cell's lattice has a point on every texel centre of every texture (where
/// [`VolumeTexture::sample`] puts the texels), if any; its multiples have too. There
/// the trilinear occupancy has its peaks, so nothing that holds a texel centre is
/// lost, and it is linear along the lattice's `u` and `v` edges where those follow
/// the texture's axes (one tile per face: the edges along the tile's sides), so their
/// iso-vertices are exact. Cells whose texture coordinates are degenerate are left
/// out. Not from the paper: found with `bake_fidelity` (fur's unsimplified bake against
/// the converged reference, IoU close / grazing: 0.933 / 0.932 at 160 steps per edge
/// and 0.926 / 0.925 at 192, neither aligned; 0.967 / 0.973 at 128 and 0.970 / 0.975 at
/// 256, aligned, with fewer triangles at 128: 17.1 M against 18.7 M at 160).
fn aligned_steps(st: &[[Vec2; 3]], textures: &[TextureLayer], n0: u32, most: u32) -> Option<u32> {
    // Per cell and texture: the texel grid's unit steps and one texel centre in the
    // cell's (u, v), which times `n` must be whole numbers.
    let grids: Vec<[f64; 6]> = st
        .par_iter()
        .flat_map_iter(|c| {
            textures.iter().filter_map(move |l| {
                let [nx, ny, _] = l.texture.dims();
                let texel = |p: Vec2| glam::DVec2::new(p.x as f64 * nx as f64, p.y as f64 * ny as f64);
                let (s0, e1, e2) = (texel(c[0] + l.offset), texel(c[1] - c[0]), texel(c[2] - c[0]));
                let det = e1.perp_dot(e2);
                if !(det.abs() > 1e-9 * e1.length() * e2.length()) {
                    return None;
                }
                // [e1 e2]^-1 of a texel step along s, along t, and to a texel centre.
                let inverse = |d: glam::DVec2| glam::DVec2::new(d.perp_dot(e2), e1.perp_dot(d)) / det;
                let to_centre = glam::DVec2::splat(0.5) - s0;
                let (a, b, c) = (inverse(glam::DVec2::X), inverse(glam::DVec2::Y), inverse(to_centre - to_centre.round()));
                Some([a.x, a.y, b.x, b.y, c.x, c.y])
            })
        })
        .collect();
    let whole = |x: f64| (x - x.round()).abs() <= ALIGNED_TOLERANCE;
    (1..=most / n0.max(1)).map(|k| k * n0).find(|&n| grids.par_iter().all(|g| g.iter().all(|x| whole(x * n as f64))))
}

/// Texels of a moved region's mask along the longer side of the `(s, t)` box, for
/// `cells` cells sampled with `n` steps per edge.
fn mask_resolution(cells: usize, n: u32) -> usize {
    ((cells as f32).sqrt() as usize * n as usize * 2).clamp(256, 4096)
}

/// The stack's effects as the bake applies them ([`Effects`]), for anything else that
/// shows the textured shell (the renderers): the same cells, layers across the shell
/// and moved-region mask as a bake of `params`.
pub fn effects(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<Effects> {
    let (_, cells) = checked_cells(mesh, shell, textures, params)?;
    let steps = lattice_steps(&cells.st, textures, params);
    Ok(Effects::new(&cells.triangles, &cells.st, params, shell, steps.heights.len() - 1, mask_resolution(cells.triangles.len(), steps.n)))
}

/// The bake's cells and their texture coordinates, once `params` are checked.
fn checked_cells(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<(TextureCoordinates, TriangleCells)> {
    params.check(mesh, shell, textures)?;
    let coords = TextureCoordinates::of(mesh, params.tiling);
    if params.moved.is_some() && coords.per_face_tiles {
        return Err(Error::InvalidParameter("moving a texture region needs a UV map".into()));
    }
    let cells = TriangleCells::new(mesh, &coords);
    Ok((coords, cells))
}

/// Layer heights on the slices `k / (depth - 1)` of the deepest texture (where
/// [`VolumeTexture::sample`] puts them: the first and last on the shell's faces), so the
/// trilinear occupancy is linear in `r` between layers and nothing one slice thick is
/// lost across the shell; each interval split evenly so there are at least `m0`
/// (uniform when that would exceed [`MAX_STEPS`]), and `per_slice` times where that
/// fits under it. Within a
/// prism the trilinear iso-surface is curved even where it is linear in `r`, so thin
/// features that lean between slices need the split as much as a finer `(u, v)`.
fn texel_layers(textures: &[TextureLayer], m0: u32, per_slice: u32) -> Vec<f32> {
    let intervals = textures.iter().map(|l| l.texture.dims()[2] as u32).max().unwrap_or(2).max(2) - 1;
    let split = m0.div_ceil(intervals).max(1);
    if intervals * split > MAX_STEPS {
        return (0..=MAX_STEPS).map(|l| l as f32 / MAX_STEPS as f32).collect();
    }
    // More layers per slice only while they fit: the slices themselves come first.
    let split = split.max(per_slice.min(MAX_STEPS / intervals));
    let steps = intervals * split;
    (0..=steps).map(|l| l as f32 / steps as f32).collect()
}

impl Setup {
    fn new(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<Self> {
        let (coords, cells) = checked_cells(mesh, shell, textures, params)?;
        let Steps { n, heights, block, finer, thin } = lattice_steps(&cells.st, textures, params);
        let lattice = Lattice::new(mesh, cells, n);
        let effects = Effects::new(&lattice.tris, &lattice.st, params, shell, heights.len() - 1, mask_resolution(lattice.tris.len(), n));
        let bounds = textures.iter().map(|l| MaxPyramid::new(&l.texture)).collect();
        let simplify_errors = simplify_errors(thin, finer);
        let flips = cell_flips(mesh, shell, &lattice.tris, &lattice.faces);
        let margins = Margins::new(mesh, shell, &lattice.tris, &heights);
        Ok(Self {
            coords,
            lattice,
            effects,
            bounds,
            heights,
            block,
            texture_finer_than_lattice: finer,
            resolution: params.resolution,
            simplify_errors,
            flips,
            margins,
        })
    }

    /// The same setup with `block` steps per block edge (a coarser lattice): the
    /// texture is then finer than the lattice.
    fn with_block(self, mesh: &Mesh, block: u32) -> Self {
        let cells = TriangleCells { triangles: self.lattice.tris, st: self.lattice.st, faces: self.lattice.faces };
        let lattice = Lattice::new(mesh, cells, self.resolution * block);
        // A step now spans several texels: only the first error keeps the silhouette.
        Self { lattice, block, texture_finer_than_lattice: true, simplify_errors: &self.simplify_errors[..1], ..self }
    }

    fn field<'a>(&'a self, textures: &'a [TextureLayer]) -> Occupancy<'a> {
        Occupancy { layers: textures, effects: &self.effects, heights: &self.heights, bounds: &self.bounds }
    }

    fn cells<'a>(&'a self, mesh: &'a Mesh, shell: &'a Shell, field: &'a Occupancy<'a>, cull: bool) -> Cells<'a> {
        Cells { mesh, shell, lattice: &self.lattice, field, heights: &self.heights, block: self.block, cull, flips: &self.flips, margins: &self.margins }
    }
}

/// Which cells' triangles are reversed: those whose map from `(u, v, r)` to the world
/// reverses orientation, decided for each patch of consistently wound faces as a whole
/// ([`face_windings`]): the sign of the sum over its cells of the map's Jacobian at
/// their centres, times each face's winding (a patch pressed flat: its shell's side).
/// One cell's own Jacobian is not enough:
/// a triangle of a folded quad can have a director leaning under it (a valid shell
/// still; its neighbour across the quad's diagonal does not) and reversing it alone
/// walks the edges on their common side the same way (Suzanne's cheek, 8-40 edges).
pub(super) fn cell_flips(mesh: &Mesh, shell: &Shell, triangles: &[[u32; 3]], faces: &[u32]) -> Vec<bool> {
    let windings = face_windings(mesh);
    let centre = Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.5);
    let signed: Vec<(u32, f64)> = triangles
        .par_iter()
        .zip(faces)
        .map(|(t, &f)| {
            let det = CellMap::new(mesh, shell, t, &[Vec2::ZERO; 3]).jacobians(centre).0.determinant() as f64;
            (windings.patch[f as usize], det * windings.sign[f as usize] as f64)
        })
        .collect();
    let (mut total, mut size) = (vec![0.0f64; windings.patches], vec![0.0f64; windings.patches]);
    signed.iter().for_each(|&(patch, det)| {
        total[patch as usize] += det;
        size[patch as usize] += det.abs();
    });
    // A patch pressed flat (or balanced to rounding) says nothing: its shell's side does.
    let fallback = if shell.side == crate::shell::Side::Interior { -1.0 } else { 1.0 };
    let orientation: Vec<f64> = total.iter().zip(&size).map(|(&t, &s)| if t.abs() > 1e-9 * s && s > 0.0 { t } else { fallback }).collect();
    faces.iter().map(|&f| (windings.sign[f as usize] as f64 * orientation[windings.patch[f as usize] as usize]) < 0.0).collect()
}

/// Lattice samples the estimate may take: tens of milliseconds, far below a bake.
const ESTIMATE_SAMPLES: usize = 4_000_000;

/// How many cells an estimate samples ([`Setup::picked`]): lattice samples at most,
/// and cells at most (at least 16 either way).
#[derive(Debug, Clone, Copy)]
struct Sampling {
    samples: usize,
    cells: usize,
}

/// The estimate's sampling ([`estimate_bake`]).
const FULL: Sampling = Sampling { samples: ESTIMATE_SAMPLES, cells: 512 };

/// The budget search's sampling ([`budget_scale`]): a quarter of the samples and
/// cells, about a quarter of the time. Not from the paper: fandisk (12,946 faces,
/// World-Size Tiles, 5% shell, budget 1 M) at tiles 1.5 to 6 times 1/32 of the
/// diagonal, against [`FULL`]: chain mail 0.97-1.06x its estimate, weave 0.99-1.04x,
/// in 0.25-0.35 of its CPU time.
const QUICK: Sampling = Sampling { samples: ESTIMATE_SAMPLES / 4, cells: 128 };

/// The cells an estimate samples (spread evenly over the mesh) and their pieces as
/// the lattice makes them, of `count` cells in all.
struct Sample {
    chosen: Vec<usize>,
    pieces: Vec<Piece>,
    count: usize,
}

impl Sample {
    /// The lattice's triangles over all cells, scaled from the sample's ([`Estimate::sampled`]).
    fn sampled(&self) -> usize {
        self.scaled(self.pieces.iter().map(|p| p.tris.len()).sum())
    }

    /// `made` triangles on the sample, scaled to all cells.
    fn scaled(&self, made: usize) -> usize {
        (made as f64 * self.count as f64 / self.chosen.len().max(1) as f64).ceil() as usize
    }
}

/// Patches of neighbouring cells, at least, that the estimate of a bake over its budget
/// after the cell pass simplifies as the bake's [`hierarchy`] does ([`Setup::patches`]).
const PATCHES: usize = 2;

/// The cell pass on some cells: their simplified pieces, and for each the triangles
/// its lattice made and how far its simplification moved it (world units).
struct CellPass {
    pieces: Vec<Piece>,
    made: Vec<usize>,
    moved: Vec<f32>,
}

/// What a bake makes, estimated on a sample of its cells spread evenly over the mesh
/// (so UV scales and weights vary as they do in the bake) and scaled to all cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Estimate {
    /// Triangles the lattice samples, before simplification (the bake's work).
    pub sampled: usize,
    /// Triangles of the result, after simplification to the budget.
    pub triangles: usize,
}

impl Setup {
    /// The cells `sampling` picks ([`Setup::picked`]) polygonized: the estimate's
    /// sample. Cells are skipped once `cancelled`.
    fn sample(&self, cells: &Cells, sampling: Sampling, cancelled: &(dyn Fn() -> bool + Sync)) -> Sample {
        let (count, picked) = self.picked(cells, sampling);
        let chosen: Vec<usize> = (0..picked).map(|p| p * count / picked).collect();
        let pieces = chosen.par_iter().map_init(Scratch::default, |s, &t| if cancelled() { Piece::default() } else { cells.polygonize(s, t) }).collect();
        Sample { chosen, pieces, count }
    }

    /// How many cells an estimate of `sampling` samples, of how many.
    fn picked(&self, cells: &Cells, sampling: Sampling) -> (usize, usize) {
        let count = cells.lattice.tris.len();
        let n = cells.lattice.n as usize;
        let per_cell = (n + 1) * (n + 2) / 2 * cells.heights.len();
        (count, (sampling.samples / per_cell).clamp(16, sampling.cells.max(16)).min(count))
    }

    /// Both counts of [`Estimate`]: the sample's cells (as the lattice made them),
    /// simplified as the bake simplifies them; where that leaves the bake over
    /// `budget`, the hierarchy's further share ([`Setup::hierarchy_share`]). Stops
    /// early once `cancelled` (the count is then meaningless).
    fn estimate(&self, mesh: &Mesh, shell: &Shell, cells: &Cells, budget: usize, sample: Sample, cancelled: &(dyn Fn() -> bool + Sync)) -> Estimate {
        let sampled = sample.sampled();
        if sample.chosen.is_empty() {
            return Estimate { sampled: 0, triangles: 0 };
        }
        let share = share_of(budget, sampled);
        let Sample { chosen, pieces, count } = sample;
        let simplified = self.cell_pass(mesh, shell, &chosen, pieces, share);
        let sample = Sample { chosen, pieces: Vec::new(), count };
        let triangles = sample.scaled(simplified.pieces.iter().map(|p| p.tris.len()).sum());
        if share >= 1.0 || !self.groups_free(mesh) || triangles as f64 <= budget as f64 * (1.0 + SHARE_TOLERANCE) || cancelled() {
            return Estimate { sampled, triangles };
        }
        // Every cell sampled: the sample is the bake's own cell pass.
        let picked = sample.chosen.len();
        let patches = if picked == sample.count { simplified } else { self.patches(mesh, shell, cells, picked, share) };
        let kept = self.hierarchy_share(patches, share, budget as f64 / triangles as f64, cancelled);
        Estimate { sampled, triangles: (triangles as f64 * kept).ceil() as usize }
    }

    /// The bake's cell pass on the cells `chosen` (their pieces `pieces`): each
    /// simplified to its `share` ([`Setup::simplified`]).
    fn cell_pass(&self, mesh: &Mesh, shell: &Shell, chosen: &[usize], pieces: Vec<Piece>, share: f64) -> CellPass {
        let made: Vec<usize> = pieces.iter().map(|p| p.tris.len()).collect();
        let (pieces, moved): (Vec<Piece>, Vec<f32>) = chosen
            .par_iter()
            .zip(pieces)
            .map(|(&t, piece)| {
                let (piece, level) = self.simplified(mesh, shell, t, piece, share, usize::MAX);
                (piece, self.moved(mesh, shell, t, level))
            })
            .unzip();
        CellPass { pieces, made, moved }
    }

    /// Whether grouping neighbouring cells can free any rim ([`hierarchy`]): with one
    /// tile per triangle every rim is a UV seam and stays locked (with one per quad,
    /// its two halves' common rim can go).
    fn groups_free(&self, mesh: &Mesh) -> bool {
        !self.coords.per_face_tiles || mesh.face_sizes().iter().any(|&n| n > 3)
    }

    /// The cell pass on patches of neighbouring cells, each the size of one of the
    /// hierarchy's groups ([`hierarchy::GROUP`] cells, grown breadth first through the
    /// cells' common edges from a seed; the seeds spread evenly over the cells like the
    /// estimate's sample), as many as fill about `picked` cells and at least
    /// [`PATCHES`], in patch order.
    fn patches(&self, mesh: &Mesh, shell: &Shell, cells: &Cells, picked: usize, share: f64) -> CellPass {
        let tris = &self.lattice.tris;
        let count = tris.len();
        let size = hierarchy::GROUP;
        let seeds = (picked / size).max(PATCHES);
        let mut by_edge: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        for (t, c) in tris.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (c[k], c[(k + 1) % 3]);
                by_edge.entry((a.min(b), a.max(b))).or_default().push(t as u32);
            }
        }
        let mut taken = vec![false; count];
        let mut chosen = Vec::with_capacity(seeds * size);
        for seed in (0..seeds).map(|i| i * count / seeds) {
            if taken[seed] {
                continue;
            }
            let first = chosen.len();
            taken[seed] = true;
            chosen.push(seed);
            let neighbours = |t: usize, visit: &mut dyn FnMut(usize)| {
                let c = tris[t];
                for k in 0..3 {
                    let (a, b) = (c[k], c[(k + 1) % 3]);
                    by_edge[&(a.min(b), a.max(b))].iter().for_each(|&n| visit(n as usize));
                }
            };
            hierarchy::grow_group(&mut chosen, first, size, neighbours, |n| !std::mem::replace(&mut taken[n], true));
        }
        let pieces: Vec<Piece> = chosen.par_iter().map_init(Scratch::default, |s, &t| cells.polygonize(s, t)).collect();
        self.cell_pass(mesh, shell, &chosen, pieces, share)
    }

    /// The share of its triangles the bake's [`hierarchy`] leaves, run on the cell
    /// pass `pass` (patches of neighbouring cells) with the budget the same fraction
    /// `goal` of the pass's triangles as the bake's budget is of its estimated pass.
    fn hierarchy_share(&self, pass: CellPass, share: f64, goal: f64, cancelled: &(dyn Fn() -> bool + Sync)) -> f64 {
        let CellPass { mut pieces, made, moved } = pass;
        let before: usize = pieces.iter().map(|p| p.tris.len()).sum();
        if before == 0 {
            return 1.0;
        }
        let budget = (before as f64 * goal).ceil() as usize;
        hierarchy::rounds(&mut pieces, &hierarchy::Cells { sampled: &made, error: &moved }, share, budget, SHARE_TOLERANCE, cancelled);
        pieces.iter().map(|p| p.tris.len()).sum::<usize>() as f64 / before as f64
    }

    /// The cell `t`'s smallest lattice step in world units.
    fn step(&self, mesh: &Mesh, shell: &Shell, t: usize) -> f32 {
        let c = &self.lattice.tris[t];
        let p = |v: u32| shell.point(mesh.positions(), v as usize, 0.0);
        let edge = (0..3).map(|k| p(c[k]).distance(p(c[(k + 1) % 3]))).fold(f32::MAX, f32::min) / self.lattice.n as f32;
        let thinnest = self.heights.windows(2).map(|w| w[1] - w[0]).fold(1.0, f32::min);
        let across = c.iter().map(|&v| shell.directors[v as usize].length()).fold(f32::MAX, f32::min) * thinnest;
        edge.min(across)
    }

    /// How far cell `t`'s piece moved at `level` ([`Setup::simplified`]), in world units.
    fn moved(&self, mesh: &Mesh, shell: &Shell, t: usize, level: usize) -> f32 {
        if level == 0 {
            return 0.0;
        }
        self.simplify_errors[level.min(self.simplify_errors.len()) - 1] * self.step(mesh, shell, t)
    }

    /// Cell `t`'s piece simplified to its `share` of the budget (unchanged at 1: none),
    /// with the first `levels` of the setup's errors ([`simplify_errors`]): the next one
    /// while the result is over the share (by more than [`SHARE_TOLERANCE`]), the last
    /// one's result kept. Returns the piece and its level (0: unsimplified).
    fn simplified(&self, mesh: &Mesh, shell: &Shell, t: usize, piece: Piece, share: f64, levels: usize) -> (Piece, usize) {
        let errors = &self.simplify_errors[..levels.min(self.simplify_errors.len())];
        if share >= 1.0 || piece.tris.is_empty() || errors.is_empty() {
            return (piece, 0);
        }
        let step = self.step(mesh, shell, t);
        let target = (piece.tris.len() as f64 * share).ceil() as usize;
        // Each level simplifies the previous one's result further (far fewer triangles
        // than the lattice's), by the difference to its error: the surface moves by at
        // most the sum, the level's error.
        let mut out = piece;
        let mut done = 0.0;
        for (level, &error) in errors.iter().enumerate() {
            out = simplify::simplify(out, target, (error - done) * step);
            done = error;
            if level + 1 == errors.len() || out.tris.len() as f64 <= target as f64 * (1.0 + SHARE_TOLERANCE) {
                return (out, level + 1);
            }
        }
        (out, errors.len())
    }
}

/// How far above its share a cell's simplified piece may stay before the next error
/// is tried (each part of a piece rounds its own share up), and a bake above its
/// budget before it says so ([`BakedMesh::over_budget`]).
const SHARE_TOLERANCE: f64 = 0.05;

/// The errors, in lattice steps, a cell's piece is simplified with in turn while it
/// stays over its share of the budget.
fn simplify_errors(thin: bool, finer: bool) -> &'static [f32] {
    match (thin, finer) {
        (true, _) => &[THIN_SIMPLIFY_ERROR],
        // A step spans more than a texel: the further errors could erase features.
        (false, true) => &SIMPLIFY_ERRORS[..1],
        (false, false) => &SIMPLIFY_ERRORS,
    }
}

/// The share of its triangles each cell keeps to meet `budget` (0: no budget).
fn share_of(budget: usize, sampled: usize) -> f64 {
    if budget == 0 {
        1.0
    } else {
        (budget as f64 / sampled.max(1) as f64).min(1.0)
    }
}

/// Whether `params`' progress asks to stop (never without one).
fn cancelled(params: &BakeParams) -> impl Fn() -> bool + Sync + '_ {
    || params.progress.as_deref().is_some_and(Progress::is_cancelled)
}

/// `Err(Cancelled)` where `params`' progress asks to stop.
fn check_cancelled(params: &BakeParams) -> Result<()> {
    params.progress.as_deref().map_or(Ok(()), Progress::check)
}

/// The setup whose lattice samples at most `params.max_triangles` triangles: the
/// texture-following lattice, coarsened (fewer steps per cell edge, down to
/// `resolution`) where it would sample more; an error when even that would. With the
/// sample that decided it (`sampling`'s cells), which an estimate goes on from.
fn fitted_setup(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams, sampling: Sampling) -> Result<(Setup, Sample)> {
    let mut setup = Setup::new(mesh, shell, textures, params)?;
    loop {
        let field = setup.field(textures);
        let sample = setup.sample(&setup.cells(mesh, shell, &field, true), sampling, &cancelled(params));
        check_cancelled(params)?;
        let sampled = sample.sampled();
        if sampled <= params.max_triangles {
            return Ok((setup, sample));
        }
        if setup.block == 1 {
            return Err(Error::OverLimit(format!(
                "this bake would make about {sampled} triangles, over the limit of {}; lower the tiling, resolution or texture size, or raise the limit",
                params.max_triangles
            )));
        }
        // Triangles grow with the square of the steps per edge.
        let block = ((setup.block as f64 * (params.max_triangles as f64 / sampled as f64).sqrt() * 0.95) as u32).clamp(1, setup.block - 1);
        setup = setup.with_block(mesh, block);
    }
}

/// Benchmarks only: bakes stop after the cell pass (no [`hierarchy`]), to time it alone.
#[cfg(feature = "test-support")]
pub static CELL_PASS_ONLY: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

#[cfg(feature = "test-support")]
fn cell_pass_only() -> bool {
    CELL_PASS_ONLY.load(std::sync::atomic::Ordering::Relaxed)
}

#[cfg(not(feature = "test-support"))]
fn cell_pass_only() -> bool {
    false
}

/// Bakes the iso-surface. `textures`: at least one, united.
pub fn bake(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<BakedMesh> {
    bake_culled(mesh, shell, textures, params, true)
}

pub(super) fn bake_culled(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams, cull: bool) -> Result<BakedMesh> {
    let Some(split) = split_base(mesh, shell, textures, params)? else {
        return bake_cells(mesh, shell, textures, params, cull);
    };
    let mut baked = bake_cells(&split.mesh, &split.shell, textures, &split.params, cull)?;
    baked.source_face.iter_mut().for_each(|f| *f = split.faces[*f as usize]);
    Ok(baked)
}

/// [`bake_culled`] on the cells of `mesh` as they are.
fn bake_cells(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams, cull: bool) -> Result<BakedMesh> {
    let (setup, sample) = fitted_setup(mesh, shell, textures, params, FULL)?;
    let sampled = sample.sampled();
    drop(sample);
    let field = setup.field(textures);
    let cells = setup.cells(mesh, shell, &field, cull);
    let share = share_of(params.triangle_budget, sampled);
    let progress = params.progress.as_deref();
    if let Some(p) = progress {
        p.start(setup.lattice.tris.len());
    }
    let (mut pieces, (mut levels, made)): (Vec<_>, (Vec<_>, Vec<_>)) = (0..setup.lattice.tris.len())
        .into_par_iter()
        .map_init(Scratch::default, |s, t| {
            if progress.is_some_and(Progress::is_cancelled) {
                return (Piece::default(), (0, 0));
            }
            let piece = cells.polygonize(s, t);
            let made = piece.tris.len();
            let (piece, level) = setup.simplified(mesh, shell, t, piece, share, usize::MAX);
            if let Some(p) = progress {
                p.step();
            }
            (piece, (level, made))
        })
        .unzip();
    if let Some(p) = progress {
        p.check()?;
    }
    // Simplified pieces whose triangles cross a neighbour's are made again with one
    // error fewer (the last: the lattice's own); each round lowers at least one, so
    // this ends.
    loop {
        let redo = simplify::crossing_pieces(&pieces);
        if redo.is_empty() {
            break;
        }
        let fresh: Vec<_> =
            redo.par_iter().map_init(Scratch::default, |s, &t| setup.simplified(mesh, shell, t, cells.polygonize(s, t), share, levels[t] - 1)).collect();
        for (t, (piece, level)) in redo.into_iter().zip(fresh) {
            (pieces[t], levels[t]) = (piece, level);
        }
    }
    // Still over the budget: groups of neighbouring cells simplified with only their
    // outer rims locked ([`hierarchy`]).
    if share < 1.0 && setup.groups_free(mesh) && !cell_pass_only() {
        let moved: Vec<f32> = levels.par_iter().enumerate().map(|(t, &level)| setup.moved(mesh, shell, t, level)).collect();
        let cells = hierarchy::Cells { sampled: &made, error: &moved };
        hierarchy::rounds(&mut pieces, &cells, share, params.triangle_budget, SHARE_TOLERANCE, || progress.is_some_and(Progress::is_cancelled));
        if let Some(p) = progress {
            p.check()?;
        }
    }
    let welded = weld(pieces, &setup.lattice.faces);
    let triangles = welded.triangles.len();
    Ok(BakedMesh {
        positions: welded.positions,
        triangles: welded.triangles,
        normals: welded.normals,
        texcoords: welded.attrs,
        corner_texcoords: welded.corner_attrs,
        source_face: welded.tags,
        per_face_tiles: setup.coords.per_face_tiles,
        lattice: [setup.lattice.n, setup.heights.len() as u32 - 1],
        texture_finer_than_lattice: setup.texture_finer_than_lattice,
        over_budget: params.triangle_budget > 0 && triangles as f64 > params.triangle_budget as f64 * (1.0 + SHARE_TOLERANCE),
        simplify_error: setup.simplify_errors.last().copied().unwrap_or(0.0),
    })
}

/// What [`bake`] is expected to make with the same arguments (checked alike): the
/// bake's own lattice, field and simplification on a sample of its cells. Stops with
/// [`Error::Cancelled`] once `params`' progress is cancelled (its counts are left alone).
pub fn estimate_bake(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<Estimate> {
    estimate_sampled(mesh, shell, textures, params, FULL)
}

/// [`estimate_bake`] on the cells `sampling` picks.
fn estimate_sampled(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams, sampling: Sampling) -> Result<Estimate> {
    match split_base(mesh, shell, textures, params)? {
        // The split bake's cells as they are: split once, as `bake_culled` does.
        Some(split) => estimate_cells(&split.mesh, &split.shell, textures, &split.params, sampling),
        None => estimate_cells(mesh, shell, textures, params, sampling),
    }
}

/// [`estimate_bake`] on the cells of `mesh` as they are.
fn estimate_cells(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams, sampling: Sampling) -> Result<Estimate> {
    let (setup, sample) = fitted_setup(mesh, shell, textures, params, sampling)?;
    let field = setup.field(textures);
    let estimate = setup.estimate(mesh, shell, &setup.cells(mesh, shell, &field, true), params.triangle_budget, sample, &cancelled(params));
    check_cancelled(params)?;
    Ok(estimate)
}

/// The triangle count [`bake`] is expected to make ([`estimate_bake`]'s `triangles`).
pub fn estimate_triangles(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<usize> {
    Ok(estimate_bake(mesh, shell, textures, params)?.triangles)
}

/// How close the budget search brackets the smallest scale that fits: the scale it
/// returns is at most this much larger than one it found over the budget.
pub const BUDGET_STEP: f64 = 0.05;

/// Rounds of growth each phase of [`budget_scale`] tries before it gives up (each at
/// least [`BUDGET_MIN_GROWTH`], at most [`BUDGET_MAX_GROWTH`]).
const BUDGET_ROUNDS: usize = 8;

/// The least and most a growth round of [`budget_scale`] multiplies the scale by.
const BUDGET_MIN_GROWTH: f64 = 1.25;
const BUDGET_MAX_GROWTH: f64 = 16.0;

/// Estimates the progress of [`budget_scale`] counts on (a bracket of three rounds,
/// bisection to [`BUDGET_STEP`] and the check); more hold the bar near its end.
const BUDGET_EXPECTED: usize = 12;

/// Tiles grown to a bake's triangle budget ([`budget_scale`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BudgetFit {
    /// How many times larger the tiles are (a UV map's tiling divided by it; World-Size
    /// Tiles' size times it); 1 where the bake already fits.
    pub scale: f32,
    /// [`estimate_bake`]'s estimate at that scale.
    pub estimate: Estimate,
    /// The largest scale the search found over the budget (`scale / below` is at most
    /// `1 +` [`BUDGET_STEP`] where the bake fits); `None` where `scale` is 1.
    pub below: Option<f32>,
    /// Whether `estimate` fits the budget (false: still over it at the largest scale
    /// the rounds reached, which `scale` then is).
    pub fits: bool,
    /// Estimates made: quick ones (a quarter of the cells) and [`estimate_bake`]'s own.
    pub estimates: [usize; 2],
}

/// How many times larger the tiles must be (the UV map's `tiling` divided by it) for
/// a bake of `params` to be estimated within its triangle budget: the smallest such
/// scale to within [`BUDGET_STEP`], its estimate and the scale below it that did not
/// fit ([`BudgetFit`]). An estimate fits where the bake would not say it is over
/// ([`BakedMesh::over_budget`]: at most [`SHARE_TOLERANCE`] above the budget). Needs
/// a UV map: for a mesh without one, [`super::charts::budget_tile_size`] grows
/// generated World-Size Tiles instead. `params.progress` counts the estimates and
/// stops the search (and the estimate under way) when cancelled: [`Error::Cancelled`].
///
/// Not from the paper. On a mesh whose cells are small next to the texture (one tile
/// per face on a dense CAD part; small World-Size Tiles), a bake is over its budget
/// because the surface holds more texture than the budget has triangles for, and
/// each cell's rim (locked, with its one-ring, by the cell pass) holds a floor of
/// triangles no error within a lattice step removes (fandisk's chain mail, one tile
/// per face: 3.22 M triangles for a budget of 1 M within a quarter step, still 1.46 M
/// within eight steps, a whole cell edge). Larger tiles keep every feature as sampled
/// and make fewer of them.
///
/// The search: estimates on a quarter of the estimate's cells (`QUICK`), first
/// growing the scale by the power of the scale the count falls with between the last
/// two estimates (the square to begin; between [`BUDGET_MIN_GROWTH`] and
/// [`BUDGET_MAX_GROWTH`] a round; a scale whose lattice is over `max_triangles` is
/// doubled) until one fits, then bisecting (geometrically) between the last scale
/// over the budget and the first that fits until they are within [`BUDGET_STEP`];
/// the count is not monotone in the scale everywhere (the lattice's steps change in
/// whole blocks), so the result is the smallest within that bracket, not of all
/// scales. [`estimate_bake`] then checks the scale found; where it is over (the quick
/// sample was optimistic), the search goes on from there with its estimates.
pub fn budget_scale(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<BudgetFit> {
    if mesh.uvs().is_none() {
        return Err(Error::InvalidParameter("scaling tiles to the budget needs a UV map (without one: budget_tile_size)".into()));
    }
    params.check(mesh, shell, textures)?;
    let progress = params.progress.as_deref();
    if let Some(p) = progress {
        p.start(BUDGET_EXPECTED);
    }
    // The most triangles that fit.
    let limit = params.triangle_budget as f64 * (1.0 + SHARE_TOLERANCE);
    let fits = |e: &Estimate| params.triangle_budget == 0 || e.triangles as f64 <= limit;
    let made = std::cell::Cell::new([0usize; 2]);
    // One estimate at `scale`: None where the lattice is over the sample limit.
    let estimate = |scale: f64, sampling: Sampling| -> Result<Option<Estimate>> {
        let mut counts = made.get();
        counts[usize::from(sampling.cells == FULL.cells)] += 1;
        made.set(counts);
        // As a caller divides its tiling by the scale returned (an `f32`).
        let grown = BakeParams { tiling: params.tiling / scale as f32, ..params.clone() };
        let e = match estimate_sampled(mesh, shell, textures, &grown, sampling) {
            Ok(e) => Some(e),
            Err(Error::OverLimit(_)) => None,
            Err(e) => return Err(e),
        };
        if let Some(p) = progress {
            p.step();
        }
        Ok(e)
    };
    let fit = |scale: f64, estimate: Estimate, below: Option<f64>| {
        if let Some(p) = progress {
            p.start(1);
            p.step();
        }
        BudgetFit { scale: scale as f32, estimate, below: below.map(|b| b as f32), fits: fits(&estimate), estimates: made.get() }
    };
    if params.triangle_budget == 0 {
        let e = estimate(1.0, FULL)?.ok_or_else(|| Error::OverLimit("this bake is over its sample limit".into()))?;
        return Ok(fit(1.0, e, None));
    }
    let first = estimate(1.0, QUICK)?;
    let found = match first {
        Some(e) if fits(&e) => Search { below: None, fit: Some((1.0, e)), largest: 1.0 },
        _ => search(1.0, first, |s| estimate(s, QUICK), limit)?,
    };
    let Some((scale, _)) = found.fit else {
        let e = last_estimate(found.largest, |s| estimate(s, FULL))?;
        return Ok(fit(found.largest, e, found.below));
    };
    // The check: the estimate's own sample at the scale found.
    match estimate(scale, FULL)? {
        Some(e) if fits(&e) => Ok(fit(scale, e, found.below)),
        over => {
            let more = search(scale, over, |s| estimate(s, FULL), limit)?;
            match more.fit {
                Some((s, e)) => Ok(fit(s, e, more.below)),
                None => {
                    let e = last_estimate(more.largest, |s| estimate(s, FULL))?;
                    Ok(fit(more.largest, e, more.below))
                }
            }
        }
    }
}

/// What [`search`] found: the largest scale over the budget, the smallest scale that
/// fits (within [`BUDGET_STEP`] of it) with its estimate, and the largest scale tried.
struct Search {
    below: Option<f64>,
    fit: Option<(f64, Estimate)>,
    largest: f64,
}

/// [`budget_scale`]'s growth rounds from `scale` (whose estimate `over`, None where
/// over the sample limit, is over `limit` triangles), then its bisection.
fn search(scale: f64, over: Option<Estimate>, estimate: impl Fn(f64) -> Result<Option<Estimate>>, limit: f64) -> Result<Search> {
    let fits = |e: &Estimate| e.triangles as f64 <= limit;
    let (mut below, mut current) = (scale, over);
    let mut previous: Option<(f64, Estimate)> = None;
    let mut found = None;
    for _ in 0..BUDGET_ROUNDS {
        let growth = match current {
            None => 2.0,
            Some(e) => {
                // How far over (against what fits) and the count's power of the scale
                // between the last two estimates (the square to begin).
                let over = e.triangles as f64 / limit;
                let power = match previous {
                    Some((s0, e0)) if e0.triangles > e.triangles => ((e0.triangles as f64 / e.triangles as f64).ln() / (below / s0).ln()).clamp(0.5, 2.0),
                    Some(_) => 0.5,
                    None => 2.0,
                };
                // A tenth beyond where the power law says it fits: bisection finds the edge.
                (over.powf(1.0 / power) * 1.1).clamp(BUDGET_MIN_GROWTH, BUDGET_MAX_GROWTH)
            }
        };
        let next = below * growth;
        match estimate(next)? {
            Some(e) if fits(&e) => {
                found = Some((next, e));
                break;
            }
            e => {
                previous = current.map(|c| (below, c));
                (below, current) = (next, e);
            }
        }
    }
    let Some((mut hi, mut at)) = found else {
        return Ok(Search { below: Some(below), fit: None, largest: below });
    };
    let largest = hi;
    while hi / below > 1.0 + BUDGET_STEP {
        let mid = (hi * below).sqrt();
        match estimate(mid)? {
            Some(e) if fits(&e) => (hi, at) = (mid, e),
            _ => below = mid,
        }
    }
    Ok(Search { below: Some(below), fit: Some((hi, at)), largest })
}

/// The estimate at `scale`, the largest a search reached without a fit (over the
/// sample limit there: refused, as the bake would be).
fn last_estimate(scale: f64, estimate: impl FnOnce(f64) -> Result<Option<Estimate>>) -> Result<Estimate> {
    estimate(scale)?.ok_or_else(|| Error::OverLimit(format!("even tiles {scale:.1} times larger are over the sample limit")))
}

#[cfg(test)]
mod layer_tests {
    use super::*;
    use crate::texture::VolumeTexture;

    fn deep(nz: usize) -> Vec<TextureLayer> {
        vec![TextureLayer { texture: VolumeTexture::new([2, 2, nz], vec![0.0; 4 * nz]).unwrap(), offset: Vec2::ZERO }]
    }

    /// Whether every slice `k / (nz - 1)` is one of `heights`.
    fn on_slices(heights: &[f32], nz: usize) -> bool {
        (0..nz).all(|k| heights.iter().any(|h| (h - k as f32 / (nz - 1) as f32).abs() < 1e-6))
    }

    fn sized(nx: usize, ny: usize, offset: Vec2) -> TextureLayer {
        TextureLayer { texture: VolumeTexture::new([nx, ny, 2], vec![0.0; nx * ny * 2]).unwrap(), offset }
    }

    #[test]
    fn aligned_lattices_put_a_point_on_every_texel_centre() {
        // One tile per face: a triangle's half tile, a quad's two halves.
        let tri = [Vec2::ZERO, Vec2::X, Vec2::Y];
        let quad = [[Vec2::ZERO, Vec2::X, Vec2::ONE], [Vec2::ZERO, Vec2::ONE, Vec2::Y]];
        let t64 = [sized(64, 64, Vec2::ZERO)];
        assert_eq!(aligned_steps(&[tri], &t64, 8, 192), Some(128));
        assert_eq!(aligned_steps(&quad, &t64, 8, 192), Some(128));
        // Each half tile holds 64 * 65 / 2 texel centres (those on the diagonal in
        // both halves); as many of its 128-step lattice points are on one.
        let texel = |c: &[Vec2; 3], i: u32, j: u32| (c[0] + (c[1] - c[0]) * i as f32 / 128.0 + (c[2] - c[0]) * j as f32 / 128.0) * 64.0 - Vec2::splat(0.5);
        for c in [tri, quad[0], quad[1]] {
            let points = (0..=128u32).flat_map(|i| (0..=128 - i).map(move |j| (i, j)));
            let on_centres = points.filter(|&(i, j)| (texel(&c, i, j) - texel(&c, i, j).round()).length() < 1e-4).count();
            assert_eq!(on_centres, 64 * 65 / 2, "{c:?}");
        }
        // Shifted by half a texel, every other point is enough; too few steps allowed: none.
        assert_eq!(aligned_steps(&[tri], &[sized(64, 64, Vec2::splat(0.5 / 64.0))], 8, 192), Some(64));
        assert_eq!(aligned_steps(&[tri], &t64, 8, 120), None);
        // Two textures: both grids (128 and 96 steps) only at 384 steps, over the limit.
        assert_eq!(aligned_steps(&[tri], &[sized(64, 64, Vec2::ZERO), sized(48, 48, Vec2::ZERO)], 8, 192), None);
        // A skewed map has no aligned lattice; a degenerate cell is left out.
        let skewed = [Vec2::new(0.013, 0.2), Vec2::new(0.91, 0.37), Vec2::new(0.3, 0.77)];
        assert_eq!(aligned_steps(&[tri, skewed], &t64, 8, 192), None);
        assert_eq!(aligned_steps(&[tri, [Vec2::X; 3]], &t64, 8, 192), Some(128));
    }

    #[test]
    fn texel_layers_stay_on_the_slices_and_split_them_only_where_that_fits() {
        // 32 slices: two layers each for thin textures, one otherwise.
        assert_eq!(texel_layers(&deep(32), 16, 2).len(), 63);
        assert_eq!(texel_layers(&deep(32), 16, 1).len(), 32);
        // 100 slices: two each would pass MAX_STEPS; the slices stay, unsplit.
        let h = texel_layers(&deep(100), 16, 2);
        assert!(on_slices(&h, 100) && h.len() == 100, "{}", h.len());
        // 60 slices: two layers each (118 intervals) still fit.
        let h = texel_layers(&deep(60), 16, 2);
        assert!(on_slices(&h, 60) && h.len() as u32 <= MAX_STEPS + 1 && h.len() == 119, "{}", h.len());
        // Beyond MAX_STEPS slices: uniform.
        assert_eq!(texel_layers(&deep(300), 16, 2).len() as u32, MAX_STEPS + 1);
    }
}
