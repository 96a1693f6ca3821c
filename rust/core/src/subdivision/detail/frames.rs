//! Local frames of a level's vertices (section 2: details are stored "in local frames
//! computed from the coarser level"): the vertex normal `n`, a tangent `t` towards the
//! vertex's first neighbour (the vertex after it in the first face that holds it),
//! projected to the tangent plane, and `b = n × t`, so (t, b, n) is right-handed.
//!
//! [`super::subdivide`] keeps the first face and the first neighbour's direction from level
//! to level: vertex `v`'s first face at the finer level is the child of its first corner,
//! and the vertex after `v` there is the edge point of the same edge. A base vertex's frame
//! therefore turns only as the surface does.

use glam::{DVec3, Vec3};

/// An orthonormal frame: tangent, bitangent, normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub t: DVec3,
    pub b: DVec3,
    pub n: DVec3,
}

impl Frame {
    /// The frame of normal `n` whose tangent is `towards` projected to the tangent plane,
    /// or, when that is too short (a neighbour along the normal, a zero normal), the world
    /// axis least aligned with `n` projected instead (the charts' frame).
    pub fn new(n: DVec3, towards: DVec3) -> Self {
        let n = if n.length_squared() > 0.0 { n.normalize() } else { DVec3::Z };
        let along = towards - n * towards.dot(n);
        let t = if along.length() > 1e-9 * towards.length() && along.length() > 0.0 { along.normalize() } else { crate::texture::charts::frame(n).0 };
        Frame { t, b: n.cross(t), n }
    }

    /// `local` (components along t, b, n) in world coordinates.
    pub fn to_world(&self, local: DVec3) -> DVec3 {
        self.t * local.x + self.b * local.y + self.n * local.z
    }

    /// `world` in this frame's components (t, b, n).
    pub fn to_local(&self, world: DVec3) -> DVec3 {
        DVec3::new(world.dot(self.t), world.dot(self.b), world.dot(self.n))
    }
}

/// The first neighbour of every vertex: the vertex after it in the first face that holds it
/// (itself for a vertex in no face).
pub fn first_neighbours(faces: impl Iterator<Item = impl AsRef<[u32]>>, vertex_count: usize) -> Vec<u32> {
    let mut next: Vec<u32> = (0..vertex_count as u32).collect();
    let mut seen = vec![false; vertex_count];
    for face in faces {
        let face = face.as_ref();
        for (k, &v) in face.iter().enumerate() {
            if !seen[v as usize] {
                seen[v as usize] = true;
                next[v as usize] = face[(k + 1) % face.len()];
            }
        }
    }
    next
}

/// The frames of `vertices` of a mesh with `positions`, `normals` and first neighbours
/// `next` (from [`first_neighbours`]).
pub fn frames_of(positions: &[Vec3], normals: &[Vec3], next: &[u32], vertices: &[u32]) -> Vec<Frame> {
    vertices.iter().map(|&v| frame_at(positions, normals, next, v as usize)).collect()
}

/// Vertex `v`'s frame: its normal, its tangent towards its first neighbour `next[v]`.
fn frame_at(positions: &[Vec3], normals: &[Vec3], next: &[u32], v: usize) -> Frame {
    Frame::new(normals[v].as_dvec3(), positions[next[v] as usize].as_dvec3() - positions[v].as_dvec3())
}

/// The frame of every vertex of `mesh` with vertex normals `normals` ([`frames_of`] for all
/// of them, in parallel).
pub fn all_frames(mesh: &crate::Mesh, normals: &[Vec3]) -> Vec<Frame> {
    use rayon::prelude::*;
    let next = first_neighbours(mesh.faces(), mesh.vertex_count());
    (0..mesh.vertex_count()).into_par_iter().map(|v| frame_at(mesh.positions(), normals, &next, v)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::vertex_normals;
    use crate::subdivision::{subdivide, Boundary, Options};

    #[test]
    fn frames_are_orthonormal_right_handed_and_fall_back_off_the_normal() {
        for (n, towards) in [(DVec3::new(0.3, -0.2, 0.9), DVec3::new(1.0, 0.5, 0.0)), (DVec3::Z, DVec3::Z * 2.0), (DVec3::X, DVec3::ZERO)] {
            let f = Frame::new(n, towards);
            assert!((f.n - n.normalize()).length() < 1e-12);
            for (a, b) in [(f.t, f.b), (f.b, f.n), (f.n, f.t)] {
                assert!(a.dot(b).abs() < 1e-12 && (a.length() - 1.0).abs() < 1e-12);
            }
            assert!((f.t.cross(f.b) - f.n).length() < 1e-12);
            let v = DVec3::new(0.2, -1.5, 0.7);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-12);
        }
        // A tangent wanted towards t = (1, 1, 0) on the plane z = 0 points there.
        let f = Frame::new(DVec3::Z, DVec3::new(2.0, 2.0, 5.0));
        assert!((f.t - DVec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-12 && (f.b - DVec3::new(-1.0, 1.0, 0.0).normalize()).length() < 1e-12);
    }

    #[test]
    fn a_base_vertex_keeps_its_frame_through_the_levels_of_a_flat_grid() {
        // On a plane subdivision moves nothing off it, and the first neighbour of an inner
        // base vertex at every level is the edge point of the same edge: the frame is the
        // same. (The boundary's smoothing moves its vertices along it.)
        let mut mesh = crate::mesh::fixtures::grid(4);
        let vertices: Vec<u32> = (0..25).filter(|v| !matches!(v % 5, 0 | 4) && !matches!(v / 5, 0 | 4)).collect();
        let frames = |m: &crate::Mesh| frames_of(m.positions(), &vertex_normals(m), &first_neighbours(m.faces(), m.vertex_count()), &vertices);
        let base = frames(&mesh);
        for _ in 0..3 {
            mesh = subdivide(&mesh, &Options { levels: 1, limit: false, boundary: Boundary::SmoothAll }).unwrap().mesh;
            for (v, (a, b)) in base.iter().zip(frames(&mesh)).enumerate() {
                assert!((a.t - b.t).length() < 1e-6 && (a.n - b.n).length() < 1e-6, "vertex {v}: {a:?} then {b:?}");
            }
        }
    }
}
