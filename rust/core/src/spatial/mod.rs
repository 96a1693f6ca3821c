//! Spatial indexes shared by the shell, the bake and the renderers: one bounding
//! volume hierarchy over axis-aligned boxes ([`Bvh`]) with box, segment and ray
//! queries and tree-against-tree joins.

mod bvh;

pub use bvh::{ray_triangle, segment_meets_box, tri_box, Bvh};
