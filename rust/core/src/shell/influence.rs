//! How far a local change of the base surface reaches in the field (section 4.3.1's
//! locality, made quantitative for the incremental update of section 7.1).
//!
//! The field at `x` is a sum of per-patch pushes `c_T(x) = w_T A_T K(x - y_T)` with
//! `K(r) = p r |r|^{-p-2}`, `|K| = p|r|^{-p-1}`, `|∇K| <= p(p+1)|r|^{-p-2}` and
//! `|∇²K| <= p(p+1)(p+2)|r|^{-p-3}`. When a triangle changes from `T` to `T'`, at a
//! point whose distance to both is at least `D`:
//!
//! `|c_T'(x) - c_T(x)| <= p|ΔA|/D^{p+1} + p|Δw|A/D^{p+1} + p(p+1)A|Δy|/D^{p+2}
//!                        + p(p+1)(p+2)(A ρ² + A' ρ'²)/(2 D^{p+3})`
//!
//! (area, taper weight, centroid shift, and the patches' spread `ρ` about their
//! centroids, which bounds the exact integral's departure from the point mass). The
//! changed triangles are grouped in grid cells and the sums are kept per cell, with
//! `D` measured from the cell's bounding sphere. Divided by `|push(x)|`, this bounds
//! the turn of the field direction (and twice it the change of the speed), so a
//! trajectory whose bound stays below a tolerance keeps its director.
//!
//! The bound is for the field integrated face by face (`theta = 0`). The Barnes-Hut
//! tree lumps a node whose centroid is in the ball, so a change up to `(1 + theta)`
//! times farther can reach a trajectory through its node's monopole; such changes
//! are of the size of the tree's own approximation error, which the update's
//! measurements include (`shell_bench`). Between its samples a trajectory is taken
//! as the chord, and `|push|` as the smaller of the two ends.

use super::lp_distance::tree::tri_props;
use glam::{DVec3, IVec3};
use std::collections::HashMap;

/// The taper's steepest slope is `1.5 / ((1 - TAPER) radius)`.
const TAPER_SLOPE: f64 = 1.5 / (1.0 - super::lp_distance::tree::TAPER);

#[derive(Debug, Clone, Copy, Default)]
struct Cell {
    centre: DVec3,
    radius: f64,
    /// Coefficients of `D^{-(p+1)}` (area), `D^{-(p+1)}/R` (taper), `D^{-(p+2)}`
    /// (shift) and `D^{-(p+3)}` (spread).
    area: f64,
    taper: f64,
    shift: f64,
    spread: f64,
}

/// Per-cell sums for a set of changed triangles.
#[derive(Debug, Clone, Default)]
pub(crate) struct ChangeBound {
    cells: Vec<Cell>,
    /// A sphere around all cells, for a quick rejection.
    centre: DVec3,
    radius: f64,
    p: f64,
}

