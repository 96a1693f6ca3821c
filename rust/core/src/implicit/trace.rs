//! A CPU sphere tracer for field trees (issue 17): renders a tree with its colours and
//! texture functions as a camera sees it.
//!
//! Sphere tracing (Hart, *Sphere tracing: a geometric method for the antialiased ray
//! tracing of implicit surfaces*, The Visual Computer 1996): where `|f(x) - f(y)| <= L
//! |x - y|`, no surface lies within `|f(x)| / L` of `x`, so a ray steps by that much
//! and never passes through the surface. `L` is the tree's Lipschitz bound
//! ([`FieldTree::lipschitz`], rules per node in [`super::bounds`]); unit-gradient
//! building blocks and the set operations keep it at 1 (Akleman and Chen, section
//! 4.1), texture displacements raise it by `|a| omega` (equations 1 and 2).
//!
//! Each ray starts where it enters the tree's box ([`FieldTree::solid_box`]; the
//! camera's near-to-far segment for an unbounded tree) and stops at a hit (`f` below
//! a tenth of the pixel's footprint there), when it leaves the box, or after
//! [`MAX_STEPS`] steps (a miss); before that, each 8x8 tile marches its empty space
//! once with a cone around its rays (4x faster on the tree, the
//! same image). Rays march in packets through the batched tape
//! evaluator (the rays still marching of a band of rows, 64 at a time), bands in
//! parallel. Hits are shaded with the tree's colour there (section 5: blended through
//! the operations; texture ramps included), Lambert under a headlight plus a little
//! ambient, the normal the analytic gradient.

use super::eval::{Need, Scratch, BLOCK};
use super::FieldTree;
use crate::{Error, Result};
use glam::{DMat4, DVec3, DVec4};
use rayon::prelude::*;

/// Steps per ray before it counts as a miss (grazing rays crawl along a surface).
pub const MAX_STEPS: usize = 256;
/// The most pixels along either side of an image.
pub const MAX_SIZE: u32 = 16384;
/// A hit is `f` below this share of the pixel's footprint; the smallest step the same.
const HIT: f64 = 0.1;
/// Light reaching every surface, whatever its normal.
const AMBIENT: f64 = 0.1;
/// Rows of pixels per parallel task; also the side of the tiles that march a cone.
const BAND_ROWS: usize = 8;
/// Steps of a tile's cone at most.
const CONE_STEPS: usize = 64;

/// A camera as Blender gives it: `view` maps world to camera space
/// (`matrix_world.inverted()`), `projection` camera to clip space (OpenGL conventions,
/// `calc_matrix_camera`; perspective or orthographic).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub view: DMat4,
    pub projection: DMat4,
    pub width: u32,
    pub height: u32,
}

/// One pixel's ray: from its point on the near plane towards its point on the far
/// plane, `length` apart; `footprint(t) = near + grow t` is the pixel's width `t` along.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: DVec3,
    pub direction: DVec3,
    pub length: f64,
    pub near: f64,
    pub grow: f64,
}

/// Unprojects pixels of a checked camera.
#[derive(Debug, Clone, Copy)]
pub struct Rays {
    inverse: DMat4,
    width: f64,
    height: f64,
}

impl Camera {
    /// Checks the camera (a size of at least one pixel and at most [`MAX_SIZE`], finite
    /// and invertible matrices) and prepares its rays.
    pub fn rays(&self) -> Result<Rays> {
        let fail = |msg: String| Err(Error::InvalidParameter(format!("field render: {msg}")));
        if !(1..=MAX_SIZE).contains(&self.width) || !(1..=MAX_SIZE).contains(&self.height) {
            return fail(format!("the image must be 1 to {MAX_SIZE} pixels on each side, got {} x {}", self.width, self.height));
        }
        if !self.view.is_finite() || !self.projection.is_finite() {
            return fail("the view and projection matrices must be finite".into());
        }
        let m = self.projection * self.view;
        let inverse = m.inverse();
        // A singular (or nearly so) matrix gives no inverse, or one that does not undo it.
        let residual = (m * inverse - DMat4::IDENTITY).to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if m.determinant() == 0.0 || !inverse.is_finite() || !(residual < 1e-6) {
            return fail("projection * view is not invertible (a camera with no extent, or a degenerate view or projection matrix)".into());
        }
        Ok(Rays { inverse, width: f64::from(self.width), height: f64::from(self.height) })
    }
}

