//! Exact integral of `|x - y|^-3` over a triangle and its gradient (p = 3), after
//! Appendix A: the triangle is a signed sum of three infinite wedges, each integrated
//! in closed form (equation A.2), with the decomposition chosen so that `x` lies in
//! none of the wedges whenever its projection lies outside the triangle.
//!
//! Numerics (all f64):
//! - `H` is evaluated as `2/|w| * atan2(|w| sin(β/2), (q-u) cos(β/2) - v sin(β/2))`,
//!   which is (A.2) with the arctangent on the right branch (the wedge integral is in
//!   `(0, 2π/|w|)`), and tends to the `w = 0` formula of Appendix A without a 0/0.
//! - `q - u` is formed as `(v² + w²)/(q + u)` when `u > 0` (no cancellation).
//! - The derivatives are those of Appendix A (`H_u`, `H_v`, `H_w`); `H_w = 0` at `w = 0`.

use glam::DVec3;

/// `∫_T |x-y|^-3 dy` and its gradient with respect to `x`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TriangleIntegral {
    pub value: f64,
    pub gradient: DVec3,
}

/// Integral over the wedge with apex `v` spanned by directions `d1`, `d2` (angle < π) in
/// the plane with unit normal `n`, evaluated at `x`; `w = (x - v)·n` (equation A.2).
#[inline]
fn wedge(v: DVec3, d1: DVec3, d2: DVec3, n: DVec3, x: DVec3, w: f64) -> (f64, DVec3) {
    let (mut a, mut b) = (d1.normalize(), d2.normalize());
    if a.cross(b).dot(n) < 0.0 {
        std::mem::swap(&mut a, &mut b);
    }
    let e1 = a;
    let e2 = n.cross(e1);
    let (sin_b, cos_b) = (b.dot(e2), b.dot(e1));
    let (sh, ch) = half_angle(sin_b, cos_b);
    let r = x - v;
    let (u, vv) = (r.dot(e1), r.dot(e2));
    let rho2 = u * u + vv * vv;
    let q = (rho2 + w * w).sqrt();
    if q == 0.0 {
        return (f64::INFINITY, DVec3::ZERO);
    }
    let q_minus_u = if u > 0.0 { (vv * vv + w * w) / (q + u) } else { q - u };
    let den = q_minus_u * ch - vv * sh;
    let aw = w.abs();
    let h = if aw == 0.0 {
        if den > 0.0 {
            2.0 * sh / den
        } else {
            f64::INFINITY
        }
    } else {
        2.0 / aw * (aw * sh).atan2(den)
    };
    // q - (u cos β + v sin β): distance-like term of the second edge ray, formed stably.
    let ub = u * cos_b + vv * sin_b;
    let perp = u * sin_b - vv * cos_b;
    let q_minus_ub = if ub > 0.0 { (perp * perp + w * w) / (q + ub) } else { q - ub };
    let hu = sin_b / (q * q_minus_ub);
    let hv = 1.0 / (q * q_minus_u) - cos_b / (q * q_minus_ub);
    let hw = if aw == 0.0 { 0.0 } else { -h / w + ((rho2 - q * u) * sin_b - q * vv * (1.0 - cos_b)) / (q * w * q_minus_u * q_minus_ub) };
    (h, e1 * hu + e2 * hv + n * hw)
}

/// `(sin β/2, cos β/2)` of the angle `β ∈ [0, π]` with sine `s >= 0` and cosine
/// `c` (a unit vector up to rounding), by the half-angle formulas instead of
/// `atan2` and `sin_cos`: the square root is taken of `1 ± c` where that is at
/// least 1 (no cancellation), the other factor follows from `sin β = 2 sin β/2 cos β/2`.
/// Those calls were about a third of the cost of a near face (three wedges each).
#[inline]
fn half_angle(s: f64, c: f64) -> (f64, f64) {
    let r = (s * s + c * c).sqrt();
    let (s, c) = (s.max(0.0) / r, c / r);
    if c >= 0.0 {
        let ch = (0.5 * (1.0 + c)).sqrt();
        (0.5 * s / ch, ch)
    } else {
        let sh = (0.5 * (1.0 - c)).sqrt();
        (sh, 0.5 * s / sh)
    }
}

