//! Double mipmaps (thick surfaces, chapter 6).
//!
//! Plain mipmaps of an occupancy texture average 2x2x2 texels (§6.2); a sparse object
//! (chain mail, a window screen) then falls below `alpha = 0.5` a few levels down and
//! vanishes from far views (figure 6.1). A double mipmap (§6.3, figure 6.2) keeps two
//! chains:
//! - the **occupancy** chain: the averaged levels down to the *transition level*, the
//!   last one before the object starts to vanish, then empty levels (alpha 0), drawn
//!   with the alpha test of chapter 5;
//! - the **transparency** chain: empty levels above the transition level, then from it
//!   down the texture read as a semi-transparent medium: per texel a directional alpha
//!   in the three texture axes ([`directional`], §6.6) and the normal distribution as
//!   an ellipsoid, `Q^-1` scaled so its longest axis is 1 ([`ndf`], §6.4), drawn
//!   with alpha blending layer by layer (§6.5.2).
//!
//! The two overlap at the transition level, and the trilinear filter between a real
//! level and the neighbouring empty one fades the occupancy out and the transparency
//! in across one level: the transitional zone of §6.5.2.
//!
//! Level `l` of a texture with `n` texels a side has `max(1, n >> l)` (as the GPU's
//! mip chains); each texel of a level covers two of the level above (three at an odd
//! end, one where the size is already 1).
//!
//! A texture that never vanishes (a slab) gets no transparency chain: its averaged
//! levels are kept all the way down. One that vanishes at once hands over at level 1
//! at the earliest, so the transparency chain always starts with an empty level and
//! close views stay the full-resolution image.

pub mod directional;
pub mod ndf;

use std::ops::Range;

use glam::{Mat3, Vec3, Vec4};
use rayon::prelude::*;
use thicket_core::texture::TextureLayer;
use thicket_core::texture::VolumeTexture;

/// How textures are filtered for distant views.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Mipmaps {
    /// The full-resolution texture everywhere (far views alias).
    Off,
    /// Plain averaged mipmaps with the alpha test (§6.2; sparse textures vanish).
    Linear,
    /// Occupancy and transparency chains (§6.3).
    #[default]
    Double,
}

/// Share of the finest level's coverage a level must keep to stay in the occupancy
/// chain: below it the object is taken to be vanishing (§6.3.3).
pub const KEEP_COVERAGE: f32 = 0.8;

/// One level of a chain: its size and texels (`x` fastest, then `y`, then `z`).
#[derive(Debug, Clone, PartialEq)]
pub struct Level<T> {
    pub dims: [usize; 3],
    pub texels: Vec<T>,
}

/// Size of level `l` of a texture of size `dims`.
pub fn level_dims(dims: [usize; 3], l: u32) -> [usize; 3] {
    dims.map(|n| (n >> l).max(1))
}

/// Number of levels down to 1x1x1, as the GPU counts them.
pub fn level_count(dims: [usize; 3]) -> u32 {
    usize::BITS - dims.iter().copied().max().unwrap_or(1).max(1).leading_zeros()
}

/// Texels of the level above covered by texel `i` of a level of size `m`, when the
/// level above has size `n`.
pub(crate) fn children(i: usize, n: usize, m: usize) -> Range<usize> {
    if m == n {
        return i..i + 1;
    }
    let start = 2 * i;
    let end = if i + 1 == m { n } else { 2 * i + 2 };
    start..end
}

/// The next level of `level`, each texel combining its children with `combine`
/// (called with the child texels, in any order).
pub(crate) fn reduce<T: Copy + Send + Sync, U: Send>(
    level: &Level<T>,
    dims: [usize; 3],
    combine: impl Fn(&mut dyn Iterator<Item = T>) -> U + Sync,
) -> Level<U> {
    let [n0, n1, n2] = level.dims;
    let [m0, m1, m2] = dims;
    let texels = (0..m0 * m1 * m2)
        .into_par_iter()
        .map(|k| {
            let (x, y, z) = (k % m0, (k / m0) % m1, k / (m0 * m1));
            let (cx, cy, cz) = (children(x, n0, m0), children(y, n1, m1), children(z, n2, m2));
            let mut it = cz.flat_map(|z| cy.clone().map(move |y| (y, z))).flat_map(|(y, z)| cx.clone().map(move |x| level.texels[x + n0 * (y + n1 * z)]));
            combine(&mut it)
        })
        .collect();
    Level { dims, texels }
}

