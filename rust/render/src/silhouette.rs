//! Silhouettes: which pixels a triangle mesh or a rendered frame covers, and their
//! intersection over union. [`bake_iou`] compares a baked mesh with the reference
//! render of the textured shell it came from, seen by the same camera: the bake's
//! fidelity to the texture, measured where it shows.
//!
//! Mesh pixels use the reference renderer's rays (pixel centres, near plane to far
//! plane), so the two masks differ only where the surfaces do.

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use thicket_core::shell::Shell;
use thicket_core::spatial::Bvh;
use thicket_core::texture::{BakeParams, TextureLayer, TexturedShell};
use thicket_core::{Mesh, Result};

use crate::image_out::Frame;
use crate::reference::{self, RenderParams};
use crate::scene::ShellScene;
use thicket_core::raycast::{Camera, PixelRays};

/// Per pixel (row 0 at the top), whether its ray meets any of `triangles` between the
/// near and the far plane. Degenerate triangles and those with an index out of range
/// are ignored; a camera whose matrices cannot be inverted sees nothing.
pub fn mesh_coverage(positions: &[Vec3], triangles: &[[u32; 3]], camera: &Camera) -> Vec<bool> {
    let (width, height) = (camera.width as usize, camera.height as usize);
    let mut covered = vec![false; width * height];
    let (Ok(rays), Some(tris)) = (PixelRays::new(camera), Triangles::new(positions, triangles)) else {
        return covered;
    };
    covered.par_chunks_mut(width.max(1)).enumerate().for_each(|(y, row)| {
        for (x, c) in row.iter_mut().enumerate() {
            *c = rays.ray(x, y).is_some_and(|(origin, dir, t_far)| tris.any_hit(origin, dir, t_far));
        }
    });
    covered
}

/// Per pixel, whether the reference renderer's frame shows a surface (alpha > 0.5).
pub fn frame_coverage(frame: &Frame) -> Vec<bool> {
    frame.rgba.iter().map(|c| c.w > 0.5).collect()
}

/// Share of the pixels a mask covers (0 for an empty image).
pub fn coverage(mask: &[bool]) -> f64 {
    mask.iter().filter(|c| **c).count() as f64 / mask.len().max(1) as f64
}

/// Intersection over union of two masks of the same image; 1 when both are empty.
///
/// # Panics
/// When the masks differ in length.
pub fn iou(a: &[bool], b: &[bool]) -> f64 {
    assert_eq!(a.len(), b.len(), "the masks must cover the same image");
    let (inter, union) = a.iter().zip(b).fold((0usize, 0usize), |(i, u), (a, b)| (i + usize::from(*a && *b), u + usize::from(*a || *b)));
    if union == 0 {
        1.0
    } else {
        inter as f64 / union as f64
    }
}

/// The silhouettes of a bake and of the reference render of its shell.
#[derive(Debug, Clone, PartialEq)]
pub struct Silhouettes {
    pub reference: Vec<bool>,
    pub baked: Vec<bool>,
}

impl Silhouettes {
    pub fn iou(&self) -> f64 {
        iou(&self.reference, &self.baked)
    }
}

/// The silhouettes of the baked mesh `baked` (positions, triangles) and of the
/// reference render of `textures` in `shell` over `mesh` with the bake's own `params`
/// (tiling, region, holes, cutter, moved region: one [`TexturedShell`]), both seen by
/// `camera`; `step` is the reference's march step ([`RenderParams::step`], a fraction
/// of the shell thickness).
pub fn bake_silhouettes(
    mesh: &Mesh,
    shell: &Shell,
    textures: &[TextureLayer],
    params: &BakeParams,
    baked: (&[Vec3], &[[u32; 3]]),
    camera: &Camera,
    step: f32,
) -> Result<Silhouettes> {
    let textured = TexturedShell::new(mesh.clone(), shell.clone(), textures.to_vec(), params.clone())?;
    let scene = ShellScene::of(&textured)?;
    let frame = reference::render(&scene, camera, &RenderParams { step, ..Default::default() })?;
    Ok(Silhouettes { reference: frame_coverage(&frame), baked: mesh_coverage(baked.0, baked.1, camera) })
}

/// The intersection over union of [`bake_silhouettes`].
#[allow(clippy::too_many_arguments)]
pub fn bake_iou(
    mesh: &Mesh,
    shell: &Shell,
    textures: &[TextureLayer],
    params: &BakeParams,
    baked_positions: &[Vec3],
    baked_triangles: &[[u32; 3]],
    camera: &Camera,
    step: f32,
) -> Result<f64> {
    Ok(bake_silhouettes(mesh, shell, textures, params, (baked_positions, baked_triangles), camera, step)?.iou())
}

