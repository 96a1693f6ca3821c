//! The one evaluator: a [`Node`] tree compiled to a post-order tape of instructions,
//! run over blocks of [`BLOCK`] points at a time. Each instruction loops over the block
//! on arrays (values, gradient components, colour channels), the layout the compiler
//! vectorizes; rayon spreads chunks of [`CHUNK`] points over the threads.
//!
//! Everything is computed in double precision: value, analytic gradient (the chain
//! rule per node, section 5's gradient tree), colour (section 5: blended by the
//! weights the gradient uses), the texture value and the dominant primitive's id.
//!
//! [`Tape::compile`] is the one walk of a tree: other back ends (the GPU tracer's
//! program) translate its instructions through [`super::tape`] rather than walk the
//! tree themselves.

use super::kernel::{self, Lanes, Prim, PrimKind};
use super::tree::{ramp_color, Node, Op, Ramp, DEFAULT_COLOR};
use crate::Result;
use glam::{DMat3, DQuat, DVec3, Vec3};
use rayon::prelude::*;

/// Points per block of the tape's array loops.
pub(crate) const BLOCK: usize = 64;
/// Points per parallel task.
const CHUNK: usize = 1024;

/// How an approximate set operation signs its arguments and result:
/// `result = outer · w_p(sign_i · f_i)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WpKind {
    /// `w_p(f1, ..., fn)`.
    Intersection,
    /// `-w_p(-f1, ..., -fn)`.
    Union,
    /// `w_p(f1, -f2)`.
    Difference,
}

impl WpKind {
    pub fn sign(self, child: usize) -> f64 {
        match self {
            WpKind::Intersection => 1.0,
            WpKind::Union => -1.0,
            WpKind::Difference => {
                if child == 0 {
                    1.0
                } else {
                    -1.0
                }
            }
        }
    }
    pub fn outer(self) -> f64 {
        if self == WpKind::Union {
            -1.0
        } else {
            1.0
        }
    }
}

/// One instruction of the tape, in post order: pops its children's results and
/// pushes its own (`Paint` and `Ramp` rewrite the top result's colour).
#[derive(Debug, Clone, PartialEq)]
pub enum Inst {
    /// A primitive compiled to its frame, with its id and diffuse colour.
    Prim {
        prim: Prim,
        id: u32,
        color: [f64; 4],
    },
    /// `f - amount`.
    Offset(f64),
    Negate,
    /// `h` over the top `n` results.
    H(usize),
    Min(usize),
    Max(usize),
    /// `outer · w_p(sign_i · f_i)` over the top `n` results ([`WpKind`]).
    Wp {
        p: f64,
        n: usize,
        kind: WpKind,
    },
    /// Shape and texture (the top two results): `f0 + amplitude (cos(omega f1 + tau) + 1)`.
    Displace {
        amplitude: f64,
        omega: f64,
        tau: f64,
    },
    /// Shape and texture: `f0 + Σ a_j (cos(omega_j f1 + tau) + 1)`.
    Fractal {
        terms: Vec<[f64; 2]>,
        tau: f64,
    },
    /// Sets the colour of the result below it (a `color` on an operation node).
    Paint([f64; 4]),
    /// Sets the colour of the result below it to the ramp at its texture value (a
    /// `ramp` on a `displace` or `fractal`).
    Ramp(Ramp),
}

/// A validated tree compiled to its tape.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Tape {
    pub insts: Vec<Inst>,
    pub primitives: u32,
    /// The most results alive at once.
    pub depth: usize,
}

impl Tape {
    /// Compiles a tree; the tree must be valid ([`Node::validate`]).
    pub fn compile(node: &Node) -> Result<Self> {
        node.validate()?;
        let mut tape = Tape { insts: Vec::new(), primitives: 0, depth: 0 };
        let mut live = 0;
        tape.emit(node, &mut live);
        Ok(tape)
    }

