//! The volumetric texture grid (chapter 3.2): occupancy samples at texel centres,
//! periodic in the two surface directions and clamped across the shell.

use crate::{Error, Result};
use glam::{Vec2, Vec3};

/// A texel footprint in `(s, t)`: the four texel indices within a slice and the
/// bilinear fractions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Column {
    i: [usize; 4],
    fx: f32,
    fy: f32,
}

/// `alpha` in `[0, 1]` on an `nx × ny × nz` grid, x fastest; `z` runs from the base
/// (`r = 0`) to the outer layer (`r = 1`).
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeTexture {
    dims: [usize; 3],
    alpha: Vec<f32>,
}

impl VolumeTexture {
    /// A texture from its samples; every dimension must be at least 1 and values are
    /// clamped to `[0, 1]` (NaN is an error).
    pub fn new(dims: [usize; 3], mut alpha: Vec<f32>) -> Result<Self> {
        if dims.contains(&0) {
            return Err(Error::InvalidParameter(format!("texture of zero size {dims:?}")));
        }
        let n = dims[0].checked_mul(dims[1]).and_then(|v| v.checked_mul(dims[2]));
        if n != Some(alpha.len()) {
            return Err(Error::InvalidParameter(format!("{} samples given for a {dims:?} texture", alpha.len())));
        }
        if let Some(i) = alpha.iter().position(|a| a.is_nan()) {
            return Err(Error::InvalidParameter(format!("texture sample {i} is NaN")));
        }
        alpha.iter_mut().for_each(|a| *a = a.clamp(0.0, 1.0));
        Ok(Self { dims, alpha })
    }

    /// Samples a function of texel-centre coordinates `(s, t, r)` in `[0, 1)²×[0, 1]`.
    pub fn from_fn(dims: [usize; 3], f: impl Fn(Vec3) -> f32 + Sync) -> Result<Self> {
        use rayon::prelude::*;
        if dims.contains(&0) {
            return Err(Error::InvalidParameter(format!("texture of zero size {dims:?}")));
        }
        let [nx, ny, nz] = dims;
        let alpha = (0..nx * ny * nz)
            .into_par_iter()
            .with_min_len(256)
            .map(|i| {
                let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
                let r = if nz == 1 { 0.5 } else { z as f32 / (nz - 1) as f32 };
                f(Vec3::new((x as f32 + 0.5) / nx as f32, (y as f32 + 0.5) / ny as f32, r))
            })
            .collect();
        Self::new(dims, alpha)
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }
    pub fn samples(&self) -> &[f32] {
        &self.alpha
    }
    /// The samples, x fastest, without copying.
    pub fn into_samples(self) -> Vec<f32> {
        self.alpha
    }

    /// Trilinear `alpha` at texture coordinates `(s, t, r)`: `s`, `t` wrap around
    /// (tiling), `r` is clamped to the shell. Texel centres sit at `(i + ½)/n` in `s`,
    /// `t` and at `k/(nz-1)` in `r` (the first and last slices lie on the shell's faces).
    pub fn sample(&self, c: Vec3) -> f32 {
        self.sample_column(&self.column(c.truncate()), c.z)
    }

    /// The bilinear footprint of `(s, t)`, shared by every `r` along it (a column of
    /// the bake's lattice samples one footprint at many heights).
    pub fn column(&self, st: Vec2) -> Column {
        let [nx, ny, _] = self.dims;
        // Texel index and fraction, wrapped into the tile (no libm floor: hot path).
        #[inline(always)]
        fn wrap(u: f32, n: usize) -> (usize, usize, f32) {
            let x = u * n as f32 - 0.5;
            let x = if x.abs() < 1e6 { x } else { 0.0 };
            let i = x as i32 - i32::from(x < (x as i32) as f32);
            let f = x - i as f32;
            let i = i.rem_euclid(n as i32) as usize;
            (i, if i + 1 == n { 0 } else { i + 1 }, f)
        }
        let (x0, x1, fx) = wrap(st.x, nx);
        let (y0, y1, fy) = wrap(st.y, ny);
        Column { i: [nx * y0 + x0, nx * y0 + x1, nx * y1 + x0, nx * y1 + x1], fx, fy }
    }

    /// Trilinear `alpha` at height `r` over a [`Self::column`] footprint.
    #[inline]
    pub fn sample_column(&self, col: &Column, r: f32) -> f32 {
        let [nx, ny, nz] = self.dims;
        let z = if r > 0.0 { r.min(1.0) * (nz - 1) as f32 } else { 0.0 };
        let z0 = (z as usize).min(nz - 1);
        let (z1, fz) = (if z0 + 1 < nz { z0 + 1 } else { z0 }, z - z0 as f32);
        let (fx, fy) = (col.fx, col.fy);
        let plane = |z: usize| {
            let s = &self.alpha[nx * ny * z..nx * ny * (z + 1)];
            let [i00, i01, i10, i11] = col.i;
            let a = s[i00] + (s[i01] - s[i00]) * fx;
            let b = s[i10] + (s[i11] - s[i10]) * fx;
            a + (b - a) * fy
        };
        let (p0, p1) = (plane(z0), plane(z1));
        p0 + (p1 - p0) * fz
    }

    /// `∇alpha` with respect to `(s, t, r)`, by central differences one texel wide.
    pub fn gradient(&self, c: Vec3) -> Vec3 {
        let [nx, ny, nz] = self.dims;
        let h = Vec3::new(1.0 / nx as f32, 1.0 / ny as f32, 1.0 / (nz.max(2) - 1) as f32);
        let d = |e: Vec3| (self.sample(c + e) - self.sample(c - e)) / (2.0 * e.max_element());
        Vec3::new(d(Vec3::X * h.x), d(Vec3::Y * h.y), d(Vec3::Z * h.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_wrap_in_s_t_and_clamp_in_r() {
        let t = VolumeTexture::from_fn([8, 4, 5], |c| c.x).unwrap();
        // Texel centres reproduce the function; s wraps (the last texel blends into the first).
        assert!((t.sample(Vec3::new(0.5625, 0.3, 0.2)) - 0.5625).abs() < 1e-6);
        assert!((t.sample(Vec3::new(1.5625, -0.7, 0.2)) - 0.5625).abs() < 1e-6);
        assert!((t.sample(Vec3::new(0.5625, 0.3, 7.0)) - 0.5625).abs() < 1e-6);
        let r = VolumeTexture::from_fn([2, 2, 5], |c| c.z).unwrap();
        for z in [0.0, 0.3, 0.77, 1.0] {
            assert!((r.sample(Vec3::new(0.1, 0.9, z)) - z).abs() < 1e-6);
            assert!((r.gradient(Vec3::new(0.1, 0.9, 0.5)) - Vec3::Z).length() < 1e-4);
        }
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(VolumeTexture::new([0, 4, 4], vec![]).is_err());
        assert!(VolumeTexture::new([2, 2, 2], vec![0.0; 7]).is_err());
        assert!(VolumeTexture::new([1, 1, 1], vec![f32::NAN]).is_err());
        assert_eq!(VolumeTexture::new([1, 1, 1], vec![3.0]).unwrap().samples(), &[1.0]);
    }
}
