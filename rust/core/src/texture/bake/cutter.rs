//! Inside/outside of a closed cutter mesh, for cutting holes (thick surfaces, chapter
//! 7.3: "re-sampling the volumetric object over the shell grid").
//!
//! A point is inside when a ray from it along +z crosses the surface an odd number of
//! times. Triangles are projected to the xy plane and binned in a uniform grid; the
//! point-in-triangle test uses edge functions with a top-left tie rule, so a ray
//! through a shared edge or vertex counts exactly one of the triangles around it.

use crate::{Error, Result};
use glam::{DVec2, Vec3};
use std::collections::HashMap;

#[derive(Debug, Clone)]
pub struct Cutter {
    tris: Vec<[Vec3; 3]>,
    lo: DVec2,
    cell: f64,
    side: usize,
    bins: Vec<Vec<u32>>,
}

impl Cutter {
    /// A cutter from triangles over `positions`; it must be closed (every edge used by
    /// an even number of triangles), or inside/outside means nothing.
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<Self> {
        if triangles.is_empty() {
            return Err(Error::InvalidParameter("the cutter has no faces".into()));
        }
        if let Some(v) = triangles.iter().flatten().find(|v| **v as usize >= positions.len()) {
            return Err(Error::InvalidParameter(format!("cutter vertex index {v} out of range")));
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(Error::InvalidParameter("the cutter has non-finite coordinates".into()));
        }
        let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let open = uses.values().filter(|u| **u % 2 == 1).count();
        if open > 0 {
            return Err(Error::InvalidParameter(format!("the cutter is not closed: {open} edges border a hole; close it (or use a vertex group)")));
        }
        let tris: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|v| positions[v as usize])).collect();
        let (mut lo, mut hi) = (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN));
        for p in tris.iter().flatten() {
            lo = lo.min(p.truncate().as_dvec2());
            hi = hi.max(p.truncate().as_dvec2());
        }
        let side = ((tris.len() as f64).sqrt().ceil() as usize).clamp(1, 512);
        let cell = ((hi - lo).max_element() / side as f64).max(1e-12);
        let mut bins = vec![Vec::new(); side * side];
        let bin = |x: f64, lo: f64| (((x - lo) / cell) as usize).min(side - 1);
        // Each triangle also goes into bins within a hair of its box, so a renderer
        // that finds a point's bin in single precision (the GPU slice renderer) still
        // sees it; `contains` tests each triangle exactly, so extra ones change nothing.
        let pad = DVec2::splat(1e-4 * cell);
        for (k, t) in tris.iter().enumerate() {
            let (a, b) =
                t.iter().fold((DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)), |(a, b), p| (a.min(p.truncate().as_dvec2()), b.max(p.truncate().as_dvec2())));
            let (a, b) = (a - pad, b + pad);
            for y in bin(a.y, lo.y)..=bin(b.y, lo.y) {
                for x in bin(a.x, lo.x)..=bin(b.x, lo.x) {
                    bins[y * side + x].push(k as u32);
                }
            }
        }
        Ok(Self { tris, lo, cell, side, bins })
    }

    /// Whether `p` lies inside the cutter.
    pub fn contains(&self, p: Vec3) -> bool {
        let q = p.truncate().as_dvec2() - self.lo;
        if q.x < 0.0 || q.y < 0.0 {
            return false;
        }
        let (x, y) = ((q.x / self.cell) as usize, (q.y / self.cell) as usize);
        if x > self.side || y > self.side {
            return false;
        }
        let bin = &self.bins[y.min(self.side - 1) * self.side + x.min(self.side - 1)];
        let mut crossings = 0u32;
        for &k in bin {
            if let Some(z) = ray_hit(&self.tris[k as usize], p) {
                crossings += u32::from(z > p.z as f64);
            }
        }
        crossings % 2 == 1
    }
}

impl Cutter {
    /// The cutter's bounding box.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.tris.iter().flatten().fold((Vec3::MAX, Vec3::MIN), |(a, b), p| (a.min(*p), b.max(*p)))
    }

    /// The cutter's triangles (what its bins are made from).
    pub fn triangles(&self) -> &[[Vec3; 3]] {
        &self.tris
    }

    /// The test's data for a renderer that runs [`contains`](Self::contains) itself
    /// (the GPU slice renderer): the triangles, the bins' first `(x, y)` and size,
    /// the bins per side, and the bins as one list (`side² + 1` offsets into the
    /// triangle indices that follow them, row by row).
    pub fn flat_bins(&self) -> (&[[Vec3; 3]], glam::Vec2, f32, usize, Vec<u32>) {
        let mut flat = Vec::with_capacity(self.bins.len() + 1 + self.bins.iter().map(Vec::len).sum::<usize>());
        let first = self.bins.len() as u32 + 1;
        let mut at = first;
        for bin in &self.bins {
            flat.push(at);
            at += bin.len() as u32;
        }
        flat.push(at);
        self.bins.iter().for_each(|b| flat.extend(b));
        (&self.tris, self.lo.as_vec2(), self.cell as f32, self.side, flat)
    }
}