    fn emit(&mut self, node: &Node, live: &mut usize) {
        let children = node.op.children();
        for (_, child) in &children {
            self.emit(child, live);
        }
        let n = children.len();
        let inst = match &node.op {
            op if op.is_primitive() => {
                let id = self.primitives;
                self.primitives += 1;
                Inst::Prim { prim: compile_prim(op), id, color: node.color.unwrap_or(DEFAULT_COLOR) }
            }
            Op::Offset { amount, .. } => Inst::Offset(*amount),
            Op::Negate { .. } => Inst::Negate,
            Op::H { .. } => Inst::H(n),
            Op::Min { .. } => Inst::Min(n),
            Op::Max { .. } => Inst::Max(n),
            Op::IntersectionWp { p, .. } => Inst::Wp { p: *p, n, kind: WpKind::Intersection },
            Op::UnionWp { p, .. } => Inst::Wp { p: *p, n, kind: WpKind::Union },
            Op::DifferenceWp { p, .. } => Inst::Wp { p: *p, n, kind: WpKind::Difference },
            Op::Displace { amplitude, omega, tau, .. } => Inst::Displace { amplitude: *amplitude, omega: *omega, tau: *tau },
            Op::Fractal { terms, tau, .. } => Inst::Fractal { terms: terms.clone(), tau: *tau },
            _ => unreachable!("every op is handled"),
        };
        let primitive = matches!(inst, Inst::Prim { .. });
        *live = *live + 1 - n;
        self.depth = self.depth.max(*live);
        self.insts.push(inst);
        if let Op::Displace { ramp: Some(r), .. } | Op::Fractal { ramp: Some(r), .. } = &node.op {
            self.insts.push(Inst::Ramp(r.clone()));
        }
        if let (Some(c), false) = (node.color, primitive) {
            self.insts.push(Inst::Paint(c));
        }
    }
}

/// The frame of a quaternion `[w, x, y, z]`, normalized.
fn frame(q: [f64; 4]) -> [DVec3; 3] {
    let m = DMat3::from_quat(DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize());
    [m.x_axis, m.y_axis, m.z_axis]
}

/// A valid primitive's compiled form.
fn compile_prim(op: &Op) -> Prim {
    let world = [DVec3::X, DVec3::Y, DVec3::Z];
    match op {
        Op::Plane { point, normal } => {
            let n = normal.normalize();
            let (a, b) = n.any_orthonormal_pair();
            Prim { kind: PrimKind::Plane, center: *point, axes: [n, a, b], half: [0.0; 3], radius: 0.0 }
        }
        Op::Sphere { center, radius } => Prim { kind: PrimKind::Sphere, center: *center, axes: world, half: [0.0; 3], radius: *radius },
        // `h` over the six world planes through the centre is the distance to it: the
        // sphere's function (same value and gradient), whose interval is exact.
        Op::Point { center, radius } => Prim { kind: PrimKind::Sphere, center: *center, axes: world, half: [0.0; 3], radius: *radius },
        Op::Segment { a, b, radius } => {
            let n = (*b - *a).normalize();
            let (u, v) = n.any_orthonormal_pair();
            let half = 0.5 * (*b - *a).length();
            Prim { kind: PrimKind::Cuboid, center: 0.5 * (*a + *b), axes: [n, u, v], half: [half, 0.0, 0.0], radius: *radius }
        }
        Op::Rectangle { center, half_size, rotation, radius } => {
            Prim { kind: PrimKind::Cuboid, center: *center, axes: frame(*rotation), half: [half_size[0], half_size[1], 0.0], radius: *radius }
        }
        Op::Box { center, half_size, rotation, radius } => {
            Prim { kind: PrimKind::Cuboid, center: *center, axes: frame(*rotation), half: *half_size, radius: *radius }
        }
        Op::Torus { center, axis, major, minor } => {
            let n = axis.normalize();
            let (u, v) = n.any_orthonormal_pair();
            Prim { kind: PrimKind::Torus, center: *center, axes: [u, v, n], half: [*major, 0.0, 0.0], radius: *minor }
        }
        _ => unreachable!("not a primitive"),
    }
}

/// What a run computes besides the values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Need {
    pub gradient: bool,
    pub attributes: bool,
}

impl Need {
    pub const VALUE: Need = Need { gradient: false, attributes: false };
    pub const GRADIENT: Need = Need { gradient: true, attributes: false };
    pub const ATTRIBUTES: Need = Need { gradient: false, attributes: true };
    pub const ALL: Need = Need { gradient: true, attributes: true };
}

/// One result of the tape over a block: structure of arrays.
#[derive(Clone)]
pub(crate) struct Slot {
    pub f: [f64; BLOCK],
    pub g: [[f64; BLOCK]; 3],
    pub c: [[f64; BLOCK]; 4],
    pub t: [f64; BLOCK],
    pub id: [u32; BLOCK],
}

