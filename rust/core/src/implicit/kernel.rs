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
#[inline]
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
    #[inline]
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

    #[test]
    fn wp_value_is_finite_and_near_max_for_large_p_and_values() {
        let v = [1e3, -1e3, 999.0];
        let w = wp_value(200.0, v.iter().copied());
        assert!(w.is_finite() && (w - 1e3).abs() < 1e-3, "{w}");
        let w = wp_value(200.0, v.iter().map(|x| -x));
        assert!(w.is_finite() && (w - 1e3).abs() < 1e-3, "{w}");
    }
}
