//! The wgpu slice renderer against the CPU reference renderer.
//!
//! These tests need a GPU adapter and FAIL without one: `make test-rust` installs
//! Mesa's lavapipe (a Vulkan driver on the CPU) where no Vulkan driver exists.

use std::sync::{Mutex, MutexGuard, OnceLock};

use glam::{Mat4, Vec2, Vec3};
use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
use thicket_core::testmeshes as tm;
use thicket_core::texture::{Generator, Pattern, TextureLayer, VolumeTexture};
use thicket_render::gpu::{GpuRenderer, SliceMode, SliceParams};
use thicket_render::mipmap::Mipmaps;
use thicket_render::reference::{self, RenderParams};
use thicket_render::{Camera, Frame, ShellScene};

/// One renderer for all tests (they take turns).
fn renderer() -> MutexGuard<'static, GpuRenderer> {
    static R: OnceLock<Mutex<GpuRenderer>> = OnceLock::new();
    R.get_or_init(|| {
        let r = GpuRenderer::new().unwrap_or_else(|e| panic!("no GPU adapter (make test-rust installs lavapipe): {e}"));
        eprintln!("GPU adapter: {}", r.adapter_name());
        Mutex::new(r)
    })
    .lock()
    .unwrap_or_else(|e| e.into_inner())
}

fn layer(texture: VolumeTexture) -> Vec<TextureLayer> {
    vec![TextureLayer { texture, offset: Vec2::ZERO }]
}

