//! Directional alpha of the transparency levels (§6.6.1): per texel and texture axis,
//! the share of light crossing the texel along that axis that the object stops.
//!
//! Two texels side by side (across the axis) average their alphas; two in a row along
//! the axis combine by the correlation rule `alpha = a1 + a2 - (a1 a2 + C s1 s2)`
//! (`C` the correlation of their opaque parts, `s` their standard deviations: `C = 0`
//! gives `1 - (1 - a1)(1 - a2)`, `C = 1` gives `max(a1, a2)`, figure 6.7). Here `C` is
//! not guessed: every texel keeps, for each ray of the finest level through it, whether
//! the ray is blocked, so the rule is evaluated exactly, level after level.
//!
//! Blending the transparency layers cannot apply the rule between layers (§6.6.2:
//! it treats them as independent, which makes correlated content too opaque). So
//! each texel also carries its column's alpha: the share of the finest rays along
//! `r` blocked anywhere across the shell. The renderer spreads it evenly over the
//! rows along `r`, which makes a view along the directors exact.

use super::{children, level_dims, Level};
use glam::Vec4;
use rayon::prelude::*;
use std::ops::Range;

/// Directional alpha (`xyz`: along `s`, `t`, `r`) and column alpha (`w`) for every
/// level of `finest` (`count` levels), from its inside texels (`alpha >= 0.5`).
pub fn chain(finest: &Level<[f32; 4]>, count: u32) -> Vec<Level<Vec4>> {
    let inside: Vec<bool> = finest.texels.iter().map(|t| t[3] >= 0.5).collect();
    let mut per_axis: Vec<Vec<Vec<f32>>> = (0..3).map(|axis| along(&inside, finest.dims, axis, count)).collect();
    per_axis.push(columns(&inside, finest.dims, count));
    (0..count as usize)
        .map(|l| {
            let dims = level_dims(finest.dims, l as u32);
            let at = |axis: usize, k: usize| per_axis[axis][l][k];
            let texels = (0..per_axis[0][l].len()).map(|k| Vec4::new(at(0, k), at(1, k), at(2, k), at(3, k))).collect();
            Level { dims, texels }
        })
        .collect()
}

/// The finest texels each texel of the next level covers, from those each texel of
/// this level (size `above`) covers, along one axis.
fn compose(ranges: &[Range<usize>], above: usize, here: usize) -> Vec<Range<usize>> {
    (0..here)
        .map(|i| {
            let ch = children(i, above, here);
            ranges[ch.start].start..ranges[ch.end - 1].end
        })
        .collect()
}

/// Column alpha for every level: the share of the finest columns along `r` under a
/// texel's footprint that hold an inside texel anywhere.
fn columns(inside: &[bool], dims: [usize; 3], count: u32) -> Vec<Vec<f32>> {
    let [nx, ny, nz] = dims;
    let blocked: Vec<bool> = (0..nx * ny).map(|c| (0..nz).any(|z| inside[c + nx * ny * z])).collect();
    let mut ranges = [(0..nx).map(|i| i..i + 1).collect::<Vec<_>>(), (0..ny).map(|i| i..i + 1).collect()];
    (0..count)
        .map(|l| {
            let here = level_dims(dims, l);
            if l > 0 {
                let above = level_dims(dims, l - 1);
                ranges = [compose(&ranges[0], above[0], here[0]), compose(&ranges[1], above[1], here[1])];
            }
            (0..here.iter().product::<usize>())
                .into_par_iter()
                .map(|k| {
                    let p = position(k, here);
                    let (xs, ys) = (ranges[0][p[0]].clone(), ranges[1][p[1]].clone());
                    let total = xs.len() * ys.len();
                    let hit = ys.flat_map(|y| xs.clone().map(move |x| x + nx * y)).filter(|&c| blocked[c]).count();
                    hit as f32 / total as f32
                })
                .collect()
        })
        .collect()
}

fn index(p: [usize; 3], d: [usize; 3]) -> usize {
    p[0] + d[0] * (p[1] + d[1] * p[2])
}

fn position(k: usize, d: [usize; 3]) -> [usize; 3] {
    [k % d[0], (k / d[0]) % d[1], k / (d[0] * d[1])]
}

