//! Offset Shell: directors by normal displacement, `d_i = t_i * n_i` with angle-weighted
//! vertex normals. The baseline that the L_p-field shell is measured against (it folds
//! over itself in concavities, chapter 4.1.1); Blender's Solidify "Simple" does the same.

use crate::mesh::vertex_normals;
use crate::Mesh;
use glam::Vec3;
use rayon::prelude::*;

/// One director per vertex: the unit vertex normal times that vertex's signed thickness.
/// Vertices without a defined normal (loose, or only on zero-area faces) get a zero director.
pub fn normal_offset_directors(mesh: &Mesh, thickness: &[f32]) -> Vec<Vec3> {
    assert_eq!(thickness.len(), mesh.vertex_count(), "one thickness per vertex");
    let normals = vertex_normals(mesh);
    normals.par_iter().zip(thickness.par_iter()).map(|(n, t)| *n * *t).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures::{cube, grid};

    #[test]
    fn plane_offsets_straight_up_by_thickness() {
        let m = grid(4);
        let d = normal_offset_directors(&m, &vec![0.25; m.vertex_count()]);
        assert!(d.iter().all(|d| (*d - Vec3::Z * 0.25).length() < 1e-6));
    }

    #[test]
    fn cube_corners_move_along_diagonals_inward_for_negative_thickness() {
        let m = cube();
        let d = normal_offset_directors(&m, &[-0.1; 8]);
        for (p, d) in m.positions().iter().zip(&d) {
            assert!((*d + p.normalize() * 0.1).length() < 1e-6);
        }
    }
}
