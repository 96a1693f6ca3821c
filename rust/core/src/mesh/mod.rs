//! Polygon meshes: any-arity faces stored as offsets into a flat corner array, with an
//! on-demand triangulation view and structural validation.

mod normals;
pub mod obj;
mod polyfill;
mod reorder;
mod topology;
mod triangulate;
mod validate;
mod weld;

pub use normals::{vertex_normal, vertex_normals};
pub(crate) use polyfill::blender_quad_flips;
pub use reorder::morton_codes;
pub use topology::{boundary_edges, face_windings, parts_of, vertex_parts, EdgeMap, EdgeUses, Incidence, Parts, Windings};
pub use triangulate::{face_triangles, newell_normal, Triangulation};
pub use validate::MeshReport;
pub(crate) use weld::Crowding;
pub use weld::Weld;

use crate::{Error, Result};
use glam::{Vec2, Vec3};

/// A polygon mesh. Faces are `corners[offsets[f]..offsets[f+1]]`, counter-clockwise
/// seen from outside (Blender's convention). UVs, when present, are per corner.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    positions: Vec<Vec3>,
    offsets: Vec<u32>,
    corners: Vec<u32>,
    uvs: Option<Vec<Vec2>>,
}

impl Default for Mesh {
    fn default() -> Self {
        Self { positions: Vec::new(), offsets: vec![0], corners: Vec::new(), uvs: None }
    }
}

