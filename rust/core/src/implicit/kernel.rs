//! The building blocks' arithmetic, shared by the evaluator and the bounds: the n-ary
//! `h` of section 3, the texture function and the primitives compiled to their frames.

use glam::DVec3;

/// The n-ary `h[f1, ..., fn]` of section 3 with its gradient, from the values and
/// gradients of its arguments.
///
/// The binary `h` is `sqrt(f1² + f2²)` where both are `>= 0` and `max(f1, f2)`
/// elsewhere; by its associativity the n-ary form is the length of the positive parts
/// `|(f1⁺, ..., fn⁺)|` where some `fi >= 0`, and `max fi` where all are negative. The
/// gradient is `Σ fi⁺ ∇fi / h` in the first case and the largest argument's gradient
/// otherwise (also where `h = 0`, the binary rule's tie). Also returns the index of the
/// largest argument (the dominant one). The length is taken scaled by the largest
/// value, so it neither overflows nor underflows.
#[inline]
pub(crate) fn h<const N: usize>(values: [f64; N], grads: [DVec3; N]) -> (f64, DVec3) {
    let mut top = 0;
    for i in 1..N {
        if values[i] > values[top] {
            top = i;
        }
    }
    let m = values[top];
    if !(m > 0.0) {
        return (m, grads[top]);
    }
    let (mut ss, mut g) = (0.0, DVec3::ZERO);
    for i in 0..N {
        let v = values[i].max(0.0) / m;
        ss += v * v;
        g += v * grads[i];
    }
    let len = ss.sqrt();
    (m * len, g / len)
}

/// The texture function `(1 + cos(omega f + tau)) / 2` (section 2, with section 7's phase).
#[inline]
pub(crate) fn texture(omega: f64, tau: f64, f: f64) -> f64 {
    0.5 * (1.0 + (omega * f + tau).cos())
}

/// Which skeleton a [`Prim`] is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PrimKind {
    /// `axes[0] · (x - center)`.
    Plane,
    /// `|x - center| - radius`.
    Sphere,
    /// `h` over the six plane functions `±fi - half[i]` of the frame, minus `radius`:
    /// the point (`half = 0`), the segment (`half = [l, 0, 0]`), the rectangle
    /// (`[a1, a2, 0]`) and the box.
    Cuboid,
    /// `h[g - half[0], -g + half[0], f3, -f3] - radius`, `g = h[f1, -f1, f2, -f2]`.
    Torus,
}

/// A primitive compiled to an orthonormal frame: `axes` are the unit plane normals
/// `n1, n2, n3 = n1 × n2` of section 3, in world space.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Prim {
    pub kind: PrimKind,
    pub center: DVec3,
    pub axes: [DVec3; 3],
    pub half: [f64; 3],
    pub radius: f64,
}

impl Prim {
    /// Value and gradient at `x`.
    #[inline]
    pub fn eval(&self, x: DVec3) -> (f64, DVec3) {
        let d = x - self.center;
        let [a0, a1, a2] = self.axes;
        match self.kind {
            PrimKind::Plane => (a0.dot(d), a0),
            PrimKind::Sphere => {
                let l = d.length();
                // At the centre the gradient is any unit vector: the first axis.
                (l - self.radius, if l > 0.0 { d / l } else { a0 })
            }
            PrimKind::Cuboid => {
                let f = [a0.dot(d), a1.dot(d), a2.dot(d)];
                let [h0, h1, h2] = self.half;
                let (v, g) = h([f[0] - h0, -f[0] - h0, f[1] - h1, -f[1] - h1, f[2] - h2, -f[2] - h2], [a0, -a0, a1, -a1, a2, -a2]);
                (v - self.radius, g)
            }
            PrimKind::Torus => {
                let f = [a0.dot(d), a1.dot(d), a2.dot(d)];
                let (g, n) = h([f[0], -f[0], f[1], -f[1]], [a0, -a0, a1, -a1]);
                let major = self.half[0];
                let (v, grad) = h([g - major, -g + major, f[2], -f[2]], [n, -n, a2, -a2]);
                (v - self.radius, grad)
            }
        }
    }
}
