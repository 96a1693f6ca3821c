//! Bake throughput: chain mail over the shell of a ~5k-face closed mesh, against the
//! `fast-surface-nets` crate polygonizing a grid with the same number of samples
//! (no shell map, no attributes, no crack handling), measured in the same run. The
//! anchor's grid is sampled on all cores; the crate itself polygonizes on one.
//! Also the bake's peak heap memory.
//!
//! `cargo run -p thicket-core --release --features test-support --example bake_bench [-- --budget | --parts A.obj ...]`

use std::time::Instant;

use rayon::prelude::*;

use fast_surface_nets::ndshape::{RuntimeShape, Shape};
use fast_surface_nets::{surface_nets, SurfaceNetsBuffer};
use thicket_core::glam::{Vec2, Vec3};
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
use thicket_core::testmeshes;
use thicket_core::texture::bake::bake;
use thicket_core::texture::{BakeParams, Generator, Pattern, TextureLayer};

#[path = "common/counting_alloc.rs"]
mod counting_alloc;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// `--budget`: chain mail in world-size tiles (the add-on's default, 1/32 of the
/// diagonal) toward the default budget of 1 M triangles: the cell pass alone, then with
/// the groups of the hierarchy, and the estimate.
fn budget_case() {
    use thicket_core::texture::bake::{estimate_triangles, CELL_PASS_ONLY};
    use thicket_core::texture::charts::with_world_size_uvs;
    let mesh = testmeshes::bumpy_head(4);
    let mesh = with_world_size_uvs(&mesh, mesh.bbox_diagonal() / 32.0).unwrap();
    let t = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
    let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let texture = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
    let layers = [TextureLayer { texture, offset: Vec2::ZERO }];
    let params = BakeParams::default();
    let timed = |only: bool| {
        CELL_PASS_ONLY.store(only, std::sync::atomic::Ordering::Relaxed);
        let start = Instant::now();
        let b = bake(&mesh, &shell, &layers, &params).unwrap();
        (start.elapsed().as_secs_f64(), b.triangles.len())
    };
    let (cells_s, cells_n) = timed(true);
    let (all_s, all_n) = timed(false);
    let estimate = estimate_triangles(&mesh, &shell, &layers, &params).unwrap();
    println!("world-size chain mail on a {}-face head, budget {}:", mesh.face_count(), params.triangle_budget);
    println!("  cell pass: {cells_n:>9} triangles, {:7.1} s", cells_s);
    println!(
        "  groups:    {all_n:>9} triangles, {:7.1} s ({:.2}x the cell pass's time; {:.2}x the budget)",
        all_s,
        all_s / cells_s,
        all_n as f64 / params.triangle_budget as f64
    );
    println!("  estimate:  {estimate:>9} triangles ({:.2}x the bake)", estimate as f64 / all_n as f64);
}

