//! Shells: the layer of space around a base mesh, given by one straight *director*
//! per vertex (thick surfaces, chapter 3.1). A shell vertex at parameter r in [0, 1]
//! sits at `base + base_offset + r * director`.
//!
//! - [`thickness`]: the per-vertex target thickness users ask for.
//! - [`offset`]: the normal-displacement baseline (Offset Shell).
//! - [`field`]: the L_p-averaged distance and its gradient (chapter 4.2).
//! - [`directors`]: directors by integrating the field (chapter 4.3-4.4).
//! - [`geometry`]: layers, outer surface and closed solids built from any directors.
//! - [`defects`], [`repair`], [`report`]: finding folds, shortening directors around
//!   them, and counting shell quality.

pub mod defects;
pub mod directors;
pub mod field;
pub mod geometry;
pub mod incremental;
pub mod intersect;
pub mod repair;
pub mod report;
pub mod offset;
pub mod thickness;

pub use directors::{build_shell, ShellParams, Shell, Side};
pub use geometry::{build_geometry, prisms, shell_geometry, Cell, ShellMesh, ShellOutput};
pub use offset::normal_offset_directors;
pub use thickness::{Thickness, ThicknessMode};
#[cfg(test)]
mod tests;
