//! The README's renderer pictures, on whatever adapter is present:
//! - `slices.png` (figure 5.2): chain mail close up, drawn by the reference renderer,
//!   by plain slicing and by the interpolating renderer at 8 slices per cell, left to
//!   right;
//! - `mipmaps.png` (figures 6.1 and 6.5): a plane of chain mail running from the camera
//!   to the horizon, drawn without mipmaps (aliasing), with averaged mipmaps (the
//!   rings vanish) and with double mipmaps (the far rings turn into a semi-transparent
//!   medium), top to bottom.
//!
//! `cargo run --release -p thicket-render --example readme_figures -- blend_fixtures`

use glam::{Mat4, Vec2, Vec3};
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
use thicket_core::testmeshes as tm;
use thicket_core::texture::{Generator, Pattern, TextureLayer, VolumeTexture};
use thicket_core::Mesh;
use thicket_render::gpu::{GpuRenderer, SliceMode, SliceParams};
use thicket_render::mipmap::Mipmaps;
use thicket_render::reference::{self, RenderParams};
use thicket_render::{Camera, Frame, ShellScene};

fn chain_mail() -> Vec<TextureLayer> {
    let texture: VolumeTexture = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
    vec![TextureLayer { texture, offset: Vec2::ZERO }]
}

/// Frames side by side (`across`) or stacked, over a dark background.
fn compose(frames: &[Frame], across: bool) -> image::RgbImage {
    let (w, h) = (frames[0].width, frames[0].height);
    let (cols, rows) = if across { (frames.len() as u32, 1) } else { (1, frames.len() as u32) };
    let mut out = image::RgbImage::new(w * cols, h * rows);
    for (k, frame) in frames.iter().enumerate() {
        let tile = image::RgbImage::from_raw(w, h, frame.rgb8_over(Vec3::splat(0.03))).expect("one RGB texel per pixel");
        let (x, y) = if across { (k as u32 * w, 0) } else { (0, k as u32 * h) };
        image::imageops::replace(&mut out, &tile, x.into(), y.into());
    }
    out
}

fn slices_figure(gpu: &mut GpuRenderer) -> image::RgbImage {
    let mesh = tm::icosphere(3);
    let t = Thickness::relative(0.05).per_vertex(&mesh, None).unwrap();
    let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let scene = ShellScene::new(&mesh, &shell, chain_mail(), 1.0).unwrap();
    let view = Mat4::look_at_rh(Vec3::new(1.2, -3.0, 1.5), Vec3::new(0.35, -0.85, 0.45), Vec3::Z);
    let camera = Camera::new(view, Mat4::perspective_rh_gl(0.12, 1.0, 0.01, 100.0), 256, 256).unwrap();
    let truth = reference::render(&scene, &camera, &RenderParams { step: 0.02, ..Default::default() }).unwrap();
    let mut frames = vec![truth];
    for mode in [SliceMode::Plain, SliceMode::Interpolating] {
        let params = SliceParams { slices: 8, mode, mipmaps: Mipmaps::Off, ..Default::default() };
        frames.push(gpu.render(&scene, &camera, &params).unwrap());
    }
    compose(&frames, true)
}

fn mipmaps_figure(gpu: &mut GpuRenderer) -> image::RgbImage {
    // A 60 x 60 plane with one UV tile per unit.
    let grid = tm::plane(60);
    let positions: Vec<Vec3> = grid.positions().iter().map(|p| *p * 30.0).collect();
    let uvs: Vec<Vec2> = grid.corners().iter().map(|&v| positions[v as usize].truncate()).collect();
    let mesh = Mesh::new(positions, &grid.face_sizes(), grid.corners().to_vec(), Some(uvs)).unwrap();
    let thickness = Thickness::absolute(0.25).per_vertex(&mesh, None).unwrap();
    let shell = build_shell(&mesh, &thickness, Side::Exterior, &ShellParams::default()).unwrap();
    let scene = ShellScene::new(&mesh, &shell, chain_mail(), 1.0).unwrap();
    let view = Mat4::look_at_rh(Vec3::new(0.0, -29.0, 2.0), Vec3::new(0.0, -5.0, -0.6), Vec3::Z);
    let camera = Camera::new(view, Mat4::perspective_rh_gl(0.5, 3.2, 0.05, 200.0), 640, 200).unwrap();
    let frames: Vec<Frame> = [Mipmaps::Off, Mipmaps::Linear, Mipmaps::Double]
        .into_iter()
        .map(|mipmaps| gpu.render(&scene, &camera, &SliceParams { mipmaps, ..Default::default() }).unwrap())
        .collect();
    compose(&frames, false)
}

fn main() {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    let mut gpu = GpuRenderer::new().unwrap_or_else(|e| panic!("{e}"));
    println!("adapter: {}", gpu.adapter_name());
    for (name, image) in [("slices.png", slices_figure(&mut gpu)), ("mipmaps.png", mipmaps_figure(&mut gpu))] {
        let path = dir.join(name);
        image.save(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        println!("wrote {}", path.display());
    }
}
