//! Generated hard test meshes for the shell tests: thin parts, narrow gaps and sharp
//! creases, where a shell of 5-20% of the bounding-box diagonal must compress. Every
//! generator but [`cards`] gives a closed, outward-oriented 2-manifold without
//! self-intersections (checked by the tests below), 1,000-8,000 triangles, 1-2 units
//! across. `cargo run -p thicket-core --release --features test-support --example
//! hard_meshes` writes them to `tests/data/hard/`. Not part of the stable API: behind
//! the `test-support` feature, not in the release library.

use crate::mesh::vertex_normals;
use crate::shell::intersect::{tri_box, triangles_intersect, TriBvh};
use crate::testmeshes::{self, voxels};
use crate::Mesh;
use glam::{DVec3, Quat, Vec2, Vec3};
use std::collections::HashMap;
use std::f32::consts::TAU;

/// The closed hard meshes, with the comb and the bunny, by name.
pub fn all_closed() -> Vec<(&'static str, Mesh)> {
    vec![
        ("hand", hand()),
        ("cup", cup()),
        ("torus_knot", torus_knot()),
        ("two_spheres", two_spheres()),
        ("coil", coil()),
        ("blade", blade()),
        ("touching_cubes", touching_cubes()),
        ("star_prism", star_prism()),
        ("comb", testmeshes::comb(2)),
        ("bunny", testmeshes::bunny()),
    ]
}

/// An open hand (palm, four fingers, a thumb) for narrow gaps between parts of one
/// surface: fingers ~7% of the diagonal thick, ~2% apart. A voxel cage with
/// per-column widths (thick middle layer, thin palm-only outer layers), smoothed by
/// two Catmull-Clark steps (quads).
pub fn hand() -> Mesh {
    let (w, g) = (0.165, 0.042); // finger and gap columns of the cage
    let xs = cumulative(&[0.14, 0.14, 0.14, w, g, w, g, w, g, w]);
    let ys = cumulative(&[0.2, 0.15, 0.2, 0.2, 0.12, 0.2, 0.2, 0.2, 0.15]);
    let zs = cumulative(&[0.025, 0.145, 0.025]);
    let rows = [3, 4, 3, 2]; // finger lengths in rows above the palm (j > 4)
    let cage = voxels([10, 9, 3], 1, |i, j, k| {
        let palm = i >= 3 && j <= 4;
        let thumb = i < 3 && j == 1 && k == 1;
        let finger = i >= 3 && (i - 3) % 2 == 0 && j > 4 && j - 4 <= rows[(i - 3) as usize / 2] && k == 1;
        palm || thumb || finger
    });
    let cage = map(&cage, |p| Vec3::new(xs[p.x as usize], ys[p.y as usize], zs[p.z as usize]));
    centred(outward(catmull_clark(&catmull_clark(&cage))))
}

/// A thin-walled cup (walls 1.5% of the diagonal thick, rounded rim, sharp outer
/// bottom edge): a surface of revolution, for thin walls whose two sides' shells meet.
pub fn cup() -> Mesh {
    let (rb, rt, h, seg) = (0.38f32, 0.5f32, 1.0f32, 48);
    let w = 0.015 * Vec3::new(2.0 * rt, 2.0 * rt, h).length();
    let (b, t) = (Vec2::new(rb, 0.0), Vec2::new(rt, h)); // (r, z): the outer crease and rim
    let d = (t - b).normalize();
    let inward = Vec2::new(-d.y, d.x);
    let top_in = t + inward * w;
    let bottom_in = top_in + d * ((w - top_in.y) / d.y); // inner wall meets the bottom (z = w)
    let line = |a: Vec2, b: Vec2, n: usize| (1..=n).map(move |k| a.lerp(b, k as f32 / n as f32));
    let rim = (1..=6).map(|k| {
        let phi = std::f32::consts::PI * k as f32 / 6.0;
        t + inward * (w / 2.0) + (-inward * phi.cos() + d * phi.sin()) * (w / 2.0)
    });
    let profile: Vec<Vec2> = line(Vec2::ZERO, b, 6)
        .chain(line(b, t, 18))
        .chain(rim)
        .chain(line(top_in, bottom_in, 18))
        .chain(line(bottom_in, Vec2::new(0.0, w), 6).take(5))
        .collect();
    let rings: Vec<Vec<Vec3>> =
        profile.iter().map(|q| (0..seg).map(|j| Quat::from_rotation_z(TAU * j as f32 / seg as f32) * Vec3::new(q.x, 0.0, q.y)).collect()).collect();
    centred(tube(&rings, false, Some((Vec3::ZERO, Vec3::Z * w))))
}