impl Slot {
    fn new() -> Box<Self> {
        Box::new(Slot { f: [0.0; BLOCK], g: [[0.0; BLOCK]; 3], c: [[0.0; BLOCK]; 4], t: [0.0; BLOCK], id: [0; BLOCK] })
    }
    pub fn gradient(&self, j: usize) -> DVec3 {
        DVec3::new(self.g[0][j], self.g[1][j], self.g[2][j])
    }
    #[inline(always)]
    fn copy_point(&mut self, j: usize, from: &Slot, need: Need) {
        self.f[j] = from.f[j];
        if need.gradient {
            for a in 0..3 {
                self.g[a][j] = from.g[a][j];
            }
        }
        if need.attributes {
            for a in 0..4 {
                self.c[a][j] = from.c[a][j];
            }
            self.t[j] = from.t[j];
        }
        self.id[j] = from.id[j];
    }
}

/// Per-thread working memory of a run: the tape's stack and the n-ary operations'
/// accumulators.
///
/// Its memory comes from a per-thread pool and goes back there when dropped: the
/// polygonizer asks for values a block at a time, and a fresh stack of zeroed slots
/// per call cost more than the tape itself. Nothing is read before it is written.
pub(crate) struct Scratch {
    stack: Vec<Box<Slot>>,
    /// Always `Some` until dropped (then back to the pool).
    work: Option<Box<Work>>,
}

struct Work {
    acc: Box<Slot>,
    top: [f64; BLOCK],
    arg: [usize; BLOCK],
    sum: [f64; BLOCK],
    /// One child's `w_p` terms.
    terms: [f64; BLOCK],
    /// The block's points as coordinate arrays.
    xyz: [[f64; BLOCK]; 3],
    /// The primitives' working memory.
    lanes: Lanes<BLOCK>,
}

/// A stack and working memory, pooled.
type Pooled = (Vec<Box<Slot>>, Box<Work>);

/// The deepest tape stack [`Scratch`] keeps for reuse (slots of [`BLOCK`] values).
const POOLED_DEPTH: usize = 64;