/// Distance from `c` to the segment `a b`.
fn segment_distance(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    let s = if l2 > 0.0 { ((c - a).dot(ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * s - c).length()
}

impl ChangeBound {
    /// `changes`: (old, new) corner positions of each changed triangle; `cell` is the
    /// grid spacing of the grouping (smaller: tighter bound, more cells).
    pub fn new(changes: &[([DVec3; 3], [DVec3; 3])], cell: f64, p: f64) -> Self {
        let mut groups: HashMap<IVec3, Vec<usize>> = HashMap::new();
        for (i, (old, new)) in changes.iter().enumerate() {
            let c = (old[0] + old[1] + old[2] + new[0] + new[1] + new[2]) / 6.0;
            groups.entry((c / cell).floor().as_ivec3()).or_default().push(i);
        }
        let (k1, k2, k3) = (p, p * (p + 1.0), 0.5 * p * (p + 1.0) * (p + 2.0));
        let mut cells: Vec<Cell> = groups
            .into_values()
            .map(|members| {
                let mut cell = Cell::default();
                let corners = members.iter().flat_map(|&i| changes[i].0.iter().chain(&changes[i].1));
                let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), q| (l.min(*q), h.max(*q)));
                cell.centre = (lo + hi) * 0.5;
                for &i in &members {
                    let (old, new) = &changes[i];
                    let ((a0, c0, r0), (a1, c1, r1)) = (tri_props(old), tri_props(new));
                    for q in old.iter().chain(new) {
                        cell.radius = cell.radius.max((*q - cell.centre).length());
                    }
                    let shift = (c1 - c0).length();
                    cell.area += k1 * (a1 - a0).abs();
                    cell.taper += k1 * TAPER_SLOPE * shift * a0.max(a1);
                    cell.shift += k2 * shift * a0.max(a1);
                    cell.spread += k3 * (a0 * r0 * r0 + a1 * r1 * r1);
                }
                cell
            })
            .collect();
        cells.sort_by(|a, b| a.centre.to_array().partial_cmp(&b.centre.to_array()).unwrap_or(std::cmp::Ordering::Equal));
        let (lo, hi) = cells.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(l, h), c| (l.min(c.centre - c.radius), h.max(c.centre + c.radius)));
        let centre = if cells.is_empty() { DVec3::ZERO } else { (lo + hi) * 0.5 };
        let radius = cells.iter().map(|c| (c.centre - centre).length() + c.radius).fold(0.0, f64::max);
        Self { cells, centre, radius, p }
    }

    /// Whether any changed triangle lies within `radius` of the segment `a b`: the
    /// locality rule (nothing beyond the support ball contributes).
    pub fn reaches(&self, a: DVec3, b: DVec3, radius: f64) -> bool {
        if self.cells.is_empty() || segment_distance(a, b, self.centre) > radius + self.radius {
            return false;
        }
        self.cells.iter().any(|c| segment_distance(a, b, c.centre) <= radius + c.radius)
    }

    /// Upper bound of `Σ |Δc_T|` anywhere on the segment `a b` for localization
    /// radius `radius`; infinite when the segment comes within 1.5 cell radii of a
    /// cell (where the expansion does not hold).
    pub fn on_segment(&self, a: DVec3, b: DVec3, radius: f64) -> f64 {
        let p = self.p;
        let mut sum = 0.0;
        for c in &self.cells {
            let dc = segment_distance(a, b, c.centre);
            if dc > radius + c.radius {
                continue; // outside the support: contributes exactly nothing
            }
            let d = dc - c.radius;
            if d <= 0.5 * c.radius || d <= 0.0 {
                return f64::INFINITY;
            }
            let d1 = if p == 3.0 { (d * d * d * d).recip() } else { d.powf(-(p + 1.0)) };
            // The taper's weight changes only for patches in its band (seen from
            // anywhere on the segment: its farther end bounds the distance).
            let far = (a - c.centre).length().max((b - c.centre).length());
            let taper = if far + c.radius >= super::lp_distance::tree::TAPER * radius { c.taper / radius } else { 0.0 };
            sum += d1 * (c.area + taper) + d1 / d * (c.shift + c.spread / d);
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shell::lp_distance::{Kernel, PatchTree};

    fn tri(c: DVec3, s: f64) -> [DVec3; 3] {
        [c, c + DVec3::new(s, 0.0, 0.0), c + DVec3::new(0.0, s, 0.1 * s)]
    }

    #[test]
    fn bounds_the_real_change_of_the_field() {
        // A patch of small triangles; some move, one grows. The field change measured
        // with exact integration stays below the bound on every segment tried.
        let mut old = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                old.push(tri(DVec3::new(i as f64 * 0.1, j as f64 * 0.1, 0.0), 0.1));
            }
        }
        let mut new = old.clone();
        for (k, t) in new.iter_mut().enumerate().filter(|(k, _)| k % 5 == 0) {
            for q in t.iter_mut() {
                *q += DVec3::new(0.01, -0.02, 0.03 + 0.001 * k as f64);
            }
        }
        new[9][2] += DVec3::new(0.05, 0.05, 0.0);
        let changes: Vec<_> = old.iter().zip(&new).filter(|(a, b)| a != b).map(|(a, b)| (*a, *b)).collect();
        let kernel = Kernel::new(3.0, 0.0);
        let (t_old, t_new) = (PatchTree::build(&old), PatchTree::build(&new));
        let bound = ChangeBound::new(&changes, 0.2, 3.0);
        let radius = 3.0;
        let mut finite = 0;
        for k in 0..40 {
            let a = DVec3::new(-0.5 + 0.05 * k as f64, 0.3, 0.4 + 0.02 * k as f64);
            let b = a + DVec3::new(0.1, 0.2, 0.3);
            let limit = bound.on_segment(a, b, radius);
            for s in 0..=8 {
                let x = a.lerp(b, s as f64 / 8.0);
                let d = t_new.eval(x, radius, DVec3::Z, &kernel).push - t_old.eval(x, radius, DVec3::Z, &kernel).push;
                assert!(d.length() <= limit, "at {x}: change {} above bound {limit}", d.length());
            }
            if limit.is_finite() {
                finite += 1;
                assert!(limit > 0.0);
            }
        }
        assert!(finite > 20, "only {finite} segments got a finite bound");
    }

    #[test]
    fn nothing_beyond_the_support_ball() {
        let t = tri(DVec3::ZERO, 0.1);
        let moved = tri(DVec3::new(0.0, 0.0, 0.05), 0.1);
        let bound = ChangeBound::new(&[(t, moved)], 0.5, 3.0);
        let (a, b) = (DVec3::new(3.0, 0.0, 0.0), DVec3::new(3.0, 0.0, 1.0));
        assert!(!bound.reaches(a, b, 2.0));
        assert_eq!(bound.on_segment(a, b, 2.0), 0.0);
        assert!(bound.reaches(a, b, 3.0));
        assert!(bound.on_segment(a, b, 3.0) > 0.0);
    }
}