/// A (2,3) torus knot (trefoil) tube whose strands pass 3% of the diagonal apart:
/// near contact between distant parts of one smooth surface. Swept with
/// parallel-transport frames, the loop's holonomy spread along it.
pub fn torus_knot() -> Mesh {
    let curve = |t: f32| {
        let r = 0.5 + 0.2 * (3.0 * t).cos();
        Vec3::new(r * (2.0 * t).cos(), r * (2.0 * t).sin(), 0.2 * (3.0 * t).sin())
    };
    let d = strand_distance(curve, TAU, 2000, TAU / 6.0);
    let c: Vec<Vec3> = (0..192).map(|i| curve(TAU * i as f32 / 192.0)).collect();
    let (lo, hi) = bounds(&c);
    let mut a = 0.1; // the tube radius that leaves a 3% gap (the diagonal grows with it)
    for _ in 0..20 {
        a = (d - 0.03 * (hi - lo + Vec3::splat(2.0 * a)).length()) / 2.0;
    }
    tube(&sweep(&c, true, a, 14), true, None)
}

/// Two separate spheres (two components) 0.5% of the diagonal apart, a vertex of
/// each facing the other.
pub fn two_spheres() -> Mesh {
    let s = testmeshes::icosphere(3);
    let top = s.positions().iter().copied().max_by(|a, b| a.x.total_cmp(&b.x)).unwrap();
    let q = Quat::from_rotation_arc(top, Vec3::X);
    let r = 0.5;
    let mut g = 0.0;
    for _ in 0..10 {
        g = 0.005 * Vec3::new(4.0 * r + g, 2.0 * r, 2.0 * r).length();
    }
    let left = map(&s, |v| q * v * r - Vec3::X * (r + g / 2.0));
    let right = map(&s, |v| Quat::from_rotation_z(std::f32::consts::PI) * (q * v * r) + Vec3::X * (r + g / 2.0));
    merge(&[left, right])
}

/// A helix tube of four close turns (2% of the diagonal apart) with flat fan caps.
pub fn coil() -> Mesh {
    let (r, a, turns, per_turn) = (0.5f32, 0.08f32, 4, 40);
    let mut pitch = 0.2;
    for _ in 0..20 {
        let diag = Vec3::new(2.0 * (r + a), 2.0 * (r + a), turns as f32 * pitch + 2.0 * a).length();
        pitch = (0.02 * diag + 2.0 * a) * (TAU * r).hypot(pitch) / (TAU * r); // gap = pitch cos(lead) - 2a
    }
    let c: Vec<Vec3> = (0..=turns * per_turn)
        .map(|i| {
            let s = TAU * i as f32 / per_turn as f32;
            Vec3::new(r * s.cos(), r * s.sin(), pitch * s / TAU)
        })
        .collect();
    centred(tube(&sweep(&c, false, a, 12), false, Some((c[0], c[c.len() - 1]))))
}

/// A knife blade: a thin wedge whose cutting edge has a 10° dihedral angle, curving
/// up to a blunt tip: a long sharp convex crease.
pub fn blade() -> Mesh {
    let (len, h) = (1.6f32, 0.35f32);
    let half = h * 5f32.to_radians().tan();
    let corners = [Vec2::new(0.0, half), Vec2::new(h, 0.0), Vec2::new(0.0, -half)]; // (y, z)
    let counts = [12, 12, 3];
    let section: Vec<Vec2> = (0..3).flat_map(|s| (0..counts[s]).map(move |k| corners[s].lerp(corners[(s + 1) % 3], k as f32 / counts[s] as f32))).collect();
    let scale = |u: f32| 1.0 - 0.6 * u * u;
    let rings: Vec<Vec<Vec3>> = (0..=48)
        .map(|i| {
            let u = i as f32 / 48.0;
            section.iter().map(|q| Vec3::new(len * u, scale(u) * q.x, scale(u) * q.y)).collect()
        })
        .collect();
    let centre = |u: f32| Vec3::new(len * u, scale(u) * h / 3.0, 0.0);
    centred(tube(&rings, false, Some((centre(0.0), centre(1.0)))))
}

