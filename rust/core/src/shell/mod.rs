//! Shells: the layer of space around a base mesh, given by one straight *director*
//! per vertex (thick surfaces, chapter 3.1). A shell vertex at parameter r in [0, 1]
//! sits at `base + base_offset + r * director`.
//!
//! - [`thickness`]: the per-vertex target thickness users ask for.
//! - [`offset`]: the normal-displacement baseline (Offset Shell).
//! - [`lp_distance`]: the L_p-averaged distance and its gradient (chapter 4.2).
//! - [`directors`]: directors by integrating the field (chapter 4.3-4.4).
//! - [`incremental`]: a shell following edits of its base mesh (7.1); `influence`
//!   bounds how far an edit reaches in the field.
//! - [`geometry`]: layers, outer surface and closed solids built from any directors.
//! - [`defects`], [`repair`], `restore`, [`report`]: finding folds, shortening
//!   directors around them, giving thickness back where normals have room, and
//!   counting shell quality.
//! - [`timing`]: per-stage build times for benchmarks (`examples/shell_stages.rs`).

pub mod defects;
pub mod directors;
pub mod geometry;
pub mod incremental;
pub(crate) mod influence;
pub mod intersect;
pub mod lp_distance;
pub mod offset;
pub mod repair;
pub mod report;
pub(crate) mod restore;
pub(crate) mod room;
pub mod thickness;
pub mod timing;
pub(crate) mod trade;

pub use directors::{build_shell, build_shell_watched, Shell, ShellParams, Side};
pub use geometry::{build_geometry, prisms, shell_geometry, Cell, ShellMesh, ShellOutput};
pub use offset::normal_offset_directors;
pub use repair::ShellCheck;
pub use thickness::{Thickness, ThicknessMode};
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_find_star;
#[cfg(test)]
mod tests_room_rule;
#[cfg(test)]
mod tests_split_seams;