impl Rays {
    /// The world point at normalized device coordinates `(x, y, z)`.
    fn unproject(&self, x: f64, y: f64, z: f64) -> Option<DVec3> {
        let p = self.inverse * DVec4::new(x, y, z, 1.0);
        let q = p.truncate() / p.w;
        (p.w != 0.0 && q.is_finite()).then_some(q)
    }

    /// The near and far points at pixel coordinates `(x, y)` (from the image's top
    /// left corner, `x` right and `y` down; a pixel's centre is at `+ 0.5`).
    fn segment(&self, x: f64, y: f64) -> Option<(DVec3, DVec3)> {
        let (nx, ny) = (2.0 * x / self.width - 1.0, 1.0 - 2.0 * y / self.height);
        Some((self.unproject(nx, ny, -1.0)?, self.unproject(nx, ny, 1.0)?))
    }

    /// The ray through pixel coordinates `(x, y)`; `None` where the camera maps it to
    /// no finite segment.
    pub fn ray(&self, x: f64, y: f64) -> Option<Ray> {
        let (a, b) = self.segment(x, y)?;
        let (a1, b1) = self.segment(x + 1.0, y)?;
        let length = (b - a).length();
        if !(length > 0.0 && length.is_finite()) {
            return None;
        }
        let (near, far) = ((a1 - a).length(), (b1 - b).length());
        Some(Ray { origin: a, direction: (b - a) / length, length, near, grow: (far - near) / length })
    }
}

/// A rendered image: `rgba` (linear, rows top to bottom, 4 floats a pixel; alpha 0
/// where nothing was hit) and each pixel's hit point (`None`: background).
#[derive(Debug, Clone, PartialEq)]
pub struct Render {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<f32>,
    pub hits: Vec<Option<DVec3>>,
}

/// Where a ray is in the march.
#[derive(Debug, Clone, Copy)]
struct March {
    ray: Ray,
    t: f64,
    end: f64,
}

/// The part `[t0, t1]` of `[0, length]` inside the box, if any.
fn clip(ray: &Ray, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, ray.length);
    for a in 0..3 {
        let inv = 1.0 / ray.direction[a];
        let (mut u, mut v) = ((lo[a] - ray.origin[a]) * inv, (hi[a] - ray.origin[a]) * inv);
        if u > v {
            std::mem::swap(&mut u, &mut v);
        }
        // NaN (a ray in the slab's plane, parallel to it) keeps the range.
        t0 = if u > t0 { u } else { t0 };
        t1 = if v < t1 { v } else { t1 };
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Renders `tree` as `camera` sees it (see the module docs); a bad camera is an error.
pub fn render(tree: &FieldTree, camera: &Camera) -> Result<Render> {
    render_with(tree, camera, CONE_STEPS)
}

/// [`render`] with at most `cone_steps` steps of each tile's cone (0: none).
fn render_with(tree: &FieldTree, camera: &Camera, cone_steps: usize) -> Result<Render> {
    let rays = camera.rays()?;
    let (w, h) = (camera.width as usize, camera.height as usize);
    let lipschitz = tree.lipschitz();
    let lipschitz = if lipschitz.is_finite() && lipschitz > 0.0 { lipschitz } else { f64::MAX };
    // The box, grown a little so that marching starts off the surface.
    let bounds = tree.solid_box().filter(|b| b.lo.is_finite() && b.hi.is_finite()).map(|b| {
        let margin = 1e-3 * (b.hi - b.lo).length() + 1e-9;
        (b.lo - margin, b.hi + margin)
    });
    let mut rgba = vec![0.0f32; w * h * 4];
    let mut hits = vec![None; w * h];
    rgba.par_chunks_mut(BAND_ROWS * w * 4).zip(hits.par_chunks_mut(BAND_ROWS * w)).enumerate().for_each_init(
        || Scratch::new(&tree.tape),
        |scratch, (band, (rgba, hits))| {
            let first = band * BAND_ROWS * w;
            let marches: Vec<Option<March>> = (first..first + hits.len())
                .map(|i| {
                    let ray = rays.ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5)?;
                    let (t, end) = match bounds {
                        Some((lo, hi)) => clip(&ray, lo, hi)?,
                        None => (0.0, ray.length),
                    };
                    Some(March { ray, t, end })
                })
                .collect();
            let mut marches = marches;
            cones(tree, lipschitz, &rays, (band * BAND_ROWS, hits.len() / w, w), cone_steps, &mut marches, scratch);
            march(tree, lipschitz, marches, hits, scratch);
            shade(tree, &rays, first, w, hits, rgba, scratch);
        },
    );
    Ok(Render { width: camera.width, height: camera.height, rgba, hits })
}

