//! Polygonizing: iso-surfaces of sampled fields as closed triangle meshes, one
//! machinery for every feature that meshes a field.
//!
//! - [`prism_table`]: marching prisms, the triangles of every case of one prism.
//! - [`marching`]: one prism marched ([`marching::march_prism`]) and where its
//!   iso-vertices go on a lattice edge ([`marching::crossing`]).
//! - [`weld`]: pieces marched apart joined through their lattice-edge keys.
//! - [`grid`]: a regular grid of cubes split into prisms, meshing any
//!   [`ScalarField`](crate::field::ScalarField) by writing only its sampler.
//! - [`validate`]: the closed 2-manifold contract, counted.
//! - [`dual`]: manifold dual contouring with sharp features on an interval-culled octree, in quads.
//! - [`estimate`]: a mesh's size before meshing, the memory limit, and the [`estimate::Watch`]
//!   (progress, cancel, limit) both meshers check as they go.
//!
//! The volumetric bake ([`crate::texture::bake`]) marches its own lattice, the shell's
//! cells with the texture's slices, through the same prism, crossing and weld.

pub mod dual;
pub mod estimate;
pub mod grid;
pub mod marching;
pub mod prism_table;
pub mod validate;
pub mod weld;

pub use estimate::{check_fits, estimate, Estimate, Mesher, Watch, DEFAULT_MAX_BYTES};
pub use grid::{mesh_field, mesh_field_watched, FieldMesh, GridParams};
pub use validate::SurfaceCheck;

#[cfg(test)]
mod tests;