/// An exterior shell of relative thickness `thickness` over `mesh` with `texture`.
fn scene(mesh: &thicket_core::Mesh, thickness: f32, texture: VolumeTexture) -> ShellScene {
    let t = Thickness::relative(thickness).per_vertex(mesh, None).unwrap();
    let shell = build_shell(mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
    ShellScene::new(mesh, &shell, layer(texture), 1.0).unwrap()
}

/// The reference renderer's slab: alpha 1 below r = 0.5, 0 above (a sharp step).
fn slab_scene() -> ShellScene {
    let slab = VolumeTexture::from_fn([4, 4, 33], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
    scene(&tm::icosphere(3), 0.1, slab)
}

fn chain_mail_scene() -> ShellScene {
    let tex = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
    scene(&tm::icosphere(3), 0.05, tex)
}

fn perspective(eye: Vec3, target: Vec3, fov: f32, size: u32) -> Camera {
    let up = if (target - eye).normalize().cross(Vec3::Z).length() < 1e-3 { Vec3::Y } else { Vec3::Z };
    Camera::new(Mat4::look_at_rh(eye, target, up), Mat4::perspective_rh_gl(fov, 1.0, 0.01, 100.0), size, size).unwrap()
}

/// The whole sphere, three quarters from above.
fn front_view(size: u32) -> Camera {
    perspective(Vec3::new(1.2, -3.0, 1.5), Vec3::ZERO, 0.8, size)
}

/// A narrow view of the sphere's limb: the surface seen at grazing angles, slices
/// across the shell (sections) in most cells.
fn grazing_view(size: u32) -> Camera {
    perspective(Vec3::new(0.0, -4.0, 0.3), Vec3::new(1.0, -0.05, 0.1), 0.12, size)
}

/// A close view of the surface facing the camera (chain mail rings a few pixels thick).
fn close_view(size: u32) -> Camera {
    perspective(Vec3::new(1.2, -3.0, 1.5), Vec3::new(0.35, -0.85, 0.45), 0.25, size)
}

/// Chapter 5's renderer as the reference renderer sees the texture: full resolution
/// everywhere (no mipmaps; they are tested against supersampled references below).
fn slice_params(slices: u32, mode: SliceMode) -> SliceParams {
    let p = RenderParams::default();
    SliceParams { slices, mode, light: p.light, ambient: p.ambient, albedo: p.albedo, mipmaps: Mipmaps::Off }
}

#[derive(Debug, Clone, Copy)]
struct Score {
    /// Intersection over union of the covered pixels.
    iou: f32,
    /// PSNR of the colour over the whole image (background black), dB.
    psnr: f32,
    /// Mean absolute colour error over the pixels covered in both.
    mae: f32,
    /// Median relative depth error over the pixels covered in both.
    depth: f32,
}

fn score(gpu: &Frame, cpu: &Frame) -> Score {
    assert_eq!((gpu.width, gpu.height), (cpu.width, cpu.height));
    let (mut inter, mut union, mut se, mut ae) = (0usize, 0usize, 0.0f64, 0.0f64);
    let mut depth = Vec::new();
    for i in 0..gpu.rgba.len() {
        let (a, b) = (gpu.rgba[i], cpu.rgba[i]);
        let (ca, cb) = (a.w > 0.5, b.w > 0.5);
        inter += usize::from(ca && cb);
        union += usize::from(ca || cb);
        let d = a.truncate() * a.w - b.truncate() * b.w;
        se += d.length_squared() as f64 / 3.0;
        if ca && cb {
            ae += (d.abs().element_sum() / 3.0) as f64;
            depth.push((gpu.depth[i] - cpu.depth[i]).abs() / cpu.depth[i]);
            assert!((gpu.normal[i].length() - 1.0).abs() < 1e-3, "normal {}", gpu.normal[i]);
        }
    }
    depth.sort_by(f32::total_cmp);
    let mse = se / gpu.rgba.len() as f64;
    Score {
        iou: inter as f32 / union.max(1) as f32,
        psnr: (10.0 * (1.0 / mse.max(1e-12)).log10()) as f32,
        mae: (ae / inter.max(1) as f64) as f32,
        depth: depth.get(depth.len() / 2).copied().unwrap_or(0.0),
    }
}

/// Renders `scene` with both modes at 8, 16 and 32 slices, scores each against the
/// reference and checks: coverage within `min_iou[k]`, the interpolating mode's colour
/// within `min_psnr[k]`, and the interpolating mode closer to the reference than
/// plain slicing (figure 5.2): a better colour, or (where plain slicing already
/// matches the colour: a slice on the iso-surface) the same colour and a better depth.
fn compare_with_reference(name: &str, scene: &ShellScene, camera: &Camera, min_iou: [f32; 3], min_psnr: [f32; 3]) {
    let reference = reference::render(scene, camera, &RenderParams { step: 0.02, ..Default::default() }).unwrap();
    assert!(reference.coverage() > 0.05, "{name}: the reference sees nothing");
    let mut r = renderer();
    for (k, slices) in [8, 16, 32].into_iter().enumerate() {
        let mut scores = Vec::new();
        for mode in [SliceMode::Plain, SliceMode::Interpolating] {
            let frame = r.render(scene, camera, &slice_params(slices, mode)).unwrap();
            let s = score(&frame, &reference);
            eprintln!("| {name:<20} | {:<13} | {slices:>2} | {:.4} | {:5.2} | {:.4} | {:.5} |", format!("{mode:?}"), s.iou, s.psnr, s.mae, s.depth);
            assert!(s.iou >= min_iou[k], "{name} {mode:?} {slices}: IoU {}", s.iou);
            if mode == SliceMode::Interpolating {
                assert!(s.psnr >= min_psnr[k], "{name} {mode:?} {slices}: PSNR {}", s.psnr);
            }
            scores.push(s);
        }
        let (plain, interp) = (scores[0], scores[1]);
        let better_colour = interp.psnr > plain.psnr + 0.01 && interp.mae < plain.mae;
        let same_colour_better_depth = interp.psnr >= plain.psnr - 0.05 && interp.depth < 0.5 * plain.depth;
        assert!(
            better_colour || same_colour_better_depth,
            "{name}, {slices} slices: interpolating ({interp:?}) is not closer to the reference than plain ({plain:?})"
        );
    }
}

// Columns of the printed table: scene and view, mode, slices, coverage IoU, colour
// PSNR (dB), mean absolute colour error, median relative depth error.

#[test]
fn slab_sphere_matches_the_reference() {
    compare_with_reference("slab, front", &slab_scene(), &front_view(128), [0.995; 3], [35.0, 38.0, 38.0]);
}

#[test]
fn slab_sphere_grazing_view_matches_the_reference() {
    compare_with_reference("slab, grazing", &slab_scene(), &grazing_view(128), [0.99; 3], [30.0, 33.0, 33.0]);
}

#[test]
fn chain_mail_matches_the_reference() {
    compare_with_reference("chain mail, close", &chain_mail_scene(), &close_view(128), [0.8, 0.95, 0.985], [13.5, 20.0, 26.0]);
}

#[test]
fn chain_mail_grazing_view_matches_the_reference() {
    compare_with_reference("chain mail, grazing", &chain_mail_scene(), &grazing_view(128), [0.8, 0.95, 0.985], [12.0, 17.0, 21.5]);
}

/// Chain mail (64 x 64 x 32) united with a second layer shifted by (0.3, 0.1) in (s, t).
fn chain_mail_and(texture: VolumeTexture) -> ShellScene {
    let mut scene = chain_mail_scene();
    scene.textures.push(TextureLayer { texture, offset: Vec2::new(0.3, 0.1) });
    scene
}

/// Bars along t, a quarter of the tile wide, solid up to r = 0.7 (a slab in strips):
/// they cover part of what the chain mail leaves open, not all of it.
fn bars() -> VolumeTexture {
    VolumeTexture::from_fn([32, 32, 17], |c| if c.x.rem_euclid(1.0) < 0.25 && c.z < 0.7 { 1.0 } else { 0.0 }).unwrap()
}

/// Renders the union and the first layer alone (interpolating, 32 slices) and checks
/// the union against the reference; returns the coverages (union, first layer).
fn check_union(name: &str, united: &ShellScene) -> (f32, f32) {
    let first = ShellScene {
        cells: united.cells.clone(),
        bounds: united.bounds.clone(),
        textures: united.textures[..1].to_vec(),
        per_face_tiles: united.per_face_tiles,
        effects: Default::default(),
    };
    let camera = close_view(128);
    let p = slice_params(32, SliceMode::Interpolating);
    let reference = reference::render(united, &camera, &RenderParams { step: 0.02, ..Default::default() }).unwrap();
    let mut r = renderer();
    // The first layer alone, then the union over the same cells: the scene is uploaded
    // again when a layer is added.
    let alone = r.render(&first, &camera, &p).unwrap();
    let frame = r.render(united, &camera, &p).unwrap();
    let s = score(&frame, &reference);
    eprintln!(
        "{name}, close, 32 slices, interpolating: {s:?}; coverage {} (first layer alone {}, reference {})",
        frame.coverage(),
        alone.coverage(),
        reference.coverage()
    );
    // The thresholds of chain mail alone at 32 slices.
    assert!(s.iou >= 0.97 && s.psnr >= 26.0, "{name}: {s:?}");
    (frame.coverage(), alone.coverage())
}

#[test]
fn united_layers_match_the_reference() {
    let (united, alone) = check_union("chain mail + bars (0.3, 0.1)", &chain_mail_and(bars()));
    assert!(united > alone + 0.01 && united < 0.99, "{united} vs {alone}");
    let rivets = Generator::new(Pattern::Rivets).generate([32, 32, 16]).unwrap();
    let (united, alone) = check_union("chain mail + rivets (0.3, 0.1)", &chain_mail_and(rivets));
    assert!(united > alone + 0.01, "{united} vs {alone}");
}

#[test]
fn moving_a_layer_changes_the_image() {
    let camera = close_view(64);
    let p = slice_params(16, SliceMode::Interpolating);
    let mut scene = chain_mail_and(bars());
    let mut r = renderer();
    let a = r.render(&scene, &camera, &p).unwrap();
    // Same cells, the second layer moved: uploaded again, a different image.
    scene.textures[1].offset = Vec2::new(0.55, 0.35);
    let b = r.render(&scene, &camera, &p).unwrap();
    assert_ne!(a, b);
    let reference = reference::render(&scene, &camera, &RenderParams { step: 0.02, ..Default::default() }).unwrap();
    let s = score(&b, &reference);
    eprintln!("bars moved to (0.55, 0.35), 16 slices: {s:?}");
    assert!(s.iou >= 0.95, "{s:?}");
}

#[test]
fn too_many_layers_is_an_error() {
    let mut scene = slab_scene();
    let camera = front_view(32);
    let p = slice_params(8, SliceMode::Interpolating);
    let mut r = renderer();
    let slab = scene.textures[0].texture.clone();
    for k in 1..4 {
        scene.textures.push(TextureLayer { texture: slab.clone(), offset: Vec2::new(0.1 * k as f32, 0.0) });
    }
    // Four layers render; five are refused, without breaking the renderer.
    let four = r.render(&scene, &camera, &p).unwrap();
    assert!(four.coverage() > 0.1);
    scene.textures.push(TextureLayer { texture: slab, offset: Vec2::ZERO });
    let e = r.render(&scene, &camera, &p).unwrap_err();
    eprintln!("five layers: {e}");
    scene.textures.truncate(1);
    assert!(r.render(&scene, &camera, &p).unwrap().coverage() > 0.1);
}

#[test]
fn orthographic_view_matches_the_reference() {
    let scene = slab_scene();
    let view = Mat4::look_at_rh(Vec3::new(0.0, -5.0, 0.0), Vec3::ZERO, Vec3::Z);
    let camera = Camera::new(view, Mat4::orthographic_rh_gl(-2.0, 2.0, -2.0, 2.0, 0.1, 100.0), 96, 96).unwrap();
    let reference = reference::render(&scene, &camera, &RenderParams::default()).unwrap();
    let frame = renderer().render(&scene, &camera, &slice_params(16, SliceMode::Interpolating)).unwrap();
    let s = score(&frame, &reference);
    eprintln!("orthographic slab, 16 slices, interpolating: {s:?}");
    assert!(s.iou > 0.99 && s.psnr > 35.0, "{s:?}");
}

#[test]
fn camera_inside_the_shell() {
    let scene = slab_scene();
    let h = 0.1 * tm::icosphere(3).bbox_diagonal();
    let p = slice_params(16, SliceMode::Interpolating);
    // In the empty upper part of the shell (r = 0.8), looking along the surface: the
    // slices behind the near plane are clipped away; the image matches the reference.
    let camera = perspective(Vec3::new(0.0, 0.0, 1.0 + 0.8 * h), Vec3::new(1.0, 0.0, 1.0), 0.8, 64);
    let reference = reference::render(&scene, &camera, &RenderParams::default()).unwrap();
    let frame = renderer().render(&scene, &camera, &p).unwrap();
    let s = score(&frame, &reference);
    eprintln!("camera inside the shell (r = 0.8): {s:?}, coverage {}", frame.coverage());
    assert!(frame.coverage() > 0.05 && s.iou > 0.97 && s.psnr > 25.0, "{s:?}");
    assert!(frame.depth.iter().all(|d| *d > 0.0));
    // Inside the solid part (r = 0.2): an image, no panic (the slice renderer shows the
    // solid around the camera; the reference only surfaces entered from outside).
    let camera = perspective(Vec3::new(0.0, 0.0, 1.0 + 0.2 * h), Vec3::new(1.0, 0.0, 1.0), 0.8, 32);
    let frame = renderer().render(&scene, &camera, &p).unwrap();
    assert!(frame.normal.iter().zip(&frame.rgba).all(|(n, c)| c.w == 0.0 || (n.length() - 1.0).abs() < 1e-3));
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let scene = slab_scene();
    let camera = perspective(Vec3::new(0.0, -4.0, 0.0), Vec3::ZERO, 0.8, 16);
    let mut r = renderer();
    let good = slice_params(8, SliceMode::Interpolating);
    for p in [
        SliceParams { slices: 0, ..good },
        SliceParams { slices: 1, ..good },
        SliceParams { slices: 100_000, ..good },
        SliceParams { light: Vec3::ZERO, ..good },
        SliceParams { light: Vec3::NAN, ..good },
        SliceParams { ambient: 2.0, ..good },
        SliceParams { albedo: Vec3::splat(f32::INFINITY), ..good },
    ] {
        assert!(r.render(&scene, &camera, &p).is_err(), "{p:?}");
    }
    // An empty shell, a shell without texture, a shell of zero thickness.
    let slab = || VolumeTexture::from_fn([4, 4, 33], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
    let empty = ShellScene { cells: vec![], bounds: vec![], textures: layer(slab()), per_face_tiles: true, effects: Default::default() };
    let e = r.render(&empty, &camera, &good).unwrap_err();
    eprintln!("empty shell: {e}");
    let bare = ShellScene { cells: scene.cells.clone(), bounds: scene.bounds.clone(), textures: vec![], per_face_tiles: true, effects: Default::default() };
    assert!(r.render(&bare, &camera, &good).is_err());
    let flat = {
        let mesh = tm::plane(4);
        let n = mesh.vertex_count();
        let shell = thicket_core::shell::Shell::from_directors(vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        ShellScene::new(&mesh, &shell, layer(slab()), 1.0).unwrap()
    };
    assert!(r.render(&flat, &camera, &good).is_err());
    // Zero-size viewports: Camera::new refuses them, the renderer too.
    assert!(Camera::new(camera.view, camera.projection, 0, 16).is_err());
    let mut tiny = camera;
    tiny.width = 0;
    assert!(r.render(&scene, &tiny, &good).is_err());
    // A viewport larger than any GPU image.
    let mut huge = camera;
    huge.width = 1 << 20;
    assert!(r.render(&scene, &huge, &good).is_err());
    // Non-finite cells render (garbage in, an image out), without panicking.
    let mut broken =
        ShellScene { cells: scene.cells.clone(), bounds: scene.bounds.clone(), textures: layer(slab()), per_face_tiles: true, effects: Default::default() };
    broken.cells[0].base[1] = Vec3::NAN;
    broken.cells[1].director[2] = Vec3::splat(f32::INFINITY);
    let _ = r.render(&broken, &camera, &good);
    // The renderer still works.
    let frame = r.render(&scene, &camera, &good).unwrap();
    assert!(frame.coverage() > 0.1);
}

#[test]
fn frames_are_deterministic() {
    let scene = slab_scene();
    let camera = front_view(48);
    let mut r = renderer();
    let p = slice_params(12, SliceMode::Interpolating);
    let a = r.render(&scene, &camera, &p).unwrap();
    let first = r.last_timings().unwrap();
    let b = r.render(&scene, &camera, &p).unwrap();
    let again = r.last_timings().unwrap();
    assert_eq!(a, b, "the same frame twice");
    // The first frame of a scene uploads it; the second reuses it.
    eprintln!("first frame {first:?}, again {again:?}");
    assert!(again.total() > std::time::Duration::ZERO);
}

#[test]
fn shaders_validate() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "wgsl") {
            let source = std::fs::read_to_string(&path).unwrap();
            let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&source)));
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
                .validate(&module)
                .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&source)));
            count += 1;
        }
    }
    assert!(count > 0, "no shader in {}", dir.display());
}

