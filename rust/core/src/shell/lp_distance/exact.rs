//! Exact integral of `|x - y|^-3` over a triangle and its gradient (p = 3), the closed
//! form of Appendix A (equation A.2) in the solid-angle form: with `w` the height of
//! `x` over the triangle's plane, `|w| |x-y|^-3 dy` is the solid angle element, so
//! `∫_T |x-y|^-3 dy = Ω / |w|` where `Ω` is the solid angle the triangle subtends at
//! `x`. Appendix A sums three wedges, each with its own arctangent; this form needs one
//! arctangent per triangle and no normalized edge directions (measured here: the near
//! faces of a field evaluation cost a third of the tracing before; chapter 4.4
//! discusses the cost of exact integration).
//!
//! Numerics (all f64):
//! - `Ω/2 = atan2(|w| 2A, D)` (Van Oosterom and Strackee, 1983) with
//!   `D = |a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|`, `a, b, c` the corners seen
//!   from `x`: the triple product `[a b c]` is `-w 2A` exactly, so the value tends to
//!   the in-plane limit `4A / D` without a 0/0.
//! - The gradient is `-(S + Ω_s n/w)/w` with `Ω_s = w V` and `S` the Biot-Savart sum
//!   of the edges (the gradient of the solid angle is `-S`): per edge `P1 -> P2`,
//!   `(r1 × e) k` with `r1 = P1 - x`, `e = P2 - P1` and
//!   `k = (|r1| + |r2|) / (|r1||r2| (|r1||r2| + r1·r2))`. The in-plane part of
//!   `r1 × e` is `-w (n × e)` exactly, so the in-plane gradient `Σ k (n × e)` has no
//!   division by `w`; `|r1||r2| + r1·r2` is formed as `|r1 × e|² / (|r1||r2| - r1·r2)`
//!   where `r1·r2 < 0` (no cancellation near the edge). The normal part is 0 at `w = 0`.

use glam::DVec3;

/// `∫_T |x-y|^-3 dy` and its gradient with respect to `x`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TriangleIntegral {
    pub value: f64,
    pub gradient: DVec3,
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
    let r = [a - x, b - x, c - x];
    let w = -r[0].dot(n);
    let l = r.map(|r| r.length());
    let den = l[0] * l[1] * l[2] + r[0].dot(r[1]) * l[2] + r[0].dot(r[2]) * l[1] + r[1].dot(r[2]) * l[0];
    let aw = w.abs();
    let value = if aw == 0.0 {
        if den > 0.0 {
            2.0 * area2 / den
        } else {
            return TriangleIntegral { value: f64::INFINITY, gradient: DVec3::ZERO };
        }
    } else {
        2.0 / aw * (aw * area2).atan2(den)
    };
    // Biot-Savart edge sums: normal part `Σ k n·(r1 × e)`, in-plane part `Σ k (n × e)`.
    let (mut normal, mut inplane) = (0.0, DVec3::ZERO);
    for i in 0..3 {
        let j = (i + 1) % 3;
        let e = r[j] - r[i];
        let cross = r[i].cross(e);
        let (ll, dot) = (l[i] * l[j], r[i].dot(r[j]));
        let sum = if dot < 0.0 { cross.length_squared() / (ll - dot) } else { ll + dot };
        let k = (l[i] + l[j]) / (ll * sum);
        if !k.is_finite() {
            return TriangleIntegral { value: f64::INFINITY, gradient: DVec3::ZERO };
        }
        normal += k * n.dot(cross);
        inplane += n.cross(e) * k;
    }
    let dw = if aw == 0.0 { 0.0 } else { -(normal + value) / w };
    TriangleIntegral { value, gradient: inplane + n * dw }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shell::lp_distance::quadrature::Quadrature;

    use crate::test_rng::Rng;

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
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

    /// The halves of a triangle (split at an edge's midpoint) add up to the whole in
    /// value and gradient, at heights from 1e-6 to 1 over points inside and outside:
    /// the halves' solid angles and edge sums are formed from other corners and edges
    /// (the new edge runs through the triangle, near the projection of many points).
    #[test]
    fn halves_add_up_to_the_whole() {
        let mut rng = Rng(0x2545_f491);
        for k in 0..800 {
            let (a, b, c) = (rng.vec(1.0), rng.vec(1.0), rng.vec(1.0));
            let nn = (b - a).cross(c - a);
            if nn.length() < 0.05 {
                continue;
            }
            let (n, m) = (nn.normalize(), 0.5 * (a + b));
            let h = [1e-6, 1e-3, 0.1, 1.0][k % 4] * if k % 8 < 4 { 1.0 } else { -1.0 };
            let x = rng.vec(1.5);
            let x = x - n * (x - a).dot(n) + n * h;
            let whole = triangle_p3(a, b, c, x);
            let (p, q) = (triangle_p3(a, m, c, x), triangle_p3(m, b, c, x));
            assert!(rel(p.value + q.value, whole.value) < 1e-7, "{k}: {} + {} vs {}", p.value, q.value, whole.value);
            let err = (p.gradient + q.gradient - whole.gradient).length() / whole.gradient.length();
            assert!(err < 1e-7, "{k}: gradient {} vs {} ({err})", p.gradient + q.gradient, whole.gradient);
        }
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

    /// Near the plane (|w| from 1e-3 to 1e-2), inside and outside the triangle, the
    /// gradient matches central differences taken at a step far below |w|.
    #[test]
    fn gradient_near_the_plane_matches_finite_differences() {
        let mut rng = Rng(777);
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let mut inside = 0;
        for k in 0..300 {
            let p = rng.vec(1.0) * 1.5 + DVec3::new(0.3, 0.3, 0.0);
            let w = (if k % 2 == 0 { 1.0 } else { -1.0 }) * 10f64.powf(-3.0 + (k % 7) as f64 / 6.0);
            let x = DVec3::new(p.x, p.y, w);
            inside += usize::from(p.x > 0.0 && p.y > 0.0 && p.x + p.y < 1.0);
            let g = triangle_p3(a, b, c, x).gradient;
            let eps = 1e-3 * w.abs();
            let d = |e: DVec3| (triangle_p3(a, b, c, x + e * eps).value - triangle_p3(a, b, c, x - e * eps).value) / (2.0 * eps);
            let fd = DVec3::new(d(DVec3::X), d(DVec3::Y), d(DVec3::Z));
            let err = (g - fd).length() / g.length();
            assert!(err < 1e-5, "{k}: x {x}: analytic {g} fd {fd} ({err})");
        }
        assert!(inside > 10 && inside < 290, "{inside} points over the triangle");
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
