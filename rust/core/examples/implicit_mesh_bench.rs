//! Meshes a soft-CSG field tree (issue 17's benchmark tree: 20 nodes, `w_p` with
//! `p = 8` over spheres, boxes and segments, each with a colour) through
//! `polygonize::mesh_field` at 128 and 256 cells along the longest side, with interval
//! culling (the tree's `ScalarField::interval`) and without (the same tree behind
//! `Unculled`, which hides its interval): the minimum and median of several runs,
//! triangles, and whether both meshes are the same bit for bit; then
//! `polygonize::dual::mesh_dual` (manifold dual contouring, quads) on the same tree and
//! box: its time, triangles (two per quad) and peak memory beside the culled grid
//! mesher's, as ratios, and where its time goes (descent, cells with their
//! evaluations, contouring, attributes); and `polygonize::estimate`'s quads and peak
//! memory beside the real ones, with its time.
//!
//! `--dual-only` (for profiling and instruction counts): dual contouring alone, its
//! time, triangles, closed-manifold check and profile.
//!
//! `--bounds x0,y0,z0,x1,y1,z1`: mesh that box (grown by two cells, as the tree's own
//! bound is) in place of the tree's bound, e.g. an older bound's box to time both
//! boxes with one build.
//!
//! `cargo run --release -p thicket-core --example implicit_mesh_bench [-- --runs N --resolutions 128,256 --bounds x0,y0,z0,x1,y1,z1 --culled-only --dual-only]`

use glam::Vec3;
use std::time::Instant;
use thicket_core::implicit::samples::SOFT_CSG_20 as TREE;
use thicket_core::implicit::FieldTree;
use thicket_core::polygonize::dual::{mesh_dual, DualParams};
use thicket_core::polygonize::grid::Unculled;
use thicket_core::polygonize::{estimate, mesh_field, GridParams, Mesher, SurfaceCheck};

#[path = "common/counting_alloc.rs"]
mod counting_alloc;

/// The peak of live heap bytes above what was live at the start, while `f` runs, in MB.
fn peak_mb<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let (out, bytes) = counting_alloc::peak_bytes(f);
    (out, bytes as f64 / 1e6)
}

fn stats(mut t: Vec<f64>) -> (f64, f64) {
    t.sort_by(f64::total_cmp);
    (t[0], t[t.len() / 2])
}