thread_local! {
    static POOL: std::cell::RefCell<Vec<Pooled>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl Scratch {
    pub fn new(tape: &Tape) -> Self {
        let (mut stack, work) = POOL.with(|p| p.borrow_mut().pop()).unwrap_or_else(|| {
            (
                Vec::new(),
                Box::new(Work {
                    acc: Slot::new(),
                    top: [0.0; BLOCK],
                    arg: [0; BLOCK],
                    sum: [0.0; BLOCK],
                    terms: [0.0; BLOCK],
                    xyz: [[0.0; BLOCK]; 3],
                    lanes: Lanes::new(),
                }),
            )
        });
        while stack.len() < tape.depth {
            stack.push(Slot::new());
        }
        Scratch { stack, work: Some(work) }
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if let Some(work) = self.work.take() {
            let stack = std::mem::take(&mut self.stack);
            // A few per thread at most (a thread holds one or two at once).
            let _ = POOL.try_with(|p| {
                let mut p = p.borrow_mut();
                // A tape far deeper than usual does not pin its stack for the
                // thread's life: only stacks of ordinary depth go back.
                if p.len() < 4 && stack.len() <= POOLED_DEPTH {
                    p.push((stack, work));
                }
            });
        }
    }
}

impl Tape {
    /// Runs the tape over up to [`BLOCK`] points; the result is the returned slot's
    /// first `points.len()` entries.
    ///
    /// On x86-64 CPUs with AVX2 (checked at run time, once) the loops run four lanes
    /// wide ([`Tape::run_avx2`]), else two (SSE2, the build's baseline). The same
    /// arithmetic either way, in the same order, and no fused multiply-adds (Rust
    /// contracts none): the results are the same bit for bit (tested).
    #[inline]
    pub fn run<'s>(&self, points: &[DVec3], need: Need, s: &'s mut Scratch) -> &'s Slot {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.run_avx2(points, need, s) };
        }
        self.run_portable(points, need, s)
    }

    /// [`Tape::run`] compiled for the build's baseline.
    #[inline(never)]
    pub(crate) fn run_portable<'s>(&self, points: &[DVec3], need: Need, s: &'s mut Scratch) -> &'s Slot {
        self.run_body(points, need, s)
    }

    /// [`Tape::run`] compiled for AVX2 (the same body: the primitives, `h`, `w_p`
    /// with its exponentials and logarithm, and the texture function are inlined into
    /// it, so compiled with the feature; `cos` and `sin` of `displace` and `fractal` stay
    /// calls into the system library, and so does [`ramp_color`], made per point only
    /// where attributes are asked for).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    pub(crate) fn run_avx2<'s>(&self, points: &[DVec3], need: Need, s: &'s mut Scratch) -> &'s Slot {
        self.run_body(points, need, s)
    }

    #[inline(always)]
    fn run_body<'s>(&self, points: &[DVec3], need: Need, s: &'s mut Scratch) -> &'s Slot {
        let n = points.len();
        debug_assert!(n <= BLOCK);
        let work = s.work.as_deref_mut().expect("held until dropped");
        for (j, p) in points.iter().enumerate() {
            work.xyz[0][j] = p.x;
            work.xyz[1][j] = p.y;
            work.xyz[2][j] = p.z;
        }
        let mut sp = 0;
        for inst in &self.insts {
            match inst {
                Inst::Prim { prim, id, color } => {
                    let out = &mut s.stack[sp];
                    let [x, y, z] = &work.xyz;
                    let [gx, gy, gz] = &mut out.g;
                    let g = [&mut gx[..n], &mut gy[..n], &mut gz[..n]];
                    if need.gradient {
                        prim.block::<true, BLOCK>(&x[..n], &y[..n], &z[..n], &mut out.f[..n], g, &mut work.lanes);
                    } else {
                        prim.block::<false, BLOCK>(&x[..n], &y[..n], &z[..n], &mut out.f[..n], g, &mut work.lanes);
                    }
                    out.id[..n].fill(*id);
                    if need.attributes {
                        for (c, v) in out.c.iter_mut().zip(color) {
                            c[..n].fill(*v);
                        }
                        out.t[..n].fill(0.0);
                    }
                    sp += 1;
                }
                Inst::Offset(amount) => s.stack[sp - 1].f[..n].iter_mut().for_each(|v| *v -= amount),
                Inst::Negate => {
                    let top = &mut s.stack[sp - 1];
                    top.f[..n].iter_mut().for_each(|v| *v = -*v);
                    if need.gradient {
                        top.g.iter_mut().for_each(|g| g[..n].iter_mut().for_each(|v| *v = -*v));
                    }
                }
                Inst::Paint(color) => {
                    if need.attributes {
                        for (c, v) in s.stack[sp - 1].c.iter_mut().zip(color) {
                            c[..n].fill(*v);
                        }
                    }
                }
                Inst::Ramp(ramp) => {
                    if need.attributes {
                        let top = &mut s.stack[sp - 1];
                        for j in 0..n {
                            let c = ramp_color(ramp, top.t[j]);
                            for (ch, v) in top.c.iter_mut().zip(c) {
                                ch[j] = v;
                            }
                        }
                    }
                }
                Inst::Min(k) | Inst::Max(k) => {
                    let first = sp - k;
                    let less = matches!(inst, Inst::Min(_));
                    for j in 0..n {
                        let mut best = first;
                        for i in first + 1..sp {
                            let (v, b) = (s.stack[i].f[j], s.stack[best].f[j]);
                            if if less { v < b } else { v > b } {
                                best = i;
                            }
                        }
                        if best != first {
                            let (lower, upper) = s.stack.split_at_mut(best);
                            lower[first].copy_point(j, &upper[0], need);
                        }
                    }
                    sp = first + 1;
                }
                Inst::H(k) => {
                    sp -= k;
                    h_block(&mut s.stack[sp..sp + k], n, need, work);
                    sp += 1;
                }
                Inst::Wp { p, n: k, kind } => {
                    sp -= k;
                    wp_block(&mut s.stack[sp..sp + k], n, *p, *kind, need, work);
                    sp += 1;
                }
                Inst::Displace { amplitude, omega, tau } => {
                    sp -= 1;
                    let (lower, upper) = s.stack.split_at_mut(sp);
                    let (shape, tex) = (&mut lower[sp - 1], &upper[0]);
                    for j in 0..n {
                        let phase = omega * tex.f[j] + tau;
                        shape.f[j] += amplitude * (phase.cos() + 1.0);
                        if need.gradient {
                            let d = -amplitude * omega * phase.sin();
                            for a in 0..3 {
                                shape.g[a][j] += d * tex.g[a][j];
                            }
                        }
                        if need.attributes {
                            shape.t[j] = 0.5 * (1.0 + phase.cos());
                        }
                    }
                }
                Inst::Fractal { terms, tau } => {
                    sp -= 1;
                    let (lower, upper) = s.stack.split_at_mut(sp);
                    let (shape, tex) = (&mut lower[sp - 1], &upper[0]);
                    let weight: f64 = terms.iter().map(|t| t[0].abs()).sum();
                    for j in 0..n {
                        let (mut add, mut d, mut t) = (0.0, 0.0, 0.0);
                        for &[a, omega] in terms {
                            let phase = omega * tex.f[j] + tau;
                            add += a * (phase.cos() + 1.0);
                            d -= a * omega * phase.sin();
                            t += a.abs() * kernel::texture(omega, *tau, tex.f[j]);
                        }
                        shape.f[j] += add;
                        if need.gradient {
                            for a in 0..3 {
                                shape.g[a][j] += d * tex.g[a][j];
                            }
                        }
                        if need.attributes {
                            shape.t[j] = if weight > 0.0 { t / weight } else { kernel::texture(terms[0][1], *tau, tex.f[j]) };
                        }
                    }
                }
            }
        }
        debug_assert_eq!(sp, 1);
        &s.stack[0]
    }
}