/// The finest level of a texture as the GPU samples it: the gradient of alpha in
/// texture units (central differences; wrapping in `s`, `t`, one-sided at the ends of
/// `r`) and alpha.
pub fn finest_level(texture: &VolumeTexture) -> Level<[f32; 4]> {
    let [nx, ny, nz] = texture.dims();
    let a = texture.samples();
    let at = |x: usize, y: usize, z: usize| a[x + nx * (y + ny * z)];
    let (sx, sy) = (nx as f32 / 2.0, ny as f32 / 2.0);
    let sz = (nz.max(2) - 1) as f32 / 2.0;
    let texels = (0..a.len())
        .map(|k| {
            let (x, y, z) = (k % nx, (k / nx) % ny, k / (nx * ny));
            let (z0, z1) = (z.saturating_sub(1), (z + 1).min(nz - 1));
            let (y0, y1) = ((y + ny - 1) % ny, (y + 1) % ny);
            let (x0, x1) = ((x + nx - 1) % nx, (x + 1) % nx);
            [(at(x1, y, z) - at(x0, y, z)) * sx, (at(x, y1, z) - at(x, y0, z)) * sy, (at(x, y, z1) - at(x, y, z0)) * sz, at(x, y, z)]
        })
        .collect();
    Level { dims: [nx, ny, nz], texels }
}

/// Averaged levels (§6.2) of `finest`, all of them.
pub fn linear_chain(finest: Level<[f32; 4]>) -> Vec<Level<[f32; 4]>> {
    let count = level_count(finest.dims);
    let mut chain = vec![finest];
    for l in 1..count {
        let dims = level_dims(chain[0].dims, l);
        let next = reduce(&chain[chain.len() - 1], dims, |it: &mut dyn Iterator<Item = [f32; 4]>| {
            let (mut sum, mut n) = ([0.0f32; 4], 0.0f32);
            for t in it {
                (0..4).for_each(|i| sum[i] += t[i]);
                n += 1.0;
            }
            sum.map(|s| s / n)
        });
        chain.push(next);
    }
    chain
}

/// Share of `(s, t)` columns with an inside texel (`alpha >= 0.5`) at any height:
/// how much of the surface the object covers seen along the directors.
pub fn column_coverage(level: &Level<[f32; 4]>) -> f32 {
    let [nx, ny, nz] = level.dims;
    let covered = (0..nx * ny).filter(|&c| (0..nz).any(|z| level.texels[c + nx * ny * z][3] >= 0.5)).count();
    covered as f32 / (nx * ny) as f32
}

/// The transition level of an averaged chain: the last level, counted from the finest,
/// whose coverage keeps [`KEEP_COVERAGE`] of the finest level's.
pub fn transition_level(chain: &[Level<[f32; 4]>]) -> u32 {
    let finest = column_coverage(&chain[0]);
    let vanishing = chain.iter().position(|l| column_coverage(l) < KEEP_COVERAGE * finest);
    vanishing.map_or(chain.len() as u32 - 1, |l| (l as u32).saturating_sub(1))
}

/// A transparency texel: directional alpha along `s`, `t`, `r` and its column's
/// alpha across the shell (`w`, see [`directional`]), and the normal distribution's
/// `Q^-1` (symmetric, largest eigenvalue 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Haze {
    pub alpha: Vec4,
    pub ndf: Mat3,
}

impl Haze {
    pub const EMPTY: Self = Self { alpha: Vec4::ZERO, ndf: Mat3::IDENTITY };
}

/// Everything the renderer uploads for one scene.
pub struct MipmapSet {
    pub mode: Mipmaps,
    /// Per texture layer, its occupancy chain (one level when `mode` is `Off`).
    pub occupancy: Vec<Vec<Level<[f32; 4]>>>,
    /// The transparency chain of the united layers (`Double` only).
    pub transparency: Vec<Level<Haze>>,
    /// The transition level of the united layers' grid (`Double` only; else 0).
    pub transition: u32,
}

