//! The building blocks' arithmetic, shared by the evaluator and the bounds: the n-ary
//! `h` of section 3, the log-sum-exp form of `w_p` (section 4), the texture function
//! and the primitives compiled to their frames.

use super::eval::BLOCK;
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
/// loop over a block of points vectorizes: `x = n ln 2 + r` with `|r| <= ln 2 / 2`
/// (Cody and Waite's split of `ln 2`), `e^r` by its Taylor series to degree 13
/// (remainder below 2e-16 relative), times `2^n` built in the exponent bits. Within
/// a relative `2 EPSILON` of `f64::exp` (tested); below `-708` (where `e^x` is subnormal) it gives
/// `e^-708`, a term that cannot change a sum holding the largest term's 1. A NaN
/// stays NaN.
#[inline(always)]
pub(crate) fn exp_nonpositive(x: f64) -> f64 {
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    // 1.5 * 2^52: adding it rounds to an integer held in the low mantissa bits.
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    debug_assert!(!(x > 0.0), "exp_nonpositive({x}): a positive argument would overflow the exponent bits");
    let x = if x < -708.0 { -708.0 } else { x };
    let t = x * std::f64::consts::LOG2_E + SHIFT;
    let n = t - SHIFT;
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let mut e = 1.0 / 6_227_020_800.0;
    for k in (0..13).rev() {
        e = e * r + INV_FACTORIAL[k];
    }
    // The low bits of `t` are `n` (-1022 <= n <= 0): `2^n` has exponent `n + 1023`.
    let scale = f64::from_bits(t.to_bits().wrapping_add(1023) << 52);
    e * scale
}

/// `1 / k!` for `k` from 0 to 12.
const INV_FACTORIAL: [f64; 13] = [
    1.0,
    1.0,
    0.5,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5_040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
];

/// The texture function `(1 + cos(omega f + tau)) / 2` (section 2, with section 7's phase).
#[inline]
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

impl Prim {
    /// Value and gradient at `x`.
    #[inline(always)]
    pub fn eval(&self, x: DVec3) -> (f64, DVec3) {
        let d = x - self.center;
        let [a0, a1, a2] = self.axes;
        match self.kind {
            PrimKind::Plane => (a0.dot(d), a0),
            PrimKind::Sphere => {
                let l = d.length();
                // At the centre the gradient is any unit vector: the first axis.
                (l - self.radius, if l > 0.0 { d / l } else { a0 })
            }
            PrimKind::Cuboid => {
                let f = [a0.dot(d), a1.dot(d), a2.dot(d)];
                let [h0, h1, h2] = self.half;
                let (v, g) = h([f[0] - h0, -f[0] - h0, f[1] - h1, -f[1] - h1, f[2] - h2, -f[2] - h2], [a0, -a0, a1, -a1, a2, -a2]);
                (v - self.radius, g)
            }
            PrimKind::Torus => {
                let f = [a0.dot(d), a1.dot(d), a2.dot(d)];
                let (g, n) = h([f[0], -f[0], f[1], -f[1]], [a0, -a0, a1, -a1]);
                let major = self.half[0];
                let (v, grad) = h([g - major, -g + major, f[2], -f[2]], [n, -n, a2, -a2]);
                (v - self.radius, grad)
            }
        }
    }

