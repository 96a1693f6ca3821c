//! Implicit shapes and solid textures from unit-gradient functions (Akleman and Chen,
//! *Coupled Modeling of Solid Textures and Implicit Shapes*, Implicit Surfaces 1999):
//! the field core that the implicit, BlobTree and discoid features evaluate.
//!
//! A [`FieldTree`] is a tree of [`Node`]s (building blocks, the `h` operation, exact and
//! approximate set operations, texture displacements) checked and compiled once, then
//! evaluated at batches of points: value, analytic gradient (section 5's gradient
//! tree, never finite differences), colour (section 5: each building block's diffuse
//! colour, blended by the weights the gradient uses), texture value and the dominant
//! primitive's id ([`FieldTree::evaluate`]). It reports bounds for culling
//! ([`FieldTree::lipschitz`], [`FieldTree::interval`], [`FieldTree::bounds`]; the
//! rules per node are in [`bounds`]) and implements [`ScalarField`], so
//! [`crate::polygonize::mesh_field`] meshes it; [`trace::render`] sphere-traces it to
//! an image (Hart 1996, safe by the Lipschitz bound).
//!
//! Negative inside: `V(f) = {f <= 0}`, as in the paper.
//!
//! # JSON schema
//!
//! A tree is a JSON object with an `"op"` and that op's fields; vectors are lists
//! `[x, y, z]` of numbers. Any node may carry `"color": [r, g, b, a]`: on a primitive
//! its diffuse colour (default `[0.8, 0.8, 0.8, 1]`), on an operation a colour that
//! replaces what its children blend. Unknown fields are refused (a misspelt optional
//! field would otherwise be silently ignored); optional fields are marked with their
//! default. Unit-gradient functions (`|∇f| = 1`) are marked *unit*; the set
//! operations keep `|∇f| <= 1` (section 4.1).
//!
//! Building blocks (sections 2 and 3; the skeletons are `h` over plane functions
//! `fi = ni · (x - center)` of an orthonormal frame `n1, n2, n3`, exactly as the
//! paper builds them, and measure the distance to their skeleton minus `radius`):
//!
//! | op | fields | function |
//! | --- | --- | --- |
//! | `plane` | `point`, `normal` (not zero; normalized) | `n · (x - point)`, unit |
//! | `sphere` | `center`, `radius >= 0` | `|x - center| - radius`, unit |
//! | `point` | `center`, `radius >= 0` (0) | `h[f1, -f1, f2, -f2, f3, -f3] - radius` over the world axes, unit |
//! | `segment` | `a`, `b` (distinct), `radius >= 0` (0) | `h[f1 - l, -f1 - l, f2, -f2, f3, -f3] - radius`, `n1` along `b - a` from the midpoint, `l = |b - a| / 2`, unit |
//! | `rectangle` | `center`, `half_size [a1, a2] >= 0`, `rotation` (identity), `radius >= 0` (0) | `h[f1 - a1, -f1 - a1, f2 - a2, -f2 - a2, f3, -f3] - radius`: the rectangle spans the rotated x and y axes, unit |
//! | `box` | `center`, `half_size [a1, a2, a3] >= 0`, `rotation` (identity), `radius >= 0` (0) | `h[f1 - a1, -f1 - a1, f2 - a2, -f2 - a2, f3 - a3, -f3 - a3] - radius` (the rectangular prism `f5`; `f5 - a5` with a radius), unit |
//! | `torus` | `center`, `axis` (not zero), `major >= 0`, `minor >= 0` | `h[g - major, -g + major, f3, -f3] - minor` with `g = h[f1, -f1, f2, -f2]` and `n3` the axis (the regular toroid `f6 - a6`), unit |
//!
//! `rotation` is a quaternion `[w, x, y, z]` (Blender's order; normalized, not zero)
//! turning the local axes into the world's.
//!
//! Operations:
//!
//! | op | fields | function |
//! | --- | --- | --- |
//! | `offset` | `child`, `amount` | `f - amount` (grows the solid by `amount`) |
//! | `negate` | `child` | `-f` (the complement; `h[f, negate f]` is `|f|`, section 3) |
//! | `h` | `children` (at least one) | `h[f1, ..., fn]` (section 3): `|(f1⁺, ..., fn⁺)|` where some `fi >= 0`, else `max fi`; unit on orthogonal unit inputs |
//! | `min` / `max` | `children` (at least one) | exact union / intersection (section 4) |
//! | `intersection_wp` | `p` (1e-3 to 1e6), `children` (at least one) | `w_p(f1, ..., fn) = log(Σ e^(p fi)) / p` |
//! | `union_wp` | `p` (1e-3 to 1e6), `children` (at least one) | `-w_p(-f1, ..., -fn)` |
//! | `difference_wp` | `p` (1e-3 to 1e6), `children` (exactly two) | `w_p(f1, -f2)` |
//! | `displace` | `shape`, `texture`, `amplitude`, `omega > 0`, `tau` (0), `ramp` (none) | `f0 + amplitude (cos(omega f1 + tau) + 1)` (equation 1 with section 7's phase `tau`) |
//! | `fractal` | `shape`, `texture`, `terms: [[a_j, omega_j > 0], ...]` (at least one), `tau` (0), `ramp` (none) | `f0 + Σ a_j (cos(omega_j f1 + tau) + 1)` (equation 2) |
//!
//! A `ramp` is a colour ramp `[[position, [r, g, b, a]], ...]`: at least one stop,
//! positions in `[0, 1]` and increasing; linear between stops, the end stops' colours
//! beyond them. With one, the node's colour is the ramp at its texture value (below),
//! so colour follows the texture function (sections 2 and 6: the texture value mapped
//! through a colour map).
//!
//! `w_p` is evaluated as a log-sum-exp around the largest `p fi`: finite for any finite
//! values and `p` (`p = 200`, `|f| = 1e3` included).
//!
//! # Carried attributes
//!
//! - Colour: a primitive's own; `min`, `max` and `h` where all arguments are negative
//!   take the largest (smallest for `min`) argument's; `h` elsewhere blends by its
//!   gradient's weights `fi⁺ / h`, normalized to sum to one; the `w_p` operations by
//!   their weights `e^(p s_i f_i) / Σ` (the softmax of section 4.1); `offset` and
//!   `negate` pass it on; `displace` and `fractal` keep the shape's, or with a `ramp`
//!   take the ramp's colour at their texture value. A `color` on an operation
//!   replaces it (a ramp included).
//! - Texture: 0 at a primitive; `displace` sets `(1 + cos(omega f1 + tau)) / 2` of its
//!   texture child (section 2's texture function; `amplitude: 0` carries it without
//!   displacing), `fractal` the `|a_j|`-weighted mean of its terms'; the operations
//!   blend it like the colour.
//! - Primitive id: primitives are numbered from 0 in the order they appear in the JSON
//!   (depth first, children in order, a `displace`'s shape before its texture); a
//!   point carries the id of the argument of largest weight at each operation (the
//!   shape's for `displace` and `fractal`).
//!
//! JSON has no references, so a tree cannot have cycles; nesting deeper than 128
//! levels is refused by the parser.

