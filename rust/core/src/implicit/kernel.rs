//! The building blocks' arithmetic, shared by the evaluator and the bounds: the n-ary
//! `h` of section 3, the log-sum-exp form of `w_p` (section 4), the texture function
//! and the primitives compiled to their frames.

use glam::DVec3;

/// The n-ary `h[f1, ..., fn]` of section 3 with its gradient, from the values and
/// gradients of its arguments.
///
/// The binary `h` is `sqrt(f1² + f2²)` where both are `>= 0` and `max(f1, f2)`
/// elsewhere; by its associativity the n-ary form is the length of the positive parts
/// `|(f1⁺, ..., fn⁺)|` where some `fi >= 0`, and `max fi` where all are negative. The
/// gradient is `Σ fi⁺ ∇fi / h` in the first case and the largest argument's gradient
/// otherwise (also where `h = 0`, the binary rule's tie). Also returns the index of the
/// largest argument (the dominant one). The length is taken scaled by the largest
/// value, so it neither overflows nor underflows.
#[inline(always)]
pub(crate) fn h<const N: usize>(values: [f64; N], grads: [DVec3; N]) -> (f64, DVec3) {
    let mut top = 0;
    for i in 1..N {
        if values[i] > values[top] {
            top = i;
        }
    }
    let m = values[top];
    if !(m > 0.0) {
        return (m, grads[top]);
    }
    let (mut ss, mut g) = (0.0, DVec3::ZERO);
    for i in 0..N {
        let v = values[i].max(0.0) / m;
        ss += v * v;
        g += v * grads[i];
    }
    let len = ss.sqrt();
    (m * len, g / len)
}

/// `h` of values only (no gradient), for intervals: monotone non-decreasing in every
/// argument, so `[h(lows), h(highs)]` encloses it.
pub(crate) fn h_value(values: impl Iterator<Item = f64> + Clone) -> f64 {
    let m = values.clone().fold(f64::NEG_INFINITY, f64::max);
    if !(m > 0.0) {
        return m;
    }
    let ss: f64 = values.map(|v| (v.max(0.0) / m).powi(2)).sum();
    m * ss.sqrt()
}

/// `log(Σ e^(p vi)) / p` by log-sum-exp around the largest `p vi`: finite for any
/// finite values and `p > 0` (no `e^(p v)` is formed).
pub(crate) fn wp_value(p: f64, values: impl Iterator<Item = f64> + Clone) -> f64 {
    let m = values.clone().map(|v| p * v).fold(f64::NEG_INFINITY, f64::max);
    let s: f64 = values.map(|v| (p * v - m).exp()).sum();
    (m + s.ln()) / p
}

/// `e^x` for `x <= 0` (the log-sum-exp terms `e^(p s_i f_i - max)`), branch free so a
/// loop over a block of points vectorizes: fdlibm's `__ieee754_exp` (section "Method"
/// of its e_exp.c, also musl's): `x = n ln 2 + r` with `|r| <= ln 2 / 2` (Cody and
/// Waite's split of `ln 2` into `hi - lo`), then the Remez rational form
/// `e^r = 1 + r + r c / (2 - c)`, `c = r - r² P(r²)` with `P` of degree 4 in `r²`
/// (error below `2^-59`), times `2^n` built in the exponent bits. Fewer operations than
/// a Taylor series to the same accuracy (a degree-13 polynomial there; about 7
/// products, 9 sums and a division here). Within a relative `2 EPSILON` of `f64::exp` (tested); below `-708` (where
/// `e^x` is subnormal) it gives `e^-708`, a term that cannot change a sum holding the
/// largest term's 1. A NaN stays NaN.
#[inline(always)]
pub(crate) fn exp_nonpositive(x: f64) -> f64 {
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    const P1: f64 = 1.666_666_666_666_660_2e-1;
    const P2: f64 = -2.777_777_777_701_559_3e-3;
    const P3: f64 = 6.613_756_321_437_934e-5;
    const P4: f64 = -1.653_390_220_546_525_2e-6;
    const P5: f64 = 4.138_136_797_057_238_5e-8;
    // 1.5 * 2^52: adding it rounds to an integer held in the low mantissa bits.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    debug_assert!(!(x > 0.0), "exp_nonpositive({x}): a positive argument would overflow the exponent bits");
    let x = if x < -708.0 { -708.0 } else { x };
    let t = x * std::f64::consts::LOG2_E + SHIFT;
    let n = t - SHIFT;
    let hi = x - n * LN2_HI;
    let lo = n * LN2_LO;
    let r = hi - lo;
    let z = r * r;
    let c = r - z * (P1 + z * (P2 + z * (P3 + z * (P4 + z * P5))));
    let e = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
    // The low bits of `t` are `n` (-1022 <= n <= 0): `2^n` has exponent `n + 1023`.
    let scale = f64::from_bits(t.to_bits().wrapping_add(1023) << 52);
    e * scale
}

