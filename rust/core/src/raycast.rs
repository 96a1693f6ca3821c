//! Cameras and the rays through their pixels, one convention for every ray caster
//! (the CPU reference renderer, the silhouettes that measure bakes, and the sphere
//! tracer and discoid ray caster to come): Blender's own view matrix (world to camera;
//! the camera looks down its −Z axis) and projection matrix (OpenGL clip space, as
//! `Object.calc_matrix_camera` returns it, so sensor fit, shift, lens and orthographic
//! scale are all Blender's); pixel `(x, y)` with row 0 at the top of the image, its ray
//! through the pixel's centre from the near plane to the far plane.

use crate::{Error, Result};
use glam::{DMat4, DVec3, Mat4, Vec3, Vec4};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// World to camera.
    pub view: Mat4,
    /// Camera to clip space (OpenGL convention: NDC z in [−1, 1]).
    pub projection: Mat4,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    pub fn new(view: Mat4, projection: Mat4, width: u32, height: u32) -> Result<Self> {
        if width == 0 || height == 0 {
            return Err(Error::InvalidParameter(format!("the viewport is {width}x{height}: nothing to render")));
        }
        if !view.is_finite() || !projection.is_finite() || (projection * view).determinant().abs() < 1e-30 {
            return Err(Error::InvalidParameter("the camera matrices are not invertible".into()));
        }
        Ok(Self { view, projection, width, height })
    }

    /// World to clip space.
    pub fn view_projection(&self) -> Mat4 {
        self.projection * self.view
    }

    /// Orthographic when the projection has no perspective row.
    pub fn is_orthographic(&self) -> bool {
        self.projection.row(3).abs_diff_eq(Vec4::W, 1e-6)
    }

    /// Normalized device coordinates of pixel `(x, y)`'s centre; row 0 is the top of
    /// the image.
    pub fn ndc(&self, x: f32, y: f32) -> (f32, f32) {
        (2.0 * (x + 0.5) / self.width as f32 - 1.0, 1.0 - 2.0 * (y + 0.5) / self.height as f32)
    }

    /// The ray through pixel `(x, y)` (row 0 at the top): origin on the near plane and
    /// unit direction, in world space.
    pub fn ray(&self, x: f32, y: f32) -> (Vec3, Vec3) {
        let (nx, ny) = self.ndc(x, y);
        let inverse = self.view_projection().inverse();
        let near = inverse.project_point3(Vec3::new(nx, ny, -1.0));
        let far = inverse.project_point3(Vec3::new(nx, ny, 1.0));
        (near, (far - near).normalize())
    }

    /// The camera's position in world space (for orthographic cameras, a point on the
    /// view axis).
    pub fn position(&self) -> Vec3 {
        self.view.inverse().transform_point3(Vec3::ZERO)
    }

    /// Depth of world point `p`: its distance in front of the camera along the view axis.
    pub fn depth(&self, p: Vec3) -> f32 {
        -self.view.transform_point3(p).z
    }
}

/// Pixel rays in double precision from the inverse view-projection: the ray casters'
/// form of [`Camera::ray`] (same pixels, same ends).
#[derive(Debug, Clone)]
pub struct PixelRays {
    inverse: DMat4,
    width: f64,
    height: f64,
}

impl PixelRays {
    pub fn new(camera: &Camera) -> Result<Self> {
        let inverse = (camera.projection.as_dmat4() * camera.view.as_dmat4()).inverse();
        if !inverse.is_finite() {
            return Err(Error::InvalidParameter("the camera matrices are not invertible".into()));
        }
        Ok(Self { inverse, width: camera.width as f64, height: camera.height as f64 })
    }