/// Two boxes face to face, 0.3% of the diagonal apart (the smaller one's face inside
/// the larger one's), faces split into quads.
pub fn touching_cubes() -> Mesh {
    let mut g = 0.0;
    for _ in 0..10 {
        g = 0.003 * Vec3::new(1.75 + g, 1.0, 1.0).length();
    }
    let a = map(&voxels([4, 4, 4], 2, |_, _, _| true), |v| v * 0.25);
    let b = map(&voxels([3, 3, 3], 2, |_, _, _| true), |v| v * 0.25 + Vec3::new(1.0 + g, 0.125, 0.125));
    centred(merge(&[a, b]))
}

/// A twisted five-pointed star prism whose caps are single concave, non-planar
/// 40-gons (saddles 4% of the height above and below the cap's plane), arms
/// thinning to sharp tips: for shells over n-gons, which Blender splits by its own
/// ear clipping ([`crate::mesh::Mesh::triangulate`] follows it).
pub fn star_prism() -> Mesh {
    let (outer, inner, height, rings, per_edge) = (0.8f32, 0.28f32, 1.0f32, 24usize, 4usize);
    let tip = |k: usize| Vec2::from_angle(k as f32 * TAU / 10.0) * if k.is_multiple_of(2) { outer } else { inner };
    // Sides bowed out by up to 3% of the radius: no three corners in a line.
    let side = |k: usize, t: f32| {
        let (a, b) = (tip(k), tip(k + 1));
        a.lerp(b, t) + (b - a).perp().normalize() * (-0.03 * outer * (std::f32::consts::PI * t).sin())
    };
    let outline: Vec<Vec2> = (0..10).flat_map(|k| (0..per_edge).map(move |s| side(k, s as f32 / per_edge as f32))).collect();
    let n = outline.len() as u32;
    let mut positions = Vec::new();
    for j in 0..=rings {
        let z = height * j as f32 / rings as f32;
        let turn = Vec2::from_angle(0.6 * z);
        for q in &outline {
            let saddle = if j == 0 || j == rings { 0.04 * height * (2.0 * q.to_angle()).sin() } else { 0.0 };
            positions.push(turn.rotate(*q).extend(z + saddle));
        }
    }
    let mut corners: Vec<u32> = (0..n).rev().collect();
    corners.extend((0..n).map(|i| rings as u32 * n + i));
    for j in 0..rings as u32 {
        for i in 0..n {
            corners.extend([j * n + i, j * n + (i + 1) % n, (j + 1) * n + (i + 1) % n, (j + 1) * n + i]);
        }
    }
    let mut sizes = vec![n, n];
    sizes.extend(std::iter::repeat_n(4, rings * n as usize));
    centred(outward(Mesh::new(positions, &sizes, corners, None).unwrap()))
}

