//! The CPU reference renderer: ground truth for the GPU slice renderer (thick surfaces,
//! chapter 5) and its fallback where no GPU exists.
//!
//! Every pixel's ray is marched through the shell in world space. The cells whose
//! bounds the ray meets, and the ray's span in each, come from a bounding volume
//! hierarchy over the cells' bounds ([`thicket_core::spatial::Bvh`]); at each
//! sample the cell containing the point is found by inverting its map (Newton's
//! method, warm-started from the parameters of the previous sample in the same cell),
//! and `alpha` is the texture's there (zero outside every cell). The first crossing of
//! `alpha = 0.5` from below is then located exactly by safeguarded regula falsi
//! (Illinois) on the ray parameter, re-inverting the cell map at every evaluation, so
//! the surface found does not depend on the march step once the step resolves it.
//! Features thinner than a step (a strand one texel wide, laterally a small share of
//! the shell) are not left to the samples: between two samples outside the surface,
//! an exact bound of the trilinear occupancy over the step's box in texture space
//! says whether it may reach 0.5 there, and only then the step is halved and probed
//! (thick surfaces, chapter 5: the texture is the trilinear interpolant of its grid).
//!
//! Shading is Lambert with an ambient term; the normal is the texture's `−∇alpha`
//! carried to world space through the cell map, or, where `alpha` jumps (the texture
//! meets a face of the shell), that face's normal.

use glam::{DVec3, Mat3, Vec3};
use rayon::prelude::*;
use thicket_core::progress::Progress;
use thicket_core::spatial::Bvh;
use thicket_core::texture::CellMap;
use thicket_core::{Error, Result};

use crate::image_out::Frame;
use crate::scene::ShellScene;
use thicket_core::raycast::{Camera, PixelRays};

/// Settings of the reference renderer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderParams {
    /// March step as a fraction of the mean shell thickness, in `[1e-4, 1]`. Features
    /// thinner than a step may be missed; the crossing itself is exact at any step.
    pub step: f32,
    /// Halvings of each march step between two samples outside the surface where a
    /// bound of the texture's occupancy along the step says it may reach 0.5 (a thin
    /// strand stepped over), at most 16; 0: the samples alone decide.
    pub probes: u32,
    /// Direction toward the light, world space (normalized here; must not be zero).
    pub light: Vec3,
    /// Ambient share of the light, in `[0, 1]`.
    pub ambient: f32,
    /// Linear surface colour.
    pub albedo: Vec3,
}

impl Default for RenderParams {
    fn default() -> Self {
        Self { step: 0.05, probes: 6, light: Vec3::new(0.3, -0.5, 0.8), ambient: 0.25, albedo: Vec3::splat(0.8) }
    }
}

impl RenderParams {
    fn validate(&self) -> Result<()> {
        let bad = |m: &str| Err(Error::InvalidParameter(m.into()));
        if !(self.step >= 1e-4 && self.step <= 1.0) {
            return bad("the march step must be between 0.0001 and 1 (a fraction of the shell thickness)");
        }
        if self.probes > 16 {
            return bad("at most 16 halvings of a march step are probed");
        }
        if !self.light.is_finite() || self.light.length_squared() < 1e-20 {
            return bad("the light direction must be a finite, non-zero vector");
        }
        if !(0.0..=1.0).contains(&self.ambient) {
            return bad("ambient must be between 0 and 1");
        }
        if !self.albedo.is_finite() || self.albedo.min_element() < 0.0 {
            return bad("the albedo must be finite and not negative");
        }
        Ok(())
    }
}

/// Renders `scene` seen by `camera`: colour (alpha 1 on the surface, 0 elsewhere),
/// depth along the view axis and the unit world normal (facing the camera) per pixel.
/// Rays start on the near plane and end on the far plane, so a camera inside the shell
/// sees what lies in front of it.
pub fn render(scene: &ShellScene, camera: &Camera, params: &RenderParams) -> Result<Frame> {
    render_watched(scene, camera, params, None)
}

/// [`render`], counting the rows rendered in `progress` and stopping with
/// [`Error::Cancelled`] once it is cancelled (rows not yet started are skipped).
pub fn render_watched(scene: &ShellScene, camera: &Camera, params: &RenderParams, progress: Option<&Progress>) -> Result<Frame> {
    params.validate()?;
    if camera.width == 0 || camera.height == 0 {
        return Err(Error::InvalidParameter(format!("the viewport is {}x{}: nothing to render", camera.width, camera.height)));
    }
    let marcher = Marcher::new(scene, params)?;
    let rays = PixelRays::new(camera)?;
    let light = params.light.normalize();
    if let Some(p) = progress {
        p.start(camera.height as usize);
    }
    let last = camera.width as usize - 1;
    let frame = Frame::from_pixels(camera.width, camera.height, Scratch::default, |scratch, x, y| {
        if progress.is_some_and(Progress::is_cancelled) {
            return None;
        }
        if let Some(p) = progress.filter(|_| x == last) {
            p.step();
        }
        let (origin, dir, t_far) = rays.ray(x, y)?;
        let hit = marcher.trace(origin, dir, t_far, scratch)?;
        let p = (origin + dir * hit.t).as_vec3();
        let n = if hit.normal.dot(dir.as_vec3()) > 0.0 { -hit.normal } else { hit.normal };
        let shade = params.ambient + (1.0 - params.ambient) * n.dot(light).max(0.0);
        Some(((params.albedo * shade).extend(1.0), camera.depth(p), n))
    });
    match progress.is_some_and(Progress::is_cancelled) {
        true => Err(Error::Cancelled),
        false => Ok(frame),
    }
}

/// A surface point found on a ray.
struct Hit {
    t: f64,
    normal: Vec3,
}

/// Per-cell data of a triangle prism for fast inversion: the map relative to the
/// first base corner is `x = r d0 + u (e1 + r f1) + v (e2 + r f2)`.
#[derive(Debug, Clone, Copy)]
struct Prism {
    origin: DVec3,
    d0: Vec3,
    e1: Vec3,
    e2: Vec3,
    f1: Vec3,
    f2: Vec3,
    /// Residual accepted from Newton's method, world units.
    tolerance: f32,
}

