//! Thicket's geometry core: meshes, shells and (later) volumetric textures.
//!
//! Pure Rust: no Python, no GPU. The pyo3 binding (`thicket-native`) and the
//! Blender add-on only adapt types; every algorithm lives here.

pub mod error;
pub mod mesh;
pub mod shell;
#[doc(hidden)]
pub mod testmeshes;

pub use glam;
pub use error::{Error, Result};
pub use mesh::{Mesh, MeshReport};
