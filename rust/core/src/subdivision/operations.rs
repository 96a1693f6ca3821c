//! Operations on multiscale detail (Velho, Perlin, Ying and Biermann, sections 5-6), as
//! per-level, per-vertex weights the synthesis applies to a model's detail: placement at
//! chosen levels, local modification around a point, and the alpha of a multiscale
//! (Burt-Adelson) blend of two models; and the post-processing shader of the planet
//! (6.2), colours from the blended scalar and the blend parameter.

use crate::mesh::Incidence;
use crate::{Error, Mesh, Result};
use glam::{DVec3, Vec3};
use std::collections::VecDeque;

/// A set of levels (bit `l` for level `l`, 1 to 31): where a model or a modification acts
/// (5: "features may be placed at one level or simultaneously at different scales").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Levels(pub u32);

impl Levels {
    pub const ALL: Levels = Levels(u32::MAX);

    /// The set of the given levels; levels outside 1 to 31 are refused.
    pub fn of(levels: &[u32]) -> Result<Self> {
        let mut bits = 0u32;
        for &l in levels {
            if !(1..=31).contains(&l) {
                return Err(Error::InvalidParameter(format!("levels must be 1 to 31, not {l}")));
            }
            bits |= 1 << l;
        }
        Ok(Levels(bits))
    }

    pub fn has(self, level: u32) -> bool {
        level < 32 && self.0 & (1 << level) != 0
    }
}

/// Local detail modification (5): at `levels`, detail near vertex `center` is scaled by
/// `gain` (0 removes it, 2 doubles it), dropping off cubically to 1, so that nothing
/// `radius` or farther from the center changes. The distance is topological: edge hops
/// at the finest level, `radius` counted in edges of the base mesh (`radius 2^L` hops at
/// level `L`, whose edges are `2^L` times shorter). See [`Local::reach`] for how far
/// each level's own change goes.
#[derive(Debug, Clone, PartialEq)]
pub struct Local {
    pub center: u32,
    pub radius: f64,
    pub gain: f64,
    pub levels: Levels,
}

/// The cubic drop-off `1 - 3 t^2 + 2 t^3` (1 at `t = 0`, 0 from `t = 1` on, flat at both
/// ends, so the modified region meets the rest without a crease).
pub fn drop_off(t: f64) -> f64 {
    let t = t.clamp(0.0, 1.0);
    1.0 - t * t * (3.0 - 2.0 * t)
}

/// Edge hops from `from` to every vertex of `mesh` (`u32::MAX` where unreachable), a
/// breadth-first search that stops beyond `limit` hops; `incidence` the faces around
/// each vertex of `mesh`.
pub fn hops(mesh: &Mesh, incidence: &Incidence, from: u32, limit: u32) -> Vec<u32> {
    let n = mesh.vertex_count();
    let mut out = vec![u32::MAX; n];
    let mut queue = VecDeque::from([from]);
    out[from as usize] = 0;
    while let Some(v) = queue.pop_front() {
        let d = out[v as usize];
        if d >= limit {
            continue;
        }
        for &f in incidence.of(v as usize) {
            let face = mesh.face(f as usize);
            let k = face.iter().position(|&w| w == v).expect("a face around v has v");
            for w in [face[(k + 1) % face.len()], face[(k + face.len() - 1) % face.len()]] {
                if out[w as usize] == u32::MAX {
                    out[w as usize] = d + 1;
                    queue.push_back(w);
                }
            }
        }
    }
    out
}

impl Local {
    pub fn validate(&self, base: &Mesh) -> Result<()> {
        if self.center as usize >= base.vertex_count() {
            return Err(Error::InvalidParameter(format!("local modification center {} is not a vertex of the mesh", self.center)));
        }
        if !(self.radius.is_finite() && self.radius > 0.0 && self.radius <= 1e4) {
            return Err(Error::InvalidParameter(format!("local modification radius must be above 0 and at most 10000 edges, not {}", self.radius)));
        }
        if !(self.gain.is_finite() && self.gain.abs() <= 1e3) {
            return Err(Error::InvalidParameter(format!("local modification gain must be finite and at most 1000 in size, not {}", self.gain)));
        }
        Ok(())
    }

