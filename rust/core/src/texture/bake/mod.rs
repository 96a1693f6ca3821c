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

impl BakeParams {
    /// The checks every bake and estimate makes before any work: settings in range,
    /// per-vertex weights that fit `mesh`, a shell that belongs to it, a texture.
    fn check(&self, mesh: &Mesh, shell: &Shell, textures: &[TextureLayer]) -> Result<()> {
        mesh.require_faces()?;
        if textures.is_empty() {
            return Err(Error::InvalidParameter("no texture to bake".into()));
        }
        if shell.directors.len() != mesh.vertex_count() {
            return Err(Error::InvalidParameter("the shell does not belong to this mesh".into()));
        }
        if !(1..=64).contains(&self.resolution) || !(2..=256).contains(&self.layers) {
            return Err(Error::InvalidParameter("resolution must be in 1..=64 and layers in 2..=256".into()));
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

/// What a bake and its estimate share: the checked settings' lattice and the
/// moved region's mask, from which the occupancy [`Field`] is made.
struct Setup {
    coords: TextureCoordinates,
    lattice: Lattice,
    moved: Option<(UvMask, Vec2)>,
}

impl Setup {
    fn new(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<Self> {
        params.check(mesh, shell, textures)?;
        let coords = TextureCoordinates::of(mesh, params.tiling);
        if params.moved.is_some() && coords.per_face_tiles {
            return Err(Error::InvalidParameter("moving a texture region needs a UV map".into()));
        }
        let n = params.resolution;
        let lattice = Lattice::new(mesh, &coords, n);
        let moved = params.moved.as_ref().map(|mv| {
            let res = ((lattice.tris.len() as f32).sqrt() as usize * n as usize * 2).clamp(256, 4096);
            (UvMask::new(&lattice.tris, &lattice.st, &mv.weights, res), mv.offset * params.tiling)
        });
        Ok(Self { coords, lattice, moved })
    }

    fn field<'a>(&'a self, textures: &'a [TextureLayer], params: &'a BakeParams) -> Field<'a> {
        let m = params.layers;
        Field {
            layers: textures,
            tris: &self.lattice.tris,
            region: params.region.as_deref(),
            holes: params.holes.as_deref(),
            cutter: params.cutter.as_ref(),
            moved: self.moved.as_ref().map(|(mask, d)| (mask, *d)),
            base_layer: params.base_layer.max(1.5 / m as f32),
            layers_r: m as f32,
        }
    }
}

/// Bakes the iso-surface. `textures`: at least one, united.
pub fn bake(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<BakedMesh> {
    let setup = Setup::new(mesh, shell, textures, params)?;
    let field = setup.field(textures, params);
    let (lattice, m) = (&setup.lattice, params.layers);
    let estimate = estimate::estimate_triangles(mesh, shell, lattice, &field, m);
    if estimate > params.max_triangles {
        return Err(Error::InvalidParameter(format!(
            "this bake would make about {estimate} triangles, over the limit of {}; lower the resolution or layers",
            params.max_triangles
        )));
    }
    let values = sample_lattice(mesh, shell, lattice, &field, m);
    let cells = Cells { mesh, shell, lattice, values: &values, layers: m };
    let pieces: Vec<_> = (0..lattice.tris.len()).into_par_iter().map_init(Scratch::default, |s, t| cells.polygonize(s, t)).collect();
    drop(values);
    let mut out = merge::merge(pieces);
    out.per_face_tiles = setup.coords.per_face_tiles;
    Ok(out)
}

/// The triangle count [`bake`] is expected to make with the same arguments (checked
/// alike): the bake's own field on a sample of its cells ([`estimate`]).
pub fn estimate_triangles(mesh: &Mesh, shell: &Shell, textures: &[TextureLayer], params: &BakeParams) -> Result<usize> {
    let setup = Setup::new(mesh, shell, textures, params)?;
    Ok(estimate::estimate_triangles(mesh, shell, &setup.lattice, &setup.field(textures, params), params.layers))
}

/// Least distance of a sample from the iso-level 0.5. Values nearer (blends of a
/// region, holes or the base slab give exactly 0.5 midway between weights 1 and 0) are
/// moved to this distance on their own side, so iso-vertices stay at least about 2%
/// of a lattice edge from lattice points: no coincident vertices, and no triangles around
/// one lattice point that touch without sharing a vertex.
const OFF_ISO: f32 = 0.01;

/// `alpha` at every lattice point (point key × (layers + 1)), each computed in the
/// cell that owns the point so shared points get one value, kept [`OFF_ISO`] off 0.5.
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
            if (*a - 0.5).abs() < OFF_ISO {
                *a = if *a >= 0.5 { 0.5 + OFF_ISO } else { 0.5 - OFF_ISO };
            }
        }
    });
    values
}
