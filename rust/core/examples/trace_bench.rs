//! Times the tracing of the shell directors alone (chapter 4.4; no repair, no check)
//! on OBJ files or, without one, on `shell_bench`'s subdivided bunny: the minimum of
//! `--runs` runs, and with `--save FILE` / `--compare FILE` the directors written or
//! compared with an earlier run's (max and mean |difference| / target), to check that
//! a faster tracer traces the same directors.
//!
//! `cargo run --release -p thicket-core --features test-support --example trace_bench --
//! [mesh.obj] [--side exterior:0.1] [--runs 3] [--save f | --compare f]`

use std::time::Instant;
use thicket_core::glam::Vec3;
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
use thicket_core::testmeshes;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |name: &str| args.iter().position(|a| a == name).map(|i| args[i + 1].clone());
    let runs: usize = arg("--runs").map_or(3, |r| r.parse().unwrap());
    let (side, fraction) = arg("--side").map_or((Side::Exterior, 0.1), |s| {
        let (side, f) = s.split_once(':').expect("side:fraction");
        (Side::parse(side).unwrap(), f.parse().expect("a fraction"))
    });
    let path = args.first().filter(|a| !a.starts_with("--"));
    let mesh = match path {
        Some(p) => thicket_core::mesh::obj::parse_obj(&std::fs::read_to_string(p).expect("readable OBJ")).expect("valid OBJ"),
        None => testmeshes::subdivide(&testmeshes::subdivide(&testmeshes::bunny())),
    };
    let t = Thickness::relative(fraction).per_vertex(&mesh, None).unwrap();
    // No repair: the traced directors alone.
    let params = ShellParams { repair_rounds: 0, ..ShellParams::default() };
    let mut best = f64::INFINITY;
    let mut directors = Vec::new();
    for _ in 0..runs {
        let start = Instant::now();
        directors = build_shell(&mesh, &t, side, &params).unwrap().directors;
        best = best.min(start.elapsed().as_secs_f64());
    }
    let n = mesh.vertex_count();
    println!(
        "{}: {n} vertices, {side:?} {:.0}%, {} threads; tracing {best:.3} s ({:.1} us per vertex and thread)",
        path.map_or("subdivided bunny", |p| p.as_str()),
        100.0 * fraction,
        rayon::current_num_threads(),
        best * 1e6 * rayon::current_num_threads() as f64 / n as f64
    );
    let flat: Vec<f32> = directors.iter().flat_map(|d| d.to_array()).collect();
    if let Some(file) = arg("--save") {
        std::fs::write(file, flat.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    }
    if let Some(file) = arg("--compare") {
        let bytes = std::fs::read(file).unwrap();
        let old: Vec<Vec3> = bytes
            .chunks_exact(12)
            .map(|c| Vec3::from_slice(&c.chunks_exact(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect::<Vec<_>>()))
            .collect();
        assert_eq!(old.len(), n, "the saved directors are for another mesh");
        let diff: Vec<f32> = (0..n).map(|v| if t[v] > 0.0 { (directors[v] - old[v]).length() / t[v].abs() } else { 0.0 }).collect();
        let max = diff.iter().copied().fold(0.0f32, f32::max);
        let mean = diff.iter().sum::<f32>() / n as f32;
        let over = |x: f32| diff.iter().filter(|d| **d > x).count();
        println!("directors vs saved: max |difference| / target {max:.4}, mean {mean:.2e}; over 1%: {}, over 5%: {}", over(0.01), over(0.05));
    }
}
