use super::*;
use crate::mesh::{boundary_edges, fixtures};
use crate::test_rng::Rng;
use crate::{hard_meshes, testmeshes};
use glam::DVec2;

fn run(mesh: &Mesh, levels: u32, limit: bool) -> Subdivided {
    subdivide(mesh, &Options { levels, limit, boundary: Boundary::SmoothAll }).unwrap()
}

/// The uniform cubic B-spline basis at `t` in [0, 1], evaluated directly.
fn bspline(t: f64) -> [f64; 4] {
    let s = 1.0 - t;
    [s * s * s / 6.0, (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0, (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0, t * t * t / 6.0]
}

#[test]
fn cube_counts_and_source_faces() {
    let cube = fixtures::cube();
    let one = run(&cube, 1, false);
    assert_eq!((one.mesh.vertex_count(), one.mesh.face_count()), (8 + 12 + 6, 24));
    assert!(one.mesh.face_sizes().iter().all(|&n| n == 4));
    // Euler: V - E + F = 2 at every level of a closed genus-0 mesh.
    let two = run(&cube, 2, true);
    assert_eq!((two.mesh.vertex_count(), two.mesh.face_count()), (98, 96));
    assert!(boundary_edges(&two.mesh).is_empty());
    // Base face f's children are the contiguous run 16 f .. 16 f + 16.
    assert!(two.source_face.iter().enumerate().all(|(i, &f)| f as usize == i / 16));
    // The base vertices keep their indices, pulled towards the centre.
    for v in 0..8 {
        let (p, q) = (cube.positions()[v], two.mesh.positions()[v]);
        assert!(q.length() < p.length() && q.normalize().dot(p.normalize()) > 0.9999, "vertex {v}: {p} -> {q}");
    }
}

#[test]
fn regular_grid_limit_is_the_bicubic_b_spline() {
    // 8 x 8 control points at integer (x, y) with random heights: faces whose 4 x 4
    // control net holds no boundary vertex are uniform bicubic B-spline patches.
    let n = 7u32;
    let mut rng = Rng(7);
    let mut grid = fixtures::grid(n);
    let z: Vec<f64> = (0..grid.vertex_count()).map(|_| rng.range(-1.0, 1.0)).collect();
    for (v, &h) in z.iter().enumerate() {
        let p = grid.positions()[v];
        grid.set_position(v, Vec3::new(p.x, p.y, h as f32)).unwrap();
    }
    let at = |i: i64, j: i64| grid.positions()[(j * (n as i64 + 1) + i) as usize].z as f64;
    for levels in 1..=3 {
        let out = run(&grid, levels, true);
        let mut checked = 0;
        for p in out.mesh.positions() {
            let (u, v) = (p.x as f64, p.y as f64);
            if !(2.0..=5.0).contains(&u) || !(2.0..=5.0).contains(&v) {
                continue;
            }
            // The patch of face (i, j); its right or top edge for u = 5 or v = 5.
            let (i, j) = ((u.floor() as i64).min(4), (v.floor() as i64).min(4));
            let (bu, bv) = (bspline(u - i as f64), bspline(v - j as f64));
            let want: f64 = (0..4).flat_map(|a| (0..4).map(move |b| (a, b))).map(|(a, b)| bu[a] * bv[b] * at(i - 1 + a as i64, j - 1 + b as i64)).sum();
            assert!((p.z as f64 - want).abs() < 1e-5, "level {levels} at ({u}, {v}): {} vs {want}", p.z);
            checked += 1;
        }
        let side = 3 * (1 << levels) + 1;
        assert_eq!(checked, side * side, "level {levels}");
    }
}

#[test]
fn planar_mixed_mesh_stays_planar() {
    // A quad, two triangles and a hexagon (with straight corners) in a tilted plane: 16 corners.
    let flat = [[0., 0.], [1., 0.], [2., 0.], [0., 1.], [1., 1.], [2., 1.], [0., 2.], [1., 2.], [2., 2.]];
    let (normal, u) = (Vec3::new(1.0, 2.0, 3.0).normalize(), Vec3::new(2.0, -1.0, 0.0).normalize());
    let w = normal.cross(u);
    let positions: Vec<Vec3> = flat.iter().map(|[x, y]| Vec3::splat(0.5) + u * *x + w * *y).collect();
    let faces = [vec![0, 1, 4, 3], vec![1, 2, 5], vec![1, 5, 4], vec![3, 4, 5, 8, 7, 6]];
    let sizes: Vec<u32> = faces.iter().map(|f| f.len() as u32).collect();
    let mesh = Mesh::new(positions, &sizes, faces.concat(), None).unwrap();
    for (levels, limit) in [(1, false), (2, true), (3, true), (4, false)] {
        let out = run(&mesh, levels, limit);
        assert_eq!(out.mesh.face_count(), 16 * 4usize.pow(levels - 1), "one quad per base corner, then 4 per quad");
        let off = out.mesh.positions().iter().map(|p| (*p - Vec3::splat(0.5)).dot(normal).abs()).fold(0.0, f32::max);
        assert!(off < 1e-6, "levels {levels} limit {limit}: {off} off the plane");
    }
}

#[test]
fn open_grid_boundary_is_the_cubic_b_spline_curve() {
    // With every boundary vertex smoothed (Blender's default), the boundary of an open
    // grid is the closed uniform cubic B-spline curve of the boundary polygon.
    let n = 4u32;
    let mut rng = Rng(3);
    let mut grid = fixtures::grid(n);
    for v in 0..grid.vertex_count() {
        let p = grid.positions()[v] + rng.vec(0.2).as_vec3();
        grid.set_position(v, p).unwrap();
    }
    let ring: Vec<u32> =
        (0..n).chain((0..n).map(|j| j * (n + 1) + n)).chain((0..n).map(|i| n * (n + 1) + n - i)).chain((0..n).map(|j| (n - j) * (n + 1))).collect();
    let m = ring.len();
    let control = |k: i64| grid.positions()[ring[k.rem_euclid(m as i64) as usize] as usize].as_dvec3();
    let curve = |t: f64| {
        let (k, b) = (t.floor() as i64, bspline(t.fract()));
        (0..4).map(|a| control(k - 1 + a as i64) * b[a]).sum::<DVec3>()
    };
    let base = Level::base(&grid).unwrap();
    let nv = grid.vertex_count();
    let edge = |a: u32, b: u32| base.edges.iter().position(|e| *e == [a.min(b), a.max(b)]).unwrap();
    for levels in 1..=2 {
        let out = run(&grid, levels, true);
        let nv1 = nv + base.edges.len() + base.face_count();
        for k in 0..m {
            let e = edge(ring[k], ring[(k + 1) % m]);
            // Base vertex k, level-1 edge point k + 1/2, level-2 edge points k + 1/4, k + 3/4.
            let mut expect = vec![(ring[k] as usize, k as f64), (nv + e, k as f64 + 0.5)];
            if levels == 2 {
                let forward = ring[k] < ring[(k + 1) % m];
                expect.push((nv1 + 2 * e, k as f64 + if forward { 0.25 } else { 0.75 }));
                expect.push((nv1 + 2 * e + 1, k as f64 + if forward { 0.75 } else { 0.25 }));
            }
            for (v, t) in expect {
                let (got, want) = (out.mesh.positions()[v].as_dvec3(), curve(t));
                assert!(got.distance(want) < 1e-5, "level {levels} vertex {v} at t = {t}: {got} vs {want}");
            }
        }
    }
}

#[test]
fn kept_corners_stay_put() {
    let grid = fixtures::grid(3);
    let out = subdivide(&grid, &Options { levels: 2, limit: true, boundary: Boundary::KeepCorners }).unwrap();
    for v in [0, 3, 12, 15] {
        assert_eq!(out.mesh.positions()[v], grid.positions()[v], "corner {v}");
    }
    // Smoothed, the same corner moves in.
    assert!(run(&grid, 2, true).mesh.positions()[0].length() > 0.1);
}

#[test]
fn limit_positions_are_the_same_from_every_level() {
    // The limit mask is a left eigenvector of the subdivision step: a vertex's limit found
    // after one level equals the one found after two, at extraordinary vertices (valence 3
    // and 5, n-gon centres), triangles and boundaries alike.
    for (name, mesh) in [("star prism", hard_meshes::star_prism()), ("icosphere", testmeshes::icosphere(1)), ("saddle", testmeshes::saddle(3))] {
        let (one, two) = (run(&mesh, 1, true), run(&mesh, 2, true));
        let scale = mesh.bbox_diagonal();
        for (v, p) in one.mesh.positions().iter().enumerate() {
            assert!(p.distance(two.mesh.positions()[v]) < 1e-5 * scale, "{name} vertex {v}: {p} vs {}", two.mesh.positions()[v]);
        }
    }
}

#[test]
fn material_indices_follow_their_faces() {
    let mesh = hard_meshes::star_prism();
    let out = run(&mesh, 2, false);
    let sizes = mesh.face_sizes();
    assert_eq!(out.source_face.len(), out.mesh.face_count());
    // Each base face of k corners has 4 k children at level 2, in order.
    let expected: Vec<u32> = sizes.iter().enumerate().flat_map(|(f, &k)| std::iter::repeat_n(f as u32, 4 * k as usize)).collect();
    assert_eq!(out.source_face, expected);
}

#[test]
fn refuses_bad_input_with_a_message() {
    let p = |n: usize| (0..n).map(|i| Vec3::new(i as f32, (i * i % 7) as f32, (i % 3) as f32)).collect::<Vec<_>>();
    let err = |mesh: Mesh, levels: u32| subdivide(&mesh, &Options { levels, ..Options::default() }).unwrap_err();
    // Three quads on the edge 0-1.
    let fin = Mesh::new(p(8), &[4, 4, 4], vec![0, 1, 2, 3, 1, 0, 4, 5, 0, 1, 6, 7], None).unwrap();
    let e = err(fin, 1);
    assert!(matches!(&e, Error::InvalidMesh(m) if m.contains("edge 0-1") && m.contains("3 faces")), "{e}");
    // Two triangles meeting at vertex 0 only.
    let bowtie = Mesh::new(p(5), &[3, 3], vec![0, 1, 2, 0, 3, 4], None).unwrap();
    let e = err(bowtie, 1);
    assert!(matches!(&e, Error::InvalidMesh(m) if m.contains("vertex 0") && m.contains("2 separate fans")), "{e}");
    // Two closed cones sharing their apex 0: every edge has two faces, yet two fans.
    let cones = Mesh::new(p(7), &[3; 6], vec![0, 1, 2, 0, 2, 3, 0, 3, 1, 0, 5, 4, 0, 6, 5, 0, 4, 6], None).unwrap();
    assert!(matches!(err(cones, 1), Error::InvalidMesh(m) if m.contains("vertex 0")));
    // The cube with face 2 wound backwards.
    let cube = fixtures::cube();
    let faces: Vec<Vec<u32>> = cube.faces().enumerate().map(|(f, v)| if f == 2 { v.iter().rev().copied().collect() } else { v.to_vec() }).collect();
    let flipped = Mesh::new(cube.positions().to_vec(), &cube.face_sizes(), faces.concat(), None).unwrap();
    let e = err(flipped, 1);
    assert!(matches!(&e, Error::InvalidMesh(m) if m.contains("same way") && m.contains("recalculate normals")), "{e}");
    let loose = Mesh::new(p(4), &[3], vec![0, 1, 2], None).unwrap();
    assert!(matches!(err(loose, 1), Error::InvalidMesh(m) if m.contains("vertex 3") && m.contains("no face")));
    let twice = Mesh::new(p(4), &[4], vec![0, 1, 2, 1], None).unwrap();
    assert!(matches!(err(twice, 1), Error::InvalidMesh(m) if m.contains("vertex 1 more than once")));
    for levels in [0, MAX_LEVELS + 1] {
        assert!(matches!(err(fixtures::cube(), levels), Error::InvalidParameter(_)), "levels {levels}");
    }
    assert!(matches!(err(Mesh::default(), 1), Error::EmptyMesh));
    // One face of 2^20 corners would make 2^32 corners at 6 levels.
    let huge = Mesh::new(p(1 << 20), &[1 << 20], (0..1 << 20).collect(), None).unwrap();
    assert!(matches!(err(huge, MAX_LEVELS), Error::OverLimit(_)));
    assert!(Boundary::parse("NONE").is_err());
}

fn with_uvs(mesh: &Mesh, levels: u32, limit: bool, smooth: UvSmooth, uvs: &[Vec2]) -> (Subdivided, Vec<Vec2>) {
    let options = Options { levels, limit, boundary: Boundary::KeepCorners };
    let (out, mut maps) = subdivide_with_uvs(mesh, &options, smooth, &[uvs]).unwrap();
    assert_eq!(maps.len(), 1);
    let uvs = maps.pop().unwrap();
    assert_eq!(uvs.len(), out.mesh.corners().len());
    (out, uvs)
}

/// The UV of each corner of `mesh` from a per-vertex map.
fn per_vertex(mesh: &Mesh, uv: impl Fn(Vec3) -> Vec2) -> Vec<Vec2> {
    mesh.corners().iter().map(|&v| uv(mesh.positions()[v as usize])).collect()
}

#[test]
fn uvs_leave_positions_bit_identical() {
    let mesh = hard_meshes::star_prism();
    let uvs = per_vertex(&mesh, |p| Vec2::new(p.x, p.y + p.z));
    for (levels, limit) in [(1, false), (2, true), (3, true)] {
        let options = Options { levels, limit, boundary: Boundary::SmoothAll };
        let (out, _) = subdivide_with_uvs(&mesh, &options, UvSmooth::PreserveBoundaries, &[&uvs, &uvs]).unwrap();
        assert_eq!(out, subdivide(&mesh, &options).unwrap());
    }
}

#[test]
fn planar_grid_uvs_stay_the_bilinear_map() {
    // A flat grid with corners kept: every level's positions are the bilinear map of the
    // base grid, on the limit too; UVs equal to the positions must stay so, by either rule.
    let grid = fixtures::grid(4);
    let uvs = per_vertex(&grid, |p| Vec2::new(p.x, p.y) * 0.25);
    for smooth in [UvSmooth::PreserveBoundaries, UvSmooth::Linear] {
        for levels in 1..=4 {
            for limit in [false, true] {
                let (out, got) = with_uvs(&grid, levels, limit, smooth, &uvs);
                for (c, &v) in out.mesh.corners().iter().enumerate() {
                    let p = out.mesh.positions()[v as usize];
                    assert!(got[c].distance(Vec2::new(p.x, p.y) * 0.25) < 1e-6, "{smooth:?} level {levels} limit {limit} corner {c}: {} at {p}", got[c]);
                }
            }
        }
    }
}

#[test]
fn inner_uvs_limit_is_the_bicubic_b_spline() {
    // Random UVs without seams on an 8 x 8 flat grid: faces whose 4 x 4 net avoids the
    // (preserved) boundary are uniform bicubic B-spline patches of the UVs.
    let n = 7u32;
    let grid = fixtures::grid(n);
    let mut rng = Rng(11);
    let control: Vec<Vec2> = (0..grid.vertex_count()).map(|_| Vec2::new(rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32)).collect();
    let uvs: Vec<Vec2> = grid.corners().iter().map(|&v| control[v as usize]).collect();
    let at = |i: i64, j: i64| control[(j * (n as i64 + 1) + i) as usize].as_dvec2();
    for levels in 1..=3 {
        let (out, got) = with_uvs(&grid, levels, true, UvSmooth::PreserveBoundaries, &uvs);
        let mut checked = 0;
        for (c, &v) in out.mesh.corners().iter().enumerate() {
            let p = out.mesh.positions()[v as usize];
            let (u, v) = (p.x as f64, p.y as f64);
            if !(2.0..=5.0).contains(&u) || !(2.0..=5.0).contains(&v) {
                continue;
            }
            let (i, j) = ((u.floor() as i64).min(4), (v.floor() as i64).min(4));
            let (bu, bv) = (bspline(u - i as f64), bspline(v - j as f64));
            let want: DVec2 = (0..4).flat_map(|a| (0..4).map(move |b| (a, b))).map(|(a, b)| at(i - 1 + a as i64, j - 1 + b as i64) * (bu[a] * bv[b])).sum();
            assert!(got[c].as_dvec2().distance(want) < 1e-5, "level {levels} at ({u}, {v}): {} vs {want}", got[c]);
            checked += 1;
        }
        let side = 3 * (1 << levels);
        assert!(checked >= side * side * 4, "level {levels}: {checked} corners checked");
    }
}

/// A 6 x 4 grid, jittered, with random UVs per vertex, cut by a seam along x = 3: the faces
/// right of it take UVs shifted by 10 (a second island).
fn seamed_grid() -> (Mesh, Vec<Vec2>) {
    let mut rng = Rng(5);
    let mut grid = fixtures::grid(6);
    let n = 6u32;
    let faces: Vec<Vec<u32>> = grid.faces().filter(|f| f[0] / (n + 1) < 4).map(|f| f.to_vec()).collect();
    let sizes = vec![4u32; faces.len()];
    let keep = 5 * (n + 1) as usize;
    grid = Mesh::new(grid.positions()[..keep].to_vec(), &sizes, faces.concat(), None).unwrap();
    for v in 0..grid.vertex_count() {
        grid.set_position(v, grid.positions()[v] + rng.vec(0.2).as_vec3()).unwrap();
    }
    let control: Vec<Vec2> = (0..grid.vertex_count()).map(|_| Vec2::new(rng.range(0.0, 1.0) as f32, rng.range(0.0, 1.0) as f32)).collect();
    let uvs = grid
        .faces()
        .flat_map(|f| {
            let shift = if f.iter().any(|&v| v % (n + 1) > 3) { 10.0 } else { 0.0 };
            f.iter().map(|&v| control[v as usize] + Vec2::new(shift, 0.0)).collect::<Vec<_>>()
        })
        .collect();
    (grid, uvs)
}

#[test]
fn seam_keeps_its_islands_apart() {
    // With preserved boundaries each island subdivides on its own: the seamed grid's UVs
    // equal those of its two halves subdivided as separate meshes.
    let (grid, uvs) = seamed_grid();
    let sizes = grid.face_sizes();
    let offsets: Vec<usize> = std::iter::once(0)
        .chain(sizes.iter().scan(0, |s, &k| {
            *s += k as usize;
            Some(*s)
        }))
        .collect();
    let right: Vec<bool> = (0..grid.face_count()).map(|f| uvs[offsets[f]].x > 5.0).collect();
    for (levels, limit) in [(1, false), (2, true), (3, false), (3, true)] {
        let (out, got) = with_uvs(&grid, levels, limit, UvSmooth::PreserveBoundaries, &uvs);
        let per_face = 4usize.pow(levels);
        for side in [false, true] {
            let faces: Vec<usize> = (0..grid.face_count()).filter(|&f| right[f] == side).collect();
            let half = Mesh::new(grid.positions().to_vec(), &vec![4; faces.len()], faces.iter().flat_map(|&f| grid.face(f).to_vec()).collect(), None).unwrap();
            let half_uvs: Vec<Vec2> = faces.iter().flat_map(|&f| uvs[offsets[f]..offsets[f + 1]].to_vec()).collect();
            // The half's loose vertices are refused, so keep only its own.
            let used: std::collections::BTreeSet<u32> = half.corners().iter().copied().collect();
            let renumber: std::collections::HashMap<u32, u32> = used.iter().enumerate().map(|(i, &v)| (v, i as u32)).collect();
            let half = Mesh::new(
                used.iter().map(|&v| half.positions()[v as usize]).collect(),
                &half.face_sizes(),
                half.corners().iter().map(|v| renumber[v]).collect(),
                None,
            )
            .unwrap();
            let (_, want) = with_uvs(&half, levels, limit, UvSmooth::PreserveBoundaries, &half_uvs);
            // A base quad's 4^L child quads hold 4^(L+1) corners.
            let corners = 4 * per_face;
            for (k, &f) in faces.iter().enumerate() {
                for i in 0..corners {
                    let (a, b) = (got[f * corners + i], want[k * corners + i]);
                    assert!(a.distance(b) < 1e-6, "levels {levels} limit {limit} face {f} child {i}: {a} vs {b}");
                }
            }
        }
        // Base corners on the seam and the boundary keep their UVs; the children of base
        // corner c at level L start with corner 4^L c.
        let seam_or_boundary = |v: u32| [0, 3, 6].contains(&(v % 7)) || !(7..28).contains(&v);
        let mut moved = 0;
        for (c, &v) in grid.corners().iter().enumerate() {
            let child = got[c * per_face];
            assert_eq!(out.mesh.corners()[c * per_face], v);
            if seam_or_boundary(v) {
                assert_eq!(child, uvs[c], "levels {levels} corner {c} at vertex {v}");
            } else {
                moved += (child.distance(uvs[c]) > 1e-4) as usize;
            }
        }
        assert_eq!(moved, 12 * 4, "levels {levels}: every corner of the 12 inner vertices moves");
    }
}

#[test]
fn uv_limits_are_the_same_from_every_level() {
    // Smooth UVs reach the same limit from levels 1 to 4 (the limit mask is an eigenvector
    // of the refinement), at valence 3, 5 and n-gon centres of the star prism.
    let mesh = hard_meshes::star_prism();
    let uvs = per_vertex(&mesh, |p| Vec2::new(p.x * p.y + p.z, (p.y * 3.0).sin()));
    let (_, first) = with_uvs(&mesh, 1, true, UvSmooth::PreserveBoundaries, &uvs);
    for levels in 2..=4 {
        let (_, got) = with_uvs(&mesh, levels, true, UvSmooth::PreserveBoundaries, &uvs);
        let step = 4usize.pow(levels - 1);
        for (c, &uv) in first.iter().enumerate() {
            assert!(uv.distance(got[c * step]) < 1e-5, "level {levels} corner {c}: {uv} vs {}", got[c * step]);
        }
    }
}

#[test]
fn linear_uvs_are_bilinear() {
    // 'NONE': face points are the centroids of the face's UVs, edge points the midpoints,
    // corners stay; per-corner random UVs on triangles, quads and a hexagon.
    let mesh = hard_meshes::star_prism();
    let mut rng = Rng(9);
    let uvs: Vec<Vec2> = (0..mesh.corners().len()).map(|_| Vec2::new(rng.uniform() as f32, rng.uniform() as f32)).collect();
    for limit in [false, true] {
        let (_, got) = with_uvs(&mesh, 1, limit, UvSmooth::Linear, &uvs);
        for (f, face) in mesh.faces().enumerate() {
            let first: usize = mesh.face_sizes()[..f].iter().map(|&k| k as usize).sum();
            let n = face.len();
            let centre = uvs[first..first + n].iter().sum::<Vec2>() / n as f32;
            for k in 0..n {
                let (c, next) = (first + k, first + (k + 1) % n);
                let quad = &got[4 * c..4 * c + 4];
                assert!(quad[0].distance(uvs[c]) < 1e-6 && quad[1].distance((uvs[c] + uvs[next]) * 0.5) < 1e-6 && quad[2].distance(centre) < 1e-6);
            }
        }
    }
}

#[test]
fn refuses_bad_uvs() {
    let cube = fixtures::cube();
    let options = Options::default();
    let short = vec![Vec2::ZERO; 23];
    assert!(matches!(subdivide_with_uvs(&cube, &options, UvSmooth::default(), &[&short]), Err(Error::InvalidParameter(m)) if m.contains("23 UVs")));
    let mut nan = vec![Vec2::ZERO; 24];
    nan[7].y = f32::NAN;
    assert!(matches!(subdivide_with_uvs(&cube, &options, UvSmooth::default(), &[&nan]), Err(Error::InvalidParameter(m)) if m.contains("corner 7")));
    assert!(UvSmooth::parse("SMOOTH_ALL").is_err() && UvSmooth::parse("NONE") == Ok(UvSmooth::Linear));
}