/// `n` separate open quad cards (foliage, debris) about 1 unit across, randomly placed
/// and turned in a cube whose side grows like `n^(1/3)` (constant density); one in five
/// is a near-parallel copy of an earlier card 0.02-0.08 away. No two cards cross.
pub fn cards(n: usize, seed: u64) -> Mesh {
    let mut rng = Rng(seed);
    let side = 1.6 * (n as f32).cbrt();
    let (mut kept, mut tris) = (Vec::<(Vec3, Quat, Vec2)>::new(), Vec::<[[DVec3; 3]; 2]>::new());
    let mut grid: HashMap<[i32; 3], Vec<usize>> = HashMap::new();
    let cell = |p: Vec3| (p / 2.0).floor().as_ivec3().to_array();
    while kept.len() < n {
        let (c, q, size) = if !kept.is_empty() && rng.f() < 0.2 {
            let (c, q, size) = kept[(rng.f() * kept.len() as f32) as usize % kept.len()];
            let shift = Vec3::new(rng.f() - 0.5, rng.f() - 0.5, 0.0) * 0.4 + Vec3::Z * (0.02 + 0.06 * rng.f());
            let tilt = Quat::from_scaled_axis(Vec3::new(rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5) * 0.1);
            (c + q * shift, q * tilt, size)
        } else {
            let (u1, u2, u3) = (rng.f(), TAU * rng.f(), TAU * rng.f()); // uniform rotation (Shoemake)
            let q = Quat::from_xyzw((1.0 - u1).sqrt() * u2.sin(), (1.0 - u1).sqrt() * u2.cos(), u1.sqrt() * u3.sin(), u1.sqrt() * u3.cos());
            (Vec3::new(rng.f(), rng.f(), rng.f()) * side, q, Vec2::new(0.6 + 0.6 * rng.f(), 0.6 + 0.6 * rng.f()))
        };
        let p = [(-1., -1.), (1., -1.), (1., 1.), (-1., 1.)].map(|(x, y)| (c + q * Vec3::new(x * size.x, y * size.y, 0.0) / 2.0).as_dvec3());
        let t = [[p[0], p[1], p[2]], [p[0], p[2], p[3]]];
        let (lo, hi) = (tri_box(&t[0]).0.min(tri_box(&t[1]).0).as_vec3(), tri_box(&t[0]).1.max(tri_box(&t[1]).1).as_vec3());
        let (clo, chi) = (cell(lo), cell(hi));
        let cells: Vec<[i32; 3]> = (clo[0]..=chi[0]).flat_map(|x| (clo[1]..=chi[1]).flat_map(move |y| (clo[2]..=chi[2]).map(move |z| [x, y, z]))).collect();
        let crosses = |o: &[[DVec3; 3]; 2]| t.iter().any(|a| o.iter().any(|b| triangles_intersect(a, b)));
        if cells.iter().any(|k| grid.get(k).is_some_and(|v| v.iter().any(|&o| crosses(&tris[o])))) {
            continue;
        }
        cells.iter().for_each(|k| grid.entry(*k).or_default().push(tris.len()));
        tris.push(t);
        kept.push((c, q, size));
    }
    let positions: Vec<Vec3> = tris.iter().flat_map(|t| [t[0][0], t[0][1], t[0][2], t[1][2]].map(|p| p.as_vec3())).collect();
    Mesh::new(positions, &vec![4; n], (0..4 * n as u32).collect(), None).unwrap()
}

/// Wavefront OBJ text: `v x y z` (6 significant digits) and 1-based `f` records.
pub fn to_obj(m: &Mesh) -> String {
    let num = |x: f32| {
        let decimals = if x == 0.0 { 0 } else { (5 - x.abs().log10().floor() as i32).clamp(0, 7) as usize };
        let s = format!("{x:.decimals$}");
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.') } else { &s };
        if s == "-0" {
            "0".to_string()
        } else {
            s.to_string()
        }
    };
    let mut out = String::new();
    for p in m.positions() {
        out += &format!("v {} {} {}\n", num(p.x), num(p.y), num(p.z));
    }
    for f in m.faces() {
        out += "f";
        f.iter().for_each(|v| out += &format!(" {}", v + 1));
        out += "\n";
    }
    out
}

/// Pairs of triangles (of the triangulation) that share no vertex and cross.
pub fn self_intersections(m: &Mesh) -> usize {
    let tris = m.triangulate().triangles;
    let p = m.positions();
    let pts: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|v| p[v as usize].as_dvec3())).collect();
    let bvh = TriBvh::build(&pts);
    let mut n = 0;
    for (i, t) in pts.iter().enumerate() {
        let (lo, hi) = tri_box(t);
        bvh.query(lo, hi, |j| {
            let j = j as usize;
            if j > i && !tris[i].iter().any(|v| tris[j].contains(v)) && triangles_intersect(t, &pts[j]) {
                n += 1;
            }
        });
    }
    n
}

/// The shortest distances from a vertex along its normal to a triangle not around it:
/// outward (the narrowest gap) and inward (the thinnest part), as found from vertices.
pub fn ray_gaps(m: &Mesh) -> (f32, f32) {
    normal_room(m).iter().fold((f32::INFINITY, f32::INFINITY), |(a, b), r| (a.min(r[0]), b.min(r[1])))
}