fn time<T>(runs: usize, mut f: impl FnMut() -> T) -> ((f64, f64), T) {
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..runs {
        let start = Instant::now();
        out = Some(f());
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    (stats(times), out.expect("at least one run"))
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| args.iter().position(|a| a == name).map(|i| args[i + 1].clone());
    let runs: usize = arg("--runs").map_or(5, |r| r.parse().unwrap());
    let resolutions: Vec<u32> = arg("--resolutions").map_or(vec![128, 256], |r| r.split(',').map(|s| s.parse().unwrap()).collect());
    let tree = FieldTree::from_json(TREE).unwrap();
    let (lo, hi) = match arg("--bounds") {
        Some(b) => {
            let c: Vec<f32> = b.split(',').map(|s| s.parse().unwrap()).collect();
            assert_eq!(c.len(), 6, "--bounds takes six numbers");
            (Vec3::new(c[0], c[1], c[2]), Vec3::new(c[3], c[4], c[5]))
        }
        None => tree.bounds().unwrap(),
    };
    println!("{} threads; a soft-CSG tree of 20 nodes, {} primitives; bounds {lo} to {hi}", rayon::current_num_threads(), tree.primitive_count());
    for resolution in resolutions {
        let margin = 2.0 * (hi - lo).max_element() / resolution as f32;
        let params = GridParams { bounds: (lo - margin, hi + margin), resolution, refine: true };
        if args.iter().any(|a| a == "--dual-only") {
            let ((dual_min, dual_median), dual) = time(runs, || mesh_dual(&tree, &DualParams { bounds: params.bounds, resolution }).unwrap());
            let tris = dual.triangles();
            let p = dual.profile;
            // A hash of the mesh's bits (positions, normals, quads, attributes): equal
            // hashes across builds say the same mesh.
            let bits = dual.positions.iter().chain(&dual.normals).flat_map(|v| v.to_array()).chain(dual.attributes.iter().copied()).map(f32::to_bits);
            let hash =
                bits.chain(dual.quads.iter().flatten().copied()).fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3));
            println!(
                "resolution {resolution}: dual contouring min {dual_min:7.1} ms, median {dual_median:7.1} ms; {} triangles, closed manifold {}, mesh hash {hash:016x}; descent {:.1} ms, cells {:.1} ms ({} evaluations), contouring {:.1} ms, normals and attributes {:.1} ms",
                tris.len(),
                SurfaceCheck::of(&dual.positions, &tris).is_closed_manifold(),
                p.descent_ms,
                p.cells_ms,
                p.evaluations,
                p.contour_ms,
                p.attributes_ms
            );
            continue;
        }
        // `--culled-only` (for profiling): the unculled mesh is made once.
        let dense_runs = if args.iter().any(|a| a == "--culled-only") { 1 } else { runs };
        let ((dense_min, dense_median), dense) = time(dense_runs, || mesh_field(&Unculled(&tree), &params).unwrap());
        let ((culled_min, culled_median), culled) = time(runs, || mesh_field(&tree, &params).unwrap());
        let same = dense.positions == culled.positions
            && dense.triangles == culled.triangles
            && dense.normals == culled.normals
            && dense.attributes.iter().map(|a| a.to_bits()).eq(culled.attributes.iter().map(|a| a.to_bits()));
        let check = SurfaceCheck::of(&culled.positions, &culled.triangles);
        println!("resolution {resolution} (cells {}), {} triangles, closed manifold {}:", culled.cells, culled.triangles.len(), check.is_closed_manifold());
        println!("  every point sampled: min {dense_min:7.1} ms, median {dense_median:7.1} ms");
        println!("  interval culling:    min {culled_min:7.1} ms, median {culled_median:7.1} ms ({:.2}x faster by the minimum)", dense_min / culled_min);
        println!("  same mesh bit for bit: {same}");
        let dual_params = DualParams { bounds: params.bounds, resolution };
        let ((dual_min, dual_median), dual) = time(runs, || mesh_dual(&tree, &dual_params).unwrap());
        let (_, grid_mb) = peak_mb(|| mesh_field(&tree, &params).unwrap());
        let (_, dual_mb) = peak_mb(|| mesh_dual(&tree, &dual_params).unwrap());
        let tris = dual.triangles();
        let check = SurfaceCheck::of(&dual.positions, &tris);
        let p = dual.profile;
        println!(
            "  dual contouring:     min {dual_min:7.1} ms, median {dual_median:7.1} ms ({:.2}x the culled grid's time by the minimum); {} quads = {} triangles ({:.2}x the grid's); closed manifold {}",
            dual_min / culled_min,
            dual.quads.len(),
            tris.len(),
            tris.len() as f64 / culled.triangles.len() as f64,
            check.is_closed_manifold()
        );
        println!("  peak memory:         grid {grid_mb:.1} MB, dual {dual_mb:.1} MB ({:.2}x)", dual_mb / grid_mb);
        let ((estimate_ms, _), e) = time(runs, || estimate(&tree, params.bounds, resolution, Mesher::Dual).unwrap());
        println!(
            "  estimate:            {estimate_ms:7.1} ms: {} quads ({:.3}x the real), peak {:.1} MB ({:.2}x the measured)",
            e.faces,
            e.faces as f64 / dual.quads.len() as f64,
            e.peak_bytes as f64 / 1e6,
            e.peak_bytes as f64 / 1e6 / dual_mb
        );
        println!(
            "  dual profile (last run): descent {:.1} ms, cells (sampling, crossings, QEF) {:.1} ms over {} blocks and {} evaluations, contouring {:.1} ms, normals and attributes {:.1} ms",
            p.descent_ms, p.cells_ms, p.live_blocks, p.evaluations, p.contour_ms, p.attributes_ms
        );
    }
}
