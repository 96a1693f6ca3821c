//! Per-stage times of shell builds on public scans (issue 14's speed target: a
//! 26k-vertex scan with thin parts in 0.5 s on 2 cores), with the machine's load:
//! `cargo run --release -p thicket-core --example shell_stages -- [mesh.obj ...]
//! [--runs N] [--cases exterior:0.1,interior:0.05] [--edits N] [--no-medial-stop]` (default /tmp/pub/{beast,homer,spot,cheburashka,fandisk}.obj),
//! exterior 10% and interior 5% of the bounding-box diagonal. Prints the build time
//! (wall and the process's CPU seconds, which a loaded machine disturbs less), its
//! stages ([`thicket_core::shell::timing`]; the tracing and the checker run side by
//! side, the untangle's sub-stages are inside it) with the exact triangle tests run
//! in each and the work counters (`#`), the repair's rounds and the shell report
//! (defects, thickness ratios), timed apart. Then, unless `--edits 0`, local edits
//! of an [`IncrementalShell`] (issue 14's target: 50 ms each): `--edits N` (3 by
//! default) times ~20 vertices around a vertex moved along their normals by 0.5% of
//! the diagonal, each update timed with its stages, and the report after the last.

use std::time::Instant;
use thicket_core::shell::incremental::IncrementalShell;
use thicket_core::shell::report::shell_report;
use thicket_core::shell::{build_shell, timing, ShellParams, Side, Thickness};
use thicket_core::Mesh;

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
    let mut edits = 3;
    if let Some(i) = args.iter().position(|a| a == "--edits") {
        edits = args.get(i + 1).and_then(|n| n.parse().ok()).expect("--edits N");
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
                timing::take_exact();
                let (start, cpu_start) = (Instant::now(), timing::cpu_seconds());
                let shell = build_shell(&mesh, &t, side, &params).unwrap();
                let (seconds, cpu_seconds) = (start.elapsed().as_secs_f64(), timing::cpu_seconds() - cpu_start);
                let stages = timing::summed(&timing::take());
                let cpu = timing::summed(&timing::take_cpu());
                let exact = timing::summed(&timing::take_exact());
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
                print_stages(&stages, &cpu, &exact);
            }
            if edits > 0 {
                edit_locally(&mesh, &t, side, &params, edits);
            }
        }
    }
}

/// One line per stage: wall and CPU seconds, exact tests, how often it ran; a
/// counter's sum.
fn print_stages(stages: &[(&'static str, f64, usize)], cpu: &[(&'static str, f64, usize)], exact: &[(&'static str, f64, usize)]) {
    for &(stage, s, n) in stages {
        match cpu.iter().find(|c| c.0 == stage) {
            Some(c) => {
                let tests = exact.iter().find(|c| c.0 == stage).map_or(0.0, |e| e.1);
                println!("    {stage:<28} {s:8.3} s, cpu {:7.3} s, {:6.2} M exact tests  ({n}x)", c.1, tests * 1e-6);
            }
            None => println!("    {stage:<28} {s:8.0}              ({n}x)"),
        }
    }
}

/// `edits` local edits of an incremental shell of `mesh`: each moves the ~20
/// vertices nearest (in rings) to a vertex spread over the mesh along their normals
/// by 0.5% of the diagonal, and is timed (wall, CPU) with its stages.
fn edit_locally(mesh: &Mesh, t: &[f32], side: Side, params: &ShellParams, edits: usize) {
    let start = Instant::now();
    let mut inc = IncrementalShell::new(mesh.clone(), t.to_vec(), side, params.clone()).unwrap();
    println!("  incremental shell built in {:.3} s", start.elapsed().as_secs_f64());
    let n = mesh.vertex_count();
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); n];
    for face in mesh.faces() {
        for (k, &a) in face.iter().enumerate() {
            let b = face[(k + 1) % face.len()];
            around[a as usize].push(b);
            around[b as usize].push(a);
        }
    }
    let diag = mesh.bbox_diagonal();
    for e in 0..edits {
        // Rings around a seed until at least 20 vertices.
        let seed = ((e as u64 * 2654435761 + 12345) % n as u64) as u32;
        let mut picked = vec![seed];
        let mut seen = vec![false; n];
        seen[seed as usize] = true;
        let mut ring = vec![seed];
        while picked.len() < 20 && !ring.is_empty() {
            let next: Vec<u32> = ring.iter().flat_map(|&v| around[v as usize].clone()).filter(|&u| !std::mem::replace(&mut seen[u as usize], true)).collect();
            picked.extend(&next);
            ring = next;
        }
        let normals = thicket_core::mesh::vertex_normals(inc.mesh());
        let mut positions = inc.mesh().positions().to_vec();
        picked.iter().for_each(|&v| positions[v as usize] += normals[v as usize] * (0.005 * diag));
        let thickness = inc.thickness().to_vec();
        timing::take();
        timing::take_cpu();
        timing::take_exact();
        let (start, cpu_start) = (Instant::now(), timing::cpu_seconds());
        let stats = inc.update(&positions, &thickness).unwrap();
        let (seconds, cpu_seconds) = (start.elapsed().as_secs_f64(), timing::cpu_seconds() - cpu_start);
        let shell = inc.shell();
        println!(
            "  edit {e}: {} vertices moved: {:.1} ms, cpu {:.1} ms [load {}]; {stats:?}; rounds {} + check {}, clean {}",
            picked.len(),
            1e3 * seconds,
            1e3 * cpu_seconds,
            load(),
            shell.check.rounds,
            shell.check.check_rounds,
            shell.check.clean
        );
        let (stages, cpu, exact) = (timing::summed(&timing::take()), timing::summed(&timing::take_cpu()), timing::summed(&timing::take_exact()));
        print_stages(&stages, &cpu, &exact);
    }
    let r = shell_report(inc.mesh(), inc.shell());
    println!(
        "  after {edits} edits: defects {:?}; ratio min {:.3} mean {:.4}",
        (r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells),
        r.min_ratio,
        r.mean_ratio
    );
}