/// `ln x`, branch free so a loop over a block of points vectorizes (the log-sum-exp's
/// `ln Σ`; [`f64::ln`] is a library call per point). The reduction and minimax
/// polynomial of fdlibm's `__ieee754_log` (also musl's `log`): `x = 2^k (1 + f)`
/// with `sqrt(2)/2 <= 1 + f < sqrt(2)`, `s = f / (2 + f)`, and
/// `ln(1 + f) = f - f²/2 + s (f²/2 + R(s²))`, `R` of degree 14 in `s` (below
/// `2^-58.45` off `ln(1 + f) - 2s` there), plus `k ln 2` split in Cody and Waite's two
/// parts. The same operations in the same order on every path, no fused multiply-adds:
/// the same bits with SSE2 or AVX2. Within 1 ulp of `f64::ln` (tested on 40k points
/// from subnormals to `f64::MAX`); `ln 1 = 0`, `ln 0 = -inf`, `ln inf = inf`, NaN
/// for a negative or NaN argument.
#[inline(always)]
pub(crate) fn ln(x: f64) -> f64 {
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    const LG1: f64 = 6.666_666_666_666_735e-1;
    const LG2: f64 = 3.999_999_999_940_942e-1;
    const LG3: f64 = 2.857_142_874_366_239e-1;
    const LG4: f64 = 2.222_219_843_214_978_4e-1;
    const LG5: f64 = 1.818_357_216_161_805e-1;
    const LG6: f64 = 1.531_383_769_920_937_3e-1;
    const LG7: f64 = 1.479_819_860_511_658_6e-1;
    // 2^52 + 2^31 as an integer in a double's bits: adding a small integer to its bits
    // and subtracting it as a double converts without a (non-AVX2) integer conversion.
    const MAGIC: f64 = 4_503_601_774_854_144.0;
    // Subnormals scaled into the normal range by 2^54 (and the exponent back).
    let tiny = x < f64::MIN_POSITIVE;
    let y = if tiny { x * 18_014_398_509_481_984.0 } else { x };
    let bias: u64 = if tiny { 1023 + 54 } else { 1023 };
    // Shift the mantissa's split point from 1 to sqrt(2)/2 (fdlibm's 0x3fe6a09e in the
    // high word), then read the exponent k and the mantissa 1 + f in [sqrt(2)/2, sqrt(2)).
    let bits = y.to_bits().wrapping_add((0x3ff0_0000 - 0x3fe6_a09e) << 32);
    let e = bits >> 52;
    let m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff).wrapping_add(0x3fe6_a09e << 32));
    let k = f64::from_bits(MAGIC.to_bits().wrapping_add(e).wrapping_sub(bias)) - MAGIC;
    let f = m - 1.0;
    let hfsq = 0.5 * f * f;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG2 + w * (LG4 + w * LG6));
    let t2 = z * (LG1 + w * (LG3 + w * (LG5 + w * LG7)));
    let r = t2 + t1;
    let v = s * (hfsq + r) + k * LN2_LO - hfsq + f + k * LN2_HI;
    // The edges: zero, infinity, negative and NaN arguments.
    // (Three selects: a `||` here compiles to branches, and the loop stays scalar.)
    let v = if x == 0.0 { f64::NEG_INFINITY } else { v };
    let v = if x == f64::INFINITY { f64::INFINITY } else { v };
    if x >= 0.0 {
        v
    } else {
        f64::NAN
    }
}

/// The texture function `(1 + cos(omega f + tau)) / 2` (section 2, with section 7's phase).
#[inline(always)]
pub(crate) fn texture(omega: f64, tau: f64, f: f64) -> f64 {
    0.5 * (1.0 + (omega * f + tau).cos())
}