/// `h` over the `k` children in `slots` into `slots[0]`: per point the largest value,
/// then the positive parts' length, gradient, colour and texture weights.
#[inline(always)]
fn h_block(slots: &mut [Box<Slot>], n: usize, need: Need, s: &mut Work) {
    argmax(slots, n, |_| 1.0, &mut s.top, &mut s.arg);
    let acc = &mut s.acc;
    acc.f[..n].fill(0.0);
    s.sum[..n].fill(0.0);
    clear(acc, n, need);
    for slot in slots.iter() {
        for j in 0..n {
            // Positive parts over the largest: the weights `fi⁺ / max`.
            let w = if s.top[j] > 0.0 { slot.f[j].max(0.0) / s.top[j] } else { 0.0 };
            acc.f[j] += w * w;
            s.sum[j] += w;
            accumulate(acc, slot, j, w, w, need);
        }
    }
    for j in 0..n {
        let (m, best) = (s.top[j], s.arg[j]);
        if m > 0.0 {
            let id = slots[best].id[j];
            let out = &mut slots[0];
            let len = acc.f[j].sqrt();
            out.f[j] = m * len;
            if need.gradient {
                for a in 0..3 {
                    out.g[a][j] = acc.g[a][j] / len;
                }
            }
            if need.attributes {
                // Colours by the gradient's weights, normalized to sum to one.
                for a in 0..4 {
                    out.c[a][j] = acc.c[a][j] / s.sum[j];
                }
                out.t[j] = acc.t[j] / s.sum[j];
            }
            out.id[j] = id;
        } else {
            take(slots, best, j, need);
        }
    }
}

