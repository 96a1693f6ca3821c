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
//! | union_wp | `max Li` | monotone | per face, `w_p` of the children's reaches (each child's own box grown by its own slack: [`soft_union_box`]) |
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
                Inst::Min(k) => {
                    let c = drain(&mut stack, *k);
                    // Bounded only where every child is.
                    let support = c.iter().map(|e| e.support).collect::<Option<Vec<_>>>().map(|s| union_support(&s, 0.0));
                    let solid = c.iter().map(|e| e.solid).collect::<Option<Vec<_>>>().and_then(|v| v.into_iter().reduce(Aabb::union));
                    Extent { support, solid }
                }
                Inst::Wp { p, n: k, kind: WpKind::Union } => match c_supports(drain(&mut stack, *k)) {
                    Some(s) => Extent { support: Some(union_support(&s, (*k as f64).ln() / p)), solid: Some(soft_union_box(&s, *p)) },
                    None => Extent { support: None, solid: None },
                },
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

/// The children's supports, `None` where one is unbounded.
fn c_supports(c: Vec<Extent>) -> Option<Vec<(Aabb, f64)>> {
    c.iter().map(|e| e.support).collect()
}

/// The support of a union whose value is at least `min fi - extra` (`min`: 0;
/// `union_wp`: `ln(n) / p`): each child's box grown by its slack above the least,
/// `m`, their union `B`, and the slack `m + extra`. Outside `B`, every
/// `fi >= d(x, Bi) - si >= d(x, Bi ⊕ (si - m)) - m >= d(x, B) - m` (a box grown as a box
/// holds the box grown as a ball, whose distance is `d(x, Bi) - (si - m)`), so the
/// union is at least `d(x, B) - m - extra`.
fn union_support(s: &[(Aabb, f64)], extra: f64) -> (Aabb, f64) {
    let m = s.iter().map(|(_, si)| *si).fold(f64::INFINITY, f64::min);
    let b = s.iter().map(|(b, si)| b.grown(si - m)).reduce(Aabb::union).expect("at least one child");
    (b, m + extra)
}

/// The box of the soft union `g = -w_p(-f1, ..., -fn)` (Akleman and Chen, section 4,
/// "Approximate Set Operations": `w_p(f1, f2) = log(e^(p f1) + e^(p f2)) / p` and
/// `V(-w_p(-f1, -f2)) ≈ V(f1) ∪ V(f2)`, here over n arguments) from its children's
/// supports `fi(x) >= d(x, Bi) - si` outside `Bi`, face by face and each child by its
/// own reach. The upper `x` face: on the half-space `x >= X` with `X >= hi_i` for every
/// `i`, every point lies outside every `Bi` and `d(x, Bi) >= X - hi_i`, so
/// `fi >= X - t_i` with `t_i = hi_i + si` (how far child `i` can reach). `-w_p(-·)` is
/// non-decreasing in every argument, so there
/// `g >= -w_p(t_1 - X, ..., t_n - X) = X - w_p(t_1, ..., t_n)`, positive once
/// `X > w_p(t)`: the soft union has no point beyond `X = max(w_p(t), max hi_i)`. The
/// lower faces alike with `t_i = -(lo_i - si)`.
///
/// `w_p(t)` lies between `max t_i` and `max t_i + ln(n) / p`: a child that reaches
/// `δ_i` less far than the farthest adds `ln(1 + e^(-p δ_i)) / p` at most, so a face
/// the farthest child reaches alone moves out by little, and only children reaching
/// about as far move it by up to `ln(n) / p` (the old rule grew every child's box by
/// the largest slack and `ln(n) / p`). A margin of `1e-12 (1 + |X|)` covers the
/// rounding of the log-sum-exp.
fn soft_union_box(s: &[(Aabb, f64)], p: f64) -> Aabb {
    // A face from each child's (reach, box face).
    let face = |faces: Vec<(f64, f64)>| {
        let x = kernel::wp_value(p, faces.iter().map(|f| f.0));
        let x = faces.iter().map(|f| f.1).fold(x, f64::max);
        x + 1e-12 * (1.0 + x.abs())
    };
    let (mut lo, mut hi) = (DVec3::ZERO, DVec3::ZERO);
    for a in 0..3 {
        hi[a] = face(s.iter().map(|(b, si)| (b.hi[a] + si, b.hi[a])).collect());
        lo[a] = -face(s.iter().map(|(b, si)| (si - b.lo[a], -b.lo[a])).collect());
    }
    Aabb { lo, hi }
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