/// For each vertex, the distance along its normal to the first triangle not around it,
/// outward and inward (the bounding-box diagonal where nothing is hit).
pub fn normal_room(m: &Mesh) -> Vec<[f32; 2]> {
    let tris = m.triangulate().triangles;
    let p = m.positions();
    let pts: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|v| p[v as usize].as_dvec3())).collect();
    let bvh = TriBvh::build(&pts);
    let len = m.bbox_diagonal() as f64;
    vertex_normals(m)
        .iter()
        .enumerate()
        .map(|(v, n)| {
            [n.as_dvec3(), -n.as_dvec3()].map(|dir| {
                let o = p[v].as_dvec3();
                let mut best = len;
                bvh.query_segment(o, o + dir * len, |t| {
                    if !tris[t as usize].contains(&(v as u32)) {
                        if let Some(h) = crate::spatial::ray_triangle(o, dir, &pts[t as usize]) {
                            best = best.min(h);
                        }
                    }
                });
                best as f32
            })
        })
        .collect()
}

/// Shortest distance between points of a closed curve `t ∈ [0, period)` at least
/// `min_sep` apart in parameter (sampled `n` times): how close its strands come.
pub fn strand_distance(curve: impl Fn(f32) -> Vec3, period: f32, n: usize, min_sep: f32) -> f32 {
    let c: Vec<Vec3> = (0..n).map(|i| curve(period * i as f32 / n as f32)).collect();
    let skip = (min_sep / period * n as f32).ceil() as usize;
    let mut best = f32::INFINITY;
    for i in 0..n {
        for j in i + skip..(i + n + 1).saturating_sub(skip).min(n) {
            best = best.min(c[i].distance(c[j]));
        }
    }
    best
}

/// Cumulative sums from 0: grid-line coordinates from cell widths.
fn cumulative(widths: &[f32]) -> Vec<f32> {
    std::iter::once(0.0)
        .chain(
            widths
                .iter()
                .scan(0.0, |s, w| {
                    *s += w;
                    Some(*s)
                })
                .collect::<Vec<_>>(),
        )
        .collect()
}

fn bounds(p: &[Vec3]) -> (Vec3, Vec3) {
    p.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &q| (lo.min(q), hi.max(q)))
}

fn map(m: &Mesh, f: impl Fn(Vec3) -> Vec3) -> Mesh {
    Mesh::new(m.positions().iter().map(|&p| f(p)).collect(), &m.face_sizes(), m.corners().to_vec(), None).unwrap()
}

/// The mesh moved so that its bounding box is centred at the origin.
fn centred(m: Mesh) -> Mesh {
    let (lo, hi) = m.bounds();
    map(&m, |p| p - (lo + hi) / 2.0)
}

/// All faces reversed when the signed volume is negative: outward normals.
fn outward(m: Mesh) -> Mesh {
    if m.signed_volume() >= 0.0 {
        return m;
    }
    let corners = m.faces().flat_map(|f| f.iter().rev().copied()).collect();
    Mesh::new(m.positions().to_vec(), &m.face_sizes(), corners, None).unwrap()
}

/// The meshes side by side in one (separate components).
fn merge(parts: &[Mesh]) -> Mesh {
    let (mut p, mut sizes, mut c) = (Vec::new(), Vec::new(), Vec::new());
    for m in parts {
        let o = p.len() as u32;
        p.extend_from_slice(m.positions());
        sizes.extend(m.face_sizes());
        c.extend(m.corners().iter().map(|v| v + o));
    }
    Mesh::new(p, &sizes, c, None).unwrap()
}

/// Rings of `m` points around a polyline (`closed`: a loop), on parallel-transport
/// frames; a loop's holonomy (the frame's turn after one lap) is undone gradually.
fn sweep(c: &[Vec3], closed: bool, radius: f32, m: usize) -> Vec<Vec<Vec3>> {
    let n = c.len();
    let at = |i: isize| if closed { c[i.rem_euclid(n as isize) as usize] } else { c[i.clamp(0, n as isize - 1) as usize] };
    let t: Vec<Vec3> = (0..n as isize).map(|i| (at(i + 1) - at(i - 1)).normalize()).collect();
    let mut u = vec![t[0].any_orthonormal_vector()];
    for i in 1..n {
        let v = Quat::from_rotation_arc(t[i - 1], t[i]) * u[i - 1];
        u.push((v - t[i] * v.dot(t[i])).normalize());
    }
    if closed {
        let back = Quat::from_rotation_arc(t[n - 1], t[0]) * u[n - 1];
        let turn = t[0].dot(u[0].cross(back)).atan2(u[0].dot(back));
        (0..n).for_each(|i| u[i] = Quat::from_axis_angle(t[i], -turn * i as f32 / n as f32) * u[i]);
    }
    (0..n)
        .map(|i| {
            let v = t[i].cross(u[i]);
            (0..m).map(|j| c[i] + (u[i] * (TAU * j as f32 / m as f32).cos() + v * (TAU * j as f32 / m as f32).sin()) * radius).collect()
        })
        .collect()
}