/// `outer · w_p(sign_i f_i)` over the `k` children into `slots[0]`, by log-sum-exp.
/// Each child's terms `e^(p s_i f_i - max)` are formed in one vectorized loop
/// ([`kernel::exp_nonpositive`]), then weigh its gradient and attributes.
#[inline(always)]
fn wp_block(slots: &mut [Box<Slot>], n: usize, p: f64, kind: WpKind, need: Need, s: &mut Work) {
    argmax(slots, n, |i| p * kind.sign(i), &mut s.top, &mut s.arg);
    let acc = &mut s.acc;
    s.sum[..n].fill(0.0);
    clear(acc, n, need);
    for (i, slot) in slots.iter().enumerate() {
        let ps = p * kind.sign(i);
        let (terms, sum, top, f) = (&mut s.terms[..n], &mut s.sum[..n], &s.top[..n], &slot.f[..n]);
        for j in 0..n {
            let e = kernel::exp_nonpositive(ps * f[j] - top[j]);
            terms[j] = e;
            sum[j] += e;
        }
        // The gradient takes the arguments' signs; the colours the bare weights.
        let sign = kind.sign(i) * kind.outer();
        if need.gradient {
            for (ag, sg) in acc.g.iter_mut().zip(&slot.g) {
                for j in 0..n {
                    ag[j] += terms[j] * sign * sg[j];
                }
            }
        }
        if need.attributes {
            for (ac, sc) in acc.c.iter_mut().zip(&slot.c) {
                for j in 0..n {
                    ac[j] += terms[j] * sc[j];
                }
            }
            for ((at, e), st) in acc.t[..n].iter_mut().zip(terms.iter()).zip(&slot.t[..n]) {
                *at += e * st;
            }
        }
    }
    // The dominant children's ids first (a gather from other slots), then loops over
    // slot 0 alone, which vectorize ([`kernel::ln`] included).
    for j in 0..n {
        slots[0].id[j] = slots[s.arg[j]].id[j];
    }
    let out = &mut slots[0];
    let (sum, top, f) = (&s.sum[..n], &s.top[..n], &mut out.f[..n]);
    for j in 0..n {
        f[j] = kind.outer() * (top[j] + kernel::ln(sum[j])) / p;
    }
    if need.gradient {
        for (og, ag) in out.g.iter_mut().zip(&acc.g) {
            for j in 0..n {
                og[j] = ag[j] / sum[j];
            }
        }
    }
    if need.attributes {
        for (oc, ac) in out.c.iter_mut().zip(&acc.c) {
            for j in 0..n {
                oc[j] = ac[j] / sum[j];
            }
        }
        for ((ot, at), sum) in out.t[..n].iter_mut().zip(&acc.t[..n]).zip(sum) {
            *ot = at / sum;
        }
    }
}

/// Per point the largest `scale(i) · f_i` and its child.
#[inline(always)]
fn argmax(slots: &[Box<Slot>], n: usize, scale: impl Fn(usize) -> f64, top: &mut [f64; BLOCK], arg: &mut [usize; BLOCK]) {
    top[..n].fill(f64::NEG_INFINITY);
    arg[..n].fill(0);
    for (i, slot) in slots.iter().enumerate() {
        let k = scale(i);
        for j in 0..n {
            let v = k * slot.f[j];
            if v > top[j] {
                top[j] = v;
                arg[j] = i;
            }
        }
    }
}

#[inline(always)]
fn clear(acc: &mut Slot, n: usize, need: Need) {
    if need.gradient {
        acc.g.iter_mut().for_each(|g| g[..n].fill(0.0));
    }
    if need.attributes {
        acc.c.iter_mut().for_each(|c| c[..n].fill(0.0));
        acc.t[..n].fill(0.0);
    }
}

/// Adds `wg` times the child's gradient and `wc` times its colour and texture.
#[inline(always)]
fn accumulate(acc: &mut Slot, slot: &Slot, j: usize, wg: f64, wc: f64, need: Need) {
    if need.gradient {
        for a in 0..3 {
            acc.g[a][j] += wg * slot.g[a][j];
        }
    }
    if need.attributes {
        for a in 0..4 {
            acc.c[a][j] += wc * slot.c[a][j];
        }
        acc.t[j] += wc * slot.t[j];
    }
}

/// Point `j` of child `i` as the result (slot 0).
#[inline(always)]
fn take(slots: &mut [Box<Slot>], i: usize, j: usize, need: Need) {
    if i != 0 {
        let (lower, upper) = slots.split_at_mut(i);
        lower[0].copy_point(j, &upper[0], need);
    }
}

/// Runs `tape` over `points` in parallel chunks, handing each block's result and its
/// range of points to `write`.
pub(crate) fn for_blocks<T: Send>(tape: &Tape, points: &[Vec3], out: &mut [T], per_point: usize, need: Need, write: impl Fn(&Slot, usize, &mut [T]) + Sync) {
    debug_assert_eq!(out.len(), points.len() * per_point);
    points.par_chunks(CHUNK).zip(out.par_chunks_mut(CHUNK * per_point)).for_each(|(points, out)| {
        let mut scratch = Scratch::new(tape);
        let mut xs = [DVec3::ZERO; BLOCK];
        for (block, out) in points.chunks(BLOCK).zip(out.chunks_mut(BLOCK * per_point)) {
            for (x, p) in xs.iter_mut().zip(block) {
                *x = p.as_dvec3();
            }
            let slot = tape.run(&xs[..block.len()], need, &mut scratch);
            write(slot, block.len(), out);
        }
    });
}