/// `--parts A.obj B.obj ...`: default bakes (5% exterior shell, budget 1 M) of every
/// pattern on the given meshes without UVs, their triangles against the budget (issue
/// 15: CAD parts ran 2-12x over it), in the modes `BAKE_MODES` names (default all):
/// `face` one tile per face, `world` World-Size Tiles of 1/32 of the diagonal, `fitted`
/// World-Size Tiles grown to the budget ([`budget_tile_size`] from 1/32, its estimate
/// the search's own), each with the estimate, closed-manifold check and crossing
/// triangle pairs; `search` only the search (tile size, estimate, estimates made,
/// wall and CPU seconds), no bake. `BAKE_PATTERNS`: only those patterns
/// (comma-separated names).
fn budget_parts(paths: &[String]) {
    use thicket_core::hard_meshes::self_intersections;
    use thicket_core::mesh::Mesh;
    use thicket_core::polygonize::SurfaceCheck;
    use thicket_core::texture::bake::estimate_triangles;
    use thicket_core::texture::charts::{budget_tile_size, with_world_size_uvs};
    let only = std::env::var("BAKE_PATTERNS").ok();
    let modes = std::env::var("BAKE_MODES").unwrap_or_else(|_| "face,world,fitted".into());
    for path in paths {
        let mesh = thicket_core::mesh::obj::parse_obj(&std::fs::read_to_string(path).unwrap()).unwrap();
        let mesh = Mesh::new(mesh.positions().to_vec(), &mesh.face_sizes(), mesh.corners().to_vec(), None).unwrap();
        let t = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let params = BakeParams::default();
        let auto = mesh.bbox_diagonal() / 32.0;
        println!("{path}: {} faces, budget {}", mesh.face_count(), params.triangle_budget);
        for p in Pattern::ALL.into_iter().filter(|p| only.as_deref().is_none_or(|o| o.split(',').any(|n| n == p.name()))) {
            let texture = Generator::new(p).generate([64, 64, 32]).unwrap();
            let layers = [TextureLayer { texture, offset: Vec2::ZERO }];
            for mode in modes.split(',') {
                let (start, cpu) = (Instant::now(), cpu_seconds());
                let (baked_on, what, found) = match mode {
                    "face" => (mesh.clone(), "one tile per face".to_string(), None),
                    "world" => (with_world_size_uvs(&mesh, auto).unwrap(), "world 1/32".to_string(), None),
                    _ => {
                        let (size, fit) = budget_tile_size(&mesh, &shell, &layers, &params, auto).unwrap();
                        (with_world_size_uvs(&mesh, size).unwrap(), format!("fitted 1/{:.1}", mesh.bbox_diagonal() / size), Some(fit))
                    }
                };
                let (fit_s, fit_cpu) = (start.elapsed().as_secs_f64(), cpu_seconds() - cpu);
                if mode == "search" {
                    let fit = found.unwrap();
                    println!(
                        "  {:11} {:18} estimate {:>9} ({:.2}x the budget{}), scale {:.2} (over at {:.2}), estimates {} quick + {} full, {:.1} s ({:.1} s CPU)",
                        p.name(),
                        what,
                        fit.estimate.triangles,
                        fit.estimate.triangles as f64 / params.triangle_budget as f64,
                        if fit.fits { "" } else { ", does not fit" },
                        fit.scale,
                        fit.below.unwrap_or(f32::NAN),
                        fit.estimates[0],
                        fit.estimates[1],
                        fit_s,
                        fit_cpu
                    );
                    continue;
                }
                // The search's estimate is the bake's own at those tiles: not made again.
                let estimate = match found {
                    Some(fit) => Ok(fit.estimate.triangles),
                    None => estimate_triangles(&baked_on, &shell, &layers, &params),
                };
                let start = Instant::now();
                match bake(&baked_on, &shell, &layers, &params) {
                    Ok(b) => {
                        let secs = start.elapsed().as_secs_f64();
                        let check = SurfaceCheck::of(&b.positions, &b.triangles);
                        let sizes = vec![3u32; b.triangles.len()];
                        let out = Mesh::new(b.positions.clone(), &sizes, b.triangles.iter().flatten().copied().collect(), None).unwrap();
                        println!(
                            "  {:11} {:18} {:>9} triangles ({:.2}x the budget{}), estimate {:.2}x, lattice {:?}, {}, {} crossing pairs, bake {:.1} s (fit {:.1} s, {:.1} s CPU)",
                            p.name(),
                            what,
                            b.triangles.len(),
                            b.triangles.len() as f64 / params.triangle_budget as f64,
                            if b.over_budget { ", says over" } else { "" },
                            estimate.map_or(f64::NAN, |e| e as f64 / b.triangles.len().max(1) as f64),
                            b.lattice,
                            if check.is_closed_manifold() { "closed manifold".to_string() } else { format!("{check:?}") },
                            self_intersections(&out),
                            secs,
                            fit_s,
                            fit_cpu
                        );
                    }
                    Err(e) => println!("  {:11} {:18} refused: {e}", p.name(), what),
                }
            }
        }
    }
}

/// CPU seconds this process has used (user and system, all threads; Linux).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