pub mod bounds;
mod eval;
mod kernel;
pub mod samples;
pub mod tape;
pub mod trace;
pub mod tree;

#[cfg(test)]
pub(crate) mod tests;

pub use bounds::Aabb;
pub use tree::{Node, Op, DEFAULT_COLOR};

use crate::field::ScalarField;
use crate::Result;
use eval::{for_blocks, Need, Scratch, Tape};
use glam::{DVec3, Vec3};

/// Attribute values per point of the [`ScalarField`] implementation: colour (4), then
/// texture, then the primitive id (as a float, exact below 2^24).
pub const ATTRIBUTE_COUNT: usize = 6;
/// Index of the texture value among a point's attributes.
pub const ATTRIBUTE_TEXTURE: usize = 4;
/// Index of the primitive id among a point's attributes.
pub const ATTRIBUTE_ID: usize = 5;

/// A checked field tree, compiled for evaluation.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldTree {
    node: Node,
    tape: Tape,
}

/// Everything the tree carries at one point, in double precision.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Sample {
    pub value: f64,
    pub gradient: DVec3,
    pub color: [f64; 4],
    pub texture: f64,
    pub id: u32,
}

/// The evaluation of a batch of points.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Evaluation {
    pub values: Vec<f32>,
    pub gradients: Vec<Vec3>,
    pub colors: Vec<[f32; 4]>,
    pub textures: Vec<f32>,
    pub ids: Vec<u32>,
}

impl FieldTree {
    /// Checks and compiles a tree.
    pub fn new(node: Node) -> Result<Self> {
        let tape = Tape::compile(&node)?;
        Ok(Self { node, tape })
    }

    /// Reads, checks and compiles a tree from its JSON (see the [module docs](crate::implicit)).
    pub fn from_json(text: &str) -> Result<Self> {
        Self::new(Node::from_json(text)?)
    }

    pub fn to_json(&self) -> String {
        self.node.to_json()
    }

    pub fn node(&self) -> &Node {
        &self.node
    }

    /// How many primitives the tree has (ids run from 0 to this, exclusive).
    pub fn primitive_count(&self) -> u32 {
        self.tape.primitives
    }

    /// Value, gradient, colour, texture and primitive id at every point, in parallel.
    pub fn evaluate(&self, points: &[Vec3]) -> Evaluation {
        let mut samples = vec![Sample::default(); points.len()];
        for_blocks(&self.tape, points, &mut samples, 1, Need::ALL, |slot, n, out| {
            for (j, o) in out[..n].iter_mut().enumerate() {
                *o = sample(slot, j);
            }
        });
        let mut e = Evaluation::default();
        for s in samples {
            e.values.push(s.value as f32);
            e.gradients.push(s.gradient.as_vec3());
            e.colors.push(s.color.map(|c| c as f32));
            e.textures.push(s.texture as f32);
            e.ids.push(s.id);
        }
        e
    }

