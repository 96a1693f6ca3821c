//! The compiled tape, read-only, for the back ends that run it elsewhere (the GPU
//! tracer's program in `thicket-render`): a tree is walked once, by the evaluator's
//! compiler ([`eval`](super::eval)); other back ends translate its instructions one by
//! one instead of walking the tree again, so every back end sees the same post order,
//! primitive frames and ids, ramps and paints.
//!
//! [`Instruction`] is the evaluator's own instruction type, read-only here (the
//! primitives' compiled frames as plain data).

use super::FieldTree;

pub use super::eval::{Inst as Instruction, WpKind};
pub use super::kernel::{Prim as Primitive, PrimKind as PrimitiveKind};

impl FieldTree {
    /// The compiled tape's instructions, in the order the evaluator runs them.
    pub fn instructions(&self) -> &[Instruction] {
        &self.tape.insts
    }

    /// The most results alive at once while the tape runs (the stack a back end
    /// needs).
    pub fn stack_depth(&self) -> usize {
        self.tape.depth
    }
}