impl Prism {
    fn new(c: &CellMap, size: f32) -> Self {
        let b0 = c.base[0];
        Self {
            origin: b0.as_dvec3(),
            d0: c.director[0],
            e1: c.base[1] - b0,
            e2: c.base[2] - b0,
            f1: c.director[1] - c.director[0],
            f2: c.director[2] - c.director[0],
            tolerance: 1e-5 * size.max(f32::MIN_POSITIVE),
        }
    }

    /// Parameters `(u, v, r)` of world point `p` by Newton's method from `q`.
    #[inline]
    fn invert(&self, p: DVec3, q: Vec3) -> Option<Vec3> {
        let x = (p - self.origin).as_vec3();
        let (q, e) = newton(q, |q| {
            let (u, v, r) = (q.x, q.y, q.z);
            let pu = self.e1 + self.f1 * r;
            let pv = self.e2 + self.f2 * r;
            let pr = self.d0 + self.f1 * u + self.f2 * v;
            (self.d0 * r + pu * u + pv * v - x, Mat3::from_cols(pu, pv, pr))
        })?;
        (e.length() <= self.tolerance).then_some(q)
    }
}

const NEWTON_ITERATIONS: usize = 10;

/// Newton's method from `q` on `residual(q) = (map(q) - x, d map / d q)`: the last
/// parameters and their residual, or `None` where the Jacobian degenerates or the
/// iterate runs away.
#[inline]
fn newton(mut q: Vec3, residual: impl Fn(Vec3) -> (Vec3, Mat3)) -> Option<(Vec3, Vec3)> {
    for _ in 0..NEWTON_ITERATIONS {
        let (e, j) = residual(q);
        let det = j.determinant();
        if det.abs() <= 1e-30 || !det.is_finite() {
            return None;
        }
        let dq = j.inverse() * e;
        q -= dq;
        if !q.is_finite() || q.abs().max_element() > 1e3 {
            return None;
        }
        if dq.abs().max_element() < 1e-6 {
            break;
        }
    }
    Some((q, residual(q).0))
}
/// Slack of the containment test in cell parameters.
const INSIDE_EPS: f32 = 1e-4;

/// Whether parameters `q` lie in a cell with `count` corners.
#[inline]
fn contains(count: usize, q: Vec3) -> bool {
    let in01 = |a: f32| (-INSIDE_EPS..=1.0 + INSIDE_EPS).contains(&a);
    in01(q.z) && if count == 4 { in01(q.x) && in01(q.y) } else { q.x >= -INSIDE_EPS && q.y >= -INSIDE_EPS && q.x + q.y <= 1.0 + INSIDE_EPS }
}

/// How far along the straight parameter segment from `q0` (in the cell) to `q1` it
/// stays in a cell with `count` corners, as a fraction in `[0, 1]`: every face of the
/// cell is linear in the parameters.
fn exit_fraction(count: usize, q0: Vec3, q1: Vec3) -> f32 {
    let d = q1 - q0;
    // Each face as `g(q) = k + n · q >= 0`.
    let faces: &[(f32, Vec3)] = if count == 4 {
        &[(0.0, Vec3::X), (1.0, Vec3::NEG_X), (0.0, Vec3::Y), (1.0, Vec3::NEG_Y), (0.0, Vec3::Z), (1.0, Vec3::NEG_Z)]
    } else {
        &[(0.0, Vec3::X), (0.0, Vec3::Y), (1.0, Vec3::new(-1.0, -1.0, 0.0)), (0.0, Vec3::Z), (1.0, Vec3::NEG_Z)]
    };
    faces.iter().fold(1.0f32, |f, (k, n)| {
        let (g0, dg) = (k + n.dot(q0), n.dot(d));
        if dg < 0.0 {
            f.min((g0.max(0.0) / -dg).clamp(0.0, 1.0))
        } else {
            f
        }
    })
}

/// Parameters of a cell's centre.
fn centre(count: usize) -> Vec3 {
    if count == 4 {
        Vec3::new(0.5, 0.5, 0.5)
    } else {
        Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.5)
    }
}

/// A cell whose bounds a ray crosses between `t0` and `t1`.
#[derive(Debug, Clone, Copy)]
struct Interval {
    t0: f64,
    t1: f64,
    cell: u32,
}

/// A cell the march is inside the bounds of, with its last parameters (warm start).
#[derive(Debug, Clone, Copy)]
struct Active {
    t0: f64,
    t1: f64,
    cell: u32,
    q: Vec3,
}

/// Per-thread buffers, reused from ray to ray.
#[derive(Default)]
struct Scratch {
    intervals: Vec<Interval>,
    active: Vec<Active>,
}

/// What a sample found: the cell (index into `cells`), its parameters and `alpha`.
#[derive(Debug, Clone, Copy)]
struct Sample {
    alpha: f32,
    inside: Option<(u32, Vec3)>,
}

/// The scene prepared for marching: BVH, per-cell inversion data, step and tolerance.
struct Marcher<'a> {
    scene: &'a ShellScene,
    prisms: Vec<Option<Prism>>,
    /// The cells with finite bounds, and a tree over their bounds (item `i` is cell
    /// `finite[i]`).
    finite: Vec<u32>,
    bvh: Bvh,
    /// March step, world units.
    step: f64,
    /// Halvings of a step probed ([`RenderParams::probes`]).
    probes: u32,
    /// Root bracketing tolerance on the ray parameter, world units.
    tolerance: f64,
}