/// Quads between consecutive rings of equal length, the last ring joined to the first
/// when `closed`, else triangle fans to `caps` (points by the first and last rings).
/// Oriented outward.
fn tube(rings: &[Vec<Vec3>], closed: bool, caps: Option<(Vec3, Vec3)>) -> Mesh {
    let (n, m) = (rings.len() as u32, rings[0].len() as u32);
    let mut p = rings.concat();
    let (mut sizes, mut c) = (Vec::new(), Vec::new());
    for i in 0..if closed { n } else { n - 1 } {
        let (a, b) = (i * m, (i + 1) % n * m);
        for j in 0..m {
            let k = (j + 1) % m;
            sizes.push(4);
            c.extend([a + j, a + k, b + k, b + j]);
        }
    }
    if let Some((first, last)) = caps {
        for (centre, ring) in [(first, 0), (last, n - 1)] {
            p.push(centre);
            let o = p.len() as u32 - 1;
            for j in 0..m {
                let (x, y) = (ring * m + j, ring * m + (j + 1) % m);
                sizes.push(3);
                c.extend(if ring == 0 { [o, y, x] } else { [o, x, y] });
            }
        }
    }
    outward(Mesh::new(p, &sizes, c, None).unwrap())
}

/// One Catmull-Clark step of a closed polygon mesh (all quads out, orientation kept).
fn catmull_clark(m: &Mesh) -> Mesh {
    let p = m.positions();
    let nv = p.len();
    let fp: Vec<Vec3> = m.faces().map(|f| f.iter().map(|&v| p[v as usize]).sum::<Vec3>() / f.len() as f32).collect();
    let (mut edge_of, mut edges) = (HashMap::new(), Vec::<(u32, u32, Vec3)>::new()); // ends, face-point sum
    let mut face_sum = vec![(Vec3::ZERO, 0.0f32); nv];
    for (fi, f) in m.faces().enumerate() {
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            let e = *edge_of.entry((a.min(b), a.max(b))).or_insert_with(|| {
                edges.push((a, b, Vec3::ZERO));
                edges.len() - 1
            });
            edges[e].2 += fp[fi];
            face_sum[a as usize].0 += fp[fi];
            face_sum[a as usize].1 += 1.0;
        }
    }
    let mut mid_sum = vec![Vec3::ZERO; nv];
    for &(a, b, _) in &edges {
        let mid = (p[a as usize] + p[b as usize]) / 2.0;
        mid_sum[a as usize] += mid;
        mid_sum[b as usize] += mid;
    }
    let mut positions: Vec<Vec3> = (0..nv)
        .map(|v| {
            let (f, n) = face_sum[v];
            (f / n + 2.0 * mid_sum[v] / n + (n - 3.0) * p[v]) / n
        })
        .collect();
    positions.extend(edges.iter().map(|&(a, b, f)| (p[a as usize] + p[b as usize] + f) / 4.0));
    positions.extend(&fp);
    let edge = |a: u32, b: u32| (nv + edge_of[&(a.min(b), a.max(b))]) as u32;
    let mut corners = Vec::new();
    for (fi, f) in m.faces().enumerate() {
        let centre = (nv + edges.len() + fi) as u32;
        for k in 0..f.len() {
            let (prev, v, next) = (f[(k + f.len() - 1) % f.len()], f[k], f[(k + 1) % f.len()]);
            corners.extend([v, edge(v, next), centre, edge(prev, v)]);
        }
    }
    Mesh::new(positions, &vec![4; corners.len() / 4], corners, None).unwrap()
}

/// A small deterministic generator (SplitMix64) of floats in `[0, 1)`.
struct Rng(u64);

