//! Frame times of the GPU slice renderer at 1024x1024 (8, 16 and 32 slices per cell,
//! plain and interpolating without mipmaps, and interpolating with double mipmaps,
//! which adds the transparency pass wherever texels are smaller than pixels) on a ~5k-face and a ~59k-face shell textured with chain
//! mail, side by side with the CPU reference renderer on the same scene and camera.
//! The reference is rendered at 256x256 and its time multiplied by 16 (it is linear
//! in the pixel count) to estimate 1024x1024.
//!
//! `cargo run --release -p thicket-render --example render_bench`

use std::time::{Duration, Instant};

use glam::{Mat4, Vec2, Vec3};
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
use thicket_core::testmeshes as tm;
use thicket_core::texture::{Generator, Pattern, TextureLayer};
use thicket_core::Mesh;
use thicket_render::gpu::{FrameTimings, GpuRenderer, SliceMode, SliceParams};
use thicket_render::mipmap::{MipmapSet, Mipmaps};
use thicket_render::reference::{self, RenderParams};
use thicket_render::{Camera, ShellScene};

const SIZE: u32 = 1024;
const REFERENCE_SIZE: u32 = 256;
const FRAMES: usize = 5;

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// A camera looking at the whole mesh from the front-left, above.
fn camera(mesh: &Mesh, size: u32) -> Camera {
    let (lo, hi) = mesh.positions().iter().fold((Vec3::MAX, Vec3::MIN), |(a, b), p| (a.min(*p), b.max(*p)));
    let (centre, radius) = ((lo + hi) * 0.5, (hi - lo).length() * 0.5);
    let eye = centre + Vec3::new(0.6, -1.0, 0.5).normalize() * radius * 2.6;
    let view = Mat4::look_at_rh(eye, centre, Vec3::Z);
    Camera::new(view, Mat4::perspective_rh_gl(0.8, 1.0, 0.01 * radius, 10.0 * radius), size, size).unwrap()
}

fn median(mut v: Vec<FrameTimings>) -> FrameTimings {
    v.sort_by_key(|t| t.total());
    v[v.len() / 2]
}

fn main() {
    let mut gpu = match GpuRenderer::new() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    println!("GPU adapter: {} [{:?}]", gpu.adapter_name(), gpu.adapter_type());
    println!("CPU threads: {}", rayon::current_num_threads());
    let texture = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
    let meshes = [("icosphere(4)", tm::icosphere(4)), ("bunny, subdivided twice", tm::subdivide(&tm::subdivide(&tm::bunny())))];
    for (name, mesh) in meshes {
        let t = Thickness::relative(0.03).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let layers = vec![TextureLayer { texture: texture.clone(), offset: Vec2::ZERO }];
        let scene = ShellScene::new(&mesh, &shell, layers, 1.0).unwrap();
        let cam = camera(&mesh, SIZE);
        println!();
        println!("## {name}: {} cells, chain mail 64x64x32, {SIZE}x{SIZE}", scene.cells.len());

        let start = Instant::now();
        let set = MipmapSet::build(&scene.textures, Mipmaps::Double);
        println!("double mipmap built on the CPU in {:.1} ms (transition level {})", ms(start.elapsed()), set.transition);
        // The first frame uploads the scene.
        let start = Instant::now();
        gpu.render(&scene, &cam, &SliceParams::default()).unwrap();
        println!("first frame (scene upload, targets, pipelines warm-up): {:.1} ms", ms(start.elapsed()));
        println!();
        println!("| renderer | slices | frame ms (median of {FRAMES}) | prepare ms | GPU passes ms | readback ms | coverage |");
        println!("|---|---|---|---|---|---|---|");
        for slices in [8, 16, 32] {
            let modes = [(SliceMode::Plain, Mipmaps::Off), (SliceMode::Interpolating, Mipmaps::Off), (SliceMode::Interpolating, Mipmaps::Double)];
            for (mode, mipmaps) in modes {
                let p = SliceParams { slices, mode, mipmaps, ..SliceParams::default() };
                let mut times = Vec::new();
                let mut coverage = 0.0;
                gpu.render(&scene, &cam, &p).unwrap();
                for _ in 0..FRAMES {
                    coverage = gpu.render(&scene, &cam, &p).unwrap().coverage();
                    times.push(gpu.last_timings().unwrap());
                }
                let t = median(times);
                println!(
                    "| GPU {mode:?}, mipmaps {mipmaps:?} | {slices} | {:.2} | {:.2} | {:.2} | {:.2} | {coverage:.3} |",
                    ms(t.total()),
                    ms(t.prepare),
                    ms(t.draw),
                    ms(t.readback)
                );
            }
        }
        let start = Instant::now();
        let frame = reference::render(&scene, &camera(&mesh, REFERENCE_SIZE), &RenderParams::default()).unwrap();
        let cpu = start.elapsed();
        println!(
            "| CPU reference ({REFERENCE_SIZE}x{REFERENCE_SIZE}: {:.0} ms) x16 | - | {:.0} (estimated) | - | - | - | {:.3} |",
            ms(cpu),
            16.0 * ms(cpu),
            frame.coverage()
        );
    }
}