impl<'a> Marcher<'a> {
    fn new(scene: &'a ShellScene, params: &RenderParams) -> Result<Self> {
        if scene.cells.is_empty() {
            return Err(Error::InvalidParameter("the shell has no cells: nothing to render".into()));
        }
        if scene.bounds.len() != scene.cells.len() {
            return Err(Error::InvalidParameter("the scene's cell bounds do not match its cells".into()));
        }
        if scene.textures.is_empty() {
            return Err(Error::InvalidParameter("no texture to render".into()));
        }
        let (mut sum, mut count) = (0.0f64, 0usize);
        for c in &scene.cells {
            for d in &c.director[..c.count.min(4)] {
                if d.is_finite() {
                    sum += d.length() as f64;
                    count += 1;
                }
            }
        }
        let thickness = sum / count.max(1) as f64;
        if !(thickness > 0.0 && thickness.is_finite()) {
            return Err(Error::InvalidParameter("the shell has no thickness: nothing to render".into()));
        }
        let finite: Vec<u32> = (0..scene.cells.len() as u32)
            .filter(|&i| {
                let (lo, hi) = scene.bounds[i as usize];
                lo.is_finite() && hi.is_finite() && lo.cmple(hi).all()
            })
            .collect();
        if finite.is_empty() {
            return Err(Error::InvalidParameter("the shell has no finite cell: nothing to render".into()));
        }
        let (lo, hi) = finite.iter().fold((Vec3::MAX, Vec3::MIN), |(a, b), &i| {
            let (l, h) = scene.bounds[i as usize];
            (a.min(l), b.max(h))
        });
        let size = (hi - lo).length() as f64;
        let prisms = scene.cells.par_iter().zip(&scene.bounds).map(|(c, (l, h))| (c.count == 3).then(|| Prism::new(c, (*h - *l).length()))).collect();
        let bvh = Bvh::from_boxes(finite.iter().map(|&i| (scene.bounds[i as usize].0.as_dvec3(), scene.bounds[i as usize].1.as_dvec3())).collect());
        Ok(Self { scene, prisms, finite, bvh, step: params.step as f64 * thickness, probes: params.probes, tolerance: 1e-6 * size.max(1e-30) })
    }

    /// The parameters of `p` in cell `c`, from the warm start `q`.
    #[inline]
    fn invert(&self, c: usize, p: DVec3, q: Vec3) -> Option<Vec3> {
        match &self.prisms[c] {
            Some(prism) => prism.invert(p, q),
            None => invert_generic(&self.scene.cells[c], p.as_vec3(), q),
        }
    }

    /// `alpha` at `origin + dir * t`, searching the active cells that span `t` (the
    /// one found last first; it is moved to the front).
    fn sample(&self, origin: DVec3, dir: DVec3, t: f64, active: &mut [Active]) -> Sample {
        let p = origin + dir * t;
        for i in 0..active.len() {
            let a = active[i];
            if t < a.t0 || t > a.t1 {
                continue;
            }
            let c = a.cell as usize;
            let cell = &self.scene.cells[c];
            let Some(q) = self.invert(c, p, a.q) else {
                active[i].q = centre(cell.count);
                continue;
            };
            active[i].q = q;
            if contains(cell.count, q) {
                active.swap(0, i);
                let alpha = self.scene.occupancy(c, q);
                return Sample { alpha, inside: Some((a.cell, q)) };
            }
        }
        Sample { alpha: 0.0, inside: None }
    }

    /// The first crossing of `alpha = 0.5` from below along the ray, if any.
    fn trace(&self, origin: DVec3, dir: DVec3, t_far: f64, s: &mut Scratch) -> Option<Hit> {
        let Scratch { intervals, active } = s;
        intervals.clear();
        active.clear();
        self.bvh.query_ray(origin, dir, t_far, |i, t0, t1| {
            intervals.push(Interval { t0, t1, cell: self.finite[i as usize] });
        });
        if intervals.is_empty() {
            return None;
        }
        intervals.sort_unstable_by(|a, b| a.t0.total_cmp(&b.t0));
        let t_end = intervals.iter().fold(0.0f64, |m, i| m.max(i.t1));
        let mut next = 0;
        let mut t = intervals[0].t0;
        let mut prev_t = t;
        // The last sample below 0.5 (always the previous sample when a crossing is found).
        let mut below: Option<Sample> = None;
        loop {
            while next < intervals.len() && intervals[next].t0 <= t {
                let i = intervals[next];
                let count = self.scene.cells[i.cell as usize].count;
                active.push(Active { t0: i.t0, t1: i.t1, cell: i.cell, q: centre(count) });
                next += 1;
            }
            active.retain(|a| a.t1 >= prev_t);
            if active.is_empty() {
                if next == intervals.len() {
                    return None;
                }
                // A gap between cells: empty space, below the iso-value.
                t = intervals[next].t0;
                prev_t = t;
                below = Some(Sample { alpha: 0.0, inside: None });
                continue;
            }
            let here = self.sample(origin, dir, t, active);
            if here.alpha >= 0.5 {
                if let Some(lo) = below {
                    return Some(self.bracket(origin, dir, (prev_t, lo), (t, here), active));
                }
            } else {
                if let Some(lo) = below.filter(|_| self.probes > 0) {
                    if let Some((a, b)) = self.between(origin, dir, (prev_t, lo), (t, here), active) {
                        return Some(self.bracket(origin, dir, a, b, active));
                    }
                }
                below = Some(here);
            }
            if t >= t_end {
                return None;
            }
            prev_t = t;
            t = (t + self.step).min(t_end);
        }
    }

    /// Between two samples of the march below the iso-value, `a` and `b`, the first
    /// sample found at or above it and the one below just before it, if any. The
    /// segment's part in each end's cell (the other end's point inverted in that cell
    /// and the straight parameter segment clipped to it) is probed
    /// ([`Marcher::probe`]); where an inversion fails, the whole segment is.
    fn between(&self, origin: DVec3, dir: DVec3, a: (f64, Sample), b: (f64, Sample), active: &mut [Active]) -> Option<((f64, Sample), (f64, Sample))> {
        match (a.1.inside, b.1.inside) {
            (None, None) => None,
            (Some((ca, _)), Some((cb, _))) if ca == cb => self.probe(origin, dir, a, b, self.probes, active),
            (sa, sb) => {
                let point = |t: f64| origin + dir * t;
                // The end of a piece inside cell `c` from parameters `q` toward `p`.
                let piece = |c: u32, q: Vec3, p: DVec3| {
                    let count = self.scene.cells[c as usize].count;
                    self.invert(c as usize, p, q).map(|far| (exit_fraction(count, q, far), far))
                };
                let first = match sa {
                    Some((ca, qa)) => match piece(ca, qa, point(b.0)) {
                        Some((f, far)) => {
                            let q = qa + (far - qa) * f;
                            let end = Sample { alpha: self.scene.occupancy(ca as usize, q), inside: Some((ca, q)) };
                            let end = (a.0 + (b.0 - a.0) * f as f64, end);
                            if end.1.alpha >= 0.5 {
                                return Some((a, end));
                            }
                            self.probe(origin, dir, a, end, self.probes, active)
                        }
                        None => return self.probe(origin, dir, a, b, self.probes, active),
                    },
                    None => None,
                };
                if first.is_some() {
                    return first;
                }
                match sb {
                    Some((cb, qb)) => match piece(cb, qb, point(a.0)) {
                        Some((f, far)) => {
                            let q = qb + (far - qb) * f;
                            let t = b.0 + (a.0 - b.0) * f as f64;
                            let start = Sample { alpha: self.scene.occupancy(cb as usize, q), inside: Some((cb, q)) };
                            if start.alpha >= 0.5 {
                                // The piece starts inside a feature: the march's own
                                // bracket from `a` finds its crossing.
                                return Some((a, (t, start)));
                            }
                            self.probe(origin, dir, (t, start), b, self.probes, active)
                        }
                        None => self.probe(origin, dir, a, b, self.probes, active),
                    },
                    None => None,
                }
            }
        }
    }

