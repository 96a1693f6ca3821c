//! A per-vertex weight (a vertex group) rasterized in texture `(s, t)` space, so it
//! can be looked up at any texture position — where a moved texture region lands
//! (thick surfaces, chapter 7.2: "this piece of texture can be moved around").

use glam::Vec2;

/// A mask's texels: the first one's `(s, t)`, their size, their counts along `s`
/// and `t`, and their values (row by row).
#[derive(Debug, Clone, Copy)]
pub struct Raster<'a> {
    pub lo: Vec2,
    pub texel: f32,
    pub size: [usize; 2],
    pub value: &'a [f32],
}

pub(super) struct UvMask {
    lo: Vec2,
    texel: f32,
    size: [usize; 2],
    value: Vec<f32>,
}

impl UvMask {
    /// Rasterizes `weights` (per vertex) over triangles with corner `(s, t)`; where
    /// triangles overlap in `(s, t)` the larger weight wins. `resolution`: texels
    /// along the longer side of the `(s, t)` bounding box.
    pub fn new(tris: &[[u32; 3]], st: &[[Vec2; 3]], weights: &[f32], resolution: usize) -> Self {
        let (mut lo, mut hi) = (Vec2::MAX, Vec2::MIN);
        for p in st.iter().flatten() {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let texel = ((hi - lo).max_element() / resolution as f32).max(1e-9);
        // One texel of margin around the box, so bilinear lookups fade out at its edge.
        let lo = lo - Vec2::splat(texel);
        let size = [((hi.x - lo.x) / texel) as usize + 2, ((hi.y - lo.y) / texel) as usize + 2];
        let mut value = vec![0.0f32; size[0] * size[1]];
        for (t, c) in tris.iter().zip(st) {
            let w = t.map(|v| weights[v as usize].clamp(0.0, 1.0));
            if w.iter().all(|w| *w <= 0.0) {
                continue;
            }
            let area = (c[1] - c[0]).perp_dot(c[2] - c[0]);
            if area.abs() < 1e-20 {
                continue;
            }
            let (a, b) = (c[0].min(c[1]).min(c[2]), c[0].max(c[1]).max(c[2]));
            let x0 = ((a.x - lo.x) / texel).floor().max(0.0) as usize;
            let y0 = ((a.y - lo.y) / texel).floor().max(0.0) as usize;
            let x1 = (((b.x - lo.x) / texel).ceil() as usize).min(size[0] - 1);
            let y1 = (((b.y - lo.y) / texel).ceil() as usize).min(size[1] - 1);
            // Half a texel of slack so texels on shared edges are always covered.
            let slack = 0.5 * texel * (c[1] - c[0]).length().max((c[2] - c[0]).length()).max((c[2] - c[1]).length()) / area.abs();
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let p = lo + Vec2::new(x as f32, y as f32) * texel;
                    let b1 = (p - c[0]).perp_dot(c[2] - c[0]) / area;
                    let b2 = (c[1] - c[0]).perp_dot(p - c[0]) / area;
                    let b0 = 1.0 - b1 - b2;
                    if b0 < -slack || b1 < -slack || b2 < -slack {
                        continue;
                    }
                    let (b0, b1, b2) = (b0.clamp(0.0, 1.0), b1.clamp(0.0, 1.0), b2.clamp(0.0, 1.0));
                    let v = (w[0] * b0 + w[1] * b1 + w[2] * b2) / (b0 + b1 + b2).max(1e-12);
                    let cell = &mut value[y * size[0] + x];
                    *cell = cell.max(v);
                }
            }
        }
        Self { lo, texel, size, value }
    }

    /// The raster, which [`sample`](Self::sample) interpolates between.
    pub fn raster(&self) -> Raster<'_> {
        Raster { lo: self.lo, texel: self.texel, size: self.size, value: &self.value }
    }

    /// Bilinear weight at `st`; 0 outside the mesh's `(s, t)` range.
    pub fn sample(&self, st: Vec2) -> f32 {
        let g = (st - self.lo) / self.texel;
        if !(g.x >= 0.0 && g.y >= 0.0) || g.x >= (self.size[0] - 1) as f32 || g.y >= (self.size[1] - 1) as f32 {
            return 0.0;
        }
        let (x, y) = (g.x as usize, g.y as usize);
        let (fx, fy) = (g.x - x as f32, g.y - y as f32);
        let at = |x: usize, y: usize| self.value[y * self.size[0] + x];
        let top = at(x, y) + (at(x + 1, y) - at(x, y)) * fx;
        let bottom = at(x, y + 1) + (at(x + 1, y + 1) - at(x, y + 1)) * fx;
        top + (bottom - top) * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rasterized_ramp_reads_back_and_fades_outside() {
        // Unit square of two triangles, weight = s.
        let st = [[Vec2::ZERO, Vec2::X, Vec2::ONE], [Vec2::ZERO, Vec2::ONE, Vec2::Y]];
        let tris = [[0, 1, 2], [0, 2, 3]];
        let m = UvMask::new(&tris, &st, &[0.0, 1.0, 1.0, 0.0], 64);
        for p in [Vec2::new(0.3, 0.2), Vec2::new(0.71, 0.9), Vec2::new(0.5, 0.5), Vec2::new(0.05, 0.95)] {
            assert!((m.sample(p) - p.x).abs() < 0.03, "{p}: {}", m.sample(p));
        }
        assert_eq!(m.sample(Vec2::new(3.0, 0.5)), 0.0);
        assert_eq!(m.sample(Vec2::new(0.5, -2.0)), 0.0);
    }
}