/// A tile's cone: the tile's centre ray from `near` to `far`, containing every ray of
/// the tile at the same parameter `s` (`0` near, `1` far) within `(1 - s) r0 + s r1`.
struct Cone {
    near: DVec3,
    far: DVec3,
    r0: f64,
    r1: f64,
    /// The most any member moves per unit of `s` (its length).
    speed: f64,
    s: f64,
    end: f64,
    members: Vec<usize>,
}

/// Marches the empty space in front of each tile once for all its rays (a cone
/// traced like a ray, Hart 1996's bounding-cone idea): at the centre `c`, no surface
/// lies within `f(c) / L`, so none within `d = f(c) / L - R(s)` of any member's point,
/// and advancing `s` by `d / speed` moves no member farther than `d`. Stops where `d`
/// drops below a tenth of the cone's radius; each member then starts from there. `band` is
/// (first row, rows, width).
fn cones(tree: &FieldTree, lipschitz: f64, rays: &Rays, band: (usize, usize, usize), steps: usize, marches: &mut [Option<March>], scratch: &mut Scratch) {
    let (row0, rows, w) = band;
    let mut cones = Vec::new();
    for x0 in (0..w).step_by(BAND_ROWS) {
        let x1 = (x0 + BAND_ROWS).min(w);
        let members: Vec<usize> = (0..rows).flat_map(|r| (x0..x1).map(move |x| r * w + x)).filter(|&i| marches[i].is_some()).collect();
        if members.len() < 2 {
            continue;
        }
        let Some((near, far)) = rays.segment((x0 + x1) as f64 / 2.0, (row0 as f64) + rows as f64 / 2.0) else { continue };
        let mut cone = Cone { near, far, r0: 0.0, r1: 0.0, speed: 0.0, s: f64::INFINITY, end: 0.0, members };
        for &i in &cone.members {
            let m = marches[i].as_ref().expect("a member");
            let r = &m.ray;
            cone.r0 = cone.r0.max(r.origin.distance(near));
            cone.r1 = cone.r1.max((r.origin + r.length * r.direction).distance(far));
            cone.speed = cone.speed.max(r.length);
            cone.s = cone.s.min(m.t / r.length);
            cone.end = cone.end.max(m.end / r.length);
        }
        if cone.r0.is_finite() && cone.r1.is_finite() {
            cones.push(cone);
        }
    }
    let mut active: Vec<usize> = (0..cones.len()).collect();
    let mut xs = [DVec3::ZERO; BLOCK];
    for _ in 0..steps {
        if active.is_empty() {
            break;
        }
        let mut still = Vec::with_capacity(active.len());
        for packet in active.chunks(BLOCK) {
            for (x, &k) in xs.iter_mut().zip(packet) {
                let c = &cones[k];
                *x = c.near.lerp(c.far, c.s);
            }
            let slot = tree.tape.run(&xs[..packet.len()], Need::VALUE, scratch);
            for (j, &k) in packet.iter().enumerate() {
                let c = &mut cones[k];
                let d = slot.f[j] / lipschitz - ((1.0 - c.s) * c.r0 + c.s * c.r1);
                if d.is_finite() && d > 0.1 * ((1.0 - c.s) * c.r0 + c.s * c.r1) {
                    c.s += d / c.speed;
                    if c.s <= c.end {
                        still.push(k);
                    }
                }
            }
        }
        active = still;
    }
    for c in cones {
        for i in c.members {
            let m = marches[i].as_mut().expect("a member");
            m.t = m.t.max(c.s * m.ray.length);
        }
    }
}

