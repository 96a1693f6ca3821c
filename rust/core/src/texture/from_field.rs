//! A volumetric texture filled from a field tree (issue 17: implicit detail riding in
//! the thick surface). The tree is authored in the texture's unit cell: its point
//! `(x, y, z)` is the texture coordinate `(s, t, r)`, `s` and `t` across one tile
//! (`[0, 1]²`, repeated over the surface by the tiling like any texture) and `r` the
//! depth from the base (0) to the outer layer (1). Each texel centre (`(i + ½)/nx`,
//! `(j + ½)/ny`, `k/(nz - 1)`, as [`VolumeTexture::from_fn`] places them) takes the
//! occupancy of `V(f) = {f <= 0}`: 1 inside, 0 outside, through a linear ramp one
//! texel wide centred on the zero set, measured in distance units `f / |∇f|` (the
//! tree's analytic gradient), so edges antialias and the bake's `alpha = 0.5`
//! iso-surface is the tree's zero set. The texel is the largest of the three
//! spacings (`1/nx`, `1/ny`, `1/(nz - 1)`). Values are evaluated at every texel,
//! gradients only within the ramp's reach of the surface (by the Lipschitz bound).
//!
//! Alpha only: [`VolumeTexture`] carries no colour, so the tree's colours are not kept.
//! The tree is sampled as it is, not made periodic: a shape crossing a tile edge is
//! cut there (author tileable trees, or keep shapes inside the cell).

use super::VolumeTexture;
use crate::field::ScalarField;
use crate::implicit::FieldTree;
use crate::{Error, Result};
use glam::Vec3;
use rayon::prelude::*;

/// The most texels a texture from a tree may have (512 × 512 × 256, the procedural
/// textures' limit).
pub const MAX_TEXELS: usize = 512 * 512 * 256;

/// Occupancy at a signed value `f` with gradient length `grad` for a ramp `texel` wide.
fn occupancy(f: f32, grad: f32, texel: f32) -> f32 {
    if !(grad > 1e-6) || !grad.is_finite() {
        return if f <= 0.0 { 1.0 } else { 0.0 };
    }
    (0.5 - f / (grad * texel)).clamp(0.0, 1.0)
}