    /// Everything at one point, in double precision (for ray marchers, tests and
    /// single queries; batches go through [`FieldTree::evaluate`]).
    pub fn sample(&self, x: DVec3) -> Sample {
        let mut scratch = Scratch::new(&self.tape);
        sample(self.tape.run(&[x], Need::ALL, &mut scratch), 0)
    }

    /// The value at one point (the value alone: no gradient or attributes computed).
    fn value_at(&self, x: DVec3) -> f64 {
        let mut scratch = Scratch::new(&self.tape);
        self.tape.run(&[x], Need::VALUE, &mut scratch).f[0]
    }

    /// A Lipschitz bound: `|f(x) - f(y)| <= L |x - y|` (1 for every building block;
    /// the rules per node are in [`bounds`]).
    pub fn lipschitz(&self) -> f64 {
        self.tape.lipschitz()
    }

    /// An enclosure of the values over the box `[lo, hi]` by interval arithmetic
    /// (rules per node in [`bounds`]).
    pub fn interval(&self, lo: DVec3, hi: DVec3) -> (f64, f64) {
        self.tape.interval(lo, hi)
    }

    /// [`FieldTree::interval`] narrowed by the Lipschitz bound around the box's centre:
    /// the tightest enclosure the core offers, one evaluation more.
    pub fn range(&self, lo: DVec3, hi: DVec3) -> (f64, f64) {
        let (l, u) = self.interval(lo, hi);
        let v = self.value_at((lo + hi) * 0.5);
        let r = self.lipschitz() * ((hi - lo) * 0.5).length();
        (l.max(v - r), u.min(v + r))
    }

    /// A box around the solid `V(f)` in double precision, `None` where the tree does not
    /// bound it (a plane, a complement, a union with one of those).
    pub fn solid_box(&self) -> Option<Aabb> {
        self.tape.solid_box()
    }

    /// [`FieldTree::solid_box`] in single precision, rounded outward: the box to mesh
    /// (add a margin of a cell or two so the grid's faces stay off the surface).
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let b = self.solid_box()?;
        Some((Vec3::from_array(b.lo.to_array().map(|c| (c as f32).next_down())), Vec3::from_array(b.hi.to_array().map(|c| (c as f32).next_up()))))
    }
}

fn sample(slot: &eval::Slot, j: usize) -> Sample {
    Sample { value: slot.f[j], gradient: slot.gradient(j), color: std::array::from_fn(|a| slot.c[a][j]), texture: slot.t[j], id: slot.id[j] }
}

impl ScalarField for FieldTree {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        for_blocks(&self.tape, points, out, 1, Need::VALUE, |slot, n, out| {
            for (o, v) in out[..n].iter_mut().zip(&slot.f) {
                *o = *v as f32;
            }
        });
    }

    /// The tree's analytic gradient.
    fn gradients(&self, points: &[Vec3], out: &mut [Vec3]) {
        for_blocks(&self.tape, points, out, 1, Need::GRADIENT, |slot, n, out| {
            for (j, o) in out[..n].iter_mut().enumerate() {
                *o = slot.gradient(j).as_vec3();
            }
        });
    }

    fn attribute_count(&self) -> usize {
        ATTRIBUTE_COUNT
    }

    /// [`FieldTree::range`], rounded outward to single precision (the values are
    /// rounded to nearest, so they stay inside).
    fn interval(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let (l, u) = self.range(lo.as_dvec3(), hi.as_dvec3());
        let (l32, u32) = (l as f32, u as f32);
        Some((if f64::from(l32) > l { l32.next_down() } else { l32 }, if f64::from(u32) < u { u32.next_up() } else { u32 }))
    }

    /// [`FieldTree::lipschitz`] rounded up to single precision (`None` where it is not
    /// a finite number).
    fn lipschitz(&self) -> Option<f32> {
        let l = FieldTree::lipschitz(self);
        let l32 = l as f32;
        (l.is_finite() && l32.is_finite()).then(|| if f64::from(l32) < l { l32.next_up() } else { l32 })
    }

    /// Colour `[r, g, b, a]`, texture, primitive id per point.
    fn attributes(&self, points: &[Vec3], out: &mut [f32]) {
        for_blocks(&self.tape, points, out, ATTRIBUTE_COUNT, Need::ATTRIBUTES, |slot, n, out| {
            for (j, o) in out.chunks_exact_mut(ATTRIBUTE_COUNT).take(n).enumerate() {
                for (o, c) in o.iter_mut().zip(&slot.c) {
                    *o = c[j] as f32;
                }
                o[ATTRIBUTE_TEXTURE] = slot.t[j] as f32;
                o[ATTRIBUTE_ID] = slot.id[j] as f32;
            }
        });
    }
}