    /// Between two samples below the iso-value, `a` and `b`, the first sample found at
    /// or above it and the one below just before it, if any: where an upper bound of
    /// the occupancy along the segment ([`Marcher::segment_bound`]) reaches 0.5, the
    /// segment is halved and both halves probed in order, `depth` times at most. A
    /// feature the samples stepped over is found unless the ray's chord through it is
    /// shorter than `2^-depth` steps. Segments between two cells are halved too.
    fn probe(
        &self,
        origin: DVec3,
        dir: DVec3,
        a: (f64, Sample),
        b: (f64, Sample),
        depth: u32,
        active: &mut [Active],
    ) -> Option<((f64, Sample), (f64, Sample))> {
        if depth == 0 {
            return None;
        }
        let tm = 0.5 * (a.0 + b.0);
        if tm <= a.0 || tm >= b.0 {
            return None;
        }
        let m = match (a.1.inside, b.1.inside) {
            (Some((ca, qa)), Some((cb, qb))) if ca == cb => {
                if self.segment_bound(ca as usize, qa, qb) < 0.5 {
                    return None;
                }
                // Within a cell the parameters are interpolated (a step bends little
                // in a cell's parameters); the bracketing then inverts the map exactly.
                let q = 0.5 * (qa + qb);
                Sample { alpha: self.scene.occupancy(ca as usize, q), inside: Some((ca, q)) }
            }
            (None, None) => return None,
            _ => self.sample(origin, dir, tm, active),
        };
        let m = (tm, m);
        if m.1.alpha >= 0.5 {
            return Some((a, m));
        }
        self.probe(origin, dir, a, m, depth - 1, active).or_else(|| self.probe(origin, dir, m, b, depth - 1, active))
    }

    /// An upper bound of the occupancy on the straight segment between parameters
    /// `qa` and `qb` of cell `c` (in texture space; a step bends little there), or 1
    /// where its box spans more than three texels along an axis (the probe halves it);
    /// once it reaches 0.5, the value found there (all the probe asks). The trilinear interpolant is multilinear within each cube between
    /// texel centres, so its largest value over the part of the segment's bounding box
    /// in a cube is at one of that part's corners: exact for the box, and tight as the
    /// segment shrinks. With the stack's effects, no bound (1).
    fn segment_bound(&self, c: usize, qa: Vec3, qb: Vec3) -> f32 {
        if !self.scene.effects.is_none() {
            return 1.0;
        }
        let cell = &self.scene.cells[c];
        let (ta, tb) = (cell.texture(qa), cell.texture(qb));
        let mut bound = 0.0f32;
        for l in &self.scene.textures {
            let [nx, ny, nz] = l.texture.dims();
            // Texel coordinates, texel centres at integers; `r` clamped to the shell.
            let texel = |t: Vec3| {
                let t = t + l.offset.extend(0.0);
                Vec3::new(t.x * nx as f32 - 0.5, t.y * ny as f32 - 0.5, t.z.clamp(0.0, 1.0) * (nz.max(2) - 1) as f32)
            };
            let (pa, pb) = (texel(ta), texel(tb));
            let (lo, hi) = (pa.min(pb) - 1e-3, pa.max(pb) + 1e-3);
            let (i0, i1) = (lo.floor(), hi.floor());
            if !(i0.is_finite() && i1.is_finite()) || (i1 - i0).max_element() > 2.0 || i0.abs().max_element() > 1e6 {
                return 1.0;
            }
            let samples = l.texture.samples();
            let wrap = |i: f32, n: usize| (i as i64).rem_euclid(n as i64) as usize;
            for cz in i0.z as i64..=i1.z as i64 {
                let z0 = cz.clamp(0, nz as i64 - 1) as usize;
                let z1 = (cz + 1).clamp(0, nz as i64 - 1) as usize;
                let (fz0, fz1) = ((lo.z - cz as f32).max(0.0), (hi.z - cz as f32).min(1.0));
                for cy in i0.y as i64..=i1.y as i64 {
                    let (y0, y1) = (wrap(cy as f32, ny), wrap(cy as f32 + 1.0, ny));
                    let (fy0, fy1) = ((lo.y - cy as f32).max(0.0), (hi.y - cy as f32).min(1.0));
                    for cx in i0.x as i64..=i1.x as i64 {
                        let (x0, x1) = (wrap(cx as f32, nx), wrap(cx as f32 + 1.0, nx));
                        let (fx0, fx1) = ((lo.x - cx as f32).max(0.0), (hi.x - cx as f32).min(1.0));
                        let at = |x: usize, y: usize, z: usize| samples[(z * ny + y) * nx + x];
                        // The cube's corners, [z][y][x].
                        let v = [
                            [[at(x0, y0, z0), at(x1, y0, z0)], [at(x0, y1, z0), at(x1, y1, z0)]],
                            [[at(x0, y0, z1), at(x1, y0, z1)], [at(x0, y1, z1), at(x1, y1, z1)]],
                        ];
                        let top = v.iter().flatten().flatten().fold(0.0f32, |m, a| m.max(*a));
                        if top <= bound {
                            continue;
                        }
                        if top < 0.5 {
                            bound = top;
                            continue;
                        }
                        let lerp = |a: f32, b: f32, f: f32| a + (b - a) * f;
                        for fz in [fz0, fz1] {
                            for fy in [fy0, fy1] {
                                let row = |x: usize| lerp(lerp(v[0][0][x], v[0][1][x], fy), lerp(v[1][0][x], v[1][1][x], fy), fz);
                                let (r0, r1) = (row(0), row(1));
                                bound = bound.max(lerp(r0, r1, fx0)).max(lerp(r0, r1, fx1));
                            }
                        }
                        if bound >= 0.5 {
                            return bound;
                        }
                    }
                }
            }
        }
        bound
    }