impl Rng {
    fn f(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::obj::parse_obj;

    /// Connected components (faces joined through shared vertices).
    fn components(m: &Mesh) -> usize {
        let mut parent: Vec<usize> = (0..m.vertex_count()).collect();
        fn root(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for f in m.faces() {
            for w in f.windows(2) {
                let (a, b) = (root(&mut parent, w[0] as usize), root(&mut parent, w[1] as usize));
                parent[a] = b;
            }
        }
        (0..parent.len()).filter(|&i| root(&mut parent, i) == i).count()
    }

    #[test]
    fn closed_meshes_are_clean() {
        for (name, m) in all_closed() {
            let r = m.report();
            assert!(r.is_closed_manifold(), "{name}: {r:?}");
            assert_eq!((r.degenerate_faces, r.loose_vertices), (0, 0), "{name}: {r:?}");
            assert!(m.signed_volume() > 0.0, "{name}");
            assert_eq!(self_intersections(&m), 0, "{name}");
            if !["comb", "bunny"].contains(&name) {
                assert!((1000..=8000).contains(&r.triangles), "{name}: {} triangles", r.triangles);
                let d = m.bbox_diagonal();
                assert!((1.0..=3.0).contains(&d), "{name}: diagonal {d}");
            }
            // What the example writes reads back as clean.
            let back = parse_obj(&to_obj(&m)).unwrap();
            assert_eq!((back.vertex_count(), back.face_count()), (m.vertex_count(), m.face_count()));
            assert_eq!(self_intersections(&back), 0, "{name} after OBJ");
        }
    }

    #[test]
    fn gaps_and_parts_are_as_designed() {
        let rel = |m: &Mesh| {
            let (gap, thick) = ray_gaps(m);
            (gap / m.bbox_diagonal(), thick / m.bbox_diagonal())
        };
        let hand = hand();
        let (gap, thick) = rel(&hand);
        assert_eq!(components(&hand), 1);
        assert!((0.015..=0.03).contains(&gap) && (0.05..=0.08).contains(&thick), "hand: gap {gap}, thickness {thick}");
        let (_, thick) = rel(&cup());
        assert!((0.013..=0.016).contains(&thick), "cup wall {thick}");
        let (gap, _) = rel(&torus_knot());
        assert!((0.02..=0.04).contains(&gap), "torus knot gap {gap}");
        let spheres = two_spheres();
        let (gap, _) = rel(&spheres);
        assert_eq!(components(&spheres), 2);
        assert!((0.0049..=0.0055).contains(&gap), "spheres gap {gap}");
        let (gap, _) = rel(&coil());
        assert!((0.018..=0.025).contains(&gap), "coil gap {gap}");
        let (gap, _) = rel(&touching_cubes());
        assert!((0.0029..=0.0031).contains(&gap), "boxes gap {gap}");
    }

    #[test]
    fn blade_edge_is_sharp() {
        // The edge vertices' two flank faces meet at about 10 degrees.
        let m = blade();
        let p = m.positions();
        let (_, hi) = m.bounds();
        let edge_faces: Vec<Vec3> = m
            .faces()
            .filter(|f| f.len() == 4 && f.iter().any(|&v| p[v as usize].y > hi.y - 1e-4))
            .map(|f| (p[f[1] as usize] - p[f[0] as usize]).cross(p[f[2] as usize] - p[f[0] as usize]).normalize())
            .collect();
        let angle = edge_faces.iter().flat_map(|a| edge_faces.iter().map(move |b| a.angle_between(*b))).fold(0.0f32, f32::max);
        assert!((165f32.to_radians()..=175f32.to_radians()).contains(&angle), "{}", angle.to_degrees());
    }

    #[test]
    fn cards_are_separate_and_spread() {
        for n in [1, 50, 400] {
            let m = cards(n, 7);
            let r = m.report();
            assert_eq!((r.faces, r.vertices, r.boundary_edges), (n, 4 * n, 4 * n));
            assert_eq!(self_intersections(&m), 0);
            assert_eq!(m, cards(n, 7));
        }
        let (small, large) = (cards(50, 1).bbox_diagonal(), cards(400, 1).bbox_diagonal());
        assert!((1.6..2.4).contains(&(large / small)), "{small} {large}"); // 8x the cards, 2x the side
    }
}
