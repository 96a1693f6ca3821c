//! The compiled tape, read-only, for the back ends that run it elsewhere (the GPU
//! tracer's program in `thicket-render`): a tree is walked once, by the evaluator's
//! compiler ([`eval`](super::eval)); other back ends translate its instructions one by
//! one instead of walking the tree again, so every back end sees the same post order,
//! primitive frames and ids, ramps and paints.
//!
//! [`Instruction`] mirrors the evaluator's private instruction type one to one (the
//! primitives' compiled frames exposed as plain data).

use super::eval::Inst;
use super::kernel::PrimKind;
use super::tree::Ramp;
use super::FieldTree;
use glam::DVec3;

pub use super::eval::WpKind;

/// Which skeleton a [`Primitive`] measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrimitiveKind {
    /// `axes[0] · (x - center)`.
    Plane,
    /// `|x - center| - radius` (the sphere and the point).
    Sphere,
    /// `h` over the six planes `±fi - half[i]` of the frame, minus `radius` (the
    /// segment, the rectangle and the box).
    Cuboid,
    /// `h[g - half[0], -g + half[0], f3, -f3] - radius`, `g = h[f1, -f1, f2, -f2]`.
    Torus,
}

/// A primitive compiled to its orthonormal frame (`axes`, in world space), with its
/// id and diffuse colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Primitive {
    pub kind: PrimitiveKind,
    pub center: DVec3,
    pub axes: [DVec3; 3],
    pub half: [f64; 3],
    pub radius: f64,
    pub id: u32,
    pub color: [f64; 4],
}

/// One instruction of the tape, in post order: it pops its operands' results and
/// pushes its own (`Paint` and `Ramp` rewrite the top result's colour).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instruction<'a> {
    Primitive(Primitive),
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
        terms: &'a [[f64; 2]],
        tau: f64,
    },
    /// Sets the top result's colour.
    Paint([f64; 4]),
    /// Sets the top result's colour to the ramp at its texture value.
    Ramp(&'a Ramp),
}

impl<'a> Instruction<'a> {
    fn of(inst: &'a Inst) -> Self {
        match inst {
            Inst::Prim { prim, id, color } => Instruction::Primitive(Primitive {
                kind: match prim.kind {
                    PrimKind::Plane => PrimitiveKind::Plane,
                    PrimKind::Sphere => PrimitiveKind::Sphere,
                    PrimKind::Cuboid => PrimitiveKind::Cuboid,
                    PrimKind::Torus => PrimitiveKind::Torus,
                },
                center: prim.center,
                axes: prim.axes,
                half: prim.half,
                radius: prim.radius,
                id: *id,
                color: *color,
            }),
            Inst::Offset(amount) => Instruction::Offset(*amount),
            Inst::Negate => Instruction::Negate,
            Inst::H(n) => Instruction::H(*n),
            Inst::Min(n) => Instruction::Min(*n),
            Inst::Max(n) => Instruction::Max(*n),
            Inst::Wp { p, n, kind } => Instruction::Wp { p: *p, n: *n, kind: *kind },
            Inst::Displace { amplitude, omega, tau } => Instruction::Displace { amplitude: *amplitude, omega: *omega, tau: *tau },
            Inst::Fractal { terms, tau } => Instruction::Fractal { terms, tau: *tau },
            Inst::Paint(color) => Instruction::Paint(*color),
            Inst::Ramp(ramp) => Instruction::Ramp(ramp),
        }
    }
}

impl FieldTree {
    /// The compiled tape's instructions, in the order the evaluator runs them.
    pub fn instructions(&self) -> impl ExactSizeIterator<Item = Instruction<'_>> + '_ {
        self.tape.insts.iter().map(Instruction::of)
    }

    /// The most results alive at once while the tape runs (the stack a back end
    /// needs).
    pub fn stack_depth(&self) -> usize {
        self.tape.depth
    }
}