/// Triangles for any-hit ray queries, over the shared [`Bvh`] of their boxes.
struct Triangles {
    bvh: Bvh,
    /// The usable triangles' corners (the tree's items).
    corners: Vec<[Vec3; 3]>,
}

impl Triangles {
    /// `None` when no triangle is usable.
    fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<Self> {
        let corners: Vec<[Vec3; 3]> = triangles
            .par_iter()
            .filter_map(|t| {
                let c = [positions.get(t[0] as usize)?, positions.get(t[1] as usize)?, positions.get(t[2] as usize)?];
                let c = c.map(|p| *p);
                let area = (c[1] - c[0]).cross(c[2] - c[0]).length_squared();
                (c.iter().all(|p| p.is_finite()) && area > 0.0).then_some(c)
            })
            .collect();
        if corners.is_empty() {
            return None;
        }
        // Boxes padded by a relative epsilon, so rounding never drops a grazed triangle.
        let boxes = corners
            .par_iter()
            .map(|c| {
                let (lo, hi) = (c[0].min(c[1]).min(c[2]).as_dvec3(), c[0].max(c[1]).max(c[2]).as_dvec3());
                let pad = 1e-6 * (hi - lo).max_element() + 1e-12;
                (lo - pad, hi + pad)
            })
            .collect();
        Some(Self { bvh: Bvh::from_boxes(boxes), corners })
    }

    /// Whether the ray `origin + t dir`, `t ∈ [0, t_far]`, meets any triangle.
    fn any_hit(&self, origin: DVec3, dir: DVec3, t_far: f64) -> bool {
        self.bvh.any_on_ray(origin, dir, t_far, |i, _, _| ray_meets_triangle(origin, dir, t_far, &self.corners[i as usize]))
    }
}

