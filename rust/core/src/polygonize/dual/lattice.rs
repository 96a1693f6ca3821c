//! The lattice of cells over the box, and the field as the polygonizer samples it: the
//! solid cut by the box (`max(f, box)`, as [`crate::polygonize::grid`] cuts it), the
//! lattice points on the box's faces outside, so the output is closed.

use crate::Result;
use glam::{UVec3, Vec3};

/// Cells per side of a block: the leaves of the octree descent, sampled as one batch.
/// Not from a paper: 4 keeps a bound's cost (a few dozen samples) below the samples
/// it saves, as in the grid mesher's culling.
pub const BLOCK: u32 = 4;

pub(super) struct Lattice {
    pub lo: Vec3,
    pub hi: Vec3,
    pub step: Vec3,
    pub cells: UVec3,
    /// How far samples on the box's faces are kept outside: [`OFF_ISO`](crate::polygonize::marching::OFF_ISO) of a cell.
    pub eps: f32,
}

impl Lattice {
    pub fn new(bounds: (Vec3, Vec3), resolution: u32) -> Result<Self> {
        let (step, cells, eps) = crate::polygonize::grid::cells_for(bounds, resolution)?;
        Ok(Self { lo: bounds.0, hi: bounds.1, step, cells, eps })
    }

    pub fn point(&self, at: UVec3) -> Vec3 {
        self.lo + self.step * at.as_vec3()
    }

    /// Whether a lattice point lies on the box's faces.
    pub fn on_face(&self, at: UVec3) -> bool {
        at.cmpeq(UVec3::ZERO).any() || at.cmpeq(self.cells).any()
    }

    /// Signed distance to the box (negative inside) and the outward normal of the
    /// nearest face.
    pub fn to_box(&self, p: Vec3) -> (f32, Vec3) {
        crate::polygonize::grid::to_box(self.lo, self.hi, p)
    }

    /// The cut field `max(f, box)` at `p`: the distance of [`Lattice::to_box`] (the
    /// largest per-axis distance, the same bits) without its face.
    #[inline]
    pub fn cut(&self, f: f32, p: Vec3) -> f32 {
        f.max((self.lo - p).max(p - self.hi).max_element())
    }

    /// The cut field at lattice point `at`, kept [`Lattice::eps`] outside on the box's
    /// faces. Inside where `<= 0`. (The tests' reference: [`super::block::Samples`]
    /// makes the same per row.)
    #[cfg(test)]
    pub fn sample(&self, f: f32, at: UVec3) -> f32 {
        let v = self.cut(f, self.point(at));
        if self.on_face(at) {
            v.max(self.eps)
        } else {
            v
        }
    }
}
