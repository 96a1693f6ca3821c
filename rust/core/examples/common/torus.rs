//! A torus of quads for benchmarks and tests (shared by `examples/detail_bench.rs` and
//! `tests/analysis_memory.rs` through `#[path]`).

use thicket_core::glam::Vec3;
use thicket_core::Mesh;

/// `major` x `minor` quads wound outward, major radius 1 and minor radius `thickness`
/// (Blender's `primitive_torus_add(major_segments=200, minor_segments=150)` is
/// `torus(200, 150, 0.25)`); all vertices regular.
pub fn torus(major: u32, minor: u32, thickness: f32) -> Mesh {
    let mut p = Vec::new();
    for i in 0..major {
        let u = i as f32 / major as f32 * std::f32::consts::TAU;
        for j in 0..minor {
            let v = j as f32 / minor as f32 * std::f32::consts::TAU;
            let r = 1.0 + thickness * v.cos();
            p.push(Vec3::new(r * u.cos(), r * u.sin(), thickness * v.sin()));
        }
    }
    let at = |i: u32, j: u32| (i % major) * minor + j % minor;
    let corners: Vec<u32> = (0..major).flat_map(|i| (0..minor).flat_map(move |j| [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)])).collect();
    Mesh::new(p, &vec![4; (major * minor) as usize], corners, None).unwrap()
}
