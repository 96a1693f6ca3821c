//! Faces split as Blender splits them when it draws, renders or checks a mesh (its mesh
//! tessellation), step by step in `f32`: a quad along its first diagonal unless that
//! folds it ([`blender_quad_flips`]); five or more corners projected along the flipped
//! Newell normal, then ear clipping that prefers convex ears and sweeps back and forth. A non-planar n-gon has no one surface: a shell checked over some
//! other split folded under Blender's (a hexagon of a public 32 k-vertex scan), so the
//! project splits n-gons as Blender does and writes its results' n-gons as those
//! triangles. Compared with Blender's own `loop_triangles` by the Python tests.

use glam::{Vec2, Vec3};

/// Vertex kinds by the turn at them (the sign of the doubled area of their corner).
const CONVEX: i8 = 1;
const TANGENTIAL: i8 = 0;
const CONCAVE: i8 = -1;

/// Whether Blender splits quad `q` along `q1 q3` rather than `q0 q2`: where the
/// halves of the first split face apart (`is_quad_flip_v3_first_third_fast`). The
/// same for the quad written backwards from its first corner (`q0 q3 q2 q1`).
pub(crate) fn blender_quad_flips(q: [Vec3; 4]) -> bool {
    let sub = |a: Vec3, b: Vec3| [a.x - b.x, a.y - b.y, a.z - b.z];
    let cross = |a: [f32; 3], b: [f32; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let (d12, d13, d14) = (sub(q[1], q[0]), sub(q[2], q[0]), sub(q[3], q[0]));
    let (a, b) = (cross(d12, d13), cross(d14, d13));
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] > 0.0
}

/// Appends the triangles of `face` (at least three corners), `face.len() - 2` of them.
pub(super) fn split(p: &[Vec3], face: &[u32], out: &mut Vec<[u32; 3]>) {
    let flat = project(p, face);
    let mut local = Vec::with_capacity(face.len() - 2);
    ear_clip(&flat, &mut local);
    out.extend(local.iter().map(|t| t.map(|k| face[k])));
}

/// The corners in the plane of the face, seen from behind (Blender's
/// `axis_dominant_v3_to_m3_negate`), so that a counter-clockwise face turns clockwise.
fn project(p: &[Vec3], face: &[u32]) -> Vec<Vec2> {
    let at = |v: u32| p[v as usize];
    // Newell's normal, summed from the last corner on, as Blender does.
    let mut n = [0.0f32; 3];
    let mut prev = at(face[face.len() - 1]);
    for &v in face {
        let cur = at(v);
        n[0] += (prev.y - cur.y) * (prev.z + cur.z);
        n[1] += (prev.z - cur.z) * (prev.x + cur.x);
        n[2] += (prev.x - cur.x) * (prev.y + cur.y);
        prev = cur;
    }
    let squared = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    let n = if squared > 1.0e-35 {
        let scale = 1.0 / squared.sqrt();
        n.map(|x| x * scale)
    } else {
        [0.0, 0.0, 1.0]
    };
    // Two directions across the flipped normal `m`.
    let m = n.map(|x| -x);
    let across = m[0] * m[0] + m[1] * m[1];
    let (u, w) = if across > f32::EPSILON {
        let d = 1.0 / across.sqrt();
        let u = [m[1] * d, -m[0] * d, 0.0];
        (u, [-m[2] * u[1], m[2] * u[0], m[0] * u[1] - m[1] * u[0]])
    } else {
        ([if m[2] < 0.0 { -1.0 } else { 1.0 }, 0.0, 0.0], [0.0, 1.0, 0.0])
    };
    let dot = |a: [f32; 3], q: Vec3| a[0] * q.x + a[1] * q.y + a[2] * q.z;
    face.iter().map(|&v| Vec2::new(dot(u, at(v)), dot(w, at(v)))).collect()
}

/// The kind of the turn `a b c`: the sign of the doubled area of `(c, b, a)`.
fn turn(a: Vec2, b: Vec2, c: Vec2) -> i8 {
    let (d2, d3) = (b - c, a - c);
    let area = d2.x * d3.y - d3.x * d2.y;
    if area > 0.0 {
        CONVEX
    } else if area == 0.0 {
        TANGENTIAL
    } else {
        CONCAVE
    }
}