    /// Origin on the near plane, unit direction and distance to the far plane of pixel
    /// `(x, y)` (row 0 at the top); `None` where the projection gives no finite ray.
    pub fn ray(&self, x: usize, y: usize) -> Option<(DVec3, DVec3, f64)> {
        let nx = 2.0 * (x as f64 + 0.5) / self.width - 1.0;
        let ny = 1.0 - 2.0 * (y as f64 + 0.5) / self.height;
        let near = self.inverse.project_point3(DVec3::new(nx, ny, -1.0));
        let far = self.inverse.project_point3(DVec3::new(nx, ny, 1.0));
        let d = far - near;
        let length = d.length();
        (near.is_finite() && length.is_finite() && length > 0.0).then(|| (near, d / length, length))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perspective_and_orthographic_rays() {
        // A camera at (0, -5, 0) looking along +Y (Blender: camera -Z toward the target).
        let view = Mat4::look_at_rh(Vec3::new(0.0, -5.0, 0.0), Vec3::ZERO, Vec3::Z);
        let persp = Camera::new(view, Mat4::perspective_rh_gl(0.8, 2.0, 0.1, 100.0), 200, 100).unwrap();
        assert!(!persp.is_orthographic());
        let (o, d) = persp.ray(99.5, 49.5);
        assert!((d - Vec3::Y).length() < 1e-4, "centre ray {d}");
        assert!((o - Vec3::new(0.0, -4.9, 0.0)).length() < 1e-3, "{o}");
        // Row 0 is the top: its rays point up.
        assert!(persp.ray(100.0, 0.0).1.z > 0.0);
        assert!((persp.position() - Vec3::new(0.0, -5.0, 0.0)).length() < 1e-4);
        assert!((persp.depth(Vec3::ZERO) - 5.0).abs() < 1e-4);
        let ortho = Camera::new(view, Mat4::orthographic_rh_gl(-2.0, 2.0, -1.0, 1.0, 0.1, 100.0), 200, 100).unwrap();
        assert!(ortho.is_orthographic());
        let (o1, d1) = ortho.ray(0.0, 0.0);
        let (_, d2) = ortho.ray(199.0, 99.0);
        assert!((d1 - d2).length() < 1e-5 && (d1 - Vec3::Y).length() < 1e-5);
        assert!((o1.x + 2.0 - 0.01).abs() < 1e-3 && (o1.z - 1.0 + 0.01).abs() < 1e-3, "{o1}");
        assert!(Camera::new(view, Mat4::ZERO, 10, 10).is_err());
        assert!(Camera::new(view, persp.projection, 0, 10).is_err());
    }

    #[test]
    fn pixel_rays_are_the_cameras_rays_in_double_precision_and_end_on_the_far_plane() {
        let view = Mat4::look_at_rh(Vec3::new(1.0, -4.0, 2.0), Vec3::new(0.2, 0.0, 0.1), Vec3::Z);
        for projection in [Mat4::perspective_rh_gl(0.9, 1.5, 0.1, 50.0), Mat4::orthographic_rh_gl(-3.0, 3.0, -2.0, 2.0, 0.1, 50.0)] {
            let camera = Camera::new(view, projection, 60, 40).unwrap();
            let rays = PixelRays::new(&camera).unwrap();
            for (x, y) in [(0, 0), (59, 0), (30, 20), (0, 39), (59, 39)] {
                let (o, d) = camera.ray(x as f32, y as f32);
                let (o64, d64, length) = rays.ray(x, y).unwrap();
                assert!((o64.as_vec3() - o).length() < 1e-4 && (d64.as_vec3() - d).length() < 1e-5, "pixel ({x}, {y})");
                // The far end projects to the same pixel, at depth 1 in NDC.
                let far = camera.view_projection().as_dmat4().project_point3(o64 + d64 * length);
                let (nx, ny) = camera.ndc(x as f32, y as f32);
                assert!((far.x - f64::from(nx)).abs() < 1e-6 && (far.y - f64::from(ny)).abs() < 1e-6 && (far.z - 1.0).abs() < 1e-6, "{far}");
            }
        }
    }
}
