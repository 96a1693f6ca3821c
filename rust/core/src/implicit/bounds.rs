//! Bounds for culling, computed on the compiled tape by the rules of each node:
//!
//! | node | Lipschitz bound `L` | interval over a box | solid's box |
//! | --- | --- | --- | --- |
//! | plane, sphere, point, segment, rectangle, box, torus | 1 (exact distances, unit gradient) | plane, sphere, point: exact; the others: the value at the box's centre ± half its diagonal, and not below the distance between the box and the skeleton's box minus the radius | the skeleton's box grown by the radius (plane: none) |
//! | offset | `L` | shifted | grown by the amount (shrinking: the child's) |
//! | negate | `L` | negated | none (the outside of a solid) |
//! | h | `sqrt(Σ Li²)` (the bound used for any `h` node: `|∇h|` is 1 on orthogonal unit-gradient inputs, as the built-in skeletons use it, but the bound cannot know that) | `[h(lows), h(highs)]`: `h` is non-decreasing in every argument | the children's boxes intersected (`h >= max fi`) |
//! | max, intersection_wp | `max Li` (`w_p`'s gradient is a convex combination) | `[op(lows), op(highs)]`, monotone | the children's boxes intersected (`w_p >= max`) |
//! | min | `max Li` | monotone | the children's boxes' union |
//! | union_wp | `max Li` | monotone | the union grown by `ln(n) / p` (`-w_p(-f) >= min f - ln(n)/p`) |
//! | difference_wp | `max Li` | non-decreasing in `f1`, non-increasing in `f2` | the first child's (`w_p(f1, -f2) >= f1`) |
//! | displace | `L0 + |a| omega L1` | `f0`'s plus `a (cos + 1)` over `omega [f1] + tau` | `a >= 0`: the shape's; else grown by `2|a|` |
//! | fractal | `L0 + Σ |a_j| omega_j L1` | per term as displace | grown by `Σ 2 max(-a_j, 0)` |
//!
//! The boxes come with the invariant they are built on: `f(x) >= d(x, B) - s` for
//! every `x` outside a box `B`, with a slack `s` (`d` the distance to the box; inside
//! it `f` may be lower, e.g. `-min(half) - radius` in a box skeleton), so `V(f)` lies in
//! `B` grown by `s` and `V(f - a)` in `B` grown by `s + a`. Intervals are exact
//! enclosures up to rounding; [`super::FieldTree::range`] also intersects them with
//! the Lipschitz bound around the box's centre.

use super::eval::{Inst, Tape, WpKind};
use super::kernel::{self, PrimKind};
use glam::DVec3;

/// An axis-aligned box, `lo <= hi` unless empty.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Aabb {
    pub fn grown(self, by: f64) -> Self {
        let by = by.max(0.0);
        Aabb { lo: self.lo - by, hi: self.hi + by }
    }
    pub fn union(self, o: Self) -> Self {
        Aabb { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi) }
    }
    /// The intersection; where it is empty, the point nearest both (a box of no size).
    pub fn intersection(self, o: Self) -> Self {
        let (lo, hi) = (self.lo.max(o.lo), self.hi.min(o.hi));
        let mid = (lo + hi) * 0.5;
        Aabb { lo: lo.min(mid), hi: hi.max(mid) }
    }
    fn size(self) -> f64 {
        (self.hi - self.lo).max(DVec3::ZERO).element_sum()
    }
}

/// The invariant `f(x) >= d(x, box) - slack`, and a box around `V(f)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Extent {
    support: Option<(Aabb, f64)>,
    solid: Option<Aabb>,
}