/// Mean alpha of `frame` over `k x k` blocks: the coverage of each pixel of an image
/// `k` times smaller.
fn downsample_alpha(frame: &Frame, k: u32) -> Vec<f32> {
    let (w, h) = (frame.width / k, frame.height / k);
    let mut out = vec![0.0; (w * h) as usize];
    for y in 0..frame.height {
        for x in 0..frame.width {
            out[((y / k) * w + x / k) as usize] += frame.rgba[(y * frame.width + x) as usize].w / (k * k) as f32;
        }
    }
    out
}

/// Coverage of a far view per mipmap mode, against the reference renderer at
/// `supersampling` times the resolution averaged down (the true share of each pixel the object covers):
/// (truth, [off, linear, double]) mean coverage and, per mode, the mean absolute
/// per-pixel coverage error.
fn far_view_coverage(scene: &ShellScene, camera: impl Fn(u32) -> Camera, size: u32, supersampling: u32) -> (f32, [f32; 3], [f32; 3]) {
    let fine = reference::render(scene, &camera(size * supersampling), &RenderParams { step: 0.02, ..Default::default() }).unwrap();
    let truth = downsample_alpha(&fine, supersampling);
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    let mut r = renderer();
    let mut coverage = [0.0; 3];
    let mut error = [0.0; 3];
    for (k, mipmaps) in [Mipmaps::Off, Mipmaps::Linear, Mipmaps::Double].into_iter().enumerate() {
        let params = SliceParams { mipmaps, ..slice_params(16, SliceMode::Interpolating) };
        let frame = r.render(scene, &camera(size), &params).unwrap();
        let alpha: Vec<f32> = frame.rgba.iter().map(|c| c.w).collect();
        coverage[k] = mean(&alpha);
        error[k] = mean(&alpha.iter().zip(&truth).map(|(a, b)| (a - b).abs()).collect::<Vec<_>>());
    }
    (mean(&truth), coverage, error)
}

