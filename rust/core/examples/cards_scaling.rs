//! Scaling of shells on meshes made of many small separate pieces (foliage cards,
//! scattered debris): `n` random quads of about one unit, each its own component, at
//! constant density, one in five close to another ([`cards`]). Prints, per `n`, the time of the
//! traced shell alone (`repair_rounds: 0`: tree build and tracing) and of the full
//! build (trace, repair, restore), and how much thickness the shell kept.
//!
//! `cargo run -p thicket-core --release --features test-support --example cards_scaling -- [options]`
//!
//! - `--big`: also 100,000 cards.
//! - `--n 1000,4000`: these counts instead.
//! - `--abs 0.1`: absolute thickness (default 0.1, a tenth of a card).
//! - `--rel 0.01`: relative thickness (share of the bbox diagonal) instead.
//! - `--side envelope`: shell side (default exterior).
//! - `--trace-only`: skip the full build.

use std::time::Instant;
use thicket_core::hard_meshes::cards;
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let mut counts: Vec<usize> = match value("--n") {
        Some(list) => list.split(',').map(|s| s.trim().parse().expect("--n takes counts")).collect(),
        None => vec![1000, 2000, 4000, 8000, 16000],
    };
    if args.iter().any(|a| a == "--big") {
        counts.push(100_000);
    }
    let rel: Option<f32> = value("--rel").map(|s| s.parse().expect("--rel takes a number"));
    let abs: f32 = value("--abs").map_or(0.1, |s| s.parse().expect("--abs takes a number"));
    let side = value("--side").map_or(Side::Exterior, |s| Side::parse(&s).unwrap());
    let trace_only = args.iter().any(|a| a == "--trace-only");
    match rel {
        Some(r) => println!("{} threads, thickness {r} of the diagonal, side {side:?}", rayon::current_num_threads()),
        None => println!("{} threads, thickness {abs}, side {side:?}", rayon::current_num_threads()),
    }
    println!("{:>7} {:>8} {:>8} {:>9} {:>9} {:>9} {:>7} {:>7} {:>6}", "cards", "faces", "diag", "thick", "trace s", "full s", "repair", "check", "mean");
    for n in counts {
        let mesh = cards(n, 0x5eed ^ n as u64);
        let rule = rel.map_or(Thickness::absolute(abs), Thickness::relative);
        let t = rule.per_vertex(&mesh, None).unwrap();
        let start = Instant::now();
        let traced = build_shell(&mesh, &t, side, &ShellParams { repair_rounds: 0, ..Default::default() }).unwrap();
        let trace = start.elapsed().as_secs_f64();
        let ratio = |s: &thicket_core::shell::Shell| s.achieved.iter().zip(&s.target).map(|(a, t)| (a / t) as f64).sum::<f64>() / s.target.len() as f64;
        let (full, rounds, checks, mean) = if trace_only {
            (f64::NAN, 0, 0, ratio(&traced))
        } else {
            let start = Instant::now();
            let shell = build_shell(&mesh, &t, side, &ShellParams::default()).unwrap();
            (start.elapsed().as_secs_f64(), shell.check.rounds, shell.check.check_rounds, ratio(&shell))
        };
        println!(
            "{n:>7} {:>8} {:>8.1} {:>9.2} {trace:>9.3} {full:>9.3} {rounds:>7} {checks:>7} {mean:>6.3}",
            mesh.face_count(),
            mesh.bbox_diagonal(),
            t[0].abs(),
        );
    }
}