/// The range of `cos` over `[a, b]`.
pub(crate) fn cos_range(a: f64, b: f64) -> (f64, f64) {
    use std::f64::consts::{PI, TAU};
    if !(a.is_finite() && b.is_finite()) || b - a >= TAU {
        return (-1.0, 1.0);
    }
    let (ca, cb) = (a.cos(), b.cos());
    let (mut lo, mut hi) = (ca.min(cb), ca.max(cb));
    // A maximum 2kπ or a minimum (2k + 1)π inside the interval.
    if (a / TAU).ceil() * TAU <= b {
        hi = 1.0;
    }
    if ((a - PI) / TAU).ceil() * TAU + PI <= b {
        lo = -1.0;
    }
    (lo, hi)
}

/// Which skeleton a [`Prim`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrimKind {
    /// `axes[0] · (x - center)`.
    Plane,
    /// `|x - center| - radius`.
    Sphere,
    /// `h` over the six plane functions `±fi - half[i]` of the frame, minus `radius`:
    /// the point (`half = 0`), the segment (`half = [l, 0, 0]`), the rectangle
    /// (`[a1, a2, 0]`) and the box.
    Cuboid,
    /// `h[g - half[0], -g + half[0], f3, -f3] - radius`, `g = h[f1, -f1, f2, -f2]`.
    Torus,
}

/// A primitive compiled to an orthonormal frame: `axes` are the unit plane normals
/// `n1, n2, n3 = n1 × n2` of section 3, in world space.
#[derive(Debug, Clone, PartialEq)]
pub struct Prim {
    pub kind: PrimKind,
    pub center: DVec3,
    pub axes: [DVec3; 3],
    pub half: [f64; 3],
    pub radius: f64,
}

/// Working memory of [`Prim::block`] for up to `L` points: each of the box's pairs of
/// plane functions, its larger value and the sign of its gradient.
#[derive(Clone)]
pub(crate) struct Lanes<const L: usize> {
    q: [[f64; L]; 3],
    s: [[f64; L]; 3],
}

impl<const L: usize> Lanes<L> {
    pub fn new() -> Self {
        Lanes { q: [[0.0; L]; 3], s: [[0.0; L]; 3] }
    }
}

impl Prim {
    /// Value and gradient at `x`: the block kernel ([`Prim::block`]) on one point.
    #[inline]
    pub fn eval(&self, x: DVec3) -> (f64, DVec3) {
        let (mut f, mut g) = ([0.0], [[0.0]; 3]);
        let [gx, gy, gz] = &mut g;
        self.block::<true, 1>(&[x.x], &[x.y], &[x.z], &mut f, [gx, gy, gz], &mut Lanes::new());
        (f[0], DVec3::new(g[0][0], g[1][0], g[2][0]))
    }