    /// How far level `level`'s own change reaches (in its hops), out of `levels`: a
    /// change within `h` hops of level `l` reaches `2 h + 5` hops of level `l + 1`,
    /// `2 (h - 1) + 4` through the subdivision (a vertex point reads the face points
    /// around it, which read the vertices diagonally across quads) and two more through
    /// the normals (a face's normal reads its diagonal corner). So level `l` acts within
    /// `radius 2^l - 5 (1 - 2^(l - L))` hops, which the later levels spread to exactly
    /// `radius 2^L` hops of level `L`. A radius too small for a coarse level leaves that
    /// level alone (its features are larger than the region).
    pub fn reach(&self, level: u32, levels: u32) -> u32 {
        let shrink = 5.0 * (1.0 - 0.5f64.powi(levels as i32 - level as i32));
        (self.radius * 2f64.powi(level as i32) - shrink).floor().max(0.0) as u32
    }

    /// The factor on each vertex's detail at `level` of `levels` (`mesh` that level's,
    /// `incidence` its faces around each vertex): `1 + (gain - 1) drop_off(hops /
    /// reach)`, 1 at levels it does not act at and from its reach on.
    pub fn weights(&self, level: u32, levels: u32, mesh: &Mesh, incidence: &Incidence) -> Vec<f64> {
        let mut out = vec![1.0; mesh.vertex_count()];
        let reach = self.reach(level, levels);
        if !self.levels.has(level) || reach == 0 {
            return out;
        }
        for (w, h) in out.iter_mut().zip(hops(mesh, incidence, self.center, reach)) {
            if h < reach {
                *w = 1.0 + (self.gain - 1.0) * drop_off(h as f64 / reach as f64);
            }
        }
        out
    }
}

/// Where the second model of a blend takes over (6.1): a blend coordinate `s` per vertex
/// and the alpha `smoothstep(-w_l / 2, w_l / 2, s)` at level `l`, `w_l = width 2^(1-l)`:
/// Burt and Adelson's transition, "proportional to the size of one sample at that scale
/// level", wide at coarse levels (their features reach across) and sharp at the finest.
#[derive(Debug, Clone, PartialEq)]
pub enum AlphaSource {
    /// `s`: the signed distance to the plane through `point` with normal `direction`
    /// (the paper's "plane oriented in the (1, 2, 0) direction"); `width` a length.
    Plane { point: DVec3, direction: DVec3 },
    /// `s`: painted weights (one per base vertex, carried to finer levels linearly)
    /// minus one half; `width` in weight units (1: the painted ramp as it is at level 1).
    Painted { weights: Vec<f32> },
}

#[derive(Debug, Clone, PartialEq)]
pub struct Alpha {
    pub source: AlphaSource,
    pub width: f64,
    /// How far the blend coordinate `s` moves per unit of time (section 3: time feeds
    /// "the synthesized alpha"): `s + sweep t`, so the second model's side grows by
    /// `sweep` (a length for a plane, weight units for painted weights) per unit of time
    /// (shrinks where negative).
    pub sweep: f64,
}

/// `3 x^2 - 2 x^3` of `x` clamped to [0, 1].
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