impl Mesh {
    /// Builds a mesh from raw arrays, rejecting what no algorithm can use:
    /// out-of-range indices, faces of fewer than 3 corners, non-finite coordinates,
    /// UV arrays of the wrong length. Geometric oddities (zero-area faces, loose
    /// vertices, non-manifold edges) are allowed and reported by [`Mesh::report`].
    pub fn new(positions: Vec<Vec3>, face_sizes: &[u32], corners: Vec<u32>, uvs: Option<Vec<Vec2>>) -> Result<Self> {
        if let Some((index, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(Error::NonFinite { index, value: p.to_array() });
        }
        let mut offsets = Vec::with_capacity(face_sizes.len() + 1);
        let mut total: u64 = 0;
        offsets.push(0);
        for (f, &n) in face_sizes.iter().enumerate() {
            if n < 3 {
                return Err(Error::InvalidMesh(format!("face {f} has {n} corners; a face needs at least 3")));
            }
            total += n as u64;
            if total > u32::MAX as u64 {
                return Err(Error::InvalidMesh("too many face corners (more than 2^32)".into()));
            }
            offsets.push(total as u32);
        }
        if total as usize != corners.len() {
            return Err(Error::InvalidMesh(format!("face sizes add up to {total} corners but {} corner indices were given", corners.len())));
        }
        let n = positions.len();
        if let Some((c, &v)) = corners.iter().enumerate().find(|(_, &v)| v as usize >= n) {
            return Err(Error::InvalidMesh(format!("corner {c} refers to vertex {v}, but the mesh has {n} vertices")));
        }
        if let Some(uv) = &uvs {
            if uv.len() != corners.len() {
                return Err(Error::InvalidMesh(format!("{} UVs given for {} face corners", uv.len(), corners.len())));
            }
        }
        Ok(Self { positions, offsets, corners, uvs })
    }

    /// A mesh of triangles only.
    pub fn from_triangles(positions: Vec<Vec3>, triangles: &[[u32; 3]]) -> Result<Self> {
        let sizes = vec![3u32; triangles.len()];
        Self::new(positions, &sizes, triangles.iter().flatten().copied().collect(), None)
    }

    /// Takes the mesh apart into positions and flat corner indices.
    pub fn into_parts(self) -> (Vec<Vec3>, Vec<u32>) {
        (self.positions, self.corners)
    }
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }
    pub fn corners(&self) -> &[u32] {
        &self.corners
    }
    pub fn uvs(&self) -> Option<&[Vec2]> {
        self.uvs.as_deref()
    }
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
    pub fn face_count(&self) -> usize {
        self.offsets.len() - 1
    }
    /// The vertex indices of face `f`.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.corners[self.offsets[f] as usize..self.offsets[f + 1] as usize]
    }
    /// The corner range of face `f` (indices into [`Mesh::corners`] and UVs).
    pub fn face_corner_range(&self, f: usize) -> std::ops::Range<usize> {
        self.offsets[f] as usize..self.offsets[f + 1] as usize
    }
    pub fn faces(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        self.offsets.windows(2).map(|w| &self.corners[w[0] as usize..w[1] as usize])
    }
    /// Number of corners of each face (Blender's `loop_total`).
    pub fn face_sizes(&self) -> Vec<u32> {
        self.offsets.windows(2).map(|w| w[1] - w[0]).collect()
    }
    /// Diagonal of the axis-aligned bounding box of the vertices that faces use.
    pub fn bbox_diagonal(&self) -> f32 {
        self.bbox_diagonal_at(&self.positions)
    }
    /// [`bbox_diagonal`](Self::bbox_diagonal) were the vertices at `positions`.
    pub fn bbox_diagonal_at(&self, positions: &[Vec3]) -> f32 {
        let (lo, hi) = self.bounds_at(positions);
        if lo.x > hi.x {
            0.0
        } else {
            (hi - lo).length()
        }
    }
    /// Axis-aligned bounds of the vertices referenced by faces (loose vertices do not count).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds_at(&self.positions)
    }
    /// [`bounds`](Self::bounds) were the vertices at `positions` (one per vertex).
    pub fn bounds_at(&self, positions: &[Vec3]) -> (Vec3, Vec3) {
        self.corners.iter().fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), &v| {
            let p = positions[v as usize];
            (lo.min(p), hi.max(p))
        })
    }
    /// Fails with [`Error::EmptyMesh`] when there are no faces to work on.
    pub fn require_faces(&self) -> Result<()> {
        if self.face_count() == 0 {
            Err(Error::EmptyMesh)
        } else {
            Ok(())
        }
    }
    /// Signed volume enclosed by the faces (divergence theorem): positive for a closed
    /// mesh whose faces point outward.
    pub fn signed_volume(&self) -> f32 {
        let p = &self.positions;
        self.triangulate().triangles.iter().map(|t| p[t[0] as usize].dot(p[t[1] as usize].cross(p[t[2] as usize])) / 6.0).sum()
    }
    /// Triangulation of every face (for integration and intersection tests only;
    /// the mesh itself keeps its polygons).
    pub fn triangulate(&self) -> Triangulation {
        Triangulation::of(self)
    }
    pub fn report(&self) -> MeshReport {
        MeshReport::of(self)
    }
    /// Moves vertex `v` (for interactive edits); non-finite positions are refused.
    pub fn set_position(&mut self, v: usize, p: Vec3) -> Result<()> {
        if !p.is_finite() {
            return Err(Error::NonFinite { index: v, value: p.to_array() });
        }
        let n = self.positions.len();
        *self.positions.get_mut(v).ok_or_else(|| Error::InvalidParameter(format!("vertex {v} does not exist ({n} vertices)")))? = p;
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod fixtures {
    use super::*;

    /// Axis-aligned unit cube centred at the origin, 6 outward quads.
    pub fn cube() -> Mesh {
        let p = [[-1., -1., -1.], [1., -1., -1.], [1., 1., -1.], [-1., 1., -1.], [-1., -1., 1.], [1., -1., 1.], [1., 1., 1.], [-1., 1., 1.]];
        let positions = p.iter().map(|a| Vec3::from_array(*a) * 0.5).collect();
        let quads = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]];
        Mesh::new(positions, &[4; 6], quads.iter().flatten().copied().collect(), None).unwrap()
    }

    /// An open n x n grid of unit quads in the z = 0 plane, normals +z.
    pub fn grid(n: u32) -> Mesh {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                positions.push(Vec3::new(i as f32, j as f32, 0.0));
            }
        }
        let mut corners = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                corners.extend([a, a + 1, a + n + 2, a + n + 1]);
            }
        }
        Mesh::new(positions, &vec![4; (n * n) as usize], corners, None).unwrap()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_out_of_range_index() {
        let e = Mesh::new(vec![Vec3::ZERO; 3], &[3], vec![0, 1, 3], None).unwrap_err();
        assert!(e.to_string().contains("vertex 3"), "{e}");
    }

    #[test]
    fn rejects_short_faces_and_count_mismatch() {
        assert!(Mesh::new(vec![Vec3::ZERO; 3], &[2], vec![0, 1], None).is_err());
        assert!(Mesh::new(vec![Vec3::ZERO; 3], &[3], vec![0, 1], None).is_err());
    }

    #[test]
    fn rejects_non_finite_coordinates() {
        let e = Mesh::new(vec![Vec3::ZERO, Vec3::new(f32::NAN, 0., 0.), Vec3::X], &[3], vec![0, 1, 2], None).unwrap_err();
        assert!(matches!(e, Error::NonFinite { index: 1, .. }), "{e}");
    }

    #[test]
    fn rejects_uv_length_mismatch() {
        let e = Mesh::new(vec![Vec3::ZERO; 3], &[3], vec![0, 1, 2], Some(vec![Vec2::ZERO; 2])).unwrap_err();
        assert!(e.to_string().contains("2 UVs"));
    }

    #[test]
    fn cube_bounds_and_faces() {
        let m = fixtures::cube();
        assert_eq!(m.face_count(), 6);
        assert_eq!(m.face(1), &[4, 5, 6, 7]);
        assert!((m.bbox_diagonal() - 3f32.sqrt()).abs() < 1e-6);
        assert!(Mesh::default().require_faces().is_err());
    }
}
