//! One prism of marching prisms, and where an iso-vertex goes on a lattice edge: the
//! steps every lattice (a bake's shell cells, a grid of cubes) shares.

use super::prism_table::{self, EDGES};

/// How close to an edge's ends an iso-vertex may be, as a share of the edge, and how
/// far lattices keep their samples off the iso-level (in their own units, [`off_level`]):
/// values on the level (a bake's blends of a region, holes or the base slab give
/// exactly 0.5 midway between weights 1 and 0) would put iso-vertices on lattice
/// points, making coincident vertices and triangles around one lattice point that
/// touch without sharing a vertex. Not from a paper: small enough to move the surface
/// by at most 1% of a lattice step, large enough for single precision.
pub const OFF_ISO: f32 = 0.01;

/// Emits the iso-surface triangles of one prism with corner values `values` (corners
/// `0, 1, 2` the bottom triangle counter-clockwise seen from above, `3, 4, 5` above
/// them; inside where `>= level`) into `out`, facing from inside to outside (reversed
/// with `flip`, for a prism whose frame reverses orientation). `vertex(a, b)` gives
/// the iso-vertex on the edge from corner `a` to corner `b`; it is asked once per edge
/// of this prism, and must give every prism sharing that edge the same vertex (its
/// place is the lattice's business: [`crossing`]).
#[inline]
pub fn march_prism(values: &[f32; 6], level: f32, flip: bool, mut vertex: impl FnMut(usize, usize) -> u32, out: &mut Vec<[u32; 3]>) {
    let case = prism_table::classify(values, level);
    if case.count == 0 {
        return;
    }
    let mut verts = [u32::MAX; 9];
    for tri in &case.tris[..case.count as usize] {
        let t = tri.map(|e| {
            let e = e as usize;
            if verts[e] == u32::MAX {
                verts[e] = vertex(EDGES[e][0], EDGES[e][1]);
            }
            verts[e]
        });
        out.push(if flip { [t[0], t[2], t[1]] } else { t });
    }
}

/// Refinement of an iso-vertex by [`crossing`]: at most `steps` evaluations, fewer once
/// the field is within `tolerance` of the level.
#[derive(Debug, Clone, Copy)]
pub struct Refine {
    pub steps: usize,
    pub tolerance: f32,
}

/// Where a field `value(f)` crosses `level` on a lattice edge from `f = 0` (sample
/// `a`) to `f = 1` (sample `b`, on the other side): Illinois regula falsi from the
/// linear guess ([`Crossing`]), as [`Refine`] allows. Where the field is curved along
/// the edge (a trilinear texture between columns, any nonlinear implicit), linear
/// interpolation of the end values moves the surface inward and thins features a few
/// lattice steps wide. The result is kept [`OFF_ISO`] of the edge from its ends, and
/// a field that cannot be evaluated leaves the last guess.
pub fn crossing(a: f32, b: f32, level: f32, refine: Refine, mut value: impl FnMut(f32) -> f32) -> f32 {
    let mut c = Crossing::new(a, b, level);
    for _ in 0..refine.steps {
        if !c.step(value(c.at()), refine.tolerance) {
            break;
        }
    }
    c.result()
}

/// The state of one [`crossing`], for callers that evaluate many edges' next points
/// as one batch: [`Crossing::at`] is where to evaluate, [`Crossing::step`] takes the
/// value there.
#[derive(Debug, Clone, Copy)]
pub struct Crossing {
    lo: f32,
    hi: f32,
    fa: f32,
    fb: f32,
    x: f32,
    side: i8,
    level: f32,
}

impl Crossing {
    /// The bracket `[0, 1]` with samples `a` and `b`; the first guess is linear.
    pub fn new(a: f32, b: f32, level: f32) -> Self {
        let (fa, fb) = (a - level, b - level);
        Self { lo: 0.0, hi: 1.0, fa, fb, x: (fa / (fa - fb)).clamp(0.0, 1.0), side: 0, level }
    }
    /// The parameter to evaluate next.
    pub fn at(&self) -> f32 {
        self.x
    }
    /// Takes the field's value at [`Crossing::at`]; false when it is done (within
    /// `tolerance` of the level, or not a number: the guess stays).
    pub fn step(&mut self, value: f32, tolerance: f32) -> bool {
        let fx = value - self.level;
        if !fx.is_finite() || fx.abs() <= tolerance {
            return false;
        }
        if (fx >= 0.0) == (self.fb >= 0.0) {
            (self.hi, self.fb) = (self.x, fx);
            if self.side == 1 {
                self.fa *= 0.5;
            }
            self.side = 1;
        } else {
            (self.lo, self.fa) = (self.x, fx);
            if self.side == -1 {
                self.fb *= 0.5;
            }
            self.side = -1;
        }
        let next = self.lo - self.fa * (self.hi - self.lo) / (self.fb - self.fa);
        self.x = if next.is_finite() && next > self.lo && next < self.hi { next } else { 0.5 * (self.lo + self.hi) };
        true
    }
    /// The crossing found, kept [`OFF_ISO`] of the edge from its ends.
    pub fn result(&self) -> f32 {
        self.x.clamp(OFF_ISO, 1.0 - OFF_ISO)
    }
}

