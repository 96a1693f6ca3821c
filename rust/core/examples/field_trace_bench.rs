//! Sphere-traces issue 17's 20-node soft-CSG tree (`implicit::samples::SOFT_CSG_20`) at
//! 512x512 (and any other `--sizes`) with a perspective camera framing it: the minimum
//! and median of several runs, and the share of pixels hit. The target is
//! under a second at 512x512.
//!
//! `cargo run --release -p thicket-core --example field_trace_bench [-- --runs N --sizes 512,1024]`

use std::time::Instant;
use thicket_core::glam::{DMat4, DVec3};
use thicket_core::implicit::samples::SOFT_CSG_20;
use thicket_core::implicit::trace::{render, Camera};
use thicket_core::implicit::FieldTree;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| args.iter().position(|a| a == name).map(|i| args[i + 1].clone());
    let runs: usize = arg("--runs").map_or(5, |r| r.parse().unwrap());
    let sizes: Vec<u32> = arg("--sizes").map_or(vec![512], |r| r.split(',').map(|s| s.parse().unwrap()).collect());
    let tree = FieldTree::from_json(SOFT_CSG_20).unwrap();
    println!(
        "{} threads; a soft-CSG tree of 20 nodes, {} primitives, Lipschitz bound {}",
        rayon::current_num_threads(),
        tree.primitive_count(),
        tree.lipschitz()
    );
    // From above and to the side, the whole tree in view (a 40-degree lens).
    let view = DMat4::look_at_rh(DVec3::new(2.2, -2.6, 1.8), DVec3::ZERO, DVec3::Z);
    for size in sizes {
        let camera = Camera { view, projection: DMat4::perspective_rh_gl(40f64.to_radians(), 1.0, 0.1, 100.0), width: size, height: size };
        let mut times = Vec::new();
        let mut hit = 0.0;
        for _ in 0..runs {
            let start = Instant::now();
            let out = render(&tree, &camera).unwrap();
            times.push(start.elapsed().as_secs_f64() * 1e3);
            hit = out.hits.iter().filter(|h| h.is_some()).count() as f64 / out.hits.len() as f64;
        }
        times.sort_by(f64::total_cmp);
        println!("{size}x{size}: min {:7.1} ms, median {:7.1} ms; {:.0}% of pixels hit", times[0], times[times.len() / 2], 100.0 * hit);
    }
}
