//! A field tree ([`thicket_core::implicit::Node`]) compiled to the flat postfix program
//! that `shaders/field_trace.wgsl` interprets: each node after its children, an opcode
//! and its parameters as `f32` words (the layout is in the shader's header).
//!
//! Only parameters are prepared here (primitives to their frames, as the core's tape
//! compiles them); the arithmetic of every opcode lives once in the core's evaluator
//! and once in the shader, and the tests compare the two renders.

use glam::{DMat3, DQuat, DVec3};
use thicket_core::implicit::tree::{Node, Op, DEFAULT_COLOR};
use thicket_core::{Error, Result};

/// Results the shader's stack holds at once (`STACK` in the shader).
pub const STACK: usize = 16;

const PRIM: f32 = 0.0;
const OFFSET: f32 = 1.0;
const NEGATE: f32 = 2.0;
const H: f32 = 3.0;
const MIN: f32 = 4.0;
const MAX: f32 = 5.0;
const WP: f32 = 6.0;
const DISPLACE: f32 = 7.0;
const FRACTAL: f32 = 8.0;
const PAINT: f32 = 9.0;
const RAMP: f32 = 10.0;

/// A compiled program: its words and the most results alive at once.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    pub words: Vec<f32>,
    pub depth: usize,
}

impl Program {
    /// Compiles a valid tree; a tree needing more than [`STACK`] results alive at once
    /// is an error naming its depth (the shader would have no room for it).
    pub fn compile(node: &Node) -> Result<Self> {
        node.validate()?;
        let mut p = Program { words: Vec::new(), depth: 0 };
        let mut live = 0;
        p.emit(node, &mut live);
        if p.depth > STACK {
            return Err(Error::InvalidParameter(format!(
                "field render: the tree needs {} results alive at once while the GPU tracer holds {STACK}; render it on the CPU (device=\"cpu\") or nest fewer operations under the later children of an operation",
                p.depth
            )));
        }
        Ok(p)
    }

    fn emit(&mut self, node: &Node, live: &mut usize) {
        let children = node.op.children();
        for (_, child) in &children {
            self.emit(child, live);
        }
        let n = children.len();
        *live = *live + 1 - n;
        self.depth = self.depth.max(*live);
        let w = &mut self.words;
        let nf = n as f32;
        match &node.op {
            op if op.is_primitive() => {
                w.push(PRIM);
                prim(op, w);
                w.extend(node.color.unwrap_or(DEFAULT_COLOR).map(|c| c as f32));
            }
            Op::Offset { amount, .. } => w.extend([OFFSET, *amount as f32]),
            Op::Negate { .. } => w.push(NEGATE),
            Op::H { .. } => w.extend([H, nf]),
            Op::Min { .. } => w.extend([MIN, nf]),
            Op::Max { .. } => w.extend([MAX, nf]),
            Op::IntersectionWp { p, .. } => w.extend([WP, nf, *p as f32, 0.0]),
            Op::UnionWp { p, .. } => w.extend([WP, nf, *p as f32, 1.0]),
            Op::DifferenceWp { p, .. } => w.extend([WP, nf, *p as f32, 2.0]),
            Op::Displace { amplitude, omega, tau, .. } => w.extend([DISPLACE, *amplitude as f32, *omega as f32, *tau as f32]),
            Op::Fractal { terms, tau, .. } => {
                let weight: f64 = terms.iter().map(|t| t[0].abs()).sum();
                w.extend([FRACTAL, terms.len() as f32, *tau as f32, weight as f32]);
                w.extend(terms.iter().flat_map(|t| t.map(|v| v as f32)));
            }
            _ => unreachable!("every op is handled"),
        }
        if let Op::Displace { ramp: Some(r), .. } | Op::Fractal { ramp: Some(r), .. } = &node.op {
            w.extend([RAMP, r.len() as f32]);
            for (pos, c) in r {
                w.push(*pos as f32);
                w.extend(c.map(|v| v as f32));
            }
        }
        if let (Some(c), false) = (node.color, node.op.is_primitive()) {
            w.push(PAINT);
            w.extend(c.map(|v| v as f32));
        }
    }
}

/// A primitive's words: kind (0 plane, 1 sphere, 2 cuboid, 3 torus), centre, the
/// three axes of its orthonormal frame, half sizes, radius (the core's compiled form).
fn prim(op: &Op, w: &mut Vec<f32>) {
    let world = [DVec3::X, DVec3::Y, DVec3::Z];
    let frame = |q: &[f64; 4]| {
        let m = DMat3::from_quat(DQuat::from_xyzw(q[1], q[2], q[3], q[0]).normalize());
        [m.x_axis, m.y_axis, m.z_axis]
    };
    let pair = |n: DVec3| {
        let (u, v) = n.any_orthonormal_pair();
        [n, u, v]
    };
    let (kind, center, axes, half, radius) = match op {
        Op::Plane { point, normal } => (0.0, *point, pair(normal.normalize()), [0.0; 3], 0.0),
        // The point's `h` over the six world planes is the distance to the centre:
        // the sphere's function, as the core compiles it.
        Op::Sphere { center, radius } | Op::Point { center, radius } => (1.0, *center, world, [0.0; 3], *radius),
        Op::Segment { a, b, radius } => (2.0, 0.5 * (*a + *b), pair((*b - *a).normalize()), [0.5 * (*b - *a).length(), 0.0, 0.0], *radius),
        Op::Rectangle { center, half_size, rotation, radius } => (2.0, *center, frame(rotation), [half_size[0], half_size[1], 0.0], *radius),
        Op::Box { center, half_size, rotation, radius } => (2.0, *center, frame(rotation), *half_size, *radius),
        Op::Torus { center, axis, major, minor } => {
            let [n, u, v] = pair(axis.normalize());
            (3.0, *center, [u, v, n], [*major, 0.0, 0.0], *minor)
        }
        _ => unreachable!("not a primitive"),
    };
    w.push(kind);
    w.extend(center.to_array().map(|v| v as f32));
    for a in axes {
        w.extend(a.to_array().map(|v| v as f32));
    }
    w.extend(half.map(|v| v as f32));
    w.push(radius as f32);
}