#[test]
fn double_mipmaps_keep_far_views_from_vanishing() {
    // Figure 6.1: chain mail on a sphere filling the view, rendered smaller and
    // smaller (a tile, 64 texels a side, spans from about 25 pixels down to 3).
    // Averaged mipmaps drop below alpha = 0.5 and the rings fade away; double
    // mipmaps turn the far texture into a semi-transparent medium that covers about
    // as much as the object really does, at every size, the transitional zone
    // included (figure 6.5). The truth: the reference renderer at 512 x 512 averaged
    // down.
    let tex = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
    let scene = scene(&tm::icosphere(2), 0.05, tex);
    let view = |size: u32| perspective(Vec3::new(0.35, -0.85, 0.4).normalize() * 4.0, Vec3::ZERO, 0.55, size);
    eprintln!("| pixels | truth | off | linear | double | pixel error off | linear | double |");
    for size in [256u32, 128, 64, 32] {
        let (truth, coverage, error) = far_view_coverage(&scene, view, size, 512 / size);
        eprintln!(
            "| {size:>4} | {truth:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
            coverage[0], coverage[1], coverage[2], error[0], error[1], error[2]
        );
        let [_, linear, double] = coverage;
        // Layers blended as independent voxels stop a little more light than the
        // correlated rings do (chapter 6.6.2): a margin of a quarter.
        assert!((double - truth).abs() < 0.25 * truth, "{size} px: double mipmaps should keep the coverage: {double} vs {truth}");
        assert!(error[2] <= error[1] + 0.01, "{size} px: double mipmaps as close per pixel as averaged ones: {error:?}");
        if size <= 64 {
            assert!(linear < 0.5 * truth, "{size} px: averaged mipmaps should make the rings vanish: {linear} vs {truth}");
            assert!(error[2] < error[0], "{size} px: double mipmaps should alias less than the full texture: {error:?}");
        }
    }
}