/// Alpha along `axis` for every level. `mask` holds, per texel along the axis and
/// finest ray across it, whether the ray is blocked within the texel.
fn along(inside: &[bool], dims: [usize; 3], axis: usize, count: u32) -> Vec<Vec<f32>> {
    let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
    let mut mask = inside.to_vec();
    let mut mask_dims = dims;
    // The finest texels each texel of the current level covers, per axis.
    let mut ranges: [Vec<Range<usize>>; 3] = dims.map(|n| (0..n).map(|i| i..i + 1).collect());
    let mut out = vec![inside.iter().map(|&i| f32::from(u8::from(i))).collect::<Vec<f32>>()];
    for l in 1..count {
        let (above, here) = (level_dims(dims, l - 1), level_dims(dims, l));
        let mut reduced = mask_dims;
        reduced[axis] = here[axis];
        // In a row along the axis: a ray is blocked if it is in either child.
        mask = (0..reduced.iter().product::<usize>())
            .into_par_iter()
            .map(|k| {
                let p = position(k, reduced);
                children(p[axis], above[axis], here[axis]).any(|ch| {
                    let mut q = p;
                    q[axis] = ch;
                    mask[index(q, mask_dims)]
                })
            })
            .collect();
        mask_dims = reduced;
        for (a, r) in ranges.iter_mut().enumerate() {
            *r = compose(r, above[a], here[a]);
        }
        // Side by side: the share of the texel's rays that are blocked.
        let alpha = (0..here.iter().product::<usize>())
            .into_par_iter()
            .map(|k| {
                let p = position(k, here);
                let (mut hit, mut total) = (0usize, 0usize);
                for u in ranges[b][p[b]].clone() {
                    for v in ranges[c][p[c]].clone() {
                        let mut q = [0; 3];
                        q[axis] = p[axis];
                        q[b] = u;
                        q[c] = v;
                        hit += usize::from(mask[index(q, mask_dims)]);
                        total += 1;
                    }
                }
                hit as f32 / total as f32
            })
            .collect();
        out.push(alpha);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A finest level of `dims` from an inside test on texel indices.
    fn level(dims: [usize; 3], inside: impl Fn([usize; 3]) -> bool) -> Level<[f32; 4]> {
        let texels = (0..dims.iter().product()).map(|k| [0.0, 0.0, 0.0, if inside(position(k, dims)) { 1.0 } else { 0.0 }]).collect();
        Level { dims, texels }
    }

    /// A deterministic pseudo-random bit per texel.
    fn bit(p: [usize; 3], seed: u64) -> bool {
        let mut h = (p[0] as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (p[1] as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
        h ^= (p[2] as u64).wrapping_mul(0x1656_67B1_9E37_79F9) ^ seed;
        h ^= h >> 29;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 32;
        h.is_multiple_of(3)
    }

    #[test]
    fn texels_in_a_row_follow_the_correlation_rule() {
        // Two texels along x, each a block of 32 x 32 finest rays (level 5 of a
        // 64 x 32 x 32 grid has 2 x 1 x 1 texels).
        let dims = [64, 32, 32];
        // Independent (C = 0): random, unrelated halves.
        let independent = level(dims, |p| bit(p, if p[0] < 32 { 1 } else { 2 }));
        // Fully correlated (C = 1): the second half repeats the first.
        let same = level(dims, |p| bit([p[0] % 32, p[1], p[2]], 1));
        let (a1, a2) = {
            let c = chain(&independent, 6);
            (c[5].texels[0].x, c[5].texels[1].x)
        };
        let whole = |l: &Level<[f32; 4]>| chain(l, 7)[6].texels[0].x;
        let joint = whole(&independent);
        let expected = 1.0 - (1.0 - a1) * (1.0 - a2);
        assert!((joint - expected).abs() < 0.02, "C = 0: {joint} vs {expected} (a1 {a1}, a2 {a2})");
        let c = chain(&same, 6);
        let (b1, b2) = (c[5].texels[0].x, c[5].texels[1].x);
        assert!((whole(&same) - b1.max(b2)).abs() < 1e-6, "C = 1: {} vs max({b1}, {b2})", whole(&same));
    }

    #[test]
    fn texels_side_by_side_average() {
        // Along z, a level-1 texel covers 2 x 2 columns side by side: one column
        // blocked of four gives 1/4, in any row along z.
        let l = level([4, 4, 4], |p| p[0] == 0 && p[1] == 0 && p[2] == 1);
        let c = chain(&l, 2);
        assert_eq!(c[1].texels[0].z, 0.25);
        // Across the other axes the single blocked texel blocks a quarter too.
        assert_eq!(c[1].texels[0].x, 0.25);
        assert_eq!(c[1].texels[1].z, 0.0);
        // Its column (one of four under a level-1 texel) is blocked at every height.
        assert!(c[1].texels.iter().all(|a| a.w == 0.25 || a.w == 0.0));
        assert_eq!(c[1].texels[0].w, 0.25);
        // Texel (0, 0, 1) of the 2 x 2 x 2 level: the same column higher up.
        assert_eq!(c[1].texels[4].w, 0.25);
        // A solid block stops everything in every direction.
        let solid = level([4, 4, 4], |_| true);
        assert!(chain(&solid, 3).iter().all(|l| l.texels.iter().all(|a| *a == Vec4::ONE)));
    }
}
