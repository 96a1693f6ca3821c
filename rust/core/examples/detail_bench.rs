//! Issue 18's speed target for the procedural rock: level 4 on Blender's default-radius
//! torus of 200 x 150 quads (30k faces, 7.7 M at level 4) under 2 s, beside plain
//! subdivision to the same level, with the peak heap of each (bytes per output face).
//! `cargo run --release -p thicket-core --example detail_bench [-- --runs N]`

#[path = "common/counting_alloc.rs"]
mod counting_alloc;
#[path = "common/torus.rs"]
mod torus;
use torus::torus;

use std::time::Instant;
use thicket_core::subdivision::detail::{procedural_detail, Model};
use thicket_core::subdivision::{subdivide, Boundary, Options};
use thicket_core::Mesh;

/// The process's CPU seconds (user and system, all threads), from /proc/self/stat: with
/// the machine shared, a figure the other load inflates less than the wall clock.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(f64::NAN);
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let runs = args.iter().position(|a| a == "--runs").map_or(3, |i| args[i + 1].parse().unwrap());
    let base = torus(200, 150, 0.25);
    println!(
        "Procedural rock at level 4 vs plain subdivision to level 4, torus of {} quads, {} threads (target: rock under 2 s)",
        base.face_count(),
        rayon::current_num_threads()
    );
    let options = Options { levels: 4, limit: false, boundary: Boundary::SmoothAll };
    let rock = Model::Rock { amplitude: 0.02 };
    let calls: [(&str, &dyn Fn() -> Mesh); 2] =
        [("subdivide", &|| subdivide(&base, &options).unwrap().mesh), ("rock", &|| procedural_detail(&base, 4, &rock, 1).unwrap().mesh)];
    for (label, call) in calls {
        let (mut best, mut best_cpu) = (f64::INFINITY, f64::INFINITY);
        let mut peak = 0;
        let mut faces = 0;
        for _ in 0..runs {
            let (start, cpu) = (Instant::now(), cpu_seconds());
            let (out, bytes) = counting_alloc::peak_bytes(call);
            best = best.min(start.elapsed().as_secs_f64());
            best_cpu = best_cpu.min(cpu_seconds() - cpu);
            peak = bytes;
            faces = out.face_count();
        }
        println!(
            "  {label:10} {faces:9} faces  best of {runs}: {best:5.2} s ({best_cpu:5.2} s of CPU), peak heap {:5.0} MB ({:4.0} bytes per face)",
            peak as f64 / 1e6,
            peak as f64 / faces as f64
        );
    }
}