#[test]
fn close_views_are_the_full_resolution_renderer() {
    // Where a texel covers more than a pixel every mipmap mode reads the finest level
    // and the transparency chain is empty there: the same image as without mipmaps.
    let tex = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
    let scene = scene(&tm::icosphere(2), 0.05, tex);
    let close = perspective(Vec3::new(1.2, -3.0, 1.5), Vec3::new(0.35, -0.85, 0.45), 0.05, 96);
    let mut r = renderer();
    let off = r.render(&scene, &close, &slice_params(16, SliceMode::Interpolating)).unwrap();
    assert!(off.coverage() > 0.1);
    for mipmaps in [Mipmaps::Linear, Mipmaps::Double] {
        let params = SliceParams { mipmaps, ..slice_params(16, SliceMode::Interpolating) };
        let frame = r.render(&scene, &close, &params).unwrap();
        assert!(frame.rgba == off.rgba && frame.depth == off.depth, "{mipmaps:?} differs from the full-resolution image");
    }
}

#[test]
fn united_layers_keep_far_views_too() {
    // Two layers (chain mail, and bubbles shifted by (0.3, 0.1) in a texture of another
    // size): the transparency chain is built from their union resampled on one grid.
    let mail = Generator::new(Pattern::ChainMail).generate([64, 64, 32]).unwrap();
    let mut scene = scene(&tm::icosphere(2), 0.05, mail);
    let bubbles = Generator::new(Pattern::Bubbles).generate([32, 32, 16]).unwrap();
    scene.textures.push(TextureLayer { texture: bubbles, offset: Vec2::new(0.3, 0.1) });
    let view = |size: u32| perspective(Vec3::new(0.35, -0.85, 0.4).normalize() * 4.0, Vec3::ZERO, 0.55, size);
    let (truth, coverage, error) = far_view_coverage(&scene, view, 32, 16);
    eprintln!("united layers, 32 px: truth {truth:.3}, off / linear / double {coverage:?}, pixel error {error:?}");
    let [_, linear, double] = coverage;
    assert!((double - truth).abs() < 0.25 * truth, "{double} vs {truth}");
    assert!(linear < double && error[2] < error[1], "{coverage:?} {error:?}");
}

