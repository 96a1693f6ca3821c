//! Thicket's geometry core: meshes, shells and (later) volumetric textures.
//!
//! Pure Rust: no Python, no GPU. The pyo3 binding (`thicket-native`) and the
//! Blender add-on only adapt types; every algorithm lives here.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > 0.0)` deliberately also rejects NaN

pub mod error;
pub mod field;
pub mod implicit;
pub mod mesh;
pub mod polygonize;
pub mod progress;
pub mod raycast;
pub mod shell;
pub mod spatial;
pub mod subdivision;
pub mod texture;
// Test meshes: in the crate's own tests, and for other crates' tests, examples and
// benches through the `test-support` feature; never in the release library.
#[cfg(any(test, feature = "test-support"))]
#[doc(hidden)]
pub mod hard_meshes;
#[cfg(any(test, feature = "test-support"))]
#[doc(hidden)]
pub mod test_rng;
#[cfg(any(test, feature = "test-support"))]
#[doc(hidden)]
pub mod testmeshes;

pub use error::{Error, Result};
pub use glam;
pub use mesh::{Mesh, MeshReport};