/// Exact `∫_T |x-y|^-3 dy` over triangle `(a, b, c)` and its gradient in `x`.
/// Zero for degenerate triangles; infinite (non-finite) when `x` lies on the triangle.
pub fn triangle_p3(a: DVec3, b: DVec3, c: DVec3, x: DVec3) -> TriangleIntegral {
    let nn = (b - a).cross(c - a);
    let area2 = nn.length();
    let scale = (b - a).length_squared().max((c - a).length_squared()).max((c - b).length_squared());
    if area2 <= 1e-14 * scale || area2 == 0.0 {
        return TriangleIntegral::default();
    }
    let n = nn / area2;
    let w = (x - a).dot(n);
    let xp = x - n * w;
    let p = [a, b, c];
    // Barycentric coordinates of the projection.
    let l0 = n.dot((b - xp).cross(c - xp)) / area2;
    let l1 = n.dot((c - xp).cross(a - xp)) / area2;
    let l = [l0, l1, 1.0 - l0 - l1];
    // A = largest, C = smallest barycentric: then x is outside W_B and W_C always,
    // and outside W_A too whenever its projection is outside the triangle.
    let ia = (0..3).max_by(|&i, &j| l[i].total_cmp(&l[j])).unwrap();
    let ic = (0..3).filter(|&i| i != ia).min_by(|&i, &j| l[i].total_cmp(&l[j])).unwrap();
    let ib = 3 - ia - ic;
    let (pa, pb, pc) = (p[ia], p[ib], p[ic]);
    // T = W_A - W_B + W_C with W_A = cone(A; B-A, C-A), W_B = cone(B; B-A, C-B),
    // W_C = cone(C; C-B, C-A).
    let (ha, ga) = wedge(pa, pb - pa, pc - pa, n, x, w);
    let (hb, gb) = wedge(pb, pb - pa, pc - pb, n, x, w);
    let (hc, gc) = wedge(pc, pc - pb, pc - pa, n, x, w);
    TriangleIntegral { value: ha - hb + hc, gradient: ga - gb + gc }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shell::lp_distance::quadrature::Quadrature;

    use crate::test_rng::Rng;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    /// The half-angle formulas agree with `atan2` and `sin_cos` to rounding, over the
    /// whole range, at both ends and around the switch at π/2.
    #[test]
    fn half_angles_match_the_trigonometric_ones() {
        use std::f64::consts::{FRAC_PI_2, PI};
        let mut rng = Rng(0x51ed_270b);
        let special = [0.0, 1e-12, 1e-6, 0.5, FRAC_PI_2 - 1e-9, FRAC_PI_2, 2.0, PI - 1e-9, PI];
        for beta in special.into_iter().chain((0..2000).map(|_| rng.uniform() * PI)) {
            let (s, c) = beta.sin_cos();
            let (sh, ch) = half_angle(s, c);
            let (want_s, want_c) = (0.5 * s.atan2(c)).sin_cos();
            assert!((sh - want_s).abs() <= 4e-16 && (ch - want_c).abs() <= 4e-16, "{beta}: ({sh}, {ch}) vs ({want_s}, {want_c})");
        }
    }

    #[test]
    fn exact_matches_quadrature_on_random_triangles() {
        let quad = Quadrature::new(12, 0.3, 10);
        let mut rng = Rng(0x9e3779b97f4a7c15);
        let mut worst: f64 = 0.0;
        for k in 0..300 {
            let (a, b, c) = (rng.vec(1.0), rng.vec(1.0), rng.vec(1.0));
            let n = (b - a).cross(c - a).normalize();
            // A point off the plane: random projection (inside or outside), random height.
            let h = (0.02 + rng.uniform()) * if k % 2 == 0 { 1.0 } else { -1.0 };
            let x = a + (rng.vec(1.0) * 1.5) + n * h;
            let x = x - n * (x - a).dot(n) + n * h;
            let e = triangle_p3(a, b, c, x);
            let (v, push) = quad.integrate([a, b, c], x, 3.0);
            let err_v = rel(e.value, v);
            let err_g = (e.gradient + push).length() / push.length();
            worst = worst.max(err_v).max(err_g);
            assert!(err_v < 1e-6, "value {k}: exact {} quad {v} ({err_v})", e.value);
            assert!(err_g < 1e-6, "gradient {k}: exact {} quad {} ({err_g})", e.gradient, -push);
        }
        eprintln!("worst relative error vs quadrature: {worst:e}");
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let mut rng = Rng(12345);
        for k in 0..200 {
            let (a, b, c) = (rng.vec(1.0), rng.vec(1.0), rng.vec(1.0));
            let x = rng.vec(1.0) * 2.0;
            let n = (b - a).cross(c - a).normalize();
            if (x - a).dot(n).abs() < 0.05 {
                continue;
            }
            let g = triangle_p3(a, b, c, x).gradient;
            let eps = 1e-5;
            let fd = DVec3::new(
                triangle_p3(a, b, c, x + DVec3::X * eps).value - triangle_p3(a, b, c, x - DVec3::X * eps).value,
                triangle_p3(a, b, c, x + DVec3::Y * eps).value - triangle_p3(a, b, c, x - DVec3::Y * eps).value,
                triangle_p3(a, b, c, x + DVec3::Z * eps).value - triangle_p3(a, b, c, x - DVec3::Z * eps).value,
            ) / (2.0 * eps);
            let err = (g - fd).length() / g.length();
            assert!(err < 1e-6, "{k}: analytic {g} fd {fd} ({err})");
        }
    }

    #[test]
    fn in_plane_and_near_plane_points_are_stable() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let quad = Quadrature::new(12, 0.3, 12);
        // In the plane, outside the triangle, in every region around it.
        for x in [DVec3::new(2.0, 0.3, 0.0), DVec3::new(-1.0, -1.0, 0.0), DVec3::new(0.3, -0.5, 0.0), DVec3::new(1.5, 1.5, 0.0), DVec3::new(3.0, 0.0, 0.0)] {
            let e = triangle_p3(a, b, c, x);
            let (v, push) = quad.integrate([a, b, c], x, 3.0);
            assert!(rel(e.value, v) < 1e-6, "{x}: {} vs {v}", e.value);
            assert!((e.gradient + push).length() / push.length() < 1e-6, "{x}: {} vs {}", e.gradient, -push);
            assert_eq!(e.gradient.z, 0.0);
            // Continuity across w = 0.
            let up = triangle_p3(a, b, c, x + DVec3::Z * 1e-9);
            assert!(rel(up.value, e.value) < 1e-6 && up.gradient.z.abs() < 1e-6);
        }
        // Just above the interior: ~ 2π/w.
        let x = DVec3::new(0.25, 0.25, 1e-6);
        let e = triangle_p3(a, b, c, x);
        assert!(rel(e.value, 2.0 * std::f64::consts::PI / 1e-6) < 1e-4, "{}", e.value);
        assert!(e.gradient.z < 0.0 && e.value.is_finite());
        // Symmetric below.
        let f = triangle_p3(a, b, c, DVec3::new(0.25, 0.25, -1e-6));
        assert!(rel(f.value, e.value) < 1e-12 && (f.gradient.z + e.gradient.z).abs() < 1e-6 * e.gradient.z.abs());
        // Degenerate triangles contribute nothing.
        assert_eq!(triangle_p3(a, b, b * 2.0, DVec3::Z).value, 0.0);
    }
}
