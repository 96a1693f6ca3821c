//! The procedural texture library (chapters 3.2 and 7.4): each pattern is a signed
//! distance in tile units, turned into occupancy by a ramp two texels wide so the
//! grid samples a smooth `alpha` (iso-surface at 0.5 = the zero set). Every pattern is
//! periodic in `(s, t)` — features near a tile edge are evaluated with their images
//! in the eight neighbouring tiles — seeded, and the moving ones take a time.

use super::VolumeTexture;
use crate::field::ScalarField;
use crate::{Error, Result};
use glam::{Vec2, Vec3};

/// The patterns of the library.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pattern {
    /// European 4-in-1 chain mail: interlocking rings tilted in alternate columns.
    ChainMail,
    /// Plain-woven fabric: warp and weft threads passing over and under each other.
    Weave,
    /// A riveted plate: domed rivet heads in staggered rows on a base plate.
    Rivets,
    /// Grass: tapered, bending blades; they grow with time (full height at time 1).
    Grass,
    /// Fur: many thin curling strands.
    Fur,
    /// Bubbles rising from a liquid film, growing and bursting at the top; periodic
    /// in time with period 2.
    Bubbles,
}

impl Pattern {
    pub const ALL: [Pattern; 6] = [Pattern::ChainMail, Pattern::Weave, Pattern::Rivets, Pattern::Grass, Pattern::Fur, Pattern::Bubbles];

    /// `"chain_mail"`, `"weave"`, `"rivets"`, `"grass"`, `"fur"` or `"bubbles"`.
    pub fn parse(s: &str) -> Result<Self> {
        Self::ALL.into_iter().find(|p| p.name() == s.to_ascii_lowercase()).ok_or_else(|| {
            let names: Vec<_> = Self::ALL.iter().map(|p| p.name()).collect();
            Error::InvalidParameter(format!("unknown texture {s:?}; one of {}", names.join(", ")))
        })
    }
    pub fn name(self) -> &'static str {
        match self {
            Pattern::ChainMail => "chain_mail",
            Pattern::Weave => "weave",
            Pattern::Rivets => "rivets",
            Pattern::Grass => "grass",
            Pattern::Fur => "fur",
            Pattern::Bubbles => "bubbles",
        }
    }
    /// Whether the pattern changes with time.
    pub fn is_animated(self) -> bool {
        matches!(self, Pattern::Grass | Pattern::Bubbles)
    }
}

/// A pattern with its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Generator {
    pub pattern: Pattern,
    pub seed: u32,
    pub time: f32,
    /// Feature size multiplier (ring and thread thickness, blade width...), 1 = default.
    pub thickness: f32,
}

impl Generator {
    pub fn new(pattern: Pattern) -> Self {
        Self { pattern, seed: 0, time: 1.0, thickness: 1.0 }
    }

    /// Samples the pattern on an `[nx, ny, nz]` grid: its [`PatternField`] through a
    /// ramp two texels wide.
    pub fn generate(&self, dims: [usize; 3]) -> Result<VolumeTexture> {
        let ramp = 2.0 / dims[0].min(dims[1]).max(2) as f32;
        let field = self.field()?;
        VolumeTexture::from_fn(dims, |c| (0.5 - field.value(c) / ramp).clamp(0.0, 1.0))
    }

    /// The pattern's shape as a [`ScalarField`] over its tile.
    pub fn field(&self) -> Result<PatternField> {
        if !(self.thickness > 0.0 && self.thickness.is_finite() && self.time.is_finite()) {
            return Err(Error::InvalidParameter("texture thickness must be positive and time finite".into()));
        }
        Ok(PatternField { features: Features::new(self) })
    }
}

/// A pattern's signed distance in tile units at texture coordinates `(s, t, r)`
/// (periodic in `s` and `t`, `r` from the base at 0 to the outer layer at 1): the
/// shape a texture's occupancy samples, as a field any polygonizer can mesh at any
/// resolution. Its gradient is the trait's central differences.
pub struct PatternField {
    features: Features,
}

impl ScalarField for PatternField {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = self.features.distance(*p);
        }
    }
    fn difference_step(&self) -> f32 {
        1e-4
    }
}