impl MipmapSet {
    pub fn build(layers: &[TextureLayer], mode: Mipmaps) -> Self {
        let finest: Vec<Level<[f32; 4]>> = layers.iter().map(|l| finest_level(&l.texture)).collect();
        match mode {
            Mipmaps::Off => Self { mode, occupancy: finest.into_iter().map(|l| vec![l]).collect(), transparency: vec![], transition: 0 },
            Mipmaps::Linear => Self { mode, occupancy: finest.into_iter().map(linear_chain).collect(), transparency: vec![], transition: 0 },
            Mipmaps::Double => {
                let united = united_level(layers, &finest);
                let united_chain = linear_chain(united.clone());
                let last = united_chain.len() as u32 - 1;
                let vanishing = transition_level(&united_chain);
                if vanishing >= last {
                    // Nothing vanishes: averaged levels all the way (no hand-over).
                    return Self { mode, occupancy: finest.into_iter().map(linear_chain).collect(), transparency: vec![], transition: last };
                }
                let transition = vanishing.max(1);
                let transparency = transparency_chain(&united, transition);
                // Each layer keeps the levels whose texels are at most as large as the
                // united grid's at the transition level, and is empty below.
                let occupancy = finest
                    .into_iter()
                    .map(|f| {
                        let texels = |d: [usize; 3]| ((d[0] * d[1]) as f32).sqrt();
                        let last = transition as f32 + (texels(f.dims) / texels(united.dims)).log2();
                        let mut chain = linear_chain(f);
                        for (l, level) in chain.iter_mut().enumerate().skip(1) {
                            if l as f32 > last + 1e-3 {
                                level.texels.iter_mut().for_each(|t| *t = [0.0; 4]);
                            }
                        }
                        chain
                    })
                    .collect();
                Self { mode, occupancy, transparency, transition }
            }
        }
    }

    /// Size of the united grid (the transparency chain's finest level).
    pub fn transparency_dims(&self) -> [usize; 3] {
        self.transparency.first().map_or([1; 3], |l| l.dims)
    }
}

/// The layers united (max alpha, each shifted by its offset) on the grid of their
/// largest sizes; a single unshifted layer as it is.
fn united_level(layers: &[TextureLayer], finest: &[Level<[f32; 4]>]) -> Level<[f32; 4]> {
    if layers.len() == 1 && layers[0].offset == glam::Vec2::ZERO {
        return finest[0].clone();
    }
    let dims = layers.iter().fold([1usize; 3], |d, l| {
        let t = l.texture.dims();
        [d[0].max(t[0]), d[1].max(t[1]), d[2].max(t[2])]
    });
    let [nx, ny, nz] = dims;
    let alpha: Vec<f32> = (0..nx * ny * nz)
        .into_par_iter()
        .map(|k| {
            let (x, y, z) = (k % nx, (k / nx) % ny, k / (nx * ny));
            let r = if nz > 1 { z as f32 / (nz - 1) as f32 } else { 0.5 };
            let c = Vec3::new((x as f32 + 0.5) / nx as f32, (y as f32 + 0.5) / ny as f32, r);
            layers.iter().map(|l| l.texture.sample(c + l.offset.extend(0.0))).fold(0.0, f32::max)
        })
        .collect();
    match VolumeTexture::new(dims, alpha) {
        Ok(t) => finest_level(&t),
        Err(_) => finest[0].clone(),
    }
}