/// Where the straight line through the two samples meets `level`, in `[0, 1]`. Not
/// kept off the ends: a lattice that uses it alone keeps its samples off the level
/// ([`off_level`]) and within a bounded range, which keeps the vertices off them.
#[inline]
pub fn linear(a: f32, b: f32, level: f32) -> f32 {
    ((level - a) / (b - a)).clamp(0.0, 1.0)
}

/// `v` moved [`OFF_ISO`] times `scale` off `level` where it is nearer, keeping its side:
/// a sample on the level would put iso-vertices on lattice points.
#[inline]
pub fn off_level(v: f32, level: f32, scale: f32) -> f32 {
    let eps = OFF_ISO * scale;
    if (v - level).abs() < eps {
        if v >= level {
            level + eps
        } else {
            level - eps
        }
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const THREE: Refine = Refine { steps: 3, tolerance: 0.0 };

    #[test]
    fn the_crossing_is_found_on_curved_edges_and_kept_off_the_ends() {
        // 1 - 2 f²: 0.5 at f = 0.5, where the linear guess from the ends says 0.25.
        let f = crossing(1.0, -1.0, 0.5, THREE, |f| 1.0 - 2.0 * f * f);
        assert!((f - 0.5).abs() < 5e-3, "{f}");
        // From below, and a steep curve (sqrt: the guess is far off).
        let f = crossing(0.0, 1.0, 0.5, THREE, f32::sqrt);
        assert!((f - 0.25).abs() < 0.02, "{f}");
        // Linear: exact at once, at any level.
        assert!((crossing(0.2, 0.8, 0.5, THREE, |f| 0.2 + 0.6 * f) - 0.5).abs() < 1e-6);
        assert!((crossing(-3.0, 1.0, 0.0, THREE, |f| -3.0 + 4.0 * f) - 0.75).abs() < 1e-6);
        // A crossing at the very end stays OFF_ISO of the edge from it.
        let f = crossing(0.9, 0.1, 0.5, THREE, |f| if f < 1e-4 { 0.9 } else { 0.1 });
        assert!((OFF_ISO..=1.0 - OFF_ISO).contains(&f), "{f}");
        // More steps converge further; a tolerance stops them early.
        let kink = |f: f32| if f < 0.3 { 1.0 - f } else { 0.7 - 4.0 * (f - 0.3) };
        let (three, more) = (crossing(1.0, -2.1, 0.5, THREE, kink), crossing(1.0, -2.1, 0.5, Refine { steps: 12, tolerance: 0.0 }, kink));
        assert!((more - 0.35).abs() < 1e-4 && (more - 0.35).abs() < (three - 0.35).abs(), "{three} {more}");
        let mut calls = 0;
        crossing(0.2, 0.8, 0.5, Refine { steps: 12, tolerance: 1e-3 }, |f| {
            calls += 1;
            0.2 + 0.6 * f
        });
        assert_eq!(calls, 1);
        // A field that cannot be evaluated leaves the linear guess.
        assert!((crossing(0.0, 1.0, 0.5, THREE, |_| f32::NAN) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn samples_on_the_level_move_off_it_and_keep_their_side() {
        assert_eq!(off_level(0.5, 0.5, 1.0), 0.5 + OFF_ISO);
        assert_eq!(off_level(0.499, 0.5, 1.0), 0.5 - OFF_ISO);
        assert_eq!(off_level(0.2, 0.5, 1.0), 0.2);
        assert_eq!(off_level(-1e-9, 0.0, 2.0), -2.0 * OFF_ISO);
    }

    #[test]
    fn a_prism_asks_each_crossed_edge_once_and_flips_on_request() {
        // Corner 0 inside: the three edges at it are crossed, one triangle.
        let values = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut asked = Vec::new();
        let mut tris = Vec::new();
        march_prism(
            &values,
            0.5,
            false,
            |a, b| {
                asked.push((a, b));
                asked.len() as u32 - 1
            },
            &mut tris,
        );
        asked.sort();
        assert_eq!(asked, vec![(0, 1), (0, 3), (2, 0)]);
        assert_eq!(tris.len(), 1);
        let mut again = Vec::new();
        let mut k = 0;
        march_prism(
            &values,
            0.5,
            true,
            |_, _| {
                k += 1;
                k - 1
            },
            &mut again,
        );
        let t = tris[0];
        assert_eq!(again[0], [t[0], t[2], t[1]]);
        // All outside or all inside: nothing.
        let mut none = Vec::new();
        march_prism(&[0.0; 6], 0.5, false, |_, _| 0, &mut none);
        march_prism(&[1.0; 6], 0.5, false, |_, _| 0, &mut none);
        assert!(none.is_empty());
    }
}