/// 32-bit integer hash (lowbias32) to `[0, 1)`.
fn rand(seed: u32, i: u32, k: u32) -> f32 {
    let mut x = seed.wrapping_mul(0x9E37_79B9) ^ i.wrapping_mul(0x85EB_CA6B) ^ k.wrapping_mul(0xC2B2_AE35);
    x ^= x >> 16;
    x = x.wrapping_mul(0x7FEB_352D);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846C_A68B);
    x ^= x >> 16;
    (x >> 8) as f32 / (1u32 << 24) as f32
}

/// The nearest periodic image of `d` (a difference of tile positions).
fn wrap(d: Vec2) -> Vec2 {
    d - d.round()
}

/// One strand (grass blade or hair): root on the base, height, lean direction.
struct Strand {
    root: Vec2,
    height: f32,
    lean: Vec2,
    radius: f32,
    phase: f32,
}

struct Features {
    pattern: Pattern,
    thickness: f32,
    time: f32,
    strands: Vec<Strand>,
    bubbles: Vec<(Vec2, f32)>,
    rivets: Vec<Vec2>,
}

impl Features {
    fn new(g: &Generator) -> Self {
        let strands = |n: u32, height: (f32, f32), radius: f32, lean: f32| -> Vec<Strand> {
            (0..n)
                .map(|i| {
                    let a = rand(g.seed, i, 3) * std::f32::consts::TAU;
                    Strand {
                        root: Vec2::new(rand(g.seed, i, 0), rand(g.seed, i, 1)),
                        height: height.0 + (height.1 - height.0) * rand(g.seed, i, 2),
                        lean: Vec2::new(a.cos(), a.sin()) * lean * (0.5 + rand(g.seed, i, 4)),
                        radius: radius * g.thickness * (0.8 + 0.4 * rand(g.seed, i, 5)),
                        phase: rand(g.seed, i, 6) * std::f32::consts::TAU,
                    }
                })
                .collect()
        };
        let (mut s, mut b, mut r) = (Vec::new(), Vec::new(), Vec::new());
        match g.pattern {
            Pattern::Grass => s = strands(28, (0.55, 0.95), 0.035, 0.25),
            Pattern::Fur => s = strands(90, (0.75, 0.95), 0.016, 0.08),
            Pattern::Bubbles => b = (0..9).map(|i| (Vec2::new(rand(g.seed, i, 0), rand(g.seed, i, 1)), rand(g.seed, i, 2))).collect(),
            Pattern::Rivets => {
                for row in 0..3 {
                    for col in 0..3 {
                        r.push(Vec2::new((col as f32 + 0.5 * (row % 2) as f32) / 3.0, (row as f32 + 0.5) / 3.0));
                    }
                }
            }
            _ => {}
        }
        Self { pattern: g.pattern, thickness: g.thickness, time: g.time, strands: s, bubbles: b, rivets: r }
    }

