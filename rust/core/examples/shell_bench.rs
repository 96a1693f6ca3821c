//! Times a full exterior shell (10% of the bbox diagonal) on a ~29k-vertex closed mesh
//! (the bunny, subdivided twice) and the incremental update after moving 1% of its
//! vertices (a smooth bump) against a rebuild of the edited mesh in the same run,
//! then prints the shell report. The traced directors (before the repair pass) are
//! compared: a refitted patch tree groups the surface a little differently from a
//! rebuilt one, which is the Barnes-Hut approximation's own noise.
//!
//! `cargo run -p thicket-core --release --features test-support --example shell_bench`

use std::time::Instant;
use thicket_core::shell::incremental::{IncrementalShell, DEFAULT_TOLERANCE};
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

    // Move the 1% of vertices nearest to one vertex outward: a smooth bump of 1% of
    // the diagonal at its centre, falling to zero at its rim.
    let centre = mesh.positions()[n / 3];
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| (mesh.positions()[a] - centre).length().total_cmp(&(mesh.positions()[b] - centre).length()));
    let k = n / 100;
    let rim = (mesh.positions()[order[k]] - centre).length();
    let normals = thicket_core::mesh::vertex_normals(&mesh);
    let diag = mesh.bbox_diagonal();
    let mut moved_positions = mesh.positions().to_vec();
    for &v in &order[..k] {
        let w = 1.0 - (mesh.positions()[v] - centre).length() / rim;
        moved_positions[v] += normals[v] * 0.01 * diag * w * w;
    }
    let moved_mesh = thicket_core::Mesh::new(moved_positions.clone(), &mesh.face_sizes(), mesh.corners().to_vec(), None).unwrap();
    let start = Instant::now();
    let rebuilt = build_shell(&moved_mesh, &t, Side::Exterior, &params).unwrap();
    let rebuild = start.elapsed().as_secs_f64();
    let b = shell_report(&moved_mesh, &rebuilt);
    println!("full rebuild after the edit: {rebuild:.3} s");
    let traced = IncrementalShell::new(moved_mesh.clone(), t.clone(), Side::Exterior, params.clone()).unwrap().traced_directors();
    let h = 0.1 * diag;
    let worst = |a: &[glam::Vec3], b: &[glam::Vec3]| a.iter().zip(b).map(|(a, b)| (*a - *b).length()).fold(0.0f32, f32::max) / h;
    let mut exact: Option<Vec<glam::Vec3>> = None;
    for tolerance in [0.0, DEFAULT_TOLERANCE] {
        let mut inc = IncrementalShell::new(mesh.clone(), t.clone(), Side::Exterior, params.clone()).unwrap();
        inc.tolerance = tolerance;
        let start = Instant::now();
        let stats = inc.update(&moved_positions, &t).unwrap();
        let incr = start.elapsed().as_secs_f64();
        let a = shell_report(inc.mesh(), inc.shell());
        let mine = inc.traced_directors();
        let name = if tolerance == 0.0 { "tolerance 0 (every director within reach)".to_string() } else { format!("tolerance {tolerance} (default)") };
        println!(
            "incremental update, {name}: {:.4} s (target 0.05 s: {:.2}x of target; {:.1}x faster than the rebuild)\n  \
             {k} vertices moved, {} directors retraced ({:.0}%), {} within reach kept; \
             traced directors differ from the rebuild's by at most {:.1e} of the thickness{}; \
             defects (self, base, inverted) {:?} vs rebuild {:?}, mean ratio {:.3} vs {:.3}",
            incr,
            incr / 0.05,
            rebuild / incr,
            stats.retraced,
            100.0 * stats.retraced as f64 / n as f64,
            stats.kept,
            worst(&mine, &traced),
            exact.as_ref().map(|e| format!(" and from tolerance 0's by {:.1e}", worst(&mine, e))).unwrap_or_default(),
            (a.outer_self_intersections, a.outer_base_intersections, a.inverted_cells),
            (b.outer_self_intersections, b.outer_base_intersections, b.inverted_cells),
            a.mean_ratio,
            b.mean_ratio
        );
        exact.get_or_insert(mine);
    }
    let start = Instant::now();
    let r = shell_report(&mesh, &shell);
    println!("report ({:.2} s): {r:#?}", start.elapsed().as_secs_f64());
}
