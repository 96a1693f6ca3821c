//! What is odd about a mesh, counted: the report users see before a shell is built.

use super::{EdgeMap, Mesh};

/// Counts of everything that can make a shell or offset questionable.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct MeshReport {
    pub vertices: usize,
    pub faces: usize,
    pub triangles: usize,
    pub ngons: usize,
    pub degenerate_faces: usize,
    pub loose_vertices: usize,
    pub boundary_edges: usize,
    pub non_manifold_edges: usize,
}

impl MeshReport {
    pub fn of(mesh: &Mesh) -> Self {
        let p = mesh.positions();
        let diag = mesh.bbox_diagonal().max(f32::MIN_POSITIVE);
        let area_eps = (diag * 1e-7).powi(2);
        let mut used = vec![false; p.len()];
        let mut degenerate_faces = 0;
        for face in mesh.faces() {
            face.iter().for_each(|&v| used[v as usize] = true);
            let pts: Vec<_> = face.iter().map(|&i| p[i as usize]).collect();
            let area2 = super::triangulate::newell_normal(&pts).length();
            let repeated = (0..face.len()).any(|i| face[i] == face[(i + 1) % face.len()]);
            if repeated || area2 <= area_eps {
                degenerate_faces += 1;
            }
        }
        let edges = EdgeMap::of(mesh);
        Self {
            vertices: p.len(),
            faces: mesh.face_count(),
            triangles: mesh.faces().map(|f| f.len() - 2).sum(),
            ngons: mesh.faces().filter(|f| f.len() > 4).count(),
            degenerate_faces,
            loose_vertices: used.iter().filter(|u| !**u).count(),
            boundary_edges: edges.count_with(|n| n == 1),
            non_manifold_edges: edges.count_with(|n| n > 2),
        }
    }

    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0 && self.non_manifold_edges == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn counts_oddities() {
        // Three triangles sharing edge 0-1 (non-manifold), one degenerate, one loose vertex.
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, -Vec3::Y, Vec3::X * 2.0, Vec3::splat(5.0)];
        let m = Mesh::new(p, &[3, 3, 3, 3], vec![0, 1, 2, 1, 0, 3, 0, 1, 4, 0, 1, 5], None).unwrap();
        let r = m.report();
        assert_eq!(r.faces, 4);
        assert_eq!(r.non_manifold_edges, 1);
        assert_eq!(r.degenerate_faces, 1);
        assert_eq!(r.loose_vertices, 1);
        assert!(!r.is_closed_manifold());
    }

    #[test]
    fn cube_is_closed() {
        let r = crate::mesh::fixtures::cube().report();
        assert!(r.is_closed_manifold());
        assert_eq!((r.vertices, r.faces, r.triangles, r.ngons), (8, 6, 12, 0));
    }
}
