//! Which cells the transparency pass of double mipmaps draws (chapter 6.5.2): those
//! that can read a level at or past the one where the transparency chain starts
//! (the transition level minus its fade-in level). Near cells, whose texels are all
//! larger than a pixel, would only discard fragments there; leaving them out keeps
//! close views as cheap as without mipmaps.

use glam::Vec3;
use rayon::prelude::*;
use thicket_core::texture::CellMap;

use crate::camera::Camera;

/// The mip level of detail the shader's `cell_lod` gives a fragment of `cell` at view
/// depth `depth`, before adding the texture's `log2(texels per tile side)`.
pub fn cell_lod(cell: &CellMap, depth: f32, pixel_scale: f32, perspective: bool) -> f32 {
    let mid = |k: usize| cell.base[k] + 0.5 * cell.director[k];
    let world = (mid(1) - mid(0)).cross(mid(2) - mid(0)).length();
    let (ds, dt) = (cell.st[1] - cell.st[0], cell.st[2] - cell.st[0]);
    let tiles = (ds.x * dt.y - ds.y * dt.x).abs();
    let pixel = pixel_scale * if perspective { depth.max(0.0) } else { 1.0 };
    (pixel * (tiles / world.max(1e-30)).sqrt()).max(1e-30).log2()
}

/// Indices of the cells whose farthest point reads level `first_level` or coarser
/// for a texture of `texels` per tile side (`bounds`: each cell's box).
pub fn cells_reaching(cells: &[CellMap], bounds: &[(Vec3, Vec3)], camera: &Camera, texels: f32, first_level: f32) -> Vec<u32> {
    let perspective = !camera.is_orthographic();
    let pixel_scale = 2.0 / (camera.projection.y_axis.y * camera.height as f32);
    let view_z = camera.view.row(2);
    cells
        .par_iter()
        .zip(bounds)
        .enumerate()
        .filter(|(_, (cell, (lo, hi)))| {
            let (centre, radius) = ((*lo + *hi) * 0.5, (*hi - *lo).length() * 0.5);
            let far = -(view_z.truncate().dot(centre) + view_z.w) + radius;
            cell_lod(cell, far, pixel_scale, perspective) + texels.log2() >= first_level
        })
        .map(|(k, _)| k as u32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec2};

    fn unit_cell(offset: Vec3) -> CellMap {
        CellMap {
            count: 3,
            base: [offset, offset + Vec3::X, offset + Vec3::Y, Vec3::ZERO],
            director: [Vec3::Z * 0.1; 4],
            st: [Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ZERO],
        }
    }

    #[test]
    fn far_cells_read_coarser_levels() {
        // A unit tile 10 units away, 90 degree view over 100 pixels: a pixel spans
        // 0.2 units, a 64-texel tile 64 / 5 texels per pixel: level log2(12.8).
        let camera = Camera::new(
            Mat4::look_at_rh(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y),
            Mat4::perspective_rh_gl(std::f32::consts::FRAC_PI_2, 1.0, 0.1, 100.0),
            100,
            100,
        )
        .unwrap();
        let pixel_scale = 2.0 / (camera.projection.y_axis.y * 100.0);
        let lod = cell_lod(&unit_cell(Vec3::ZERO), 10.0, pixel_scale, true) + 64f32.log2();
        assert!((lod - 12.8f32.log2()).abs() < 1e-4, "{lod}");
        let cells = [unit_cell(Vec3::ZERO), unit_cell(Vec3::new(0.0, 0.0, -300.0))];
        let bounds: Vec<_> = cells.iter().map(|c| (c.base[0], c.base[0] + Vec3::new(1.0, 1.0, 0.1))).collect();
        // Level 5: only the far cell (300 units farther) reaches it.
        assert_eq!(cells_reaching(&cells, &bounds, &camera, 64.0, 5.0), vec![1]);
        assert_eq!(cells_reaching(&cells, &bounds, &camera, 64.0, 1.0), vec![0, 1]);
    }
}