impl Tape {
    /// A Lipschitz bound of the whole tree.
    pub fn lipschitz(&self) -> f64 {
        let mut stack: Vec<f64> = Vec::with_capacity(self.depth);
        for inst in &self.insts {
            let v = match inst {
                Inst::Prim { .. } => 1.0,
                Inst::Offset(_) | Inst::Negate | Inst::Paint(_) | Inst::Ramp(_) => stack.pop().expect("a child"),
                Inst::H(k) => drain(&mut stack, *k).iter().map(|l| l * l).sum::<f64>().sqrt(),
                Inst::Min(k) | Inst::Max(k) | Inst::Wp { n: k, .. } => drain(&mut stack, *k).iter().copied().fold(0.0, f64::max),
                Inst::Displace { amplitude, omega, .. } => {
                    let (l0, l1) = pair(&mut stack);
                    l0 + amplitude.abs() * omega * l1
                }
                Inst::Fractal { terms, .. } => {
                    let (l0, l1) = pair(&mut stack);
                    l0 + terms.iter().map(|[a, omega]| a.abs() * omega).sum::<f64>() * l1
                }
            };
            stack.push(v);
        }
        stack[0]
    }

    /// Encloses the tree's values over the box `[lo, hi]` by interval arithmetic.
    pub fn interval(&self, lo: DVec3, hi: DVec3) -> (f64, f64) {
        let mut stack: Vec<(f64, f64)> = Vec::with_capacity(self.depth);
        for inst in &self.insts {
            let v = match inst {
                Inst::Prim { prim, .. } => prim.interval(lo, hi),
                Inst::Offset(a) => {
                    let (l, u) = stack.pop().expect("a child");
                    (l - a, u - a)
                }
                Inst::Negate => {
                    let (l, u) = stack.pop().expect("a child");
                    (-u, -l)
                }
                Inst::Paint(_) | Inst::Ramp(_) => stack.pop().expect("a child"),
                Inst::H(k) => {
                    let c = drain(&mut stack, *k);
                    (kernel::h_value(c.iter().map(|v| v.0)), kernel::h_value(c.iter().map(|v| v.1)))
                }
                Inst::Min(k) => drain(&mut stack, *k).iter().fold((f64::INFINITY, f64::INFINITY), |a, v| (a.0.min(v.0), a.1.min(v.1))),
                Inst::Max(k) => drain(&mut stack, *k).iter().fold((f64::NEG_INFINITY, f64::NEG_INFINITY), |a, v| (a.0.max(v.0), a.1.max(v.1))),
                Inst::Wp { p, n, kind } => {
                    let c = drain(&mut stack, *n);
                    // The arguments `sign · f` at their lowest and highest.
                    let low = c.iter().enumerate().map(|(i, v)| if kind.sign(i) > 0.0 { v.0 } else { -v.1 });
                    let high = c.iter().enumerate().map(|(i, v)| if kind.sign(i) > 0.0 { v.1 } else { -v.0 });
                    let (l, u) = (kernel::wp_value(*p, low), kernel::wp_value(*p, high));
                    if *kind == WpKind::Union {
                        (-u, -l)
                    } else {
                        (l, u)
                    }
                }
                Inst::Displace { amplitude, omega, tau } => {
                    let ((l0, u0), (l1, u1)) = pair(&mut stack);
                    let (tl, tu) = wave(*amplitude, *omega, *tau, l1, u1);
                    (l0 + tl, u0 + tu)
                }
                Inst::Fractal { terms, tau } => {
                    let ((mut l, mut u), (l1, u1)) = pair(&mut stack);
                    for &[a, omega] in terms {
                        let (tl, tu) = wave(a, omega, *tau, l1, u1);
                        l += tl;
                        u += tu;
                    }
                    (l, u)
                }
            };
            stack.push(v);
        }
        stack[0]
    }