    /// Signed distance (tile units) at texture coordinates `c = (s, t, r)`.
    fn distance(&self, c: Vec3) -> f32 {
        let st = Vec2::new(c.x, c.y);
        match self.pattern {
            Pattern::ChainMail => {
                // Shell depth 0.5 tile; rings of radius 0.44 and wire 0.04, columns tilted
                // ±25°: each ring passes through its four diagonal neighbours (linked,
                // 0.017 tile apart) and clears the ones beside it.
                let z = (c.z - 0.5) * 0.5;
                let (big, wire) = (0.44, 0.04 * self.thickness);
                let ring = |centre: Vec2, tilt: f32| {
                    let d = wrap(st - centre);
                    let (sn, cs) = tilt.sin_cos();
                    let q = Vec3::new(d.x * cs - z * sn, d.y, d.x * sn + z * cs);
                    Vec2::new(Vec2::new(q.x, q.y).length() - big, q.z).length() - wire
                };
                let t = 25f32.to_radians();
                ring(Vec2::ZERO, t).min(ring(Vec2::splat(0.5), -t))
            }
            Pattern::Weave => {
                // Four threads each way; warp height +-A sin, weft opposite: over-under.
                let (n, a) = (4.0, 0.06);
                let z = (c.z - 0.5) * 0.5;
                let (rw, rz) = (0.36 / n * self.thickness, a * 0.95 * self.thickness);
                let pi = std::f32::consts::PI;
                let thread = |along: f32, across: f32, sign: f32| {
                    let j = (across * n - 0.5).round();
                    let dc = across - (j + 0.5) / n;
                    let zc = sign * a * (pi * n * along + pi * j).sin();
                    (Vec2::new(dc / rw, (z - zc) / rz).length() - 1.0) * rw.min(rz)
                };
                thread(st.x, st.y, 1.0).min(thread(st.y, st.x, -1.0))
            }
            Pattern::Rivets => {
                let z = c.z * 0.5;
                let plate = z - 0.1 * self.thickness;
                self.rivets.iter().fold(plate, |d, p| {
                    let q = wrap(st - *p);
                    d.min(Vec3::new(q.x, q.y, z - 0.1 * self.thickness).length() - 0.1)
                })
            }
            Pattern::Grass | Pattern::Fur => {
                let growth = if self.pattern == Pattern::Grass { self.time.clamp(0.05, 1.0) } else { 1.0 };
                self.strands.iter().fold(f32::INFINITY, |d, s| {
                    let h = s.height * growth;
                    let u = (c.z / h).clamp(0.0, 1.0);
                    let curl =
                        if self.pattern == Pattern::Fur { Vec2::new((s.phase + 6.0 * u).sin(), (s.phase + 6.0 * u).cos()) * 0.02 * u } else { Vec2::ZERO };
                    let centre = s.root + s.lean * u * u + curl;
                    let radius = s.radius * (1.0 - 0.85 * u);
                    let radial = wrap(st - centre).length() - radius;
                    d.min(radial.max(c.z - h))
                })
            }
            Pattern::Bubbles => {
                // Shell depth 0.5 tile, like the others, so bubbles are round when the
                // shell is half a tile thick.
                let z = c.z * 0.5;
                let film = z - 0.03;
                self.bubbles.iter().enumerate().fold(film, |d, (i, (p, phase))| {
                    // Life in [0, 1): rise from the film, grow, burst near the top.
                    let life = (phase + self.time * 0.5).rem_euclid(1.0);
                    let radius = (0.04 + 0.06 * life) * self.thickness * if life > 0.9 { (1.0 - life) * 10.0 } else { 1.0 };
                    let drift = Vec2::new((life * 5.0 + i as f32).sin(), (life * 4.0 + i as f32).cos()) * 0.03;
                    let centre = Vec3::new(0.0, 0.0, 0.03 + life * 0.36);
                    let q = wrap(st - *p - drift);
                    d.min((Vec3::new(q.x, q.y, z) - centre).length() - radius)
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_pattern_is_tileable_and_not_empty() {
        for p in Pattern::ALL {
            let t = Generator { seed: 7, ..Generator::new(p) }.generate([32, 32, 16]).unwrap();
            let inside = t.samples().iter().filter(|a| **a >= 0.5).count();
            let n = t.samples().len();
            assert!(inside > n / 200 && inside < n * 9 / 10, "{p:?}: {inside} of {n}");
            // Periodic: the field continues across the tile edge as it does inside.
            for k in 0..50 {
                let y = k as f32 / 50.0;
                let z = 0.2 + 0.6 * (k % 7) as f32 / 7.0;
                let edge = (t.sample(Vec3::new(1.0 - 1e-4, y, z)) - t.sample(Vec3::new(1e-4, y, z))).abs();
                assert!(edge < 0.05, "{p:?} seam at y={y} z={z}: {edge}");
            }
            assert_eq!(Pattern::parse(p.name()).unwrap(), p);
        }
        assert!(Pattern::parse("plaid").is_err());
    }

    #[test]
    fn chain_mail_rings_interlock_without_touching() {
        // Two neighbouring rings of the same texture: no texel inside both (they do not
        // fuse), and each ring's wire passes through the other's hole (linked): along
        // the diagonal between their centres the occupancy must go in, out, in, out.
        let f = Features::new(&Generator::new(Pattern::ChainMail));
        let t = 25f32.to_radians();
        let ring = |c: Vec3, centre: Vec2, tilt: f32| {
            let z = (c.z - 0.5) * 0.5;
            let d = wrap(c.truncate() - centre);
            let (sn, cs) = f32::sin_cos(tilt);
            let q = Vec3::new(d.x * cs - z * sn, d.y, d.x * sn + z * cs);
            Vec2::new(Vec2::new(q.x, q.y).length() - 0.44, q.z).length() - 0.04
        };
        let mut fused = 0;
        for i in 0..64 {
            for j in 0..64 {
                for k in 0..32 {
                    let c = Vec3::new(i as f32 / 64.0, j as f32 / 64.0, k as f32 / 31.0);
                    fused += usize::from(ring(c, Vec2::ZERO, t) < 0.0 && ring(c, Vec2::splat(0.5), -t) < 0.0);
                    assert!((f.distance(c) - ring(c, Vec2::ZERO, t).min(ring(c, Vec2::splat(0.5), -t))).abs() < 1e-6);
                }
            }
        }
        assert_eq!(fused, 0);
        // Linked: ring B's centre line crosses ring A's disc an odd number of times.
        let crossings = (0..720)
            .map(|k| {
                let a = k as f32 / 720.0 * std::f32::consts::TAU;
                let (qx, qy) = (0.44 * a.cos(), 0.44 * a.sin());
                // B's centre line in world (tilt -t about y), then in A's frame (tilt t).
                let (sn, cs) = (-t).sin_cos();
                let p = Vec3::new(0.5 + qx * cs, 0.5 + qy, -qx * sn);
                let (sa, ca) = t.sin_cos();
                let q = Vec3::new(p.x * ca - p.z * sa, p.y, p.x * sa + p.z * ca);
                (q.z > 0.0, Vec2::new(q.x, q.y).length() < 0.44)
            })
            .collect::<Vec<_>>();
        let through = crossings.windows(2).filter(|w| w[0].0 != w[1].0 && w[1].1).count();
        assert_eq!(through % 2, 1, "{through} crossings");
    }

    #[test]
    fn grass_grows_and_bubbles_move_with_time() {
        let at = |p, time| Generator { time, ..Generator::new(p) }.generate([24, 24, 16]).unwrap();
        let filled = |t: &VolumeTexture| t.samples().iter().filter(|a| **a >= 0.5).count();
        assert!(filled(&at(Pattern::Grass, 0.3)) < filled(&at(Pattern::Grass, 1.0)));
        assert!(at(Pattern::Bubbles, 0.0) != at(Pattern::Bubbles, 0.4));
        let (a, b) = (at(Pattern::Bubbles, 0.1), at(Pattern::Bubbles, 2.1));
        let worst = a.samples().iter().zip(b.samples()).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "period 2: {worst}");
    }

    /// Each pattern's field meshed over one tile through the shared polygonizer: a
    /// closed manifold (strands and rings cut by the tile's box are closed by it) whose
    /// volume is the share of the tile the field calls inside, counted independently
    /// on a grid of points.
    #[test]
    fn every_pattern_field_meshes_to_a_closed_manifold_holding_its_volume() {
        use crate::polygonize::{mesh_field, GridParams, SurfaceCheck};
        let meshed_volume = |field: &PatternField, resolution: u32| {
            let m = mesh_field(field, &GridParams { bounds: (Vec3::ZERO, Vec3::ONE), resolution, refine: true }).unwrap();
            let c = SurfaceCheck::of(&m.positions, &m.triangles);
            assert!(c.is_closed_manifold() && !m.triangles.is_empty(), "{c:?}");
            m.triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| m.positions[v as usize].as_dvec3());
                    a.dot(b.cross(c)) / 6.0
                })
                .sum::<f64>()
        };
        for pattern in Pattern::ALL {
            let field = Generator::new(pattern).field().unwrap();
            // Monte Carlo: unbiased where a regular grid of samples is not (a film a few
            // samples thick counts whole rows); 1/sqrt(n) is about 0.5% here.
            let n = 400_000u32;
            let inside = (0..n).filter(|&i| field.value(Vec3::new(rand(7, i, 0), rand(7, i, 1), rand(7, i, 2))) <= 0.0).count() as f64 / f64::from(n);
            let error = |resolution| (meshed_volume(&field, resolution) - inside).abs() / inside;
            let coarse = error(64);
            if matches!(pattern, Pattern::Grass | Pattern::Fur) {
                // Strand tips thinner than a cell are lost at 64 cells; finer, they come back.
                let fine = error(128);
                assert!(fine < 0.08 && fine < 0.5 * coarse, "{}: volume error {coarse:.3} at 64 cells, {fine:.3} at 128", pattern.name());
            } else {
                assert!(coarse < 0.03, "{}: volume error {coarse:.3}", pattern.name());
            }
        }
        assert!(Generator { thickness: 0.0, ..Generator::new(Pattern::Fur) }.field().is_err());
    }
}
