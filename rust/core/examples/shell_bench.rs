//! Times a full exterior shell (10% of the bbox diagonal) on a ~29k-vertex closed mesh
//! (the bunny, subdivided twice) and the incremental update after moving 1% of its
//! vertices (a smooth bump), then prints the shell report.
//!
//! `cargo run -p thicket-core --release --example shell_bench`

use std::time::Instant;
use thicket_core::shell::incremental::IncrementalShell;
use thicket_core::shell::report::shell_report;
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
use thicket_core::testmeshes;

fn main() {
    let mesh = testmeshes::subdivide(&testmeshes::subdivide(&testmeshes::bunny()));
    let n = mesh.vertex_count();
    let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let params = ShellParams::default();
    println!("mesh: {n} vertices, {} triangles, {} threads", mesh.face_count(), rayon::current_num_threads());

    let _ = build_shell(&mesh, &t, Side::Exterior, &params).unwrap(); // warm-up
    let start = Instant::now();
    let shell = build_shell(&mesh, &t, Side::Exterior, &params).unwrap();
    let full = start.elapsed().as_secs_f64();
    println!("full exterior shell: {:.3} s (target 0.5 s: {:.2}x of target)", full, full / 0.5);

    let mut inc = IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, params.clone()).unwrap();
    // Move the 1% of vertices nearest to one vertex outward: a smooth bump of 1% of
    // the diagonal at its centre, falling to zero at its rim.
    let centre = mesh.positions()[n / 3];
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| (mesh.positions()[a] - centre).length().total_cmp(&(mesh.positions()[b] - centre).length()));
    let k = n / 100;
    let rim = (mesh.positions()[order[k]] - centre).length();
    let normals = thicket_core::mesh::vertex_normals(&mesh);
    let diag = mesh.bbox_diagonal();
    let moved: Vec<(u32, glam::Vec3)> = order[..k]
        .iter()
        .map(|&v| {
            let w = 1.0 - (mesh.positions()[v] - centre).length() / rim;
            (v as u32, mesh.positions()[v] + normals[v] * 0.01 * diag * w * w)
        })
        .collect();
    let start = Instant::now();
    let retraced = inc.move_vertices(&moved).unwrap();
    let incr = start.elapsed().as_secs_f64();
    println!(
        "incremental update ({k} vertices moved, {retraced} directors retraced = {:.0}%: the support ball is 2.2x a thickness of 10% of the diagonal): {:.4} s (target 0.05 s: {:.2}x of target)",
        100.0 * retraced as f64 / n as f64,
        incr,
        incr / 0.05
    );
    let start = Instant::now();
    let rebuilt = build_shell(inc.mesh(), &t, Side::Exterior, &params).unwrap();
    let rebuild = start.elapsed().as_secs_f64();
    let (a, b) = (shell_report(inc.mesh(), inc.shell()), shell_report(inc.mesh(), &rebuilt));
    println!(
        "incremental vs full rebuild ({rebuild:.3} s, {:.2}x the incremental time): defects (self, base, inverted) {:?} vs {:?}, mean ratio {:.3} vs {:.3}",
        rebuild / incr,
        (a.outer_self_intersections, a.outer_base_intersections, a.inverted_cells),
        (b.outer_self_intersections, b.outer_base_intersections, b.inverted_cells),
        a.mean_ratio,
        b.mean_ratio
    );
    let start = Instant::now();
    let r = shell_report(&mesh, &shell);
    println!("report ({:.2} s): {r:#?}", start.elapsed().as_secs_f64());
}