    /// A box around the solid `V(f)`, `None` where the rules cannot bound it.
    pub fn solid_box(&self) -> Option<Aabb> {
        let mut stack: Vec<Extent> = Vec::with_capacity(self.depth);
        for inst in &self.insts {
            let v = match inst {
                Inst::Prim { prim, .. } => match prim.skeleton_box() {
                    Some((lo, hi)) if prim.kind != PrimKind::Plane => {
                        let b = Aabb { lo, hi };
                        Extent { support: Some((b, prim.radius)), solid: Some(b.grown(prim.radius)) }
                    }
                    _ => Extent { support: None, solid: None },
                },
                Inst::Offset(a) => {
                    let c = stack.pop().expect("a child");
                    let support = c.support.map(|(b, s)| (b, s + a));
                    let from_support = support.map(|(b, s)| b.grown(s));
                    let solid = if *a <= 0.0 { meet(c.solid, from_support) } else { from_support };
                    Extent { support, solid }
                }
                Inst::Negate => {
                    stack.pop();
                    Extent { support: None, solid: None }
                }
                Inst::Paint(_) | Inst::Ramp(_) => stack.pop().expect("a child"),
                Inst::H(k) | Inst::Max(k) | Inst::Wp { n: k, kind: WpKind::Intersection, .. } => {
                    let c = drain(&mut stack, *k);
                    // Every child bounds the result from below: the tightest support,
                    // and the solid inside every child's.
                    let support = c.iter().filter_map(|e| e.support).min_by(|a, b| a.0.grown(a.1).size().total_cmp(&b.0.grown(b.1).size()));
                    let solid = c.iter().fold(None, |acc, e| meet(acc, e.solid));
                    Extent { support, solid }
                }
                Inst::Min(k) | Inst::Wp { n: k, kind: WpKind::Union, .. } => {
                    let c = drain(&mut stack, *k);
                    let slack = match inst {
                        Inst::Wp { p, .. } => (*k as f64).ln() / p,
                        _ => 0.0,
                    };
                    // Bounded only where every child is.
                    let supports = c.iter().map(|e| e.support).collect::<Option<Vec<_>>>();
                    let support = supports.and_then(|v| v.into_iter().reduce(|(a, sa), (b, sb)| (a.union(b), sa.max(sb)))).map(|(b, s)| (b, s + slack));
                    let solid = if slack == 0.0 {
                        c.iter().map(|e| e.solid).collect::<Option<Vec<_>>>().and_then(|v| v.into_iter().reduce(Aabb::union))
                    } else {
                        support.map(|(b, s)| b.grown(s))
                    };
                    Extent { support, solid }
                }
                Inst::Wp { n, .. } => {
                    // difference: w_p(f1, -f2) >= f1.
                    drain(&mut stack, *n)[0]
                }
                Inst::Displace { amplitude, .. } => {
                    let (shape, _) = pair(&mut stack);
                    grow_by_terms(shape, [*amplitude].into_iter())
                }
                Inst::Fractal { terms, .. } => {
                    let (shape, _) = pair(&mut stack);
                    grow_by_terms(shape, terms.iter().map(|t| t[0]))
                }
            };
            stack.push(v);
        }
        stack[0].solid
    }
}

/// `f0 + Σ a_j (cos + 1) >= f0 + Σ min(2 a_j, 0)`.
fn grow_by_terms(shape: Extent, amplitudes: impl Iterator<Item = f64>) -> Extent {
    let slack: f64 = amplitudes.map(|a| (-2.0 * a).max(0.0)).sum();
    if slack == 0.0 {
        return shape;
    }
    let support = shape.support.map(|(b, s)| (b, s + slack));
    Extent { support, solid: support.map(|(b, s)| b.grown(s)) }
}

/// The intersection of two optional boxes (`None`: unbounded).
fn meet(a: Option<Aabb>, b: Option<Aabb>) -> Option<Aabb> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.intersection(b)),
        (a, None) => a,
        (None, b) => b,
    }
}

/// `a (cos(omega f + tau) + 1)` for `f` in `[l, u]`.
fn wave(a: f64, omega: f64, tau: f64, l: f64, u: f64) -> (f64, f64) {
    let (cl, cu) = kernel::cos_range(omega * l + tau, omega * u + tau);
    let (x, y) = (a * (cl + 1.0), a * (cu + 1.0));
    (x.min(y), x.max(y))
}

fn drain<T>(stack: &mut Vec<T>, k: usize) -> Vec<T> {
    let at = stack.len() - k;
    stack.split_off(at)
}

fn pair<T>(stack: &mut Vec<T>) -> (T, T) {
    let b = stack.pop().expect("two children");
    let a = stack.pop().expect("two children");
    (a, b)
}