    /// Values only over a block of points given as coordinate arrays (`x`, `y`, `z` and
    /// `out` of one length): the same arithmetic as [`Prim::eval`] in the same order
    /// (so the same values, bit for bit, but for the sign of a zero and a NaN
    /// coordinate, which `f64::max` may drop: points are checked finite before they
    /// reach a tape), written without branches per point so the
    /// loop vectorizes; `h` of the box's six plane functions uses that at most one of
    /// `fi - ai` and `-fi - ai` is positive (`ai >= 0`): the larger is `|fi| - ai`.
    #[inline(always)]
    pub(crate) fn values(&self, x: &[f64], y: &[f64], z: &[f64], out: &mut [f64]) {
        let c = self.center;
        let r = self.radius;
        let n = out.len();
        assert!(n <= BLOCK, "a block at most");
        let (x, y, z) = (&x[..n], &y[..n], &z[..n]);
        match self.kind {
            PrimKind::Sphere => {
                for j in 0..n {
                    let (dx, dy, dz) = (x[j] - c.x, y[j] - c.y, z[j] - c.z);
                    out[j] = (dx * dx + dy * dy + dz * dz).sqrt() - r;
                }
            }
            PrimKind::Cuboid => {
                let [a0, a1, a2] = self.axes;
                let [h0, h1, h2] = self.half;
                // Two passes, so that the second's divisions are made for every point
                // and its choice is a select: in one loop the compiler branches there
                // and the loop stays scalar.
                let mut q = [[0.0; BLOCK]; 3];
                for j in 0..n {
                    let (dx, dy, dz) = (x[j] - c.x, y[j] - c.y, z[j] - c.z);
                    q[0][j] = (a0.x * dx + a0.y * dy + a0.z * dz).abs() - h0;
                    q[1][j] = (a1.x * dx + a1.y * dy + a1.z * dz).abs() - h1;
                    q[2][j] = (a2.x * dx + a2.y * dy + a2.z * dz).abs() - h2;
                }
                let [q0, q1, q2] = &q;
                for j in 0..n {
                    let m = q0[j].max(q1[j]).max(q2[j]);
                    let (p0, p1, p2) = (q0[j].max(0.0) / m, q1[j].max(0.0) / m, q2[j].max(0.0) / m);
                    let len = (p0 * p0 + p1 * p1 + p2 * p2).sqrt();
                    let v = m * len;
                    out[j] = if m > 0.0 { v } else { m } - r;
                }
            }
            PrimKind::Plane | PrimKind::Torus => {
                for j in 0..n {
                    out[j] = self.eval(DVec3::new(x[j], y[j], z[j])).0;
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

    /// The block loop of values ([`Prim::values`]) against [`Prim::eval`] point by
    /// point, bit for bit, for every kind: random frames, sizes (zero included) and
    /// points, with points on the frame's planes and at the centre.
    #[test]
    fn block_values_match_eval_bit_for_bit() {
        let mut rng = crate::test_rng::Rng(0xb10c_4a1e);
        let mut r = || rng.uniform();
        for case in 0..400 {
            let kind = [PrimKind::Sphere, PrimKind::Cuboid, PrimKind::Plane, PrimKind::Torus][case % 4];
            let q = glam::DQuat::from_xyzw(r() - 0.5, r() - 0.5, r() - 0.5, r() - 0.5).normalize();
            let m = glam::DMat3::from_quat(q);
            let center = DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5);
            let size = |x: f64| if case % 5 == 0 { 0.0 } else { x };
            let prim =
                Prim { kind, center, axes: [m.x_axis, m.y_axis, m.z_axis], half: [size(r()), size(r() * 0.5), size(r() * 0.2)], radius: size(r() * 0.1) };
            let mut points: Vec<DVec3> = (0..61).map(|_| DVec3::new(2.0 * r() - 1.0, 2.0 * r() - 1.0, 2.0 * r() - 1.0)).collect();
            points.push(center);
            points.push(center + prim.axes[1] * 0.3);
            points.push(center + prim.axes[0] * prim.half[0]);
            let (x, y, z): (Vec<f64>, Vec<f64>, Vec<f64>) =
                (points.iter().map(|p| p.x).collect(), points.iter().map(|p| p.y).collect(), points.iter().map(|p| p.z).collect());
            let mut out = vec![0.0; points.len()];
            prim.values(&x, &y, &z, &mut out);
            for (p, v) in points.iter().zip(&out) {
                let want = prim.eval(*p).0;
                assert!(v.to_bits() == want.to_bits() || (*v == 0.0 && want == 0.0), "{kind:?} at {p}: {v} vs {want}");
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