/// Height at which the vertical line through `p` meets triangle `t`, counting shared
/// edges and vertices once (top-left rule on the projected, counter-clockwise triangle).
fn ray_hit(t: &[Vec3; 3], p: Vec3) -> Option<f64> {
    let [a, mut b, mut c] = t.map(|v| v.as_dvec3());
    let area = (b - a).truncate().perp_dot((c - a).truncate());
    if area == 0.0 {
        return None;
    }
    if area < 0.0 {
        std::mem::swap(&mut b, &mut c);
    }
    let q = p.truncate().as_dvec2();
    let edge = |u: glam::DVec3, v: glam::DVec3| {
        let d = (v - u).truncate();
        let e = d.perp_dot(q - u.truncate());
        // Top-left: an upper horizontal edge (pointing -x) or a left edge (pointing -y).
        e > 0.0 || (e == 0.0 && (d.y < 0.0 || (d.y == 0.0 && d.x < 0.0)))
    };
    if !(edge(a, b) && edge(b, c) && edge(c, a)) {
        return None;
    }
    let w = [(c - b).truncate().perp_dot(q - b.truncate()), (a - c).truncate().perp_dot(q - c.truncate()), (b - a).truncate().perp_dot(q - a.truncate())];
    let sum = w[0] + w[1] + w[2];
    Some((a.z * w[0] + b.z * w[1] + c.z * w[2]) / sum)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_flat_bins_give_contains() {
        // The flat bins, walked as the GPU slice renderer walks them (the point's
        // bin, the crossings above it among its triangles), agree with `contains`.
        let sphere = crate::testmeshes::icosphere(3);
        let s = sphere.triangulate();
        let cutter = Cutter::new(sphere.positions(), &s.triangles).unwrap();
        let (lo, hi) = cutter.bounds();
        assert!((lo + Vec3::ONE).length() < 0.05 && (hi - Vec3::ONE).length() < 0.05, "{lo} {hi}");
        let (tris, first, cell, side, flat) = cutter.flat_bins();
        assert_eq!(flat.len(), side * side + 1 + cutter.bins.iter().map(Vec::len).sum::<usize>());
        let walk = |p: Vec3| {
            let g = ((p.truncate() - first) / cell).floor();
            if g.x < 0.0 || g.y < 0.0 || g.x > side as f32 || g.y > side as f32 {
                return false;
            }
            let b = (g.y as usize).min(side - 1) * side + (g.x as usize).min(side - 1);
            let above = (flat[b]..flat[b + 1]).filter(|&k| ray_hit(&tris[flat[k as usize] as usize], p).is_some_and(|z| z > p.z as f64)).count();
            above % 2 == 1
        };
        let mut inside = 0;
        for x in -12..=12 {
            for y in -12..=12 {
                for z in -12..=12 {
                    let p = Vec3::new(x as f32, y as f32, z as f32) / 10.0 + Vec3::new(0.013, 0.007, 0.0);
                    assert_eq!(walk(p), cutter.contains(p), "{p}");
                    inside += usize::from(walk(p));
                }
            }
        }
        assert!(inside > 3000, "{inside}");
    }

    #[test]
    fn points_inside_a_sphere_and_a_cube_are_found_exactly() {
        let sphere = crate::testmeshes::icosphere(3);
        let s = sphere.triangulate();
        let cutter = Cutter::new(sphere.positions(), &s.triangles).unwrap();
        // Grid points, including ones exactly on vertices' xy (shared edges and vertices).
        let mut checked = 0;
        for x in -12..=12 {
            for y in -12..=12 {
                for z in -12..=12 {
                    let p = Vec3::new(x as f32, y as f32, z as f32) / 10.0;
                    let r = p.length();
                    // The faceted sphere lies between radius ~0.99 and 1.
                    if (r - 0.995).abs() > 0.02 {
                        assert_eq!(cutter.contains(p), r < 0.99, "{p}");
                        checked += 1;
                    }
                }
            }
        }
        assert!(checked > 10_000);
        for v in sphere.positions() {
            // Straight through vertices: the ray hits each sheet once.
            assert!(cutter.contains(*v * 0.5));
        }
        let cube = crate::mesh::fixtures::cube().triangulate();
        let c = Cutter::new(crate::mesh::fixtures::cube().positions(), &cube.triangles).unwrap();
        let (lo, hi) = c.tris.iter().flatten().fold((Vec3::MAX, Vec3::MIN), |(a, b), p| (a.min(*p), b.max(*p)));
        let mid = (lo + hi) / 2.0;
        // The ray along +z runs through the cube's vertical walls and edges.
        assert!(c.contains(mid) && c.contains(Vec3::new(lo.x, mid.y, mid.z) * 0.999 + mid * 0.001));
        assert!(!c.contains(hi + Vec3::ONE));
    }

    #[test]
    fn open_or_empty_cutters_are_refused() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let err = Cutter::new(&p, &[[0, 1, 2]]).err().unwrap().to_string();
        assert!(err.contains("not closed"), "{err}");
        assert!(Cutter::new(&p, &[]).is_err());
        assert!(Cutter::new(&p, &[[0, 1, 7]]).is_err());
    }
}
