//! Normal distributions as ellipsoids (§6.4, after Neyret): a texel's normals are
//! those of an ellipsoid `x^T Q x = 1`, stored as `Q^-1`, which is almost additive over
//! texels, so levels are filtered by summing `Q^-1` weighted by opacity (§6.4.3). The
//! sum is scaled so the longest axis is 1 (largest eigenvalue of `Q^-1`), which keeps
//! every entry within `[-1, 1]`.

use glam::{Mat3, Vec3};

/// Thickness of the flat ellipsoid standing for one surface normal at the finest
/// level (relative to its unit radius).
pub const FLAT: f32 = 0.2;

/// `Q^-1` of a flat ellipsoid whose normals gather around `n` (unit).
pub fn disk(n: Vec3) -> Mat3 {
    Mat3::IDENTITY - (1.0 - FLAT * FLAT) * Mat3::from_cols(n * n.x, n * n.y, n * n.z)
}

/// The finest level's ellipsoid from the gradient of alpha in texture units (`dims`:
/// the texture's size): a disk across the gradient, or none where alpha is flat
/// (within a feature or outside all: no surface in the texel). The ellipsoids live
/// in texture coordinates `(s, t, r)`; the renderer carries their normals to world
/// space through each cell's map.
pub fn of_gradient(gradient: Vec3, dims: [usize; 3]) -> Option<Mat3> {
    let per_texel = gradient / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2].max(2) as f32 - 1.0);
    (per_texel.length() >= 1e-3 && gradient.is_finite()).then(|| disk(gradient.normalize()))
}

/// The opacity-weighted sum of `(Q^-1, opacity)`, scaled to a longest axis of 1; a
/// sphere when nothing is opaque.
pub fn filter(items: &mut dyn Iterator<Item = (Mat3, f32)>) -> Mat3 {
    normalized(items.fold(Mat3::ZERO, |m, (q, w)| m + q * w))
}

/// A sum of `Q^-1` scaled to a longest axis of 1; a sphere when it is zero.
pub fn normalized(sum: Mat3) -> Mat3 {
    let top = largest_eigenvalue(&sum);
    if top > 1e-12 && top.is_finite() {
        sum * (1.0 / top)
    } else {
        Mat3::IDENTITY
    }
}

/// Largest eigenvalue of a symmetric 3x3 matrix (the trigonometric closed form).
pub fn largest_eigenvalue(m: &Mat3) -> f32 {
    let (a, b, c) = (m.x_axis, m.y_axis, m.z_axis);
    let off = a.y * a.y + a.z * a.z + b.z * b.z;
    let q = (a.x + b.y + c.z) / 3.0;
    if off <= 1e-20 * (q * q).max(1e-30) {
        return a.x.max(b.y).max(c.z);
    }
    let p2 = (a.x - q).powi(2) + (b.y - q).powi(2) + (c.z - q).powi(2) + 2.0 * off;
    let p = (p2 / 6.0).sqrt();
    let shifted = (*m - Mat3::IDENTITY * q) * (1.0 / p);
    let r = (shifted.determinant() / 2.0).clamp(-1.0, 1.0);
    q + 2.0 * p * (r.acos() / 3.0).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    #[test]
    fn largest_eigenvalue_of_rotated_diagonals() {
        for (k, diag) in [[1.0, 0.5, 0.04], [0.3, 0.3, 0.9], [2.0, 2.0, 2.0], [0.01, 1e-4, 0.0]].iter().enumerate() {
            let r = Mat3::from_quat(Quat::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 0.3 + k as f32));
            let m = r * Mat3::from_diagonal(Vec3::from(*diag)) * r.transpose();
            let want = diag.iter().copied().fold(f32::MIN, f32::max);
            assert!((largest_eigenvalue(&m) - want).abs() < 1e-4 * want.max(1e-3), "{diag:?}: {}", largest_eigenvalue(&m));
        }
    }

    #[test]
    fn two_disks_filter_to_a_disk_across_both_normals() {
        let (n1, n2) = (Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.6, 0.0, 0.8));
        let m = filter(&mut [(disk(n1), 1.0), (disk(n2), 1.0)].into_iter());
        // Longest axis 1; the thinnest axis is the mean normal.
        assert!((largest_eigenvalue(&m) - 1.0).abs() < 1e-5);
        let mean = (n1 + n2).normalize();
        let along = mean.dot(m * mean);
        let across = Vec3::Y.dot(m * Vec3::Y);
        assert!(along < 0.2 * across, "{along} vs {across}");
        // Spread normals make a rounder ellipsoid than either disk.
        let tilt = Vec3::new(0.6, 0.0, -0.8).normalize().dot(m * Vec3::new(0.6, 0.0, -0.8).normalize());
        assert!(tilt > FLAT * FLAT * 2.0, "{tilt}");
        // A transparent texel does not count.
        let only = filter(&mut [(disk(n1), 1.0), (disk(n2), 0.0)].into_iter());
        assert!(only.abs_diff_eq(disk(n1), 1e-6));
        assert_eq!(of_gradient(Vec3::ZERO, [8; 3]), None, "no surface, no ellipsoid");
        assert_eq!(filter(&mut std::iter::empty()), Mat3::IDENTITY);
    }
}
