//! Preview fidelity: the CPU reference renderer at its default march (what the add-on
//! draws without a GPU) against the same renderer converged (step 0.05% of the shell),
//! for every built-in pattern (64 x 64 x 32), close and grazing: silhouette IoU and
//! frame time, on spot (a public scan with a UV map, tiling 4) and on the 320-face head
//! without UVs (one tile per face); 5% exterior shells. Beside it, in the same run, the
//! march fixed in depth alone (`texel_step` 0: the default before issue 15), its frames
//! alternated with the default's (best of `--runs`).
//!
//! `cargo run -p thicket-render --release --example preview_fidelity [-- --spot PATH] [--size PIXELS] [--runs N]`

use std::time::Instant;
use thicket_core::glam::{Mat4, Vec2, Vec3};
use thicket_core::mesh::obj::parse_obj;
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
use thicket_core::testmeshes;
use thicket_core::texture::{Generator, Pattern, TextureLayer};
use thicket_core::Mesh;
use thicket_render::reference::{self, RenderParams};
use thicket_render::silhouette::{frame_coverage, iou};
use thicket_render::{Camera, ShellScene};

/// An OBJ with its `vt` records as per-corner UVs (core's reader keeps positions only).
fn obj_with_uvs(text: &str) -> Mesh {
    let plain = parse_obj(text).unwrap();
    let vt: Vec<Vec2> = text
        .lines()
        .filter_map(|l| l.strip_prefix("vt "))
        .map(|l| {
            let c: Vec<f32> = l.split_whitespace().take(2).map(|s| s.parse().unwrap()).collect();
            Vec2::new(c[0], c[1])
        })
        .collect();
    let uvs: Vec<Vec2> = text
        .lines()
        .filter_map(|l| l.strip_prefix("f "))
        .flat_map(|l| l.split_whitespace().map(|tok| vt[tok.split('/').nth(1).unwrap().parse::<usize>().unwrap() - 1]))
        .collect();
    Mesh::new(plain.positions().to_vec(), &plain.face_sizes(), plain.corners().to_vec(), Some(uvs)).unwrap()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1));
    let size = flag("--size").and_then(|v| v.parse().ok()).unwrap_or(160u32);
    let runs = flag("--runs").and_then(|v| v.parse().ok()).unwrap_or(3usize);
    let spot = flag("--spot").cloned().unwrap_or_else(|| "/tmp/pub/spot.obj".into());
    let mut meshes = vec![("head, no UVs", testmeshes::bumpy_head(2), 1.0)];
    match std::fs::read_to_string(&spot) {
        Ok(text) => meshes.insert(0, ("spot, UV map", obj_with_uvs(&text), 4.0)),
        Err(e) => eprintln!("{spot}: {e}; spot skipped"),
    }
    let old = RenderParams { probes: 0, ..Default::default() };
    let new = RenderParams::default();
    // The truth marches finely and nothing else: independent of the texel bound and probes.
    let converged = RenderParams { step: 0.0005, probes: 0, ..Default::default() };
    println!(
        "threads {}; {size}x{size}; default step {} of the shell, probes {}; converged step {}",
        rayon::current_num_threads(),
        new.step,
        new.probes,
        converged.step
    );
    println!("{:13} {:11} {:>7} | {:>13} {:>15} | {:>13} {:>15}", "mesh", "pattern", "view", "IoU before", "ms before", "IoU now", "ms now");
    for (name, mesh, tiling) in &meshes {
        let t = Thickness::relative(0.05).per_vertex(mesh, None).unwrap();
        let shell = build_shell(mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let (lo, hi) = mesh.positions().iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
        // Close: a quarter of the mesh fills the view. Grazing: the view skims the top.
        let views = [
            ("close", Mat4::look_at_rh(centre + Vec3::new(0.3, -1.2, 0.4) * radius, centre + Vec3::new(0.1, -0.5, 0.2) * radius, Vec3::Z), 0.6),
            ("grazing", Mat4::look_at_rh(centre + Vec3::new(-2.5, -0.2, 0.75) * radius, centre + Vec3::new(0.0, 0.0, 0.7) * radius, Vec3::Z), 0.5),
        ];
        for p in Pattern::ALL {
            if std::env::var("ONLY").is_ok_and(|o| !o.contains(p.name())) {
                continue;
            }
            let texture = Generator::new(p).generate([64, 64, 32]).unwrap();
            let scene = ShellScene::new(mesh, &shell, vec![TextureLayer { texture, offset: Vec2::ZERO }], *tiling).unwrap();
            for (view_name, view, fov) in &views {
                let camera = Camera::new(*view, Mat4::perspective_rh_gl(*fov, 1.0, 0.01 * radius, 20.0 * radius), size, size).unwrap();
                if std::env::var("PROFILE").is_ok() {
                    for _ in 0..runs {
                        reference::render(&scene, &camera, &new).unwrap();
                    }
                    continue;
                }
                let truth = frame_coverage(&reference::render(&scene, &camera, &converged).unwrap());
                let (mut best_old, mut best_new) = (f64::INFINITY, f64::INFINITY);
                let (mut iou_old, mut iou_new) = (0.0, 0.0);
                for _ in 0..runs {
                    for (params, best, score) in [(&old, &mut best_old, &mut iou_old), (&new, &mut best_new, &mut iou_new)] {
                        let start = Instant::now();
                        let frame = reference::render(&scene, &camera, params).unwrap();
                        *best = best.min(start.elapsed().as_secs_f64() * 1e3);
                        *score = iou(&truth, &frame_coverage(&frame));
                    }
                }
                println!("{name:13} {:11} {view_name:>7} | {iou_old:>13.3} {best_old:>15.1} | {iou_new:>13.3} {best_new:>15.1}", p.name());
            }
        }
    }
}
