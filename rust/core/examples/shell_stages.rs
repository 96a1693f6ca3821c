//! Per-stage times of shell builds on public scans (issue 14's speed target: a
//! 26k-vertex scan with thin parts in 0.5 s on 2 cores), with the machine's load:
//! `cargo run --release -p thicket-core --example shell_stages -- [mesh.obj ...]
//! [--runs N] [--cases exterior:0.1,interior:0.05] [--no-medial-stop]` (default /tmp/pub/{beast,homer,spot,cheburashka,fandisk}.obj),
//! exterior 10% and interior 5% of the bounding-box diagonal. Prints the build time
//! (wall and the process's CPU seconds, which a loaded machine disturbs less), its
//! stages ([`thicket_core::shell::timing`]; the tracing and the checker run side by
//! side, the untangle's sub-stages are inside it) with their work counters (`#`),
//! the repair's rounds and the shell report (defects, thickness ratios), timed apart.

use std::time::Instant;
use thicket_core::shell::report::shell_report;
use thicket_core::shell::{build_shell, timing, ShellParams, Side, Thickness};

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg").map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" ")).unwrap_or_default()
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut runs = 1;
    if let Some(i) = args.iter().position(|a| a == "--runs") {
        runs = args.get(i + 1).and_then(|n| n.parse().ok()).expect("--runs N");
        args.drain(i..i + 2);
    }
    if args.is_empty() {
        args = ["beast", "homer", "spot", "cheburashka", "fandisk"].iter().map(|m| format!("/tmp/pub/{m}.obj")).collect();
    }
    println!("{} threads, load {}", rayon::current_num_threads(), load());
    timing::enable(true);
    // `--no-medial-stop`: the traced directors go to the repair unbounded (as before
    // the medial stop), to compare the two in one binary.
    let medial_stop = match args.iter().position(|a| a == "--no-medial-stop") {
        Some(i) => {
            args.remove(i);
            false
        }
        None => true,
    };
    // `--cases exterior:0.1,exterior:0.2,interior:0.05` (the default: exterior 10% and
    // interior 5%).
    let mut cases = vec![(Side::Exterior, 0.1f32), (Side::Interior, 0.05)];
    if let Some(i) = args.iter().position(|a| a == "--cases") {
        let list = args.get(i + 1).expect("--cases side:fraction,...").clone();
        cases = list
            .split(',')
            .map(|c| {
                let (side, f) = c.split_once(':').expect("side:fraction");
                (Side::parse(side).expect("a side"), f.parse().expect("a fraction"))
            })
            .collect();
        args.drain(i..i + 2);
    }
    let params = ShellParams { medial_stop, ..ShellParams::default() };
    for path in &args {
        let Ok(text) = std::fs::read_to_string(path) else {
            println!("{path}: not readable, skipped");
            continue;
        };
        let mesh = thicket_core::mesh::obj::parse_obj(&text).expect("valid OBJ");
        for &(side, fraction) in &cases {
            let t = Thickness::relative(fraction).per_vertex(&mesh, None).unwrap();
            for run in 0..runs {
                timing::take();
                timing::take_cpu();
                let (start, cpu_start) = (Instant::now(), timing::cpu_seconds());
                let shell = build_shell(&mesh, &t, side, &params).unwrap();
                let (seconds, cpu_seconds) = (start.elapsed().as_secs_f64(), timing::cpu_seconds() - cpu_start);
                let stages = timing::summed(&timing::take());
                let cpu = timing::summed(&timing::take_cpu());
                let start = Instant::now();
                let r = shell_report(&mesh, &shell);
                let report = start.elapsed().as_secs_f64();
                let name = std::path::Path::new(path).file_stem().unwrap().to_string_lossy();
                println!(
                    "{name} ({} v) {side:?} {:.0}% run {run}: {seconds:.3} s, cpu {cpu_seconds:.2} s [load {}]; rounds {} + check {}; defects {:?}; ratio min {:.3} mean {:.4}; compressed {}; normal room {} at 95%: {:.3}; report {report:.3} s",
                    mesh.vertex_count(),
                    100.0 * fraction,
                    load(),
                    shell.check.rounds,
                    shell.check.check_rounds,
                    (r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells),
                    r.min_ratio,
                    r.mean_ratio,
                    r.compressed_vertices,
                    r.normal_valid_vertices,
                    r.normal_valid_at_95,
                );
                for (stage, s, n) in stages {
                    match cpu.iter().find(|c| c.0 == stage) {
                        Some(c) => println!("    {stage:<28} {s:8.3} s, cpu {:7.2} s  ({n}x)", c.1),
                        None => println!("    {stage:<28} {s:8.0}              ({n}x)"),
                    }
                }
            }
        }
    }
}
