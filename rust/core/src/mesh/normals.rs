//! Vertex normals weighted by corner angle (Thürmer & Wüthrich), the same weighting
//! Blender uses, so an offset along them matches Solidify's "Simple" direction.

use super::Mesh;
use glam::Vec3;

/// Unit angle-weighted vertex normals. Vertices without a non-degenerate adjacent
/// face (loose vertices, vertices of zero-area faces only) get `Vec3::ZERO`.
pub fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let p = mesh.positions();
    let mut n = vec![Vec3::ZERO; p.len()];
    for face in mesh.faces() {
        add_face(p, face, |i, w| n[face[i] as usize] += w);
    }
    n.iter_mut().for_each(|v| *v = v.normalize_or_zero());
    n
}

/// The normal of vertex `v` from the faces around it (`faces`, indices into the
/// mesh): [`vertex_normals`] for one vertex, after a local edit.
pub fn vertex_normal(mesh: &Mesh, v: u32, faces: &[u32]) -> Vec3 {
    let mut n = Vec3::ZERO;
    for &f in faces {
        let face = mesh.face(f as usize);
        add_face(mesh.positions(), face, |i, w| {
            if face[i] == v {
                n += w
            }
        });
    }
    n.normalize_or_zero()
}

/// Calls `add(corner, weighted normal)` for each corner of a non-degenerate face.
fn add_face(p: &[Vec3], face: &[u32], mut add: impl FnMut(usize, Vec3)) {
    // Corners on the stack for faces of up to 8 (no allocation per face).
    let mut small = [Vec3::ZERO; 8];
    let large: Vec<Vec3>;
    let pts: &[Vec3] = if face.len() <= small.len() {
        small.iter_mut().zip(face).for_each(|(s, &i)| *s = p[i as usize]);
        &small[..face.len()]
    } else {
        large = face.iter().map(|&i| p[i as usize]).collect();
        &large
    };
    let fnorm = super::triangulate::newell_normal(pts).normalize_or_zero();
    if fnorm == Vec3::ZERO {
        return;
    }
    let k = face.len();
    for i in 0..k {
        let prev = pts[(i + k - 1) % k] - pts[i];
        let next = pts[(i + 1) % k] - pts[i];
        let angle = prev.angle_between(next);
        if angle.is_finite() {
            add(i, fnorm * angle);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures;

    #[test]
    fn cube_corner_normals_point_along_diagonals() {
        let m = fixtures::cube();
        for (p, n) in m.positions().iter().zip(vertex_normals(&m)) {
            assert!((n - p.normalize()).length() < 1e-5, "{p} {n}");
        }
    }

    #[test]
    fn loose_vertex_gets_zero_normal() {
        let mut p = fixtures::grid(1).positions().to_vec();
        p.push(Vec3::splat(9.0));
        let m = Mesh::new(p, &[4], vec![0, 1, 3, 2], None).unwrap();
        let n = vertex_normals(&m);
        assert_eq!(n[4], Vec3::ZERO);
        assert!((n[0] - Vec3::Z).length() < 1e-6);
    }
}
