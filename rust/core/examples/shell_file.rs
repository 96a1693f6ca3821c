//! Times shells on any OBJ file (a user's scan, a subdivided test mesh) and prints
//! their reports: `cargo run --release -p thicket-core --example shell_file --
//! mesh.obj [exterior:0.1 interior:0.05 ...]` (side:thickness as a fraction of the
//! bounding-box diagonal; default exterior 10% and 20%, interior 5%). With `--edit`,
//! each shell then follows three edits (a smooth bump of 1% of the diagonal over 1%
//! of the vertices, out, in, out: the Blender benchmark's edit) incrementally, timed
//! beside a rebuild of the edited mesh.

use std::time::Instant;
use thicket_core::shell::incremental::IncrementalShell;
use thicket_core::shell::report::shell_report;
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    // --no-report: time the shells only (for profiling the build).
    let report = !args.iter().any(|a| a == "--no-report");
    let edit = args.iter().any(|a| a == "--edit");
    args.retain(|a| a != "--no-report" && a != "--edit");
    let path = args.first().expect("usage: shell_file mesh.obj [side:fraction ...]");
    let mesh = thicket_core::mesh::obj::parse_obj(&std::fs::read_to_string(path).expect("readable OBJ")).expect("valid OBJ");
    let mut runs: Vec<(Side, f32)> = args[1..]
        .iter()
        .map(|a| {
            let (side, f) = a.split_once(':').expect("side:fraction");
            let side = match side {
                "exterior" => Side::Exterior,
                "interior" => Side::Interior,
                "envelope" => Side::Envelope,
                _ => panic!("side is exterior, interior or envelope"),
            };
            (side, f.parse().expect("a fraction"))
        })
        .collect();
    if runs.is_empty() {
        runs = vec![(Side::Exterior, 0.1), (Side::Exterior, 0.2), (Side::Interior, 0.05)];
    }
    println!("{path}: {} vertices, {} faces, {} threads", mesh.vertex_count(), mesh.face_count(), rayon::current_num_threads());
    let params = ShellParams::default();
    for (side, fraction) in runs {
        let t = Thickness::relative(fraction).per_vertex(&mesh, None).unwrap();
        let start = Instant::now();
        let shell = build_shell(&mesh, &t, side, &params).unwrap();
        let seconds = start.elapsed().as_secs_f64();
        if edit {
            edits(&mesh, &t, side, &params);
        }
        if !report {
            println!("{side:?} {:.0}%: {seconds:.3} s", 100.0 * fraction);
            continue;
        }
        let start = Instant::now();
        let r = shell_report(&mesh, &shell);
        let checked = start.elapsed().as_secs_f64();
        println!(
            "{side:?} {:.0}%: {seconds:.3} s, report (the exact check and normal room) {checked:.3} s; defects (self, base, inverted) {:?}; ratio min {:.3} mean {:.3}; compressed {}; room along the normal: {} vertices, {:.3} of them at 95%",
            100.0 * fraction,
            (r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells),
            r.min_ratio,
            r.mean_ratio,
            r.compressed_vertices,
            r.normal_valid_vertices,
            r.normal_valid_at_95
        );
    }
}

/// Three bump edits followed by an incremental shell, each timed beside a rebuild.
fn edits(mesh: &thicket_core::Mesh, t: &[f32], side: Side, params: &ShellParams) {
    let n = mesh.vertex_count();
    if n == 0 {
        return;
    }
    let p = mesh.positions();
    let centre = p[n / 3];
    let distance: Vec<f32> = p.iter().map(|q| (*q - centre).length()).collect();
    let mut sorted = distance.clone();
    sorted.sort_by(f32::total_cmp);
    let rim = sorted[n / 100];
    let normals = thicket_core::mesh::vertex_normals(mesh);
    let diag = mesh.bbox_diagonal();
    let mut inc = IncrementalShell::new(mesh.clone(), t.to_vec(), side, params.clone()).unwrap();
    for step in 0..3 {
        let sign = if step % 2 == 0 { 1.0 } else { -1.0 };
        let moved: Vec<glam::Vec3> = (0..n)
            .map(|v| {
                let w = (1.0 - distance[v] / rim).max(0.0);
                p[v] + normals[v] * (0.01 * diag * w * w * sign)
            })
            .collect();
        let start = Instant::now();
        let stats = inc.update(&moved, t).unwrap();
        let incremental = start.elapsed().as_secs_f64();
        let edited = thicket_core::Mesh::new(moved.clone(), &mesh.face_sizes(), mesh.corners().to_vec(), None).unwrap();
        let start = Instant::now();
        let rebuilt = build_shell(&edited, t, side, params).unwrap();
        let rebuild = start.elapsed().as_secs_f64();
        let r = shell_report(inc.mesh(), inc.shell());
        let mean = |s: &thicket_core::shell::Shell| s.achieved.iter().zip(&s.target).map(|(a, t)| if *t > 0.0 { a / t } else { 1.0 }).sum::<f32>() / n as f32;
        // Directors more than a quarter of their target from the rebuild's (the Python
        // suite allows 3 on Suzanne).
        let s = inc.shell();
        let far = (0..n).filter(|&v| (s.directors[v] - rebuilt.directors[v]).length() > 0.25 * rebuilt.target[v]).count();
        println!(
            "  edit {}: incremental {:.1} ms ({} retraced, {} kept, {} resettled{}; {} repair rounds), rebuild {:.0} ms; defects {:?}; mean ratio {:.4} (rebuild {:.4}); {far} directors off by > 1/4",
            step + 1,
            incremental * 1e3,
            stats.retraced,
            stats.kept,
            stats.resettled,
            if stats.field_rebuilt { ", field tree built anew" } else { "" },
            inc.shell().check.rounds,
            rebuild * 1e3,
            (r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells),
            mean(inc.shell()),
            mean(&rebuilt)
        );
    }
}