/// Regions and holes (per-vertex effects) drawn by the slice renderer as the bake and
/// the reference apply them (`texture::bake::Effects`): the texture cut away where the
/// holes are, the base slab where the region is not. Each effect changes the image.
#[test]
fn regions_and_holes_match_the_reference() {
    use thicket_core::texture::{BakeParams, TexturedShell};
    let mesh = tm::icosphere(3);
    let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let slab = VolumeTexture::from_fn([8, 8, 17], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
    let layers = layer(slab);
    let upper: Vec<f32> = mesh.positions().iter().map(|p| if p.z > 0.2 { 1.0 } else { 0.0 }).collect();
    let camera = perspective(Vec3::new(0.4, -4.0, 0.6), Vec3::ZERO, 0.8, 96);
    let plain = ShellScene::new(&mesh, &shell, layers.clone(), 1.0).unwrap();
    let mut r = renderer();
    let plain_frame = r.render(&plain, &camera, &slice_params(16, SliceMode::Interpolating)).unwrap();
    let cases = [
        ("holes", BakeParams { holes: Some(upper.clone()), ..Default::default() }),
        ("region", BakeParams { region: Some(upper.iter().map(|w| 1.0 - w).collect()), ..Default::default() }),
        ("holes and region", BakeParams { holes: Some(upper.iter().map(|w| 0.5 * w).collect()), region: Some(vec![0.6; upper.len()]), ..Default::default() }),
    ];
    for (name, params) in cases {
        let scene = ShellScene::of(&TexturedShell::new(mesh.clone(), shell.clone(), layers.clone(), params).unwrap()).unwrap();
        let reference = reference::render(&scene, &camera, &RenderParams { step: 0.02, ..Default::default() }).unwrap();
        let frame = r.render(&scene, &camera, &slice_params(16, SliceMode::Interpolating)).unwrap();
        let s = score(&frame, &reference);
        let unchanged = score(&plain_frame, &reference);
        eprintln!("{name}: {s:?}; the plain image against it: {unchanged:?}");
        assert!(s.iou > 0.97 && s.psnr > 22.0, "{name}: {s:?}");
        assert!(unchanged.iou < s.iou - 0.02, "{name}: the effect must show: {unchanged:?} vs {s:?}");
    }
}

/// A cutter and a moved region drawn by the slice renderer as the bake and the
/// reference apply them: the cutter's own inside test (its triangles in their bins),
/// the moved region's mask from the same raster the CPU reads.
/// Each effect changes the image, and the renderer follows it.
#[test]
fn cutter_and_moved_region_match_the_reference() {
    use thicket_core::texture::bake::{Cutter, MovedRegion};
    use thicket_core::texture::{BakeParams, TexturedShell};
    let params = slice_params(16, SliceMode::Interpolating);
    let mut r = renderer();
    let check = |r: &mut GpuRenderer, name: &str, scene: ShellScene, plain: &ShellScene, camera: &Camera, iou: f32| {
        let reference = reference::render(&scene, camera, &RenderParams { step: 0.02, ..Default::default() }).unwrap();
        let frame = r.render(&scene, camera, &params).unwrap();
        let s = score(&frame, &reference);
        let unchanged = score(&r.render(plain, camera, &params).unwrap(), &reference);
        eprintln!("{name}: {s:?}; the plain image against it: {unchanged:?}");
        assert!(s.iou > iou && s.psnr > 22.0, "{name}: {s:?}");
        assert!(unchanged.iou < s.iou - 0.05, "{name}: the effect must show: {unchanged:?} vs {s:?}");
    };
    // A box cutting away the sphere's shell beyond x = 0.3.
    let mesh = tm::icosphere(3);
    let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
    let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let slab = layer(VolumeTexture::from_fn([8, 8, 17], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap());
    let corners: Vec<Vec3> =
        (0..8).map(|i| Vec3::new(if i & 1 == 0 { -2.0 } else { 0.3 }, if i & 2 == 0 { -2.0 } else { 2.0 }, if i & 4 == 0 { -2.0 } else { 2.0 })).collect();
    let faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let tris: Vec<[u32; 3]> = faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect();
    let cut = BakeParams { cutter: Some(Cutter::new(&corners, &tris).unwrap()), ..Default::default() };
    let plain = ShellScene::new(&mesh, &shell, slab.clone(), 1.0).unwrap();
    let scene = ShellScene::of(&TexturedShell::new(mesh.clone(), shell.clone(), slab.clone(), cut).unwrap()).unwrap();
    let camera = perspective(Vec3::new(0.4, -4.0, 0.6), Vec3::ZERO, 0.8, 96);
    check(&mut r, "cutter", scene, &plain, &camera, 0.99);
    // Stripes along s on a plane seen from above, those over x < 0 moved by a quarter
    // period.
    let grid = tm::plane(12);
    let uvs: Vec<Vec2> = grid.corners().iter().map(|&v| grid.positions()[v as usize].truncate() * 0.5 + 0.5).collect();
    let grid = thicket_core::Mesh::new(grid.positions().to_vec(), &grid.face_sizes(), grid.corners().to_vec(), Some(uvs)).unwrap();
    let t = Thickness::relative(0.05).per_vertex(&grid, None).unwrap();
    let shell = build_shell(&grid, &t, Side::Exterior, &ShellParams::default()).unwrap();
    let stripes = layer(VolumeTexture::from_fn([16, 16, 9], |c| if c.x < 0.5 && c.z < 0.6 { 1.0 } else { 0.0 }).unwrap());
    let left: Vec<f32> = grid.positions().iter().map(|p| if p.x < -0.05 { 1.0 } else { 0.0 }).collect();
    let moved = BakeParams { tiling: 3.0, moved: Some(MovedRegion { weights: left, offset: Vec2::new(0.25 / 3.0, 0.0) }), ..Default::default() };
    let plain = ShellScene::new(&grid, &shell, stripes.clone(), 3.0).unwrap();
    let scene = ShellScene::of(&TexturedShell::new(grid.clone(), shell.clone(), stripes.clone(), moved).unwrap()).unwrap();
    let camera = perspective(Vec3::new(0.0, -0.3, 3.0), Vec3::ZERO, 0.7, 96);
    check(&mut r, "moved region", scene, &plain, &camera, 0.95);
}