/// Möller–Trumbore in double precision, edges included, `t ∈ [0, t_far]`.
#[inline]
fn ray_meets_triangle(origin: DVec3, dir: DVec3, t_far: f64, c: &[Vec3; 3]) -> bool {
    let a = c[0].as_dvec3();
    let (e1, e2) = (c[1].as_dvec3() - a, c[2].as_dvec3() - a);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return false;
    }
    let s = origin - a;
    let u = s.dot(p) / det;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) / det;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    (0.0..=t_far).contains(&(e2.dot(q) / det))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec2};
    use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
    use thicket_core::testmeshes as tm;
    use thicket_core::texture::bake::MovedRegion;
    use thicket_core::texture::VolumeTexture;

    /// An orthographic camera on +Z looking down at the origin: 4 world units across
    /// `size` pixels.
    fn ortho_camera(size: u32) -> Camera {
        let view = Mat4::look_at_rh(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
        Camera::new(view, Mat4::orthographic_rh_gl(-2.0, 2.0, -2.0, 2.0, 0.1, 100.0), size, size).unwrap()
    }

    #[test]
    fn a_triangle_head_on_covers_its_projected_area() {
        // A triangle with no edge along the pixel grid (aligned edges bias the count).
        let tri = [Vec3::new(-1.1, -0.9, 0.0), Vec3::new(1.3, -1.2, 0.0), Vec3::new(0.2, 1.1, 0.0)];
        let area = 0.5 * (tri[1] - tri[0]).cross(tri[2] - tri[0]).length() as f64;
        let count = |mask: &[bool]| mask.iter().filter(|c| **c).count() as f64;
        // Orthographic, 25 pixels per unit.
        let camera = ortho_camera(100);
        let mask = mesh_coverage(&tri, &[[0, 1, 2]], &camera);
        let expected = area * 625.0;
        assert!((count(&mask) - expected).abs() < 0.02 * expected, "{} pixels, expected {expected}", count(&mask));
        // Either winding; behind the camera or past the far plane, nothing.
        assert_eq!(mesh_coverage(&tri, &[[0, 2, 1]], &camera), mask);
        let behind = tri.map(|p| p + Vec3::Z * 6.0);
        assert!(!mesh_coverage(&behind, &[[0, 1, 2]], &camera).contains(&true));
        // Perspective, 2 units away with a vertical field of view of 0.8: the scale is
        // 50 / (2 tan 0.4) pixels per unit.
        let view = Mat4::look_at_rh(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, Vec3::Y);
        let camera = Camera::new(view, Mat4::perspective_rh_gl(0.8, 1.0, 0.01, 10.0), 100, 100).unwrap();
        let mask = mesh_coverage(&tri.map(|p| p * 0.5), &[[0, 1, 2]], &camera);
        let expected = 0.25 * area * (50.0 / (2.0 * 0.4f64.tan())).powi(2);
        assert!((count(&mask) - expected).abs() < 0.02 * expected, "{} pixels, expected {expected}", count(&mask));
    }

    #[test]
    fn row_zero_is_the_top() {
        // Seen from +Z with +Y up, a triangle spanning y in [0.51, 1.51] covers the
        // rows whose centres `2 - (row + 0.5) / 25` it spans.
        let tri = [Vec3::new(-0.5, 0.51, 0.0), Vec3::new(0.5, 0.51, 0.0), Vec3::new(0.0, 1.51, 0.0)];
        let mask = mesh_coverage(&tri, &[[0, 1, 2]], &ortho_camera(100));
        let rows: Vec<usize> = (0..100).filter(|y| mask[y * 100..(y + 1) * 100].contains(&true)).collect();
        assert!(rows.first() == Some(&13) && rows.last() == Some(&36), "{rows:?}");
    }

    #[test]
    fn the_bvh_agrees_with_brute_force() {
        let mesh = tm::bumpy_head(3);
        let tris: Vec<[u32; 3]> = mesh.faces().map(|f| [f[0], f[1], f[2]]).collect();
        let positions = mesh.positions();
        let view = Mat4::look_at_rh(Vec3::new(1.5, -2.5, 1.0), Vec3::ZERO, Vec3::Z);
        let camera = Camera::new(view, Mat4::perspective_rh_gl(0.9, 1.0, 0.01, 10.0), 64, 64).unwrap();
        let mask = mesh_coverage(positions, &tris, &camera);
        let rays = PixelRays::new(&camera).unwrap();
        let corners: Vec<[Vec3; 3]> = tris.iter().map(|t| t.map(|i| positions[i as usize])).collect();
        for y in 0..64 {
            for x in 0..64 {
                let (o, d, t_far) = rays.ray(x, y).unwrap();
                let brute = corners.iter().any(|c| ray_meets_triangle(o, d, t_far, c));
                assert_eq!(mask[y * 64 + x], brute, "pixel ({x}, {y})");
            }
        }
        let share = coverage(&mask);
        assert!(share > 0.2 && share < 0.9, "coverage {share}");
        // Bad input: nothing usable, nothing covered.
        assert!(!mesh_coverage(positions, &[[0, 0, 1], [0, 1, 99_999_999]], &camera).contains(&true));
        assert!(!mesh_coverage(&[], &[], &camera).contains(&true));
    }

    #[test]
    fn iou_basics() {
        assert_eq!(iou(&[], &[]), 1.0);
        assert_eq!(iou(&[false; 4], &[false; 4]), 1.0);
        assert_eq!(iou(&[true, false, true], &[true, false, true]), 1.0);
        assert_eq!(iou(&[true, false], &[false, true]), 0.0);
        assert!((iou(&[true, true, false], &[false, true, true]) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(coverage(&[true, false, false, false]), 0.25);
    }

    #[test]
    fn bake_iou_of_the_surface_itself_is_near_one() {
        // A slab texture on an exterior icosphere(3) shell: its surface is the sphere
        // of radius 1 + 15.5/32 h, which a fine icosphere stands in for.
        let mesh = tm::icosphere(3);
        let h = 0.1 * mesh.bbox_diagonal();
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let slab = VolumeTexture::from_fn([4, 4, 33], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
        let layers = [TextureLayer { texture: slab, offset: Vec2::ZERO }];
        let sphere = tm::icosphere(5);
        let r = 1.0 + 15.5 / 32.0 * h;
        let positions: Vec<Vec3> = sphere.positions().iter().map(|p| *p * r).collect();
        let tris: Vec<[u32; 3]> = sphere.faces().map(|f| [f[0], f[1], f[2]]).collect();
        let view = Mat4::look_at_rh(Vec3::new(0.5, -4.0, 0.3), Vec3::ZERO, Vec3::Z);
        let camera = Camera::new(view, Mat4::perspective_rh_gl(0.8, 1.0, 0.01, 100.0), 96, 96).unwrap();
        let s = bake_silhouettes(&mesh, &shell, &layers, &BakeParams::default(), (&positions, &tris), &camera, 0.05).unwrap();
        assert!(coverage(&s.reference) > 0.3);
        assert!(s.iou() > 0.97, "IoU {}", s.iou());
        // A smaller sphere: the IoU falls to the ratio of the projected discs' areas,
        // `ρ² / (D² − ρ²)` each for a sphere of radius `ρ` at distance `D`.
        let small: Vec<Vec3> = positions.iter().map(|p| *p * 0.8).collect();
        let i = bake_iou(&mesh, &shell, &layers, &BakeParams::default(), &small, &tris, &camera, 0.05).unwrap();
        let disc = |rho: f32| rho * rho / (Vec3::new(0.5, -4.0, 0.3).length_squared() - rho * rho);
        let expected = (disc(0.8 * r) / disc(r)) as f64;
        assert!((i - expected).abs() < 0.03, "IoU {i}, expected {expected}");
    }

    /// Silhouette IoUs of a bake of `params` against the reference with the same
    /// params (preview = bake) and against the reference of the textures as placed.
    fn with_and_without(mesh: &Mesh, shell: &Shell, layers: &[TextureLayer], params: &BakeParams, camera: &Camera) -> (f64, f64) {
        let b = thicket_core::texture::bake(mesh, shell, layers, params).unwrap();
        let baked = (&b.positions[..], &b.triangles[..]);
        let placed = BakeParams { tiling: params.tiling, ..Default::default() };
        let same = bake_silhouettes(mesh, shell, layers, params, baked, camera, 0.02).unwrap();
        let plain = bake_silhouettes(mesh, shell, layers, &placed, baked, camera, 0.02).unwrap();
        assert!(coverage(&same.baked) > 0.02, "the bake shows");
        (same.iou(), plain.iou())
    }

    #[test]
    fn the_reference_shows_region_holes_cutter_and_moved_region_as_the_bake_does() {
        // Preview = bake: the reference renderer applies the stack's effects through
        // the bake's own definition. Each effect changes the silhouette (the plain
        // reference disagrees with the bake), and the reference with the effect agrees.
        let mesh = tm::icosphere(3);
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let slab = VolumeTexture::from_fn([8, 8, 17], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
        let layers = [TextureLayer { texture: slab, offset: Vec2::ZERO }];
        let view = Mat4::look_at_rh(Vec3::new(0.4, -4.0, 0.6), Vec3::ZERO, Vec3::Z);
        let camera = Camera::new(view, Mat4::perspective_rh_gl(0.8, 1.0, 0.01, 100.0), 96, 96).unwrap();
        let upper: Vec<f32> = mesh.positions().iter().map(|p| if p.z > 0.2 { 1.0 } else { 0.0 }).collect();
        let box_corners: Vec<Vec3> =
            (0..8).map(|i| Vec3::new(if i & 1 == 0 { -2.0 } else { 0.3 }, if i & 2 == 0 { -2.0 } else { 2.0 }, if i & 4 == 0 { -2.0 } else { 2.0 })).collect();
        let box_faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let box_tris: Vec<[u32; 3]> = box_faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect();
        let cases = [
            ("holes", BakeParams { holes: Some(upper.clone()), ..Default::default() }),
            ("region", BakeParams { region: Some(upper.iter().map(|w| 1.0 - w).collect()), ..Default::default() }),
            ("cutter", BakeParams { cutter: Some(thicket_core::texture::bake::Cutter::new(&box_corners, &box_tris).unwrap()), ..Default::default() }),
        ];
        for (what, params) in cases {
            let (same, plain) = with_and_without(&mesh, &shell, &layers, &params, &camera);
            eprintln!("{what}: same {same:.3} plain {plain:.3}");
            assert!(same > 0.95, "{what}: the reference with the effect against the bake: IoU {same}");
            assert!(plain < same - 0.05, "{what}: the effect must show: IoU {plain} without it, {same} with it");
        }
        // A moved region (needs UVs): stripes along s on a plane seen from above, the
        // stripes over x < 0 moved by a quarter period.
        let grid = tm::plane(12);
        let uvs: Vec<Vec2> = grid.corners().iter().map(|&v| grid.positions()[v as usize].truncate() * 0.5 + 0.5).collect();
        let grid = Mesh::new(grid.positions().to_vec(), &grid.face_sizes(), grid.corners().to_vec(), Some(uvs)).unwrap();
        let t = Thickness::relative(0.05).per_vertex(&grid, None).unwrap();
        let shell = build_shell(&grid, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let stripes = VolumeTexture::from_fn([16, 16, 9], |c| if c.x < 0.5 && c.z < 0.6 { 1.0 } else { 0.0 }).unwrap();
        let layers = [TextureLayer { texture: stripes, offset: Vec2::ZERO }];
        let left: Vec<f32> = grid.positions().iter().map(|p| if p.x < -0.05 { 1.0 } else { 0.0 }).collect();
        let params = BakeParams { tiling: 3.0, moved: Some(MovedRegion { weights: left, offset: Vec2::new(0.25 / 3.0, 0.0) }), ..Default::default() };
        let view = Mat4::look_at_rh(Vec3::new(0.0, -0.3, 3.0), Vec3::ZERO, Vec3::Y);
        let camera = Camera::new(view, Mat4::perspective_rh_gl(0.7, 1.0, 0.01, 100.0), 96, 96).unwrap();
        let (same, plain) = with_and_without(&grid, &shell, &layers, &params, &camera);
        eprintln!("moved: same {same:.3} plain {plain:.3}");
        assert!(same > 0.9, "moved region: IoU {same}");
        assert!(plain < same - 0.05, "moved region must show: IoU {plain} without it, {same} with it");
    }
}
