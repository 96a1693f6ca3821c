//! High-order numerical integration of `|x-y|^-p` (and its gradient) over a triangle:
//! collapsed (Duffy) tensor Gauss–Legendre rules on adaptively 4-split sub-triangles.
//! The general-p path of the field (chapter 4.2, any p > 1) and the independent
//! reference that the exact p = 3 formulas are tested against.

use glam::DVec3;

/// Gauss–Legendre nodes and weights on [0, 1], by Newton iteration on P_n.
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let n = n.max(1);
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, z);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * z * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 1 { z } else { p1 };
            let pm = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (z * pn - pm) / (z * z - 1.0);
            let dz = pn / dp;
            z -= dz;
            if dz.abs() < 1e-15 {
                break;
            }
        }
        out.push((0.5 * (1.0 - z), 1.0 / ((1.0 - z * z) * dp * dp)));
    }
    out
}

/// An adaptive quadrature rule: `order` Gauss points per direction; a sub-triangle is
/// split while its diameter exceeds `ratio` times its centroid's distance to `x`,
/// at most `max_depth` times.
#[derive(Debug, Clone)]
pub struct Quadrature {
    rule: Vec<(f64, f64)>,
    pub ratio: f64,
    pub max_depth: u32,
}

impl Quadrature {
    pub fn new(order: usize, ratio: f64, max_depth: u32) -> Self {
        Self { rule: gauss_legendre(order), ratio, max_depth }
    }

    /// `(∫_T |x-y|^-p dy, p ∫_T (x-y)|x-y|^{-p-2} dy)`: the value and the "push",
    /// i.e. minus the gradient of the value with respect to `x`.
    pub fn integrate(&self, tri: [DVec3; 3], x: DVec3, p: f64) -> (f64, DVec3) {
        self.rec(tri, x, p, 0)
    }

    fn rec(&self, [a, b, c]: [DVec3; 3], x: DVec3, p: f64, depth: u32) -> (f64, DVec3) {
        let diam = (b - a).length().max((c - a).length()).max((c - b).length());
        let dist = (x - (a + b + c) / 3.0).length();
        if depth < self.max_depth && diam > self.ratio * dist {
            let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
            let mut acc = (0.0, DVec3::ZERO);
            for t in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
                let r = self.rec(t, x, p, depth + 1);
                acc.0 += r.0;
                acc.1 += r.1;
            }
            return acc;
        }
        let area2 = (b - a).cross(c - a).length();
        let (mut val, mut push) = (0.0, DVec3::ZERO);
        for &(xi, wi) in &self.rule {
            for &(eta, wj) in &self.rule {
                // Duffy: (xi, eta) in the unit square -> triangle, Jacobian xi * 2 * area.
                let y = a + (b - a) * (xi * (1.0 - eta)) + (c - a) * (xi * eta);
                let d = x - y;
                let r2 = d.length_squared();
                let k = r2.powf(-0.5 * p);
                let wgt = wi * wj * xi * area2;
                val += wgt * k;
                push += d * (wgt * p * k / r2);
            }
        }
        (val, push)
    }
}
