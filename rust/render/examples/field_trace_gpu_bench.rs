//! `make bench`: issue 17's 20-node soft-CSG tree (`implicit::samples::SOFT_CSG_20`)
//! sphere-traced at 512x512 by the CPU tracer and by the GPU tracer
//! (`thicket_render::field`, on whatever adapter is present: lavapipe without a GPU),
//! the median of `--runs` frames on the CPU (3) and, on the GPU, the first frame (its
//! first-use costs and buffers included) timed apart, then the median of `--gpu-runs`
//! warm frames (9 on a hardware adapter, 1 on a software one: lavapipe takes seconds a
//! frame on 2 cores). A GPU frame is `FieldTracer::render_rgba`, what
//! `thicket_native.field_render` asks for (colours only); the warm median's frame is
//! split into prepare (program, uniform), GPU (submit to done: the trace and the copy
//! to the readback buffer) and readback (map, unpack), and the full frame (depths and
//! normals too, `FieldTracer::render`) is timed once warm. The device and pipeline are
//! made before; the ratio is of the warm GPU frame to the CPU's.
//!
//! `cargo run --release -p thicket-render --example field_trace_gpu_bench [-- --runs N --gpu-runs M]`

use std::time::Instant;
use thicket_core::glam::{DMat4, DVec3};
use thicket_core::implicit::samples::SOFT_CSG_20;
use thicket_core::implicit::trace::{render, Camera};
use thicket_core::implicit::FieldTree;
use thicket_render::field::FieldTracer;

fn median_ms(runs: usize, mut f: impl FnMut()) -> f64 {
    median_of(runs, || {
        let start = Instant::now();
        f();
        (start.elapsed().as_secs_f64() * 1e3, ())
    })
    .0
}

/// The median by the first element of `runs` results of `f`, with its second.
fn median_of<T: Copy>(runs: usize, mut f: impl FnMut() -> (f64, T)) -> (f64, T) {
    let mut times: Vec<(f64, T)> = (0..runs).map(|_| f()).collect();
    times.sort_by(|a, b| a.0.total_cmp(&b.0));
    times[times.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str, default: usize| args.iter().position(|a| a == name).map_or(default, |i| args[i + 1].parse().unwrap());
    let runs = arg("--runs", 3);
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
    let software = tracer.is_software();
    let gpu_runs = arg("--gpu-runs", if software { 1 } else { 9 }).max(1);
    let frame = || {
        let start = Instant::now();
        tracer.render_rgba(&tree, &camera).unwrap();
        (start.elapsed().as_secs_f64() * 1e3, tracer.last_times().unwrap())
    };
    let (first, first_times) = median_of(1, frame);
    let (gpu, times) = median_of(gpu_runs, frame);
    let full = median_ms(1, || {
        tracer.render(&tree, &camera).unwrap();
    });
    println!(
        "field trace 512x512, 20-node tree ({} threads): CPU {cpu:.1} ms, GPU {gpu:.1} ms (median of {gpu_runs} warm frames: prepare {:.2}, GPU {:.1}, readback {:.2}; allocated: {}) on {}; GPU/CPU {:.3}",
        rayon::current_num_threads(),
        times.prepare,
        times.gpu,
        times.readback,
        times.allocated,
        tracer.adapter_name(),
        gpu / cpu
    );
    println!(
        "  first frame {first:.1} ms (prepare {:.2}, GPU {:.1}, readback {:.2}); a warm full frame (depths and normals too) {full:.1} ms",
        first_times.prepare, first_times.gpu, first_times.readback
    );
}