    /// Locates `alpha = 0.5` between `a` (below) and `b` (at or above) by Illinois
    /// regula falsi with bisection as a safeguard, to [`Marcher::tolerance`], and
    /// shades it.
    fn bracket(&self, origin: DVec3, dir: DVec3, a: (f64, Sample), b: (f64, Sample), active: &mut [Active]) -> Hit {
        let (mut ta, mut sa) = a;
        let (mut tb, mut sb) = b;
        let (mut fa, mut fb) = (sa.alpha as f64 - 0.5, sb.alpha as f64 - 0.5);
        let mut side = 0i8;
        // Width before the last step: twice the bracket, so the first step is a secant.
        let mut width = 2.0 * (tb - ta);
        for _ in 0..100 {
            if tb - ta <= self.tolerance {
                break;
            }
            let mid = 0.5 * (ta + tb);
            if mid <= ta || mid >= tb {
                break; // At the resolution of the ray parameter.
            }
            // Regula falsi, unless the last step did not halve the bracket.
            let falsi = ta - fa * (tb - ta) / (fb - fa);
            let tm = if tb - ta <= 0.5 * width && falsi > ta && falsi < tb { falsi } else { mid };
            width = tb - ta;
            let sm = self.sample(origin, dir, tm, active);
            let fm = sm.alpha as f64 - 0.5;
            if fm >= 0.0 {
                (tb, sb, fb) = (tm, sm, fm);
                if side == 1 {
                    fa *= 0.5;
                }
                side = 1;
            } else {
                (ta, sa, fa) = (tm, sm, fm);
                if side == -1 {
                    fb *= 0.5;
                }
                side = -1;
            }
        }
        // `fa`, `fb` may have been halved: compare the samples' own alphas.
        let jump = sb.alpha - sa.alpha > 0.25;
        let normal = match sb.inside {
            Some((c, q)) => self.normal(c as usize, q, jump),
            None => Vec3::ZERO,
        };
        let normal = if normal.is_finite() && normal.length_squared() > 0.0 { normal } else { -dir.as_vec3() };
        Hit { t: tb, normal }
    }

    /// The unit normal at parameters `q` of cell `c` (orientation not settled): the
    /// carried `−∇alpha`, or the nearest face's where `alpha` jumps or has no gradient.
    fn normal(&self, c: usize, q: Vec3, jump: bool) -> Vec3 {
        let cell = &self.scene.cells[c];
        if !jump {
            let n = if self.scene.effects.is_none() {
                -cell.gradient_to_world(q, self.scene.gradient(cell.texture(q)))
            } else {
                // The stack's effects shape the surface too (the base slab's top, a
                // moved piece): the occupancy's own gradient, by central differences
                // in the cell's parameters.
                let h = 1e-3;
                let d = |e: Vec3| (self.scene.occupancy(c, q + e * h) - self.scene.occupancy(c, q - e * h)) / (2.0 * h);
                -cell.parameter_gradient_to_world(q, Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z)))
            };
            if n.is_finite() && n.length_squared() > 1e-24 {
                return n.normalize();
            }
        }
        // Outward parameter gradients of the faces and the distances to them.
        let faces: [(f32, Vec3); 6] = if cell.count == 4 {
            [(q.x, Vec3::NEG_X), (1.0 - q.x, Vec3::X), (q.y, Vec3::NEG_Y), (1.0 - q.y, Vec3::Y), (q.z, Vec3::NEG_Z), (1.0 - q.z, Vec3::Z)]
        } else {
            [
                (q.x, Vec3::NEG_X),
                (q.y, Vec3::NEG_Y),
                (1.0 - q.x - q.y, Vec3::new(1.0, 1.0, 0.0)),
                (q.z, Vec3::NEG_Z),
                (1.0 - q.z, Vec3::Z),
                (f32::INFINITY, Vec3::Z),
            ]
        };
        let (_, g) = faces.iter().fold((f32::INFINITY, Vec3::Z), |best, f| if f.0 < best.0 { *f } else { best });
        cell.parameter_gradient_to_world(q, g).normalize_or_zero()
    }
}