/// The transparency chain of `finest` (§6.4, §6.6): empty above `transition`, then
/// directional alpha from the rays of the finest level and opacity-weighted normal
/// ellipsoids.
pub fn transparency_chain(finest: &Level<[f32; 4]>, transition: u32) -> Vec<Level<Haze>> {
    let count = level_count(finest.dims);
    let alphas = directional::chain(finest, count);
    // Per texel: the ellipsoid and the share of its finest texels holding surface.
    // Texels without surface (inside or outside a feature) have no normal to add.
    let finest_ellipsoids = finest
        .texels
        .iter()
        .map(|t| match ndf::of_gradient(Vec3::new(t[0], t[1], t[2]), finest.dims) {
            Some(disk) => (disk, 1.0),
            None => (Mat3::IDENTITY, 0.0),
        })
        .collect();
    let mut ellipsoids = vec![Level { dims: finest.dims, texels: finest_ellipsoids }];
    for l in 1..count {
        let above = &ellipsoids[l as usize - 1];
        let opacity = &alphas[l as usize - 1];
        // Children weighted by opacity (their mean directional alpha) times surface.
        let weighted = Level {
            dims: above.dims,
            texels: above.texels.iter().zip(&opacity.texels).map(|(&(s, surface), a)| (s, surface, (a.x + a.y + a.z) / 3.0)).collect(),
        };
        ellipsoids.push(reduce(&weighted, level_dims(finest.dims, l), |it: &mut dyn Iterator<Item = (Mat3, f32, f32)>| {
            let (mut sum, mut surface, mut n) = (Mat3::ZERO, 0.0, 0.0);
            for (s, share, alpha) in it {
                sum += s * (share * alpha);
                surface += share;
                n += 1.0;
            }
            (ndf::normalized(sum), surface / n)
        }));
    }
    alphas
        .into_iter()
        .zip(ellipsoids)
        .enumerate()
        .map(|(l, (a, e))| {
            let texels = if (l as u32) < transition {
                vec![Haze::EMPTY; a.texels.len()]
            } else {
                a.texels.iter().zip(&e.texels).map(|(alpha, (ndf, _))| Haze { alpha: *alpha, ndf: *ndf }).collect()
            };
            Level { dims: a.dims, texels }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use thicket_core::texture::{Generator, Pattern};

    #[test]
    fn levels_have_the_gpu_sizes_and_cover_every_texel_once() {
        let dims = [12, 5, 17];
        assert_eq!(level_count(dims), 5);
        for l in 1..5 {
            let (above, here) = (level_dims(dims, l - 1), level_dims(dims, l));
            for axis in 0..3 {
                let covered: Vec<usize> = (0..here[axis]).flat_map(|i| children(i, above[axis], here[axis])).collect();
                assert_eq!(covered, (0..above[axis]).collect::<Vec<_>>(), "level {l} axis {axis}");
            }
        }
    }

    #[test]
    fn averaged_chain_makes_chain_mail_vanish_but_not_a_slab() {
        // Figure 6.1: sparse rings drop below alpha = 0.5 a few levels down.
        let rings = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
        let chain = linear_chain(finest_level(&rings));
        let coverage: Vec<f32> = chain.iter().map(column_coverage).collect();
        assert!(coverage[chain.len() - 2] < 0.5 * coverage[0], "{coverage:?}");
        let t = transition_level(&chain);
        assert!(t >= 1 && (t as usize) < chain.len() - 2, "transition {t}, {coverage:?}");
        assert!(coverage[t as usize] >= KEEP_COVERAGE * coverage[0] && coverage[t as usize + 1] < KEEP_COVERAGE * coverage[0]);
        // A slab alpha = 1 below r = 0.5 covers everything at every level.
        let slab = VolumeTexture::from_fn([16, 16, 16], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
        let chain = linear_chain(finest_level(&slab));
        assert_eq!(transition_level(&chain), chain.len() as u32 - 1);
    }

    #[test]
    fn a_double_mipmap_hands_over_at_the_transition_level() {
        let rings = Generator::new(Pattern::ChainMail).generate([32, 32, 16]).unwrap();
        let layers = [TextureLayer { texture: rings, offset: glam::Vec2::ZERO }];
        let set = MipmapSet::build(&layers, Mipmaps::Double);
        let t = set.transition as usize;
        let occupancy = &set.occupancy[0];
        assert_eq!(occupancy.len(), set.transparency.len());
        let any_alpha = |l: &Level<[f32; 4]>| l.texels.iter().any(|x| x[3] > 0.0);
        let any_haze = |l: &Level<Haze>| l.texels.iter().any(|x| x.alpha.max_element() > 0.0);
        for (l, (occupied, haze)) in occupancy.iter().zip(&set.transparency).enumerate() {
            // Occupancy down to the transition level, transparency from it on: they
            // overlap there and each is empty on the other side.
            assert_eq!(any_alpha(occupied), l <= t, "occupancy level {l}, transition {t}");
            assert_eq!(any_haze(haze), l >= t, "transparency level {l}, transition {t}");
        }
        assert!(t >= 1, "the transparency chain starts with an empty level");
        // A slab never vanishes: no transparency chain, averaged levels all the way.
        let slab = VolumeTexture::from_fn([16, 16, 16], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
        let flat = MipmapSet::build(&[TextureLayer { texture: slab, offset: glam::Vec2::ZERO }], Mipmaps::Double);
        assert!(flat.transparency.is_empty());
        assert!(flat.occupancy[0].iter().all(any_alpha));
        // Stored ellipsoids: symmetric, longest axis 1 (entries within [-1, 1]).
        for level in &set.transparency[t..] {
            for h in &level.texels {
                assert!((h.ndf - h.ndf.transpose()).abs_diff_eq(Mat3::ZERO, 1e-6));
                assert!(h.ndf.to_cols_array().iter().all(|v| v.abs() <= 1.0 + 1e-5));
                assert!((ndf::largest_eigenvalue(&h.ndf) - 1.0).abs() < 1e-3);
            }
        }
    }
}