/// Sphere-traces the rays (Hart 1996, section 2): packets of up to [`BLOCK`] of the
/// rays still marching go through the tape together, each steps by `max(f / L, the
/// smallest step)`; hits land in `hits`.
fn march(tree: &FieldTree, lipschitz: f64, mut marches: Vec<Option<March>>, hits: &mut [Option<DVec3>], scratch: &mut Scratch) {
    let mut active: Vec<usize> = (0..marches.len()).filter(|&i| marches[i].is_some_and(|m| m.t <= m.end)).collect();
    let mut xs = [DVec3::ZERO; BLOCK];
    for _ in 0..MAX_STEPS {
        if active.is_empty() {
            break;
        }
        let mut still = Vec::with_capacity(active.len());
        for packet in active.chunks(BLOCK) {
            for (x, &i) in xs.iter_mut().zip(packet) {
                let m = marches[i].as_ref().expect("an active ray");
                *x = m.ray.origin + m.t * m.ray.direction;
            }
            let slot = tree.tape.run(&xs[..packet.len()], Need::VALUE, scratch);
            for (k, &i) in packet.iter().enumerate() {
                let m = marches[i].as_mut().expect("an active ray");
                let f = slot.f[k];
                let eps = HIT * (m.ray.near + m.ray.grow * m.t).max(1e-12);
                if f < eps {
                    hits[i] = Some(xs[k]);
                    continue;
                }
                // NaN (never from a finite tree) still advances by the smallest step.
                m.t += (f / lipschitz).max(eps);
                if m.t <= m.end {
                    still.push(i);
                }
            }
        }
        active = still;
    }
    for i in active {
        marches[i] = None;
    }
}