/// Newton's method on any cell map (quads included), from `q`.
fn invert_generic(cell: &CellMap, x: Vec3, q: Vec3) -> Option<Vec3> {
    let (q, e) = newton(q, |q| (cell.world(q) - x, cell.jacobians(q).0))?;
    let size = (0..cell.count).map(|k| cell.director[k].length() + (cell.base[k] - cell.base[0]).length()).sum::<f32>();
    (e.length() <= 1e-5 * size + 4.0 * f32::EPSILON * x.abs().max_element()).then_some(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec2};
    use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
    use thicket_core::testmeshes as tm;
    use thicket_core::texture::{Generator, Pattern, TextureLayer, VolumeTexture};
    use thicket_core::Mesh;

    fn layer(texture: VolumeTexture) -> Vec<TextureLayer> {
        vec![TextureLayer { texture, offset: Vec2::ZERO }]
    }

    fn slab() -> VolumeTexture {
        VolumeTexture::from_fn([4, 4, 33], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap()
    }

    /// The slab texture on an exterior icosphere(3) shell; its surface is the sphere
    /// of radius `R`. Returns the scene, `R` and the thickness `h`.
    fn sphere_scene() -> (ShellScene, f32, f32) {
        let mesh = tm::icosphere(3);
        let h = 0.1 * mesh.bbox_diagonal();
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        // The slab's iso-surface: texel rows 15/32 (alpha 1) and 16/32 (alpha 0).
        let r = 1.0 + 15.5 / 32.0 * h;
        (ShellScene::new(&mesh, &shell, layer(slab()), 1.0).unwrap(), r, h)
    }

    fn perspective(eye: Vec3, target: Vec3, size: u32) -> Camera {
        let up = if (target - eye).normalize().cross(Vec3::Z).length() < 1e-3 { Vec3::Y } else { Vec3::Z };
        let view = Mat4::look_at_rh(eye, target, up);
        Camera::new(view, Mat4::perspective_rh_gl(0.8, 1.0, 0.01, 100.0), size, size).unwrap()
    }

    /// The analytic sphere of radius `r` at the origin along pixel `(x, y)`'s ray: the
    /// ray parameter of the nearest crossing in front of the near plane.
    fn sphere_t(camera: &Camera, x: u32, y: u32, r: f32) -> Option<(Vec3, f32)> {
        let (o, d) = camera.ray(x as f32, y as f32);
        let b = o.dot(d);
        let c = o.length_squared() - r * r;
        let disc = b * b - c;
        if disc < 0.0 {
            return None;
        }
        let (t0, t1) = (-b - disc.sqrt(), -b + disc.sqrt());
        let t = if t0 >= 0.0 { t0 } else { t1 };
        (t >= 0.0).then_some((o + d * t, t))
    }

    /// The world point of a rendered pixel from its depth.
    fn hit_point(camera: &Camera, x: u32, y: u32, depth: f32) -> Vec3 {
        let (o, d) = camera.ray(x as f32, y as f32);
        let (d0, d1) = (camera.depth(o), camera.depth(o + d));
        o + d * ((depth - d0) / (d1 - d0))
    }

    struct Comparison {
        iou: f32,
        /// Mean `n · radial` over pixels well inside the silhouette.
        radial: f32,
        /// Largest depth error over pixels covered in both, relative to `R`.
        depth_error: Vec<f32>,
    }

    fn compare(frame: &Frame, camera: &Camera, r: f32) -> Comparison {
        let (mut inter, mut union, mut dots, mut inner) = (0, 0, 0.0, 0);
        let mut depth_error = Vec::new();
        for y in 0..frame.height {
            for x in 0..frame.width {
                let i = (y * frame.width + x) as usize;
                let covered = frame.rgba[i].w > 0.5;
                let analytic = sphere_t(camera, x, y, r);
                inter += usize::from(covered && analytic.is_some());
                union += usize::from(covered || analytic.is_some());
                if let (true, Some((p, _))) = (covered, analytic) {
                    assert!((frame.normal[i].length() - 1.0).abs() < 1e-3);
                    depth_error.push((frame.depth[i] - camera.depth(p)).abs() / r);
                    // Well inside the silhouette: the ray meets the sphere of radius 0.9 R.
                    if sphere_t(camera, x, y, 0.9 * r).is_some() {
                        let q = hit_point(camera, x, y, frame.depth[i]);
                        dots += frame.normal[i].dot(q.normalize());
                        inner += 1;
                    }
                }
            }
        }
        depth_error.sort_by(f32::total_cmp);
        Comparison { iou: inter as f32 / union.max(1) as f32, radial: dots / inner.max(1) as f32, depth_error }
    }

    #[test]
    fn reference_slab_sphere_matches_the_analytic_sphere() {
        let (scene, r, h) = sphere_scene();
        assert!(h > 0.3);
        let params = RenderParams::default();
        for dir in [Vec3::NEG_Y, Vec3::new(1.0, 1.0, 1.0), Vec3::new(0.3, -0.2, -1.0), Vec3::Z] {
            let eye = dir.normalize() * 4.0;
            let camera = perspective(eye, Vec3::ZERO, 96);
            let frame = render(&scene, &camera, &params).unwrap();
            let c = compare(&frame, &camera, r);
            assert!(c.iou >= 0.97, "{dir}: IoU {}", c.iou);
            assert!(c.radial > 0.98, "{dir}: mean radial agreement {}", c.radial);
            // The centre pixel: depth = distance − R.
            let centre = (48 * 96 + 48) as usize;
            let expected = camera.depth(sphere_t(&camera, 48, 48, r).unwrap().0);
            assert!((expected - (4.0 - r)).abs() < 1e-3 * r);
            assert!((frame.depth[centre] - (4.0 - r)).abs() < 0.01 * r, "{dir}: depth {}", frame.depth[centre]);
            // Colour: lit, opaque; background transparent and infinitely far.
            assert_eq!(frame.rgba[centre].w, 1.0);
            assert!(frame.rgba[0].w == 0.0 && frame.depth[0].is_infinite() && frame.normal[0] == Vec3::ZERO);
        }
    }

    #[test]
    fn reference_grazing_view_works() {
        let (scene, r, h) = sphere_scene();
        // Just outside the shell, looking along the surface and slightly down at it.
        let eye = Vec3::new(0.0, 0.0, 1.0 + 1.2 * h);
        let camera = perspective(eye, Vec3::new(2.0, 0.0, 0.6), 96);
        let frame = render(&scene, &camera, &RenderParams::default()).unwrap();
        let c = compare(&frame, &camera, r);
        assert!(frame.coverage() > 0.1, "coverage {}", frame.coverage());
        assert!(c.iou >= 0.95, "IoU {}", c.iou);
        // Grazing rays amplify the polyhedral base's sag; most pixels still agree.
        let median = c.depth_error[c.depth_error.len() / 2];
        assert!(median < 0.02, "median depth error {median}");
    }

    #[test]
    fn reference_root_bracketing_is_exact() {
        let (scene, r, _) = sphere_scene();
        let camera = perspective(Vec3::new(0.5, -4.0, 0.3), Vec3::ZERO, 96);
        let coarse = render(&scene, &camera, &RenderParams { step: 0.05, ..Default::default() }).unwrap();
        let fine = render(&scene, &camera, &RenderParams { step: 0.025, ..Default::default() }).unwrap();
        for (x, y) in [(48, 48), (30, 60), (60, 40)] {
            let i = y * 96 + x;
            let (a, b) = (coarse.depth[i], fine.depth[i]);
            assert!(a.is_finite() && (a - b).abs() <= 1e-4 * r, "({x}, {y}): {a} vs {b}");
        }
    }

    #[test]
    fn reference_orthographic_disc_has_the_right_size() {
        let (scene, r, _) = sphere_scene();
        let view = Mat4::look_at_rh(Vec3::new(0.0, -5.0, 0.0), Vec3::ZERO, Vec3::Z);
        // 4 world units across 100 pixels: the disc's area is π (R · 25)² pixels.
        let ortho = Mat4::orthographic_rh_gl(-2.0, 2.0, -2.0, 2.0, 0.1, 100.0);
        let camera = Camera::new(view, ortho, 100, 100).unwrap();
        let frame = render(&scene, &camera, &RenderParams::default()).unwrap();
        let covered = frame.rgba.iter().filter(|c| c.w > 0.5).count() as f32;
        let expected = std::f32::consts::PI * (r * 25.0).powi(2);
        assert!((covered - expected).abs() < 0.02 * expected, "{covered} pixels, expected {expected}");
        let c = compare(&frame, &camera, r);
        assert!(c.iou >= 0.97 && c.radial > 0.98, "IoU {} radial {}", c.iou, c.radial);
        // Orthographic depth: 5 − R at the centre.
        assert!((frame.depth[50 * 100 + 50] - (5.0 - r)).abs() < 0.01 * r);
    }

    #[test]
    fn reference_camera_inside_the_shell() {
        let (scene, _, h) = sphere_scene();
        // In the empty upper part of the shell (r = 0.8), looking along the surface.
        let eye = Vec3::new(0.0, 0.0, 1.0 + 0.8 * h);
        let camera = perspective(eye, Vec3::new(1.0, 0.0, 1.0), 64);
        let frame = render(&scene, &camera, &RenderParams::default()).unwrap();
        assert!(frame.coverage() > 0.05, "coverage {}", frame.coverage());
        assert!(frame.depth.iter().all(|d| *d > 0.0));
        // Inside the solid part (r = 0.2): rays leave the surface, none enters it.
        let camera = perspective(Vec3::new(0.0, 0.0, 1.0 + 0.2 * h), Vec3::new(1.0, 0.0, 1.0), 32);
        render(&scene, &camera, &RenderParams::default()).unwrap();
    }

    #[test]
    fn reference_bad_input_is_an_error() {
        let (scene, _, _) = sphere_scene();
        let camera = perspective(Vec3::new(0.0, -4.0, 0.0), Vec3::ZERO, 16);
        for p in [
            RenderParams { step: 0.0, ..Default::default() },
            RenderParams { step: f32::NAN, ..Default::default() },
            RenderParams { probes: 17, ..Default::default() },
            RenderParams { light: Vec3::ZERO, ..Default::default() },
            RenderParams { ambient: 2.0, ..Default::default() },
            RenderParams { albedo: Vec3::splat(f32::INFINITY), ..Default::default() },
        ] {
            assert!(render(&scene, &camera, &p).is_err(), "{p:?}");
        }
        let empty = ShellScene { cells: vec![], bounds: vec![], textures: layer(slab()), per_face_tiles: true, effects: Default::default() };
        assert!(render(&empty, &camera, &RenderParams::default()).is_err());
        let flat = {
            let mesh = tm::plane(4);
            let n = mesh.vertex_count();
            let shell = thicket_core::shell::Shell::from_directors(vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
            ShellScene::new(&mesh, &shell, layer(slab()), 1.0).unwrap()
        };
        assert!(render(&flat, &camera, &RenderParams::default()).is_err());
        // Zero-size viewports never reach the renderer.
        let mut tiny = camera;
        tiny.width = 0;
        assert!(render(&scene, &tiny, &RenderParams::default()).is_err());
    }

    #[test]
    fn reference_uv_sheet_and_quad_cells_render_alike() {
        // A sheet with UVs, rendered from above: the slab covers the whole sheet.
        let base = tm::plane(6);
        let uvs: Vec<Vec2> = base.corners().iter().map(|&v| base.positions()[v as usize].truncate() * 0.5 + 0.5).collect();
        let mesh = Mesh::new(base.positions().to_vec(), &base.face_sizes(), base.corners().to_vec(), Some(uvs)).unwrap();
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let scene = ShellScene::new(&mesh, &shell, layer(slab()), 2.0).unwrap();
        assert!(scene.cells.iter().all(|c| c.count == 3));
        let (lo, hi) = scene.bounds();
        let centre = (lo + hi) * 0.5;
        let camera = perspective(centre + Vec3::new(0.3, 0.2, 3.0), centre, 48);
        let triangles = render(&scene, &camera, &RenderParams::default()).unwrap();
        assert!(triangles.coverage() > 0.1);
        let i = 24 * 48 + 24;
        assert!(triangles.rgba[i].w == 1.0 && triangles.normal[i].z > 0.99, "{}", triangles.normal[i]);
        // The same sheet as quad cells (the generic inversion path): the same picture.
        let uv = mesh.uvs().unwrap();
        let cells: Vec<CellMap> = (0..mesh.face_count())
            .map(|f| {
                let st: Vec<Vec2> = uv[mesh.face_corner_range(f)].iter().map(|u| *u * 2.0).collect();
                CellMap::new(&mesh, &shell, mesh.face(f), &st)
            })
            .collect();
        assert!(cells.iter().all(|c| c.count == 4));
        let bounds = cells
            .iter()
            .map(|c| {
                let corners = (0..4).flat_map(|k| [c.base[k], c.base[k] + c.director[k]]);
                corners.fold((Vec3::MAX, Vec3::MIN), |(a, b), p| (a.min(p), b.max(p)))
            })
            .collect();
        let quads = ShellScene { cells, bounds, textures: layer(slab()), per_face_tiles: false, effects: Default::default() };
        let quads = render(&quads, &camera, &RenderParams::default()).unwrap();
        let differ = triangles.rgba.iter().zip(&quads.rgba).filter(|(a, b)| (a.w - b.w).abs() > 0.5).count();
        assert!(differ <= 16, "{differ} pixels differ");
        assert!((triangles.depth[i] - quads.depth[i]).abs() < 1e-5, "{} vs {}", triangles.depth[i], quads.depth[i]);
        assert!((triangles.normal[i] - quads.normal[i]).length() < 1e-3);
    }

    /// A sheet with UVs (tiling `tiling`) under `texture`, its shell 10% of the
    /// diagonal, and a camera looking down at it from `(0, -2, 1)` away.
    fn sheet_scene(texture: VolumeTexture, tiling: f32, size: u32) -> (ShellScene, Camera) {
        let base = tm::plane(6);
        let uvs: Vec<Vec2> = base.corners().iter().map(|&v| base.positions()[v as usize].truncate() * 0.5 + 0.5).collect();
        let mesh = Mesh::new(base.positions().to_vec(), &base.face_sizes(), base.corners().to_vec(), Some(uvs)).unwrap();
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let scene = ShellScene::new(&mesh, &shell, layer(texture), tiling).unwrap();
        let (lo, hi) = scene.bounds();
        let centre = (lo + hi) * 0.5;
        (scene, perspective(centre + Vec3::new(0.0, -2.0, 1.0), centre, size))
    }

    #[test]
    fn reference_probes_find_strands_the_step_misses() {
        use crate::silhouette::{frame_coverage, iou};
        // One-texel strands every fourth texel, three quarters of the shell high, tiled
        // so finely that a step of 5% of the shell spans about two texels.
        let strands = VolumeTexture::from_fn([16, 16, 8], |c| {
            let (x, y) = ((c.x * 16.0) as u32, (c.y * 16.0) as u32);
            if x % 4 == 0 && y % 4 == 0 && c.z < 0.75 {
                1.0
            } else {
                0.0
            }
        })
        .unwrap();
        let (scene, camera) = sheet_scene(strands, 16.0, 64);
        let truth = frame_coverage(&render(&scene, &camera, &RenderParams { step: 0.001, probes: 0, ..Default::default() }).unwrap());
        let unprobed = frame_coverage(&render(&scene, &camera, &RenderParams { probes: 0, ..Default::default() }).unwrap());
        let probed = frame_coverage(&render(&scene, &camera, &RenderParams::default()).unwrap());
        let covered = truth.iter().filter(|c| **c).count();
        assert!(covered > 400, "the strands cover {covered} pixels");
        let (before, now) = (iou(&truth, &unprobed), iou(&truth, &probed));
        eprintln!("strands: IoU against the fine march {before:.3} unprobed, {now:.3} probed");
        assert!(before < 0.9, "the coarse step alone should miss strands: IoU {before}");
        assert!(now >= 0.97, "probed IoU {now}");
    }

    #[test]
    fn segment_bound_bounds_the_occupancy_along_the_segment() {
        use thicket_core::test_rng::Rng;
        // A noisy texture, and segments of up to two texels in random cells: the bound
        // is never below the occupancy densely sampled along the segment, and where a
        // segment is short it is close to it.
        let mut rng = Rng(7);
        let noise: Vec<f32> = (0..16 * 16 * 8).map(|_| rng.uniform() as f32).collect();
        let texture = VolumeTexture::new([16, 16, 8], noise).unwrap();
        let (scene, _) = sheet_scene(texture, 3.0, 8);
        let marcher = Marcher::new(&scene, &RenderParams::default()).unwrap();
        let (mut checked, mut tight) = (0, 0);
        for _ in 0..2000 {
            let c = rng.pick(scene.cells.len());
            let u = rng.range(0.0, 0.9) as f32;
            let v = rng.range(0.0, 0.9 - u as f64) as f32;
            let qa = Vec3::new(u, v, rng.uniform() as f32);
            let qb = (qa + Vec3::new(rng.range(-0.05, 0.05) as f32, rng.range(-0.05, 0.05) as f32, rng.range(-0.2, 0.2) as f32)).clamp(Vec3::ZERO, Vec3::ONE);
            let bound = marcher.segment_bound(c, qa, qb);
            let largest = (0..=200).map(|k| scene.occupancy(c, qa + (qb - qa) * (k as f32 / 200.0))).fold(0.0f32, f32::max);
            if bound < 1.0 {
                // At 0.5 the search stops: the probe asks no more.
                assert!(bound >= largest.min(0.5) - 1e-5, "bound {bound} under the occupancy {largest}");
                checked += 1;
                tight += usize::from(bound - largest < 0.2);
            }
        }
        assert!(checked > 1000 && tight > checked / 2, "{checked} bounded, {tight} within 0.2");
    }

    #[test]
    fn exit_fraction_stops_on_the_cell_boundary() {
        let inside = Vec3::new(0.2, 0.3, 0.5);
        // Out through u + v = 1, through r = 0, and not out at all.
        assert!((exit_fraction(3, inside, Vec3::new(0.7, 0.8, 0.5)) - 0.5).abs() < 1e-6);
        assert!((exit_fraction(3, inside, Vec3::new(0.2, 0.3, -0.5)) - 0.5).abs() < 1e-6);
        assert_eq!(exit_fraction(3, inside, Vec3::new(0.3, 0.3, 0.6)), 1.0);
        // A quad cell: out through u = 1.
        assert!((exit_fraction(4, inside, Vec3::new(1.8, 0.3, 0.5)) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn reference_chain_mail_renders_in_reasonable_time() {
        let mesh = tm::icosphere(3);
        let t = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let tex = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
        let scene = ShellScene::new(&mesh, &shell, layer(tex), 1.0).unwrap();
        let camera = perspective(Vec3::new(1.0, -3.0, 1.5), Vec3::ZERO, 128);
        let start = std::time::Instant::now();
        let frame = render(&scene, &camera, &RenderParams::default()).unwrap();
        let elapsed = start.elapsed();
        eprintln!("chain mail 128x128 on icosphere(3): {elapsed:?}, coverage {:.3}", frame.coverage());
        assert!(frame.coverage() > 0.1 && frame.coverage() < 0.6, "coverage {}", frame.coverage());
        assert!(frame.normal.iter().zip(&frame.rgba).all(|(n, c)| c.w == 0.0 || (n.length() - 1.0).abs() < 1e-3));
    }
}