/// Ear clipping of a clockwise polygon (Blender's polygon fill): from where the last
/// ear was cut, the next ear whose corner is convex (else tangential) and holds no
/// other concave or tangential corner, the sweep turning round where the next
/// candidate is not convex. Triangles as local corner indices `(prev, tip, next)`.
fn ear_clip(co: &[Vec2], out: &mut Vec<[usize; 3]>) {
    let n = co.len();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut kind: Vec<i8> = (0..n).map(|i| turn(co[prev[i]], co[i], co[next[i]])).collect();
    // Corners that can lie inside an ear: not convex, not yet cut.
    let mut blocking: Vec<bool> = kind.iter().map(|&k| k != CONVEX).collect();
    let mut not_convex = blocking.iter().filter(|&&b| b).count();
    let (mut first, mut left, mut start, mut reverse) = (0, n, 0, false);

    let holds_a_corner = |tip: usize, next: &[usize], prev: &[usize], blocking: &[bool]| {
        let (a, b, c) = (co[tip], co[next[tip]], co[prev[tip]]);
        let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
        (0..n).any(|k| {
            let q = co[k];
            blocking[k]
                && k != tip
                && k != next[tip]
                && k != prev[tip]
                && q.cmpge(lo).all()
                && q.cmple(hi).all()
                && turn(a, b, q) != CONCAVE
                && turn(b, c, q) != CONCAVE
                && turn(c, a, q) != CONCAVE
        })
    };
    while left > 3 {
        let mut ear = None;
        'passes: for accept in [CONVEX, TANGENTIAL] {
            let mut tip = start;
            for _ in 0..left {
                if not_convex == 0 || (kind[tip] == accept && !holds_a_corner(tip, &next, &prev, &blocking)) {
                    ear = Some(tip);
                    break 'passes;
                }
                tip = if reverse { prev[tip] } else { next[tip] };
            }
        }
        // A degenerate polygon: the first corner that is not concave, if any.
        let tip = ear.unwrap_or_else(|| {
            let mut tip = start;
            for _ in 0..left {
                if kind[tip] != CONCAVE {
                    break;
                }
                tip = next[tip];
            }
            tip
        });
        if kind[tip] != CONVEX {
            not_convex -= 1;
        }
        let (a, c) = (prev[tip], next[tip]);
        out.push([a, tip, c]);
        blocking[tip] = false;
        (next[a], prev[c]) = (c, a);
        if first == tip {
            first = c;
        }
        left -= 1;
        // The corners beside the cut may have turned convex (convex ones stay so).
        for k in [a, c] {
            if kind[k] != CONVEX {
                kind[k] = turn(co[prev[k]], co[k], co[next[k]]);
                if kind[k] == CONVEX {
                    not_convex -= 1;
                    blocking[k] = false;
                }
            }
        }
        start = if reverse { prev[a] } else { next[c] };
        if kind[start] != CONVEX {
            start = if reverse { prev[start] } else { next[start] };
            reverse = !reverse;
        }
    }
    if left == 3 {
        out.push([first, next[first], next[next[first]]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Doubled signed area of a local triangle in the plane.
    fn area(co: &[Vec2], t: [usize; 3]) -> f32 {
        (co[t[1]] - co[t[0]]).perp_dot(co[t[2]] - co[t[0]])
    }

    #[test]
    fn every_polygon_gets_all_its_triangles_without_overlap() {
        // Random star-shaped (concave) polygons, clockwise: the triangles cover the
        // polygon's area exactly and each turns as the polygon does.
        let mut rng = crate::test_rng::Rng(3);
        for _ in 0..500 {
            let n = 5 + (rng.range(0.0, 40.0) as usize);
            let co: Vec<Vec2> = (0..n)
                .map(|i| {
                    let a = -(i as f32) * std::f32::consts::TAU / n as f32;
                    Vec2::from_angle(a) * rng.range(0.2, 1.0) as f32
                })
                .collect();
            let mut out = Vec::new();
            ear_clip(&co, &mut out);
            assert_eq!(out.len(), n - 2);
            let whole: f32 = (0..n).map(|i| co[i].perp_dot(co[(i + 1) % n])).sum();
            let parts: f32 = out.iter().map(|&t| area(&co, t)).sum();
            assert!((whole - parts).abs() < 1e-4 * whole.abs(), "{whole} {parts}");
            assert!(out.iter().all(|&t| area(&co, t) <= 0.0), "a triangle turns the other way");
        }
    }

    #[test]
    fn degenerate_polygons_still_give_their_triangles() {
        let line: Vec<Vec2> = (0..7).map(|i| Vec2::new(i as f32, 0.0)).collect();
        let mut out = Vec::new();
        ear_clip(&line, &mut out);
        assert_eq!(out.len(), 5);
        let mut used: Vec<usize> = out.iter().flatten().copied().collect();
        used.sort_unstable();
        used.dedup();
        assert_eq!(used.len(), 7);
        let same = vec![Vec3::ONE; 6];
        let mut tris = Vec::new();
        split(&same, &[0, 1, 2, 3, 4, 5], &mut tris);
        assert_eq!(tris.len(), 4);
    }
}
