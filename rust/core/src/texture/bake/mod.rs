//! Bake to geometry: the `alpha = 0.5` iso-surface of the texture over the whole shell
//! as one mesh (chapter 3: the thick surface's detailed surface).
//!
//! - [`lattice`]: every cell (a triangle prism; quads and n-gons are triangulated) is
//!   sampled on a lattice of `resolution` steps per base edge and `layers` steps along
//!   the directors, numbered globally so neighbouring cells share samples.
//! - [`field`]: the occupancy sampled there: textures united, partial regions blended
//!   with a base slab (figure 3.3), a moved region and holes (chapter 7).
//! - [`polygonize`]: marching prisms ([`prism_table`]), one cell at a time.
//! - [`merge`]: iso-vertices shared by cells joined through their lattice-edge keys.
//! - [`cutter`] and [`uv_mask`]: a closed mesh's inside, and a vertex group in `(s, t)`.
//!
//! Shared samples, conforming splits and edge keys make the result free of cracks and
//! duplicated vertices. The shell's own boundary (base layer, outer layer, walls along
//! open mesh edges) is sampled as outside, so every baked surface is closed. Normals
//! come from the field's gradient carried to world space by each cell's map.

pub mod cutter;
mod estimate;
mod field;
mod lattice;
mod merge;
mod polygonize;
mod prism_table;
mod uv_mask;

use super::mapping::{CellMap, TextureCoordinates};
use super::VolumeTexture;
use crate::shell::Shell;
use crate::{Error, Mesh, Result};
pub use cutter::Cutter;
use field::Field;
use glam::{Vec2, Vec3};
use lattice::Lattice;
use polygonize::{Cells, Scratch};
use rayon::prelude::*;
use uv_mask::UvMask;

/// A texture placed in the shell: `(s, t)` offset (editing: move, combine).
#[derive(Debug, Clone)]
pub struct TextureLayer {
    pub texture: VolumeTexture,
    pub offset: Vec2,
}

/// Bake settings.
#[derive(Debug, Clone)]
pub struct BakeParams {
    /// Lattice steps along each base edge of a cell.
    pub resolution: u32,
    /// Lattice steps along the directors.
    pub layers: u32,
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
    /// Refuse bakes whose estimate exceeds this many triangles.
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
            layers: 16,
            tiling: 1.0,
            region: None,
            base_layer: 0.1,
            holes: None,
            cutter: None,
            moved: None,
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
    /// `(s, t, r)` of each vertex.
    pub texcoords: Vec<Vec3>,
    /// True when the mesh had no UVs and each face got its own tile.
    pub per_face_tiles: bool,
}

/// Bakes the iso-surface. `layers`: the textures (at least one), unioned.
pub fn bake(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<BakedMesh> {
    mesh.require_faces()?;
    if textures.is_empty() {
        return Err(Error::InvalidParameter("no texture to bake".into()));
    }
    if shell.directors.len() != mesh.vertex_count() {
        return Err(Error::InvalidParameter("the shell does not belong to this mesh".into()));
    }
    if !(1..=64).contains(&params.resolution) || !(2..=256).contains(&params.layers) {
        return Err(Error::InvalidParameter("resolution must be in 1..=64 and layers in 2..=256".into()));
    }
    if !(params.tiling > 0.0 && params.tiling.is_finite()) {
        return Err(Error::InvalidParameter("tiling must be a positive number".into()));
    }
    let n_vertices = mesh.vertex_count();
    let weights =
        [("region", &params.region), ("holes", &params.holes), ("moved region", &params.moved.as_ref().map(|m| m.weights.clone()))];
    for (what, w) in weights {
        if w.as_ref().is_some_and(|w| w.len() != n_vertices || w.iter().any(|x| !x.is_finite())) {
            return Err(Error::InvalidParameter(format!("{what} weights: one finite value per vertex")));
        }
    }
    let coords = TextureCoordinates::of(mesh, params.tiling);
    if params.moved.is_some() && coords.per_face_tiles {
        return Err(Error::InvalidParameter("moving a texture region needs a UV map".into()));
    }
    let (n, m) = (params.resolution, params.layers);
    let lattice = Lattice::new(mesh, &coords, n);
    let estimate = estimate::estimate_triangles(&lattice, textures, m);
    if estimate > params.max_triangles {
        return Err(Error::InvalidParameter(format!(
            "this bake would make about {estimate} triangles, over the limit of {}; lower the resolution or layers",
            params.max_triangles
        )));
    }
    let moved = params.moved.as_ref().map(|mv| {
        let res = ((lattice.tris.len() as f32).sqrt() as usize * n as usize * 2).clamp(256, 4096);
        (UvMask::new(&lattice.tris, &lattice.st, &mv.weights, res), mv.offset * params.tiling)
    });
    let field = Field {
        layers: textures,
        tris: &lattice.tris,
        region: params.region.as_deref(),
        holes: params.holes.as_deref(),
        cutter: params.cutter.as_ref(),
        moved,
        base_layer: params.base_layer.max(1.5 / m as f32),
        layers_r: m as f32,
    };
    let values = sample_lattice(mesh, shell, &lattice, &field, m);

    let cells = Cells { mesh, shell, lattice: &lattice, values: &values, layers: m };
    let pieces: Vec<_> = (0..lattice.tris.len()).into_par_iter().map_init(Scratch::default, |s, t| cells.polygonize(s, t)).collect();
    drop(values);
    let mut out = merge::merge(pieces);
    out.per_face_tiles = coords.per_face_tiles;
    Ok(out)
}

/// The triangle count a bake is expected to make ([`estimate`]).
pub fn estimate_triangles_for(mesh: &Mesh, textures: &[TextureLayer], params: &BakeParams) -> usize {
    let coords = TextureCoordinates::of(mesh, params.tiling);
    estimate::estimate_triangles(&Lattice::new(mesh, &coords, params.resolution), textures, params.layers)
}

/// `alpha` at every lattice point (point key × (layers + 1)), each computed in the
/// cell that owns the point so shared points get one value. Values are kept off
/// exactly 0.5 so no iso-vertex lands on a lattice point (no coincident vertices).
fn sample_lattice(mesh: &Mesh, shell: &Shell, lattice: &Lattice, field: &Field, m: u32) -> Vec<f32> {
    let owner = lattice.owners();
    let n = lattice.n as f32;
    let layers = m as usize + 1;
    let mut values = vec![0.0f32; lattice.key_count() * layers];
    values.par_chunks_mut(layers).enumerate().for_each_init(Vec::new, |scratch, (k, column)| {
        let (t, i, j) = owner[k];
        if t == u32::MAX || lattice.boundary[k] {
            return;
        }
        let t = t as usize;
        let cell = CellMap::new(mesh, shell, &lattice.tris[t], &lattice.st[t]);
        field.column(t, &cell, (i as f32 / n, j as f32 / n), column, scratch);
        // The shell's base and outer layer are outside.
        column[0] = 0.0;
        column[m as usize] = 0.0;
        for a in column.iter_mut() {
            if (*a - 0.5).abs() < 1e-6 {
                *a = 0.5 + 1e-6;
            }
        }
    });
    values
}
