//! Test meshes shared by the unit tests, the renderer's tests and the benches
//! (examples): spheres, planes, closed shapes with concavities, an open saddle, the
//! bunny. Not part of the stable API: behind the `test-support` feature, not in the
//! release library.

use crate::mesh::obj::parse_obj;
use crate::Mesh;
use glam::Vec3;
use std::collections::HashMap;

/// Icosahedron subdivided `level` times, projected onto the unit sphere.
pub fn icosphere(level: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut p: Vec<Vec3> = [
        [-1., t, 0.],
        [1., t, 0.],
        [-1., -t, 0.],
        [1., -t, 0.],
        [0., -1., t],
        [0., 1., t],
        [0., -1., -t],
        [0., 1., -t],
        [t, 0., -1.],
        [t, 0., 1.],
        [-t, 0., -1.],
        [-t, 0., 1.],
    ]
    .iter()
    .map(|a| Vec3::from_array(*a).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = HashMap::new();
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut m = |a: u32, b: u32, p: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                p.len() as u32 - 1
            })
        };
        for [a, b, c] in tris {
            let (ab, bc, ca) = (m(a, b, &mut p), m(b, c, &mut p), m(c, a, &mut p));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    Mesh::from_triangles(p, &tris).expect("valid icosphere")
}

/// A closed, star-shaped "head": an icosphere with smooth bumps and dents (concave
/// regions, no self-intersection since the radius stays positive along every ray).
pub fn bumpy_head(level: u32) -> Mesh {
    let s = icosphere(level);
    let p = s
        .positions()
        .iter()
        .map(|d| {
            let r = 1.0 + 0.18 * (3.0 * d.x).sin() * (2.0 * d.y + 0.5).cos() + 0.12 * (4.0 * d.z).cos() * d.y
                - 0.25 * (-((*d - Vec3::new(0.0, 0.3, 0.95).normalize()).length_squared()) * 6.0).exp();
            *d * Vec3::new(1.0, 1.15, 0.9) * r
        })
        .collect();
    let tris: Vec<[u32; 3]> = s.faces().map(|f| [f[0], f[1], f[2]]).collect();
    Mesh::from_triangles(p, &tris).expect("valid head")
}

/// An open `n x n` quad grid spanning `[-1, 1]²` with heights `z(x, y)`.
pub fn height_grid(n: u32, z: impl Fn(f32, f32) -> f32) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (2.0 * i as f32 / n as f32 - 1.0, 2.0 * j as f32 / n as f32 - 1.0);
            positions.push(Vec3::new(x, y, z(x, y)));
        }
    }
    let mut corners = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            corners.extend([a, a + 1, a + n + 2, a + n + 1]);
        }
    }
    Mesh::new(positions, &vec![4; (n * n) as usize], corners, None).expect("valid grid")
}

/// Flat open plane.
pub fn plane(n: u32) -> Mesh {
    height_grid(n, |_, _| 0.0)
}

/// Open saddle sheet `z = x² - y²`.
pub fn saddle(n: u32) -> Mesh {
    height_grid(n, |x, y| x * x - y * y)
}

/// Closed quad surface of a set of unit voxels (`filled(i, j, k)` on an
/// `nx x ny x nz` grid), each voxel face split into `sub x sub` quads.
pub fn voxels(dims: [i32; 3], sub: u32, filled: impl Fn(i32, i32, i32) -> bool) -> Mesh {
    let f = |c: [i32; 3]| (0..3).all(|a| c[a] >= 0 && c[a] < dims[a]) && filled(c[0], c[1], c[2]);
    let s = sub as i32;
    let mut index: HashMap<[i32; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut corners = Vec::new();
    let mut vid = |q: [i32; 3], positions: &mut Vec<Vec3>| -> u32 {
        *index.entry(q).or_insert_with(|| {
            positions.push(Vec3::new(q[0] as f32, q[1] as f32, q[2] as f32) / s as f32);
            positions.len() as u32 - 1
        })
    };
    for i in 0..dims[0] {
        for j in 0..dims[1] {
            for k in 0..dims[2] {
                let c = [i, j, k];
                if !f(c) {
                    continue;
                }
                for a in 0..3 {
                    for sign in [1, -1] {
                        let mut nb = c;
                        nb[a] += sign;
                        if f(nb) {
                            continue;
                        }
                        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
                        let mut base = [c[0] * s, c[1] * s, c[2] * s];
                        if sign > 0 {
                            base[a] += s;
                        }
                        for du in 0..s {
                            for dv in 0..s {
                                let at = |x: i32, y: i32| {
                                    let mut q = base;
                                    q[u] += x;
                                    q[v] += y;
                                    q
                                };
                                let mut quad = [at(du, dv), at(du + 1, dv), at(du + 1, dv + 1), at(du, dv + 1)];
                                if sign < 0 {
                                    quad.reverse();
                                }
                                for q in quad {
                                    corners.push(vid(q, &mut positions));
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    let n = corners.len() / 4;
    Mesh::new(positions, &vec![4; n], corners, None).expect("valid voxel mesh")
}

/// A 10 x 6 x 6 box with a deep narrow notch (1 wide, 4 deep) cut from the top.
pub fn notched_box(sub: u32) -> Mesh {
    voxels([10, 6, 6], sub, |i, j, _| !(i == 5 && j >= 2))
}

/// A comb: a base bar with five 1-wide fins 2 apart (closer than twice the shell
/// thickness used in the tests).
pub fn comb(sub: u32) -> Mesh {
    voxels([13, 6, 4], sub, |i, j, _| j == 0 || i % 3 == 0)
}

/// Path of the bundled bunny scan.
pub fn bunny_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/bunny-3k.obj")
}

/// The bundled bunny scan (1839 vertices, closed).
pub fn bunny() -> Mesh {
    let text = std::fs::read_to_string(bunny_path()).expect("tests/data/bunny-3k.obj");
    parse_obj(&text).expect("valid bunny")
}

/// Splits every triangle into four at edge midpoints (flat; triangles only).
pub fn subdivide(mesh: &Mesh) -> Mesh {
    let mut p = mesh.positions().to_vec();
    let mut mid = HashMap::new();
    let mut m = |a: u32, b: u32, p: &mut Vec<Vec3>| -> u32 {
        *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
            p.push((p[a as usize] + p[b as usize]) * 0.5);
            p.len() as u32 - 1
        })
    };
    let mut tris = Vec::new();
    for [a, b, c] in mesh.triangulate().triangles {
        let (ab, bc, ca) = (m(a, b, &mut p), m(b, c, &mut p), m(c, a, &mut p));
        tris.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
    }
    Mesh::from_triangles(p, &tris).expect("valid subdivision")
}