/// The texture of `tree` on an `[nx, ny, nz]` grid (see the module docs).
pub fn texture_from_field(tree: &FieldTree, dims: [usize; 3]) -> Result<VolumeTexture> {
    if dims.contains(&0) {
        return Err(Error::InvalidParameter(format!("texture of zero size {dims:?}")));
    }
    let n = dims[0].checked_mul(dims[1]).and_then(|v| v.checked_mul(dims[2]));
    if n.is_none_or(|n| n > MAX_TEXELS) {
        return Err(Error::InvalidParameter(format!("texture size {dims:?} is too large (at most {MAX_TEXELS} texels)")));
    }
    let [nx, ny, nz] = dims;
    let n = nx * ny * nz;
    let points: Vec<Vec3> = (0..n)
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| {
            let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
            let r = if nz == 1 { 0.5 } else { z as f32 / (nz - 1) as f32 };
            Vec3::new((x as f32 + 0.5) / nx as f32, (y as f32 + 0.5) / ny as f32, r)
        })
        .collect();
    let texel = (1.0 / nx as f32).max(1.0 / ny as f32).max(1.0 / (nz.max(2) - 1) as f32);
    let mut values = vec![0.0; n];
    tree.values(&points, &mut values);
    // The ramp needs the gradient only where `|f| < |∇f| texel / 2`, and `|∇f|` is at
    // most the Lipschitz bound: elsewhere the occupancy is 0 or 1 by the sign alone
    // (the same as the ramp's clamp gives), so gradients are evaluated only in that
    // band (2% over it, for rounding). Without a finite bound, everywhere.
    let lipschitz = tree.lipschitz();
    let band = if lipschitz.is_finite() { (0.5 * lipschitz * f64::from(texel) * 1.02) as f32 } else { f32::INFINITY };
    let near: Vec<usize> = (0..n).filter(|&i| !(values[i].abs() > band)).collect();
    let near_points: Vec<Vec3> = near.iter().map(|&i| points[i]).collect();
    let mut gradients = vec![Vec3::ZERO; near.len()];
    tree.gradients(&near_points, &mut gradients);
    let mut alpha: Vec<f32> = values.par_iter().with_min_len(4096).map(|&f| if f <= 0.0 { 1.0 } else { 0.0 }).collect();
    for (&i, g) in near.iter().zip(&gradients) {
        alpha[i] = occupancy(values[i], g.length(), texel);
    }
    VolumeTexture::new(dims, alpha)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_in_the_unit_cell_fills_its_volume() {
        let radius = 0.3f32;
        let tree = FieldTree::from_json(&format!(r#"{{"op": "sphere", "center": [0.5, 0.5, 0.5], "radius": {radius}}}"#)).unwrap();
        let dims = [64, 64, 65];
        let t = texture_from_field(&tree, dims).unwrap();
        let [nx, ny, nz] = dims;
        let texel = 1.0 / 64.0;
        let (mut sum, mut checked) = (0.0f64, 0);
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let a = t.samples()[x + nx * (y + ny * z)];
                    sum += f64::from(a);
                    let p = Vec3::new((x as f32 + 0.5) / nx as f32, (y as f32 + 0.5) / ny as f32, z as f32 / (nz - 1) as f32);
                    let d = (p - Vec3::splat(0.5)).length() - radius;
                    // Beyond half a texel from the surface: exactly inside or outside.
                    if d < -0.5 * texel {
                        assert_eq!(a, 1.0, "inside at {p}");
                        checked += 1;
                    } else if d > 0.5 * texel {
                        assert_eq!(a, 0.0, "outside at {p}");
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > nx * ny * nz * 9 / 10);
        // Each texel stands for 1/nx × 1/ny × 1/(nz - 1) of the cell.
        let volume = sum / (nx * ny * (nz - 1)) as f64;
        let exact = 4.0 / 3.0 * std::f64::consts::PI * f64::from(radius).powi(3);
        let error = (volume - exact).abs() / exact;
        assert!(error < 0.01, "volume {volume} vs {exact}: {:.4}% off", error * 100.0);
    }

    /// Gradients only near the surface give the texture that gradients everywhere give,
    /// bit for bit, for a tree whose gradient is at most one (a soft union) and one
    /// whose Lipschitz bound is above one (a displacement: a wider band).
    #[test]
    fn gradients_near_the_surface_only_give_the_full_ramp() {
        let trees = [
            r#"{"op": "union_wp", "p": 6, "children": [
              {"op": "torus", "center": [0.5, 0.5, 0.5], "axis": [0.3, 0.1, 1], "major": 0.3, "minor": 0.08},
              {"op": "segment", "a": [0.1, 0.2, 0.2], "b": [0.9, 0.7, 0.8], "radius": 0.05}]}"#,
            r#"{"op": "displace", "amplitude": 0.05, "omega": 30, "tau": 0.2,
              "shape": {"op": "box", "center": [0.5, 0.5, 0.5], "half_size": [0.3, 0.25, 0.2], "radius": 0.02},
              "texture": {"op": "sphere", "center": [0.2, 0.3, 0.1], "radius": 0}}"#,
        ];
        let dims = [40, 36, 33];
        for json in trees {
            let tree = FieldTree::from_json(json).unwrap();
            assert!(tree.lipschitz().is_finite());
            let t = texture_from_field(&tree, dims).unwrap();
            let [nx, ny, nz] = dims;
            let texel = (1.0 / nx as f32).max(1.0 / ny as f32).max(1.0 / (nz - 1) as f32);
            let points: Vec<Vec3> = (0..nx * ny * nz)
                .map(|i| Vec3::new(((i % nx) as f32 + 0.5) / nx as f32, ((i / nx % ny) as f32 + 0.5) / ny as f32, (i / (nx * ny)) as f32 / (nz - 1) as f32))
                .collect();
            let (mut values, mut gradients) = (vec![0.0; points.len()], vec![Vec3::ZERO; points.len()]);
            tree.values(&points, &mut values);
            tree.gradients(&points, &mut gradients);
            let mut ramp = 0;
            for (i, a) in t.samples().iter().enumerate() {
                let full = occupancy(values[i], gradients[i].length(), texel);
                assert_eq!(*a, full, "{json} at {}", points[i]);
                ramp += usize::from(full > 0.0 && full < 1.0);
            }
            assert!(ramp > 500, "the surface crosses the grid ({ramp} texels on the ramp)");
        }
    }

    #[test]
    fn bad_sizes_are_refused() {
        let tree = FieldTree::from_json(r#"{"op": "sphere", "center": [0.5, 0.5, 0.5], "radius": 0.2}"#).unwrap();
        assert!(texture_from_field(&tree, [0, 4, 4]).is_err());
        assert!(texture_from_field(&tree, [1024, 1024, 1024]).is_err());
        assert!(texture_from_field(&tree, [usize::MAX, 2, 2]).is_err());
        assert!(texture_from_field(&tree, [1, 1, 1]).unwrap().samples()[0] > 0.5);
    }
}
