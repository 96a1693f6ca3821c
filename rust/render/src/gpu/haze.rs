//! Which cells the transparency pass of double mipmaps draws (chapter 6.5.2), and in
//! what order. Only cells that can read a level at or past the one where the
//! transparency chain starts (the transition level minus its fade-in level): near
//! cells, whose texels are all larger than a pixel, would only discard fragments;
//! leaving them out keeps close views as cheap as without mipmaps.
//!
//! Blending wants back to front. The paper draws layer by layer from the base
//! outward, which is back to front where the shell faces the camera; where it faces
//! away (the far side of a closed object, seen through its holes) the layers are
//! drawn from the outer one inward instead, and those cells first. Within each group
//! cells go from far to near.

use glam::Vec3;
use rayon::prelude::*;
use thicket_core::texture::CellMap;

use thicket_core::raycast::Camera;

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

/// The cells the transparency pass draws: facing away from the camera (layers drawn
/// outer first) and facing it (base first), each from far to near.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HazeOrder {
    pub away: Vec<u32>,
    pub facing: Vec<u32>,
}

/// The cells whose farthest point reads level `first_level` or coarser for a texture
/// of `texels` per tile side (`bounds`: each cell's box), in drawing order.
pub fn draw_order(cells: &[CellMap], bounds: &[(Vec3, Vec3)], camera: &Camera, texels: f32, first_level: f32) -> HazeOrder {
    let perspective = !camera.is_orthographic();
    let pixel_scale = 2.0 / (camera.projection.y_axis.y * camera.height as f32);
    let view_z = camera.view.row(2);
    let inverse = camera.view.inverse();
    let (eye, forward) = (inverse.transform_point3(Vec3::ZERO), inverse.transform_vector3(Vec3::NEG_Z));
    let mut drawn: Vec<(f32, bool, u32)> = cells
        .par_iter()
        .zip(bounds)
        .enumerate()
        .filter_map(|(k, (cell, (lo, hi)))| {
            let (centre, radius) = ((*lo + *hi) * 0.5, (*hi - *lo).length() * 0.5);
            let depth = -(view_z.truncate().dot(centre) + view_z.w);
            if cell_lod(cell, depth + radius, pixel_scale, perspective) + texels.log2() < first_level {
                return None;
            }
            let toward_eye = if perspective { eye - centre } else { -forward };
            let outward = cell.director[0] + cell.director[1] + cell.director[2];
            Some((depth, outward.dot(toward_eye) > 0.0, k as u32))
        })
        .collect();
    drawn.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    let (facing, away): (Vec<_>, Vec<_>) = drawn.into_iter().partition(|d| d.1);
    HazeOrder { away: away.into_iter().map(|d| d.2).collect(), facing: facing.into_iter().map(|d| d.2).collect() }
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
        assert_eq!(draw_order(&cells, &bounds, &camera, 64.0, 5.0).facing, vec![1]);
        // Both face the camera (directors along +z, the eye above): far one first.
        assert_eq!(draw_order(&cells, &bounds, &camera, 64.0, 1.0), HazeOrder { away: vec![], facing: vec![1, 0] });
        // Seen from below, they face away.
        let below = Camera::new(
            Mat4::look_at_rh(Vec3::new(0.0, 0.0, -400.0), Vec3::ZERO, Vec3::Y),
            Mat4::perspective_rh_gl(std::f32::consts::FRAC_PI_2, 1.0, 0.1, 1000.0),
            100,
            100,
        )
        .unwrap();
        assert_eq!(draw_order(&cells, &bounds, &below, 64.0, 1.0), HazeOrder { away: vec![0, 1], facing: vec![] });
    }
}