impl Alpha {
    pub fn validate(&self, base: &Mesh) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidParameter(m));
        if !(self.width.is_finite() && self.width >= 0.0) {
            return bad(format!("blend width must be finite and not negative, not {}", self.width));
        }
        if !self.sweep.is_finite() {
            return bad(format!("blend sweep must be finite, not {}", self.sweep));
        }
        match &self.source {
            AlphaSource::Plane { point, direction } => {
                if !(point.is_finite() && direction.is_finite() && direction.length() > 0.0) {
                    return bad(format!("the blend plane needs a finite point and a nonzero direction, not {point} and {direction}"));
                }
            }
            AlphaSource::Painted { weights } => {
                if self.width > 1.0 {
                    return bad(format!("a painted blend's width must be at most 1 (weights 0 and 1 would not be pure), not {}", self.width));
                }
                if weights.len() != base.vertex_count() {
                    return bad(format!("blend weights have {} entries for {} vertices", weights.len(), base.vertex_count()));
                }
                if let Some(w) = weights.iter().find(|w| !w.is_finite()) {
                    return bad(format!("blend weights must be finite, not {w}"));
                }
            }
        }
        Ok(())
    }

    /// The alpha of each vertex at `level` and `time`: `positions` the level's (before
    /// its detail), `painted` the painted weights carried to it (ignored for a plane). A
    /// width of 0 is a step (alpha 0 or 1 only).
    pub fn at(&self, level: u32, positions: &[Vec3], painted: &[f32], time: f64) -> Vec<f64> {
        let w = self.width * 0.5f64.powi(level as i32 - 1);
        let shift = self.sweep * time;
        let alpha = |s: f64| match w > 0.0 {
            true => smoothstep((s + shift) / w + 0.5),
            false => f64::from(u8::from(s + shift >= 0.0)),
        };
        match &self.source {
            AlphaSource::Plane { point, direction } => {
                let d = direction.normalize();
                positions.iter().map(|p| alpha((p.as_dvec3() - *point).dot(d))).collect()
            }
            AlphaSource::Painted { .. } => painted.iter().map(|&a| alpha(a as f64 - 0.5)).collect(),
        }
    }
}

/// The planet's post-processing shader (6.2): a colour per vertex from the blended
/// scalar `h` (its height over the base, relative to `scale`) and the blend parameter
/// `b`: oceans below `sea`, deeper darker; lowlands, mountains, and snow caps above
/// `snow`; each band's colour mixed between the two sub-planets' palettes by `b`.
#[derive(Debug, Clone, PartialEq)]
pub struct Planet {
    /// Heights are divided by it: the band limits below are in its units.
    pub scale: f64,
    pub sea: f64,
    pub snow: f64,
    /// How fast the sea level and the snow line rise per unit of time (section 3: time
    /// feeds "the post-processing shader"), in the units of `sea` and `snow`: see
    /// [`Planet::at_time`].
    pub sea_rate: f64,
    pub snow_rate: f64,
    /// Colours (linear RGB) of deep sea, shallow sea, lowland, mountain and snow for
    /// sub-planet 0 (`b = 0`) and 1.
    pub palettes: [[Vec3; 5]; 2],
}

impl Default for Planet {
    fn default() -> Self {
        let earth = [Vec3::new(0.01, 0.03, 0.15), Vec3::new(0.05, 0.25, 0.45), Vec3::new(0.10, 0.35, 0.08), Vec3::new(0.30, 0.22, 0.15), Vec3::ONE];
        let mars =
            [Vec3::new(0.10, 0.02, 0.02), Vec3::new(0.35, 0.12, 0.05), Vec3::new(0.60, 0.30, 0.12), Vec3::new(0.40, 0.18, 0.10), Vec3::new(0.95, 0.85, 0.80)];
        Planet { scale: 1.0, sea: 0.0, snow: 0.6, sea_rate: 0.0, snow_rate: 0.0, palettes: [earth, mars] }
    }
}

/// The least share of its land band at time 0 a planet keeps between its sea and its snow
/// line at any time ([`Planet::at_time`]).
pub const MIN_LAND: f64 = 0.1;

impl Planet {
    /// The shader at `time`: sea level `sea + sea_rate time`, snow line `snow +
    /// snow_rate time` (rising seas, retreating snow caps...), the snow line held at least
    /// [`MIN_LAND`] of the land band at time 0 (`snow - sea`) above the sea: a sea that
    /// rises past the snow line carries the caps up on a thin shore instead of refusing the
    /// frame. Validate the result (a band empty at time 0 stays refused).
    pub fn at_time(&self, time: f64) -> Planet {
        let sea = self.sea + self.sea_rate * time;
        let snow = (self.snow + self.snow_rate * time).max(sea + MIN_LAND * (self.snow - self.sea));
        Planet { sea, snow, ..self.clone() }
    }