fn main() {
    if std::env::args().any(|a| a == "--budget") {
        return budget_case();
    }
    let args: Vec<String> = std::env::args().collect();
    if let Some(i) = args.iter().position(|a| a == "--parts") {
        return budget_parts(&args[i + 1..]);
    }
    let mesh = testmeshes::bumpy_head(4);
    let t = Thickness::relative(0.03).per_vertex(&mesh, None).unwrap();
    let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let texture = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
    let layers = [TextureLayer { texture: texture.clone(), offset: Vec2::ZERO }];
    // The fixed lattice, unsimplified: the polygonizer's throughput at a known sample count.
    let params = BakeParams { resolution: 8, depth_steps: 16, follow_texture: false, triangle_budget: 0, ..Default::default() };
    let faces = mesh.face_count();
    // Lattice samples: vertices, edge points, face points, times layers + 1.
    let edges = faces * 3 / 2;
    let (n, m) = (params.resolution as usize, params.depth_steps as usize);
    let samples = (mesh.vertex_count() + edges * (n - 1) + faces * (n - 1) * (n - 2) / 2) * (m + 1);
    println!("mesh: {} faces; chain mail 64x64x32; lattice {n} per edge x {m} layers = {samples} samples; {} threads", faces, rayon::current_num_threads());

    let ((ours, tris), peak) = counting_alloc::peak_bytes(|| {
        let (mut ours, mut tris) = (Vec::new(), 0);
        for _ in 0..5 {
            let start = Instant::now();
            let b = bake(&mesh, &shell, &layers, &params).unwrap();
            ours.push(start.elapsed().as_secs_f64());
            tris = b.triangles.len();
        }
        (ours, tris)
    });
    let ours = median(ours);

    // The same number of samples on a cube grid of the tiled texture.
    let side = (samples as f64).cbrt().round() as u32;
    let shape = RuntimeShape::<u32, 3>::new([side, side, side]);
    let sample_grid = || {
        let mut sdf = vec![0.0f32; shape.usize()];
        let tiles = 6.0;
        // Sampled on every core, like the bake; the crate then polygonizes on one.
        sdf.par_iter_mut().enumerate().for_each(|(i, v)| {
            let [x, y, z] = shape.delinearize(i as u32);
            let c = Vec3::new(x as f32 / side as f32 * tiles, y as f32 / side as f32 * tiles, z as f32 / (side - 1) as f32);
            // Outside the boundary layer, like the bake; surface nets wants negative inside.
            let edge = x == 0 || y == 0 || z == 0 || x == side - 1 || y == side - 1 || z == side - 1;
            *v = if edge { 0.5 } else { 0.5 - texture.sample(c) };
        });
        sdf
    };
    let mut fsn_total = Vec::new();
    let mut fsn_poly = Vec::new();
    let mut fsn_tris = 0;
    let mut buffer = SurfaceNetsBuffer::default();
    for _ in 0..5 {
        let start = Instant::now();
        let sdf = sample_grid();
        let sampled = start.elapsed().as_secs_f64();
        surface_nets(&sdf, &shape, [0; 3], [side - 1; 3], &mut buffer);
        let total = start.elapsed().as_secs_f64();
        fsn_total.push(total);
        fsn_poly.push(total - sampled);
        fsn_tris = buffer.indices.len() / 3;
    }
    let (fsn_total, fsn_poly) = (median(fsn_total), median(fsn_poly));
    println!(
        "Thicket bake:       {:8.1} ms, {tris:>8} triangles, {:6.2} M triangles/s, {:5.1} M samples/s, peak heap {:.0} MiB",
        ours * 1e3,
        tris as f64 / ours / 1e6,
        samples as f64 / ours / 1e6,
        peak as f64 / (1 << 20) as f64
    );
    println!(
        "fast-surface-nets:  {:8.1} ms ({:.1} ms polygonizing, single thread), {fsn_tris:>8} triangles on a {side}^3 grid, {:6.2} M triangles/s, {:5.1} M samples/s",
        fsn_total * 1e3,
        fsn_poly * 1e3,
        fsn_tris as f64 / fsn_total / 1e6,
        samples as f64 / fsn_total / 1e6
    );
    println!("ratio (Thicket / fast-surface-nets, time per sample, sampling included): {:.2}x; polygonizing only: {:.2}x", ours / fsn_total, ours / fsn_poly);
}