    /// The one kernel of the primitives: values, and with `GRADIENT` the analytic
    /// gradients, over a block of points given as coordinate arrays (`x`, `y`, `z`,
    /// `f` and each of `g` of one length, at most `L`), structure of arrays.
    /// Every lane runs the same arithmetic whichever the mode and the block's length,
    /// so a value is the same bit for bit with or without its gradient and alone or in
    /// a block. Written without branches per point (choices are selects), so the loops
    /// vectorize.
    ///
    /// The box's `h` of its six plane functions (section 3) uses that at most one of
    /// `fi - ai` and `-fi - ai` is positive (`ai >= 0`): the larger is `|fi| - ai`,
    /// and the pair's gradient is `+ni` where `fi - ai >= -fi - ai` (the first of the
    /// pair on a tie, as the n-ary `h` takes it), else `-ni`. Its value is the same, bit
    /// for bit, as [`h`] of the six (tested), its gradient too but for the sign of a
    /// zero.
    ///
    /// `tmp` is working memory for up to `L` points (`L >= f.len()`), kept by the caller
    /// so that no call clears it.
    #[inline(always)]
    pub(crate) fn block<const GRADIENT: bool, const L: usize>(&self, x: &[f64], y: &[f64], z: &[f64], f: &mut [f64], g: [&mut [f64]; 3], tmp: &mut Lanes<L>) {
        let c = self.center;
        let r = self.radius;
        let n = f.len();
        assert!(n <= L, "{L} points at most");
        let (x, y, z) = (&x[..n], &y[..n], &z[..n]);
        let [gx, gy, gz] = g;
        let (gx, gy, gz) = if GRADIENT { (&mut gx[..n], &mut gy[..n], &mut gz[..n]) } else { (&mut [][..], &mut [][..], &mut [][..]) };
        let [a0, a1, a2] = self.axes;
        match self.kind {
            PrimKind::Plane => {
                for j in 0..n {
                    let (dx, dy, dz) = (x[j] - c.x, y[j] - c.y, z[j] - c.z);
                    f[j] = a0.x * dx + a0.y * dy + a0.z * dz;
                }
                if GRADIENT {
                    gx.fill(a0.x);
                    gy.fill(a0.y);
                    gz.fill(a0.z);
                }
            }
            PrimKind::Sphere => {
                for j in 0..n {
                    let (dx, dy, dz) = (x[j] - c.x, y[j] - c.y, z[j] - c.z);
                    let l = (dx * dx + dy * dy + dz * dz).sqrt();
                    f[j] = l - r;
                    if GRADIENT {
                        // At the centre the gradient is any unit vector: the first axis.
                        let inside = l > 0.0;
                        let (ux, uy, uz) = (dx / l, dy / l, dz / l);
                        gx[j] = if inside { ux } else { a0.x };
                        gy[j] = if inside { uy } else { a0.y };
                        gz[j] = if inside { uz } else { a0.z };
                    }
                }
            }
            PrimKind::Cuboid => {
                let [h0, h1, h2] = self.half;
                // Two passes, so that the second's divisions are made for every point
                // and its choice is a select: in one loop the compiler branches there
                // and the loop stays scalar. The first: each pair's larger value
                // `|fi| - ai` and the sign of its gradient.
                let Lanes { q, s } = tmp;
                for j in 0..n {
                    let (dx, dy, dz) = (x[j] - c.x, y[j] - c.y, z[j] - c.z);
                    let fs = [a0.x * dx + a0.y * dy + a0.z * dz, a1.x * dx + a1.y * dy + a1.z * dz, a2.x * dx + a2.y * dy + a2.z * dz];
                    for (i, (fi, hi)) in fs.into_iter().zip([h0, h1, h2]).enumerate() {
                        q[i][j] = fi.abs() - hi;
                        if GRADIENT {
                            s[i][j] = if fi - hi >= -fi - hi { 1.0 } else { -1.0 };
                        }
                    }
                }
                let [q0, q1, q2] = &*q;
                let [s0, s1, s2] = &*s;
                for j in 0..n {
                    // The largest (the first of equals) and its gradient `±ni`.
                    let (mut m, mut st, mut at) = (q0[j], s0[j], a0);
                    if GRADIENT {
                        (st, at) = if q1[j] > m { (s1[j], a1) } else { (st, at) };
                    }
                    m = if q1[j] > m { q1[j] } else { m };
                    if GRADIENT {
                        (st, at) = if q2[j] > m { (s2[j], a2) } else { (st, at) };
                    }
                    m = if q2[j] > m { q2[j] } else { m };
                    let (p0, p1, p2) = (q0[j].max(0.0) / m, q1[j].max(0.0) / m, q2[j].max(0.0) / m);
                    let len = (p0 * p0 + p1 * p1 + p2 * p2).sqrt();
                    let outside = m > 0.0;
                    f[j] = if outside { m * len } else { m } - r;
                    if GRADIENT {
                        // `Σ fi⁺ ∇fi / h` outside (in the n-ary `h`'s order, from a
                        // positive zero, so zeros keep its signs too); inside the
                        // largest's gradient.
                        let sum = |a: [f64; 3]| ((0.0 + p0 * (s0[j] * a[0])) + p1 * (s1[j] * a[1])) + p2 * (s2[j] * a[2]);
                        let (ox, oy, oz) = (sum([a0.x, a1.x, a2.x]) / len, sum([a0.y, a1.y, a2.y]) / len, sum([a0.z, a1.z, a2.z]) / len);
                        gx[j] = if outside { ox } else { st * at.x };
                        gy[j] = if outside { oy } else { st * at.y };
                        gz[j] = if outside { oz } else { st * at.z };
                    }
                }
            }
            PrimKind::Torus => {
                // Nested `h`s with branches: point by point.
                let major = self.half[0];
                for j in 0..n {
                    let d = DVec3::new(x[j], y[j], z[j]) - c;
                    let fs = [a0.dot(d), a1.dot(d), a2.dot(d)];
                    let (gv, gn) = h([fs[0], -fs[0], fs[1], -fs[1]], [a0, -a0, a1, -a1]);
                    let (v, grad) = h([gv - major, -gv + major, fs[2], -fs[2]], [gn, -gn, a2, -a2]);
                    f[j] = v - r;
                    if GRADIENT {
                        (gx[j], gy[j], gz[j]) = (grad.x, grad.y, grad.z);
                    }
                }
            }
        }
    }

