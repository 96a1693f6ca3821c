//! A field tree's compiled tape ([`thicket_core::implicit::tape`]) translated to the
//! flat postfix program that `shaders/field_trace.wgsl` interprets: one tape
//! instruction to one opcode and its parameters as `f32` words (the layout is in the
//! shader's header).
//!
//! The tree is walked once, by the core's compiler; this is a straight mapping of its
//! instructions (post order, primitive frames and ids, paints and ramps included), so
//! the CPU evaluator and the shader run the same program. The arithmetic of every
//! opcode lives once in the core's evaluator and once in the shader, and the tests
//! compare the two renders.

use thicket_core::implicit::tape::{Instruction, PrimitiveKind, WpKind};
use thicket_core::implicit::FieldTree;
use thicket_core::{Error, Result};

/// Results the shader's stack holds at once (`STACK` in the shader).
pub const STACK: usize = 16;

/// The shader's opcodes (the first word of each instruction).
pub mod opcode {
    pub const PRIM: f32 = 0.0;
    pub const OFFSET: f32 = 1.0;
    pub const NEGATE: f32 = 2.0;
    pub const H: f32 = 3.0;
    pub const MIN: f32 = 4.0;
    pub const MAX: f32 = 5.0;
    pub const WP: f32 = 6.0;
    pub const DISPLACE: f32 = 7.0;
    pub const FRACTAL: f32 = 8.0;
    pub const PAINT: f32 = 9.0;
    pub const RAMP: f32 = 10.0;
}
use opcode::*;

/// A compiled program: its words, where each tape instruction's words start, and the
/// most results alive at once (the tape's).
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    pub words: Vec<f32>,
    /// The first word of each of the tape's instructions, in order.
    pub starts: Vec<usize>,
    pub depth: usize,
}

impl Program {
    /// Translates the tree's tape; a tree needing more than [`STACK`] results alive at
    /// once is an error naming its depth (the shader would have no room for it).
    pub fn compile(tree: &FieldTree) -> Result<Self> {
        let depth = tree.stack_depth();
        if depth > STACK {
            return Err(Error::InvalidParameter(format!(
                "field render: the tree needs {depth} results alive at once while the GPU tracer holds {STACK}; render it on the CPU (device=\"cpu\") or nest fewer operations under the later children of an operation"
            )));
        }
        let instructions = tree.instructions();
        let mut p = Program { words: Vec::new(), starts: Vec::with_capacity(instructions.len()), depth };
        for inst in instructions {
            p.starts.push(p.words.len());
            emit(inst, &mut p.words);
        }
        Ok(p)
    }
}

/// One instruction's words.
fn emit(inst: &Instruction, w: &mut Vec<f32>) {
    let f = |v: f64| v as f32;
    match inst {
        // Kind (0 plane, 1 sphere, 2 cuboid, 3 torus), centre, the three axes of its
        // frame, half sizes, radius, colour.
        Instruction::Prim { prim: p, color, .. } => {
            let kind = match p.kind {
                PrimitiveKind::Plane => 0.0,
                PrimitiveKind::Sphere => 1.0,
                PrimitiveKind::Cuboid => 2.0,
                PrimitiveKind::Torus => 3.0,
            };
            w.extend([PRIM, kind]);
            w.extend(p.center.to_array().map(f));
            for a in p.axes {
                w.extend(a.to_array().map(f));
            }
            w.extend(p.half.map(f));
            w.push(f(p.radius));
            w.extend(color.map(f));
        }
        Instruction::Offset(amount) => w.extend([OFFSET, f(*amount)]),
        Instruction::Negate => w.push(NEGATE),
        Instruction::H(n) => w.extend([H, *n as f32]),
        Instruction::Min(n) => w.extend([MIN, *n as f32]),
        Instruction::Max(n) => w.extend([MAX, *n as f32]),
        Instruction::Wp { p, n, kind } => {
            let kind = match kind {
                WpKind::Intersection => 0.0,
                WpKind::Union => 1.0,
                WpKind::Difference => 2.0,
            };
            w.extend([WP, *n as f32, f(*p), kind]);
        }
        Instruction::Displace { amplitude, omega, tau } => w.extend([DISPLACE, f(*amplitude), f(*omega), f(*tau)]),
        Instruction::Fractal { terms, tau } => {
            let weight: f64 = terms.iter().map(|t| t[0].abs()).sum();
            w.extend([FRACTAL, terms.len() as f32, f(*tau), f(weight)]);
            w.extend(terms.iter().flat_map(|t| t.map(f)));
        }
        Instruction::Paint(color) => {
            w.push(PAINT);
            w.extend(color.map(f));
        }
        Instruction::Ramp(ramp) => {
            w.extend([RAMP, ramp.len() as f32]);
            for (pos, c) in ramp {
                w.push(f(*pos));
                w.extend(c.map(f));
            }
        }
    }
}