    pub fn validate(&self) -> Result<()> {
        let finite = [self.scale, self.sea, self.snow, self.sea_rate, self.snow_rate].iter().all(|x| x.is_finite())
            && self.palettes.iter().flatten().all(|c| c.is_finite());
        if !(finite && self.scale > 0.0 && self.snow > self.sea) {
            return Err(Error::InvalidParameter(format!(
                "planet shader: scale must be above 0 and snow above sea, all finite (scale {}, sea {}, snow {})",
                self.scale, self.sea, self.snow
            )));
        }
        Ok(())
    }

    /// RGBA (alpha 1) of each vertex from its scalar `h` and blend parameter `b`.
    pub fn colors(&self, h: &[f32], b: &[f32]) -> Vec<[f32; 4]> {
        h.iter()
            .zip(b)
            .map(|(&h, &b)| {
                let band = |palette: &[Vec3; 5]| self.band(palette, h as f64 / self.scale);
                let c = band(&self.palettes[0]).lerp(band(&self.palettes[1]), b.clamp(0.0, 1.0));
                [c.x, c.y, c.z, 1.0]
            })
            .collect()
    }

    /// One palette's colour at relative height `x`: deep to shallow sea over the depth
    /// `snow - sea` below `sea`, lowland to mountain from `sea` to the snow line, snow
    /// above it (a short ramp, a tenth of the range, so the caps' edges are not jagged).
    fn band(&self, p: &[Vec3; 5], x: f64) -> Vec3 {
        let range = self.snow - self.sea;
        if x < self.sea {
            return p[1].lerp(p[0], ((self.sea - x) / range).min(1.0) as f32);
        }
        let t = ((x - self.sea) / range).min(1.0) as f32;
        let land = p[2].lerp(p[3], t);
        land.lerp(p[4], smoothstep((x - self.snow) / (0.1 * range)) as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::fixtures;

    #[test]
    fn drop_off_is_one_at_the_center_zero_at_the_radius_and_flat_at_both() {
        assert_eq!(drop_off(0.0), 1.0);
        assert_eq!(drop_off(1.0), 0.0);
        assert_eq!(drop_off(3.0), 0.0);
        let h = 1e-6;
        assert!((drop_off(h) - 1.0).abs() < 1e-9 && drop_off(1.0 - h) < 1e-9, "no crease at either end");
        assert!((drop_off(0.5) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn hops_on_a_grid_are_the_manhattan_distance() {
        let grid = fixtures::grid(6); // 7 x 7 vertices
        let center = 3 * 7 + 3;
        let d = hops(&grid, &Incidence::faces(&grid), center, u32::MAX);
        for (v, &h) in d.iter().enumerate() {
            let (x, y) = (v % 7, v / 7);
            assert_eq!(h as usize, x.abs_diff(3) + y.abs_diff(3), "vertex {v}");
        }
        let near = hops(&grid, &Incidence::faces(&grid), center, 2);
        assert_eq!(near.iter().filter(|&&h| h != u32::MAX).count(), 1 + 4 + 8, "reaches no farther than the limit");
    }

    #[test]
    fn local_weights_are_gain_at_the_center_and_one_beyond_the_reach() {
        let grid = fixtures::grid(12);
        let incidence = Incidence::faces(&grid);
        let center = 6 * 13 + 6;
        let local = Local { center, radius: 1.5, gain: 0.0, levels: Levels::of(&[2, 3]).unwrap() };
        // Of 3 levels: level 3 acts within 1.5 * 8 = 12 hops, level 2 within
        // floor(6 - 2.5) = 3, level 1 within floor(3 - 3.75) = 0 (none).
        assert_eq!([local.reach(1, 3), local.reach(2, 3), local.reach(3, 3)], [0, 3, 12]);
        let w = local.weights(2, 3, &grid, &incidence);
        let d = hops(&grid, &incidence, center, u32::MAX);
        assert_eq!(w[center as usize], 0.0);
        for (v, (&w, &h)) in w.iter().zip(&d).enumerate() {
            if h >= 3 {
                assert_eq!(w, 1.0, "vertex {v}");
            } else {
                assert!((w - (1.0 - drop_off(h as f64 / 3.0))).abs() < 1e-12);
            }
        }
        assert!(local.weights(1, 3, &grid, &incidence).iter().all(|&w| w == 1.0), "not at levels it does not act at");
    }

    #[test]
    fn plane_alpha_is_a_step_at_width_zero_and_halves_its_ramp_per_level() {
        let points: Vec<Vec3> = (-10..=10).map(|i| Vec3::new(i as f32 * 0.1, 0.0, 0.0)).collect();
        let alpha = |width: f64, level| {
            Alpha { source: AlphaSource::Plane { point: DVec3::ZERO, direction: DVec3::X * 3.0 }, width, sweep: 0.0 }.at(level, &points, &[], 0.0)
        };
        let step = alpha(0.0, 1);
        assert!(step.iter().zip(&points).all(|(&a, p)| a == if p.x >= 0.0 { 1.0 } else { 0.0 }));
        let ramp = |a: &[f64]| a.iter().filter(|&&a| a > 0.0 && a < 1.0).count();
        let (one, two) = (alpha(1.0, 1), alpha(1.0, 2));
        assert_eq!(ramp(&one), 9, "width 1 at level 1: |x| < 0.5");
        assert_eq!(ramp(&two), 5, "width 1/2 at level 2: |x| < 0.25");
        assert!((one[10] - 0.5).abs() < 1e-12 && one.windows(2).all(|w| w[0] <= w[1]));
    }

    #[test]
    fn painted_alpha_reads_the_carried_weights() {
        let a = Alpha { source: AlphaSource::Painted { weights: vec![0.0; 3] }, width: 1.0, sweep: 0.0 };
        assert_eq!(a.at(1, &[Vec3::ZERO; 3], &[0.0, 0.5, 1.0], 0.0), vec![0.0, 0.5, 1.0]);
        let sharp = a.at(3, &[Vec3::ZERO; 3], &[0.3, 0.5, 0.7], 0.0);
        assert_eq!((sharp[0], sharp[2]), (0.0, 1.0), "width 1/4 at level 3: 0.3 and 0.7 lie beyond the ramp");
    }

    #[test]
    fn planet_bands_follow_height_and_the_blend_mixes_palettes() {
        let planet = Planet::default();
        let c = planet.colors(&[-1.0, -0.0001, 0.0, 0.3, 0.59, 1.0], &[0.0; 6]);
        let earth = planet.palettes[0];
        let rgb = |c: [f32; 4]| Vec3::new(c[0], c[1], c[2]);
        assert!(rgb(c[0]).abs_diff_eq(earth[0], 1e-6), "deep sea below sea - range");
        assert!(rgb(c[1]).abs_diff_eq(earth[1], 1e-3), "shallow just below sea level");
        assert!(rgb(c[2]).abs_diff_eq(earth[2], 1e-6), "lowland at sea level");
        assert!(rgb(c[5]).abs_diff_eq(earth[4], 1e-6), "snow on the peaks");
        assert!(c[3][1] > c[4][1] && c[4][0] > c[3][0], "greener low, browner high");
        let mixed = planet.colors(&[0.0], &[0.5]);
        assert!(rgb(mixed[0]).abs_diff_eq(earth[2].lerp(planet.palettes[1][2], 0.5), 1e-6));
        assert!(Planet { snow: -1.0, ..Planet::default() }.validate().is_err());
    }

    #[test]
    fn time_sweeps_the_alpha_as_moving_its_plane_or_its_weights() {
        let points: Vec<Vec3> = (-10..=10).map(|i| Vec3::new(i as f32 * 0.1, 0.3, -0.2)).collect();
        let dir = DVec3::new(2.0, 0.0, 0.0);
        let plane = |point: DVec3, sweep: f64| Alpha { source: AlphaSource::Plane { point, direction: dir }, width: 0.4, sweep };
        // At time 2 with sweep 0.15, the front has moved 0.3 against the direction: the
        // second model's side grows, as a plane 0.3 back.
        for level in 1..4 {
            let swept = plane(DVec3::ZERO, 0.15).at(level, &points, &[], 2.0);
            let moved = plane(DVec3::new(-0.3, 0.0, 0.0), 0.0).at(level, &points, &[], 0.0);
            for (a, b) in swept.iter().zip(&moved) {
                assert!((a - b).abs() < 1e-12, "level {level}: {a} {b}");
            }
            assert_eq!(plane(DVec3::ZERO, 0.15).at(level, &points, &[], 0.0), plane(DVec3::ZERO, 0.0).at(level, &points, &[], 0.0));
        }
        let painted = |sweep| Alpha { source: AlphaSource::Painted { weights: vec![0.0; 3] }, width: 1.0, sweep };
        let w = [0.1f32, 0.4, 0.6];
        let shifted: Vec<f32> = w.iter().map(|x| x + 0.25).collect();
        let (a, b) = (painted(0.5).at(2, &[Vec3::ZERO; 3], &w, 0.5), painted(0.0).at(2, &[Vec3::ZERO; 3], &shifted, 0.0));
        assert!(a.iter().zip(&b).all(|(a, b)| (a - b).abs() < 1e-6) && a[0] > 0.0 && a[0] < 1.0, "{a:?} {b:?}");
        assert!(plane(DVec3::ZERO, f64::NAN).validate(&fixtures::cube()).is_err());
    }

    #[test]
    fn the_planet_at_a_time_has_its_sea_and_snow_moved_by_their_rates() {
        let planet = Planet { sea_rate: 0.1, snow_rate: -0.05, ..Planet::default() };
        let rgb = |c: [f32; 4]| Vec3::new(c[0], c[1], c[2]);
        let later = planet.at_time(2.0);
        assert!((later.sea - 0.2).abs() < 1e-12 && (later.snow - 0.5).abs() < 1e-12);
        let h = [0.1f32, 0.3, 0.55];
        let want = Planet { sea: 0.2, snow: 0.5, ..Planet::default() }.colors(&h, &[0.0; 3]);
        assert!(later.colors(&h, &[0.0; 3]).iter().flatten().zip(want.iter().flatten()).all(|(a, b)| (a - b).abs() < 1e-6));
        // Flooded: a lowland at time 0 is sea at time 2.
        let (now, then) = (planet.colors(&[0.1], &[0.0]), later.colors(&[0.1], &[0.0]));
        assert!(now[0][1] > now[0][2] && then[0][2] > then[0][1], "green land, then blue sea: {now:?} {then:?}");
        // A sea risen past the snow line (0.5 against 0.35 at time 5) carries the snow line
        // up to a tenth of the land band (0.6) above it: the frame renders, sea below, a
        // thin shore, snow above; a band empty at time 0 is still refused.
        let flooded = planet.at_time(5.0);
        assert!(flooded.validate().is_ok() && (flooded.sea - 0.5).abs() < 1e-12 && (flooded.snow - 0.56).abs() < 1e-12, "{flooded:?}");
        let c = flooded.colors(&[0.4, 0.52, 0.7], &[0.0; 3]);
        assert!(c.iter().flatten().all(|x| x.is_finite()));
        assert!(c[0][2] > c[0][1] && rgb(c[2]).abs_diff_eq(Vec3::ONE, 1e-6) && c[1][1] > c[1][2], "sea, shore, snow: {c:?}");
        let before = planet.at_time(3.0);
        assert!((before.sea - 0.3).abs() < 1e-12 && (before.snow - 0.45).abs() < 1e-12, "not clamped before the sea reaches it");
        assert!(Planet { snow: 0.0, ..Planet::default() }.at_time(2.0).validate().is_err());
    }
}