    /// The box around the skeleton (the set the primitive measures its distance from);
    /// `None` for a plane.
    pub fn skeleton_box(&self) -> Option<(DVec3, DVec3)> {
        let extent = match self.kind {
            PrimKind::Plane => return None,
            PrimKind::Sphere => DVec3::ZERO,
            PrimKind::Cuboid => self.axes.iter().zip(self.half).map(|(a, h)| a.abs() * h).sum(),
            // A circle of radius `major` around axes[2]: along world axis j it reaches
            // major · sqrt(1 - axis_j²).
            PrimKind::Torus => (DVec3::ONE - self.axes[2] * self.axes[2]).max(DVec3::ZERO).powf(0.5) * self.half[0],
        };
        Some((self.center - extent, self.center + extent))
    }

    /// Encloses the primitive's values over the box `[lo, hi]`: exact for the plane and
    /// the sphere; for the skeletons (distances to the skeleton minus the radius,
    /// Lipschitz 1) the value at the box's centre within its half diagonal, and not
    /// below the distance between the box and the skeleton's box (nor the skeleton's
    /// deepest value where they meet), minus the radius.
    pub fn interval(&self, lo: DVec3, hi: DVec3) -> (f64, f64) {
        let (mid, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
        match self.kind {
            PrimKind::Plane => {
                let n = self.axes[0];
                let v = n.dot(mid - self.center);
                let r = n.abs().dot(half);
                (v - r, v + r)
            }
            PrimKind::Sphere => {
                let near = (lo - self.center).max(self.center - hi).max(DVec3::ZERO).length();
                let far = (self.center - lo).abs().max((self.center - hi).abs()).length();
                (near - self.radius, far - self.radius)
            }
            PrimKind::Cuboid | PrimKind::Torus => {
                let v = self.eval(mid).0;
                let r = half.length();
                let (slo, shi) = self.skeleton_box().expect("skeletons are bounded");
                // Apart from the skeleton's box, at least their distance; else at
                // least the skeleton's deepest value (`-min half` at a box's centre;
                // 0 on a circle).
                let gap = (slo - hi).max(lo - shi).max(DVec3::ZERO).length();
                let deepest = if self.kind == PrimKind::Cuboid { -self.half.iter().copied().fold(f64::INFINITY, f64::min) } else { 0.0 };
                let floor = if gap > 0.0 { gap } else { deepest } - self.radius;
                ((v - r).max(floor), v + r)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::eval::BLOCK;
    use super::*;

    #[test]
    fn cos_range_matches_dense_sampling() {
        let mut rng = crate::test_rng::Rng(0x9e37_79b9);
        let mut rand = || rng.uniform();
        for _ in 0..2000 {
            let a = 40.0 * rand() - 20.0;
            let b = a + 8.0 * rand() * rand();
            let (lo, hi) = cos_range(a, b);
            let (mut slo, mut shi) = (f64::INFINITY, f64::NEG_INFINITY);
            for k in 0..=4000 {
                let c = (a + (b - a) * k as f64 / 4000.0).cos();
                slo = slo.min(c);
                shi = shi.max(c);
            }
            // Contains every sample, and is tight up to the sampling's resolution.
            assert!(lo <= slo + 1e-12 && hi >= shi - 1e-12, "[{a}, {b}]: {lo}..{hi} vs {slo}..{shi}");
            assert!(slo - lo < 1e-5 && hi - shi < 1e-5, "[{a}, {b}]: {lo}..{hi} vs {slo}..{shi}");
        }
    }

    /// The vectorized exponential against `f64::exp`: within a relative `2 EPSILON` down to `-708`, the
    /// subnormal tail held at `e^-708` (far below a term of 1), NaN kept.
    #[test]
    fn exp_nonpositive_matches_std_exp() {
        let mut rng = crate::test_rng::Rng(0x5eed_e4b0);
        let mut xs: Vec<f64> = vec![0.0, -0.0, -1e-300, -1e-17, -0.5 * std::f64::consts::LN_2, -std::f64::consts::LN_2, -1.0, -36.0, -707.9, -708.0];
        xs.extend((0..20000).map(|k| -rng.uniform() * if k % 2 == 0 { 40.0 } else { 708.0 }));
        for x in xs {
            let (got, want) = (exp_nonpositive(x), x.exp());
            assert!((got - want).abs() <= 2.0 * f64::EPSILON * want, "exp({x}): {got} vs {want}");
        }
        for x in [-708.5, -745.0, -1e4, f64::NEG_INFINITY] {
            let got = exp_nonpositive(x);
            assert!(got >= x.exp() && got <= 1e-307, "exp({x}): {got}");
        }
        assert!(exp_nonpositive(f64::NAN).is_nan());
    }

    /// The vectorizable logarithm against `f64::ln`: within 1 ulp on 40k points over
    /// `[0.5, 2]`, `[1, 64]` (the log-sum-exp's sums), subnormals and the whole
    /// exponent range up to `f64::MAX`; exact at 1 and powers of two' neighbours'
    /// edges; the edge cases (0, infinity, negative, NaN) as `f64::ln` gives them.
    #[test]
    fn ln_matches_std_ln() {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        let mut rng = crate::test_rng::Rng(0x1095_eed5);
        let mut xs: Vec<f64> = vec![
            1.0,
            f64::MIN_POSITIVE,
            f64::MIN_POSITIVE * (1.0 - f64::EPSILON),
            f64::from_bits(1),
            f64::from_bits(0x000f_ffff_ffff_ffff),
            f64::MAX,
            1e300,
            1.0 + f64::EPSILON,
            1.0 - f64::EPSILON / 2.0,
            std::f64::consts::SQRT_2,
            std::f64::consts::FRAC_1_SQRT_2,
            std::f64::consts::E,
            2.0,
            0.5,
            15.0,
        ];
        for k in 0..40000 {
            let u = rng.uniform();
            xs.push(match k % 4 {
                0 => 0.5 + 1.5 * u,
                1 => 1.0 + 63.0 * u,
                // Subnormals, mantissa bits at random.
                2 => f64::from_bits((u * 0x000f_ffff_ffff_ffff_u64 as f64) as u64 + 1),
                // Every exponent: 2^(-1074..1024).
                _ => (2.0f64).powf(-1074.0 + 2098.0 * u).min(f64::MAX),
            });
        }
        let mut worst = 0;
        for &x in &xs {
            let (got, want) = (ln(x), x.ln());
            worst = worst.max(ulps(got, want));
            assert!(ulps(got, want) <= 1, "ln({x:e}): {got:e} vs {want:e}");
        }
        assert!(worst <= 1);
        assert_eq!(ln(1.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(ln(0.0), f64::NEG_INFINITY);
        assert_eq!(ln(-0.0), f64::NEG_INFINITY);
        assert_eq!(ln(f64::INFINITY), f64::INFINITY);
        assert!(ln(-1.0).is_nan() && ln(f64::NEG_INFINITY).is_nan() && ln(f64::NAN).is_nan() && ln(-f64::MIN_POSITIVE).is_nan());
    }

    /// Each kind's function as the paper writes it, point by point with branches: the
    /// reference the block kernel is held to.
    fn reference(prim: &Prim, x: DVec3) -> (f64, DVec3) {
        let d = x - prim.center;
        let [a0, a1, a2] = prim.axes;
        let f = [a0.dot(d), a1.dot(d), a2.dot(d)];
        let [h0, h1, h2] = prim.half;
        match prim.kind {
            PrimKind::Plane => (f[0], a0),
            PrimKind::Sphere => {
                let l = d.length();
                (l - prim.radius, if l > 0.0 { d / l } else { a0 })
            }
            PrimKind::Cuboid => {
                let (v, g) = h([f[0] - h0, -f[0] - h0, f[1] - h1, -f[1] - h1, f[2] - h2, -f[2] - h2], [a0, -a0, a1, -a1, a2, -a2]);
                (v - prim.radius, g)
            }
            PrimKind::Torus => {
                let (g, n) = h([f[0], -f[0], f[1], -f[1]], [a0, -a0, a1, -a1]);
                let (v, grad) = h([g - h0, -g + h0, f[2], -f[2]], [n, -n, a2, -a2]);
                (v - prim.radius, grad)
            }
        }
    }

    /// Equal bits, or both zero (the sign of a zero aside).
    fn same(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a == 0.0 && b == 0.0)
    }

    /// The block kernel ([`Prim::block`]) with and without gradients, and on one point
    /// ([`Prim::eval`]), against the branching reference (the n-ary `h` of the six
    /// plane functions for the box) bit for bit but for the sign of a zero, for every
    /// kind: random frames, sizes (zero included) and points, with points at the centre,
    /// on the frame's planes, on a face and on ties between two faces, in blocks of
    /// every length.
    #[test]
    fn block_kernel_matches_the_reference_bit_for_bit() {
        let mut rng = crate::test_rng::Rng(0xb10c_4a1e);
        let mut r = || rng.uniform();
        for case in 0..800 {
            let kind = [PrimKind::Sphere, PrimKind::Cuboid, PrimKind::Plane, PrimKind::Torus][case % 4];
            let q = glam::DQuat::from_xyzw(r() - 0.5, r() - 0.5, r() - 0.5, r() - 0.5).normalize();
            let m = glam::DMat3::from_quat(q);
            let center = DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5);
            let size = |x: f64| if case % 5 == 0 { 0.0 } else { x };
            let prim =
                Prim { kind, center, axes: [m.x_axis, m.y_axis, m.z_axis], half: [size(r()), size(r() * 0.5), size(r() * 0.2)], radius: size(r() * 0.1) };
            let len = 1 + case % BLOCK;
            let mut points: Vec<DVec3> = (0..len).map(|_| DVec3::new(2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0)).collect();
            let [a0, a1, a2] = prim.axes;
            let [h0, h1, _] = prim.half;
            let special = [center, center + a1 * 0.3, center + a0 * h0, center - a0 * h0 + a2 * 0.01, center + a0 * (h0 + 0.2) + a1 * (h1 + 0.2)];
            for (p, s) in points.iter_mut().zip(special) {
                *p = s;
            }
            let (x, y, z): (Vec<f64>, Vec<f64>, Vec<f64>) =
                (points.iter().map(|p| p.x).collect(), points.iter().map(|p| p.y).collect(), points.iter().map(|p| p.z).collect());
            let mut values = vec![0.0; len];
            let mut none = [[0.0; 0]; 3];
            let [n0, n1, n2] = &mut none;
            let mut lanes = Lanes::<BLOCK>::new();
            prim.block::<false, BLOCK>(&x, &y, &z, &mut values, [n0, n1, n2], &mut lanes);
            let (mut f, mut g) = (vec![0.0; len], [vec![0.0; len], vec![0.0; len], vec![0.0; len]]);
            let [g0, g1, g2] = &mut g;
            prim.block::<true, BLOCK>(&x, &y, &z, &mut f, [g0, g1, g2], &mut lanes);
            for (j, p) in points.iter().enumerate() {
                let (want, want_g) = reference(&prim, *p);
                let (one, one_g) = prim.eval(*p);
                let got_g = DVec3::new(g[0][j], g[1][j], g[2][j]);
                assert!(same(values[j], want) && same(f[j], want) && same(one, want), "{kind:?} at {p}: {} / {} / {one} vs {want}", values[j], f[j]);
                for a in 0..3 {
                    assert!(same(got_g[a], want_g[a]) && same(one_g[a], want_g[a]), "{kind:?} at {p}: gradient {got_g} / {one_g} vs {want_g}");
                }
            }
        }
    }

    #[test]
    fn wp_value_is_finite_and_near_max_for_large_p_and_values() {
        let v = [1e3, -1e3, 999.0];
        let w = wp_value(200.0, v.iter().copied());
        assert!(w.is_finite() && (w - 1e3).abs() < 1e-3, "{w}");
        let w = wp_value(200.0, v.iter().map(|x| -x));
        assert!(w.is_finite() && (w - 1e3).abs() < 1e-3, "{w}");
    }
}
