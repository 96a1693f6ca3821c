//! `make bench`: issue 17's 20-node soft-CSG tree (`implicit::samples::SOFT_CSG_20`)
//! sphere-traced at 512x512 by the CPU tracer and by the GPU tracer
//! (`thicket_render::field`, on whatever adapter is present: lavapipe without a GPU),
//! the median of `--runs` frames on the CPU (3) and, on the GPU, the first frame (its
//! first-use costs included) timed apart, then the median of `--gpu-runs` warm frames
//! (9) on a hardware adapter; on a software adapter (lavapipe: about 10 s a frame on 2
//! cores) the first frame alone. The device and pipeline are made before; the ratio is
//! of the warm GPU frame (the first on software) to the CPU's.
//!
//! `cargo run --release -p thicket-render --example field_trace_gpu_bench [-- --runs N --gpu-runs M]`

use std::time::Instant;
use thicket_core::glam::{DMat4, DVec3};
use thicket_core::implicit::samples::SOFT_CSG_20;
use thicket_core::implicit::trace::{render, Camera};
use thicket_core::implicit::FieldTree;
use thicket_render::field::FieldTracer;

fn median_ms(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str, default: usize| args.iter().position(|a| a == name).map_or(default, |i| args[i + 1].parse().unwrap());
    let (runs, gpu_runs) = (arg("--runs", 3), arg("--gpu-runs", 9).max(1));
    let tree = FieldTree::from_json(SOFT_CSG_20).unwrap();
    let view = DMat4::look_at_rh(DVec3::new(2.2, -2.6, 1.8), DVec3::ZERO, DVec3::Z);
    let camera = Camera { view, projection: DMat4::perspective_rh_gl(40f64.to_radians(), 1.0, 0.1, 100.0), width: 512, height: 512 };
    let cpu = median_ms(runs, || {
        render(&tree, &camera).unwrap();
    });
    let tracer = match FieldTracer::new() {
        Ok(t) => t,
        Err(e) => {
            println!("field trace 512x512, 20-node tree: CPU {cpu:.1} ms; no GPU tracer ({e})");
            return;
        }
    };
    let frame = || {
        tracer.render(&tree, &camera).unwrap();
    };
    let first = median_ms(1, frame);
    let software = tracer.is_software();
    let (gpu, warm) = if software {
        (first, "first frame only: software adapter".to_string())
    } else {
        (median_ms(gpu_runs, frame), format!("median of {gpu_runs} warm frames"))
    };
    println!(
        "field trace 512x512, 20-node tree ({} threads): CPU {cpu:.1} ms, GPU {gpu:.1} ms ({warm}; first frame {first:.1} ms) on {}; GPU/CPU {:.2}",
        rayon::current_num_threads(),
        tracer.adapter_name(),
        gpu / cpu
    );
}
