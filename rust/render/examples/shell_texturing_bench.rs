//! Thicket's slice renderer beside shell texturing, the technique games and Blender
//! users use today for fur and grass (N copies of the mesh offset along the vertex
//! normals, alpha-tested with the same texture slice), in one run: silhouette IoU
//! against the CPU reference ray marcher at 16 slices / 16 shells, close and grazing
//! views, on a mesh with concave regions (the bumpy head, exterior L_p shell of 5%,
//! one tile per face, 64 x 64 x 32 textures), with the median frame time of both GPU
//! renderers on the same adapter (on lavapipe these are CPU times).
//!
//! `cargo run --release -p thicket-render --example shell_texturing_bench [-- --size PIXELS] [--frames N]`

use std::time::Duration;

use thicket_core::glam::{Mat4, Vec2, Vec3};
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
use thicket_core::testmeshes;
use thicket_core::texture::{Generator, Pattern, TextureLayer};
use thicket_render::gpu::{FrameTimings, GpuRenderer, ShellTexturingParams, ShellTexturingRenderer, ShellTexturingScene, SliceParams};
use thicket_render::mipmap::Mipmaps;
use thicket_render::reference::{self, RenderParams};
use thicket_render::silhouette::{coverage, frame_coverage, iou};
use thicket_render::{Camera, ShellScene};

const SLICES: u32 = 16;

fn median_ms(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e3
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse::<u32>().ok());
    let size = flag("--size").unwrap_or(256);
    let frames = flag("--frames").unwrap_or(5).max(1) as usize;
    let (mut slices, mut shells) = match (GpuRenderer::new(), ShellTexturingRenderer::new()) {
        (Ok(a), Ok(b)) => (a, b),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    let adapter = slices.adapter_name();
    let cpu = matches!(slices.adapter_type(), wgpu::DeviceType::Cpu);

    let mesh = testmeshes::bumpy_head(2);
    let thickness = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
    let shell = build_shell(&mesh, &thickness, Side::Exterior, &ShellParams::default()).unwrap();
    let (lo, hi) = mesh.positions().iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
    // bake_fidelity's views. Close: a quarter of the head fills the view. Grazing: the
    // view skims the top.
    let views = [
        ("close", Mat4::look_at_rh(centre + Vec3::new(0.3, -1.2, 0.4) * radius, centre + Vec3::new(0.1, -0.5, 0.2) * radius, Vec3::Z), 0.6),
        ("grazing", Mat4::look_at_rh(centre + Vec3::new(-2.5, -0.2, 0.75) * radius, centre + Vec3::new(0.0, 0.0, 0.7) * radius, Vec3::Z), 0.5),
    ];
    let reference_params = RenderParams { step: 0.01, ..Default::default() };
    let slice_params = SliceParams { slices: SLICES, ..Default::default() };
    // The full-resolution texture everywhere, as the reference and the peer sample it.
    let full_resolution = SliceParams { mipmaps: Mipmaps::Off, ..slice_params };
    let shell_params = ShellTexturingParams { shells: SLICES, ..Default::default() };

    println!("GPU adapter: {adapter}{}", if cpu { " (a CPU device: frame times below are CPU times)" } else { "" });
    println!(
        "mesh: bumpy head, {} faces, one tile per face; exterior L_p shell 5%; textures 64x64x32; {size}x{size}; \
         median of {frames} frames (after one warm-up)",
        mesh.face_count()
    );
    println!(
        "ours: Thicket's slice renderer, {SLICES} slices per cell, default settings (interpolating, double mipmaps); \
         peer: shell texturing, {SLICES} shells along the vertex normals, same target thickness; \
         IoU against the reference ray marcher (alpha = 0.5); \"no mip\": ours with mipmaps off (finest level, \
         as the peer samples), one frame"
    );
    println!();
    println!("| pattern | view | ref coverage | IoU ours | IoU ours, no mip | IoU peer | IoU peer/ours | ms ours | ms peer | ms peer/ours |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for pattern in [Pattern::ChainMail, Pattern::Grass, Pattern::Fur] {
        let texture = Generator::new(pattern).generate([64, 64, 32]).unwrap();
        let layers = vec![TextureLayer { texture, offset: Vec2::ZERO }];
        let scene = ShellScene::new(&mesh, &shell, layers.clone(), 1.0).unwrap();
        let copies = ShellTexturingScene::new(&mesh, &thickness, layers, 1.0).unwrap();
        for (name, view, fov) in &views {
            let camera = Camera::new(*view, Mat4::perspective_rh_gl(*fov, 1.0, 0.01 * radius, 20.0 * radius), size, size).unwrap();
            let truth = frame_coverage(&reference::render(&scene, &camera, &reference_params).unwrap());
            // One warm-up frame each (uploads), then alternate so both see the same load.
            let mut ours = slices.render(&scene, &camera, &slice_params).unwrap();
            let mut peer = shells.render(&copies, &camera, &shell_params).unwrap();
            let (mut t_ours, mut t_peer) = (Vec::new(), Vec::new());
            for _ in 0..frames {
                ours = slices.render(&scene, &camera, &slice_params).unwrap();
                t_ours.push(slices.last_timings().map_or(Duration::ZERO, |t: FrameTimings| t.total()));
                peer = shells.render(&copies, &camera, &shell_params).unwrap();
                t_peer.push(shells.last_timings().map_or(Duration::ZERO, |t| t.total()));
            }
            let no_mip = iou(&truth, &frame_coverage(&slices.render(&scene, &camera, &full_resolution).unwrap()));
            let (iou_ours, iou_peer) = (iou(&truth, &frame_coverage(&ours)), iou(&truth, &frame_coverage(&peer)));
            let (ms_ours, ms_peer) = (median_ms(t_ours), median_ms(t_peer));
            println!(
                "| {} | {name} | {:.3} | {iou_ours:.3} | {no_mip:.3} | {iou_peer:.3} | {:.2} | {ms_ours:.1} | {ms_peer:.1} | {:.2} |",
                pattern.name(),
                coverage(&truth),
                iou_peer / iou_ours.max(1e-9),
                ms_peer / ms_ours.max(1e-9)
            );
        }
    }
}
