//! Shells: the layer of space around a base mesh, given by one straight *director*
//! per vertex (thick surfaces, chapter 3.1). A shell vertex at parameter r in [0, 1]
//! sits at `base + r * director`.
//!
//! - [`thickness`]: the per-vertex target thickness users ask for.
//! - [`offset`]: the normal-displacement baseline (Offset Shell).
//! - [`geometry`]: layers, outer surface and closed solids built from any directors.

pub mod geometry;
pub mod offset;
pub mod thickness;

pub use geometry::{build_geometry, ShellMesh, ShellOutput};
pub use offset::normal_offset_directors;
pub use thickness::{Thickness, ThicknessMode};