/// Shades the hits of a band: the tree's colour at the hit times ambient plus Lambert
/// under a headlight (light along the ray), the normal the analytic gradient
/// (section 5); the colour's alpha, in `[0, 1]`. Anything not finite is painted 0.
fn shade(tree: &FieldTree, rays: &Rays, first: usize, w: usize, hits: &[Option<DVec3>], rgba: &mut [f32], scratch: &mut Scratch) {
    let hit: Vec<usize> = (0..hits.len()).filter(|&i| hits[i].is_some()).collect();
    let mut xs = [DVec3::ZERO; BLOCK];
    for packet in hit.chunks(BLOCK) {
        for (x, &i) in xs.iter_mut().zip(packet) {
            *x = hits[i].expect("a hit");
        }
        let slot = tree.tape.run(&xs[..packet.len()], Need::ALL, scratch);
        for (k, &i) in packet.iter().enumerate() {
            let p = first + i;
            let view = rays.ray((p % w) as f64 + 0.5, (p / w) as f64 + 0.5).map_or(DVec3::Z, |r| r.direction);
            let normal = slot.gradient(k).try_normalize().unwrap_or(-view);
            let light = AMBIENT + (1.0 - AMBIENT) * normal.dot(view).abs();
            let out = &mut rgba[i * 4..i * 4 + 4];
            for (a, o) in out[..3].iter_mut().enumerate() {
                *o = (slot.c[a][k] * light) as f32;
            }
            out[3] = slot.c[3][k].clamp(0.0, 1.0) as f32;
            for o in out.iter_mut() {
                if !o.is_finite() {
                    *o = 0.0;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Rng;
    use serde_json::json;

    const FOV: f64 = 0.7;

    /// A perspective camera at `eye` looking down -z (y up), as Blender's matrices are.
    fn perspective(eye: DVec3, w: u32, h: u32) -> Camera {
        let view = DMat4::look_at_rh(eye, eye - DVec3::Z, DVec3::Y);
        Camera { view, projection: DMat4::perspective_rh_gl(FOV, w as f64 / h as f64, 0.1, 100.0), width: w, height: h }
    }

    /// The ray through a pixel's centre of [`perspective`], built from the field of
    /// view (not by unprojecting): from the eye.
    fn eye_ray(eye: DVec3, w: u32, h: u32, i: usize, j: usize) -> (DVec3, DVec3) {
        let t = (FOV / 2.0).tan();
        let x = (2.0 * (i as f64 + 0.5) / w as f64 - 1.0) * t * w as f64 / h as f64;
        let y = (1.0 - 2.0 * (j as f64 + 0.5) / h as f64) * t;
        (eye, DVec3::new(x, y, -1.0).normalize())
    }

    /// The first intersection of a ray with a sphere, by the quadratic.
    fn ray_sphere(o: DVec3, d: DVec3, c: DVec3, r: f64) -> Option<DVec3> {
        let oc = o - c;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - r * r);
        (disc >= 0.0).then(|| o + (-b - disc.sqrt()) * d)
    }

    fn sphere(c: DVec3, r: f64, color: [f64; 4]) -> serde_json::Value {
        json!({"op": "sphere", "center": [c.x, c.y, c.z], "radius": r, "color": color})
    }

    fn iou(a: &[bool], b: &[bool]) -> f64 {
        let both = a.iter().zip(b).filter(|(a, b)| **a && **b).count();
        let any = a.iter().zip(b).filter(|(a, b)| **a || **b).count();
        both as f64 / any as f64
    }

    #[test]
    fn a_sphere_matches_its_projected_disc_and_depth() {
        let (w, h) = (160, 120);
        let eye = DVec3::new(0.2, 0.1, 5.0);
        let (c, r) = (DVec3::new(0.5, -0.3, 0.2), 1.1);
        let tree = FieldTree::from_json(&sphere(c, r, [0.2, 0.6, 0.9, 1.0]).to_string()).unwrap();
        let out = render(&tree, &perspective(eye, w, h)).unwrap();
        assert_eq!(out.rgba.len(), (w * h * 4) as usize);
        let mut analytic = Vec::new();
        let mut worst: f64 = 0.0;
        for j in 0..h as usize {
            for i in 0..w as usize {
                let (o, d) = eye_ray(eye, w, h, i, j);
                let want = ray_sphere(o, d, c, r);
                analytic.push(want.is_some());
                if let (Some(want), Some(got)) = (want, out.hits[j * w as usize + i]) {
                    // A hit stops within a tenth of a pixel of the surface (about 0.025
                    // wide there): along the ray, within that over the cosine.
                    let cos = (want - c).normalize().dot(-d);
                    worst = worst.max((got - want).length() * cos);
                    assert!(got.distance(o + d * (got - o).length()) < 1e-9, "on the ray");
                }
            }
        }
        let traced: Vec<bool> = out.hits.iter().map(Option::is_some).collect();
        let score = iou(&traced, &analytic);
        assert!(score > 0.98, "IoU {score}");
        assert!(worst < 3e-3, "hit {worst} (times the cosine) from the analytic intersection");
        // Hit pixels are opaque and lit, the background transparent.
        for (k, hit) in out.hits.iter().enumerate() {
            let px = &out.rgba[k * 4..k * 4 + 4];
            if hit.is_some() {
                assert!(px[3] == 1.0 && px[2] > 0.09 && px[2] <= 0.9 + 1e-6, "{px:?}");
            } else {
                assert_eq!(px, [0.0; 4]);
            }
        }
        // Facing the camera, the centre is lit fully: the colour itself.
        let (ci, cj) = (w as usize / 2, h as usize / 2);
        let centre = &out.rgba[(cj * w as usize + ci) * 4..][..3];
        assert!(centre[2] > 0.8, "{centre:?}");
    }

    #[test]
    fn orthographic_cameras_work() {
        let (w, h) = (128, 96);
        let (c, r) = (DVec3::new(0.3, 0.2, -1.0), 0.8);
        let tree = FieldTree::from_json(&sphere(c, r, [1.0, 1.0, 1.0, 1.0]).to_string()).unwrap();
        let (half_w, half_h) = (2.0, 1.5);
        let view = DMat4::look_at_rh(DVec3::new(0.0, 0.0, 4.0), DVec3::ZERO, DVec3::Y);
        let camera = Camera { view, projection: DMat4::orthographic_rh_gl(-half_w, half_w, -half_h, half_h, 0.1, 50.0), width: w, height: h };
        let out = render(&tree, &camera).unwrap();
        let mut analytic = Vec::new();
        let mut worst: f64 = 0.0;
        for j in 0..h as usize {
            for i in 0..w as usize {
                let x = -half_w + 2.0 * half_w * (i as f64 + 0.5) / w as f64;
                let y = half_h - 2.0 * half_h * (j as f64 + 0.5) / h as f64;
                let d2 = (x - c.x).powi(2) + (y - c.y).powi(2);
                analytic.push(d2 <= r * r);
                if let (true, Some(got)) = (d2 < r * r, out.hits[j * w as usize + i]) {
                    // Within a tenth of a pixel (4 / 128 wide) of the surface, along the
                    // ray within that over the cosine.
                    let cos = (r * r - d2).sqrt() / r;
                    worst = worst.max((got - DVec3::new(x, y, c.z + (r * r - d2).sqrt())).length() * cos);
                }
            }
        }
        let traced: Vec<bool> = out.hits.iter().map(Option::is_some).collect();
        let score = iou(&traced, &analytic);
        assert!(score > 0.98, "IoU {score}");
        assert!(worst < 0.1 * 4.0 / 128.0, "{worst}");
    }

    #[test]
    fn a_coloured_union_shows_each_colour_on_its_side() {
        let (w, h) = (96, 64);
        let red = sphere(DVec3::new(-1.0, 0.0, 0.0), 0.8, [1.0, 0.0, 0.0, 1.0]);
        let blue = sphere(DVec3::new(1.0, 0.0, 0.0), 0.8, [0.0, 0.0, 1.0, 1.0]);
        let tree = FieldTree::from_json(&json!({"op": "union_wp", "p": 16, "children": [red, blue]}).to_string()).unwrap();
        let out = render(&tree, &perspective(DVec3::new(0.0, 0.0, 6.0), w, h)).unwrap();
        let (mut left, mut right) = (0, 0);
        for (k, hit) in out.hits.iter().enumerate() {
            let Some(p) = hit else { continue };
            let px = &out.rgba[k * 4..k * 4 + 4];
            let (x, i) = (p.x, k % w as usize);
            // Pixels clearly on one side: their own colour.
            if x < -0.3 {
                assert!(i < w as usize / 2 && px[0] > 5.0 * px[2], "{px:?} at {p}");
                left += 1;
            } else if x > 0.3 {
                assert!(i >= w as usize / 2 && px[2] > 5.0 * px[0], "{px:?} at {p}");
                right += 1;
            }
        }
        assert!(left > 300 && right > 300, "{left} {right}");
    }

    #[test]
    fn a_ramp_colours_the_render() {
        // Stripes of a plane's texture function across a sphere: red and blue bands.
        let s = sphere(DVec3::ZERO, 1.0, [0.5, 0.5, 0.5, 1.0]);
        let plane = json!({"op": "plane", "point": [0, 0, 0], "normal": [1, 0, 0]});
        let ramp = json!([[0.0, [1, 0, 0, 1]], [0.49, [1, 0, 0, 1]], [0.51, [0, 0, 1, 1]], [1.0, [0, 0, 1, 1]]]);
        let d = json!({"op": "displace", "shape": s, "texture": plane, "amplitude": 0, "omega": 6, "ramp": ramp});
        let out = render(&FieldTree::from_json(&d.to_string()).unwrap(), &perspective(DVec3::new(0.0, 0.0, 4.0), 64, 64)).unwrap();
        for (k, hit) in out.hits.iter().enumerate() {
            let Some(p) = hit else { continue };
            let t = 0.5 * (1.0 + (6.0 * p.x).cos());
            let px = &out.rgba[k * 4..k * 4 + 4];
            if t < 0.45 {
                assert!(px[0] > 0.09 && px[2] == 0.0, "{px:?} at t = {t}");
            } else if t > 0.55 {
                assert!(px[2] > 0.09 && px[0] == 0.0, "{px:?} at t = {t}");
            }
        }
    }

    #[test]
    fn no_nan_for_any_tree_and_camera_placement() {
        let mut rng = Rng(99);
        let mut docs = crate::implicit::tests::catalogue();
        docs.extend((0..12).map(|_| crate::implicit::tests::random_any_tree(&mut rng, 4)));
        // A steep texture (a Lipschitz bound of 2001), a point of radius 0, a complement.
        let s = sphere(DVec3::ZERO, 0.5, [1.0, 1.0, 1.0, 1.0]);
        docs.push(json!({"op": "displace", "shape": s, "texture": s, "amplitude": 10, "omega": 200}));
        docs.push(json!({"op": "point", "center": [0, 0, 0]}));
        docs.push(json!({"op": "negate", "child": s}));
        docs.push(json!({"op": "sphere", "center": [0, 0, 0], "radius": 1e6}));
        for doc in docs {
            let tree = FieldTree::from_json(&doc.to_string()).unwrap();
            // Outside, and inside (the camera in the solid or the box).
            for eye in [DVec3::new(0.3, 0.2, 4.0), DVec3::new(0.01, 0.02, 0.03)] {
                let out = render(&tree, &perspective(eye, 24, 16)).unwrap();
                assert!(out.rgba.iter().all(|v| v.is_finite()), "{doc}");
                assert!(out.hits.iter().flatten().all(|p| p.is_finite()));
            }
        }
    }

    #[test]
    fn tile_cones_change_nothing_but_the_time() {
        let tree = FieldTree::from_json(crate::implicit::samples::SOFT_CSG_20).unwrap();
        let view = DMat4::look_at_rh(DVec3::new(2.2, -2.6, 1.8), DVec3::ZERO, DVec3::Z);
        let camera = Camera { view, projection: DMat4::perspective_rh_gl(0.7, 1.5, 0.1, 100.0), width: 150, height: 100 };
        let (with, without) = (render_with(&tree, &camera, CONE_STEPS).unwrap(), render_with(&tree, &camera, 0).unwrap());
        let rays = camera.rays().unwrap();
        let mut differ = 0;
        for (k, (a, b)) in with.hits.iter().zip(&without.hits).enumerate() {
            match (a, b) {
                (Some(a), Some(b)) => {
                    // Both within a tenth of a pixel of the same surface, unless a
                    // grazing ray stopped at another spot of it.
                    let ray = rays.ray((k % 150) as f64 + 0.5, (k / 150) as f64 + 0.5).unwrap();
                    let px = ray.near + ray.grow * (*a - ray.origin).length();
                    differ += usize::from(a.distance(*b) > 0.2 * px);
                }
                (None, None) => {}
                _ => differ += 1,
            }
        }
        assert!(differ <= 15, "{differ} of 15000 pixels differ");
    }

    #[test]
    fn bad_cameras_are_errors() {
        let tree = FieldTree::from_json(&sphere(DVec3::ZERO, 1.0, [1.0; 4]).to_string()).unwrap();
        let good = perspective(DVec3::new(0.0, 0.0, 5.0), 8, 8);
        let cases = [
            (Camera { width: 0, ..good }, "1 to 16384 pixels"),
            (Camera { height: 0, ..good }, "1 to 16384 pixels"),
            (Camera { width: MAX_SIZE + 1, ..good }, "1 to 16384 pixels"),
            (Camera { view: DMat4::ZERO, ..good }, "not invertible"),
            (Camera { projection: DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0)), ..good }, "not invertible"),
            (Camera { projection: DMat4::from_cols_array(&[f64::NAN; 16]), ..good }, "must be finite"),
            (Camera { view: DMat4::from_scale(DVec3::splat(f64::INFINITY)), ..good }, "must be finite"),
        ];
        for (camera, want) in cases {
            match render(&tree, &camera) {
                Err(Error::InvalidParameter(msg)) => assert!(msg.contains(want), "{msg:?} should say {want:?}"),
                other => panic!("expected an error saying {want:?}, got {:?}", other.map(|r| r.width)),
            }
        }
        // One pixel is fine.
        assert_eq!(render(&tree, &Camera { width: 1, height: 1, ..good }).unwrap().rgba.len(), 4);
    }
}
