//! Volumetric textures in the shell (thick surfaces, chapters 3 and 7): a tileable 3D
//! grid of occupancy `alpha` whose third axis runs from the base (`r = 0`) to the
//! outer layer (`r = 1`); the detailed surface is the iso-surface `alpha = 0.5`.
//!
//! - [`volume`]: the grid, trilinear sampling (periodic in `s`, `t`) and gradient.
//! - [`procedural`]: the generator library (chain mail, weave, rivets, grass, fur,
//!   bubbles), each tileable, seeded and, where it moves, driven by a time.
//! - [`mapping`]: texture coordinates of the shell's cells (UVs times tiling, or one
//!   tile per face) and the cell map between world and texture space.
//! - [`charts`]: generated texture coordinates for meshes without a UV map: charts
//!   projected flat, one tile every `tile_size` mesh units.
//! - [`layer`]: a texture placed in the shell with its `(s, t)` offset.
//! - [`bake`]: the iso-surface polygonized over the whole shell as one crack-free mesh.
//! - [`textured_shell`]: mesh, shell, textures and effects as one checked object, from
//!   which the bake, its estimate and the renderers all take what they show.
//! - [`io`]: textures from and to files (PNG slice stacks, OpenEXR volumes).

pub mod bake;
pub mod charts;
pub mod from_field;
pub mod io;
pub mod layer;
pub mod mapping;
pub mod procedural;
pub mod textured_shell;
pub mod volume;

pub use bake::{bake, BakeParams, BakedMesh};
pub use charts::{with_world_size_uvs, Charts};
pub use from_field::texture_from_field;
pub use layer::TextureLayer;
pub use mapping::{CellMap, TextureCoordinates, TriangleCells};
pub use procedural::{Generator, Pattern};
pub use textured_shell::TexturedShell;
pub use volume::VolumeTexture;

#[cfg(test)]
mod tests;
