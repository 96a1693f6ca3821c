//! A preview of a textured shell by the method asked for: the policy every caller
//! shares (the Blender add-on through the binding, Rust tools), so they name methods
//! alike and fall back alike. `Auto` draws with the GPU slice renderer (interpolating
//! slices, chapter 5) and, where no GPU can draw, with the CPU reference renderer,
//! saying why; a method that names the slice renderer fails instead of falling back.
//! The process keeps one GPU renderer, made on first use.

use crate::gpu::{GpuRenderer, SliceMode, SliceParams};
use crate::mipmap::Mipmaps;
use crate::reference::{render_watched, RenderParams};
use crate::{Camera, Frame, ShellScene};
use std::sync::Mutex;
use thicket_core::progress::Progress;
use thicket_core::{Error, Result};

/// Which renderer draws a preview.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RenderMethod {
    /// Interpolating slices on the GPU, the CPU reference where there is no GPU.
    Auto,
    /// The slice renderer's two-pass slice interpolation (chapter 5.2).
    Interpolating,
    /// The slice renderer's plain slices (chapter 5.1).
    Plain,
    /// The CPU reference ray marcher.
    Reference,
}

impl RenderMethod {
    pub const ALL: [RenderMethod; 4] = [RenderMethod::Auto, RenderMethod::Interpolating, RenderMethod::Plain, RenderMethod::Reference];

    pub fn name(self) -> &'static str {
        match self {
            RenderMethod::Auto => "auto",
            RenderMethod::Interpolating => "interpolating",
            RenderMethod::Plain => "plain",
            RenderMethod::Reference => "reference",
        }
    }

    /// `"auto"`, `"interpolating"`, `"plain"` or `"reference"`.
    pub fn parse(s: &str) -> Result<Self> {
        Self::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<_> = Self::ALL.iter().map(|m| m.name()).collect();
            Error::InvalidParameter(format!("unknown render method {s:?}; one of {}", names.join(", ")))
        })
    }

    /// The slice renderer's mode, or `None` for the reference renderer.
    pub fn slice_mode(self) -> Option<SliceMode> {
        match self {
            RenderMethod::Auto | RenderMethod::Interpolating => Some(SliceMode::Interpolating),
            RenderMethod::Plain => Some(SliceMode::Plain),
            RenderMethod::Reference => None,
        }
    }
}

impl Mipmaps {
    pub fn name(self) -> &'static str {
        match self {
            Mipmaps::Double => "double",
            Mipmaps::Linear => "linear",
            Mipmaps::Off => "off",
        }
    }

    /// `"double"`, `"linear"` or `"off"`.
    pub fn parse(s: &str) -> Result<Self> {
        [Mipmaps::Double, Mipmaps::Linear, Mipmaps::Off]
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| Error::InvalidParameter(format!("unknown mipmaps {s:?}; one of double, linear, off")))
    }
}

/// A drawn preview: the frame, which renderer drew it, and why the GPU did not where
/// `Auto` fell back (empty otherwise).
#[derive(Debug, Clone)]
pub struct Preview {
    pub frame: Frame,
    pub renderer: String,
    pub fallback: String,
}

/// How to draw: the method, the slice renderer's settings (its mode is the
/// method's) and the reference renderer's.
#[derive(Debug, Clone, Copy)]
pub struct PreviewParams {
    pub method: RenderMethod,
    pub slices: SliceParams,
    pub reference: RenderParams,
}

impl PreviewParams {
    /// Settings out of range are the caller's error, not a reason to fall back.
    pub fn validate(&self) -> Result<()> {
        match self.method.slice_mode() {
            Some(mode) => SliceParams { mode, ..self.slices }.validate(),
            None => Ok(()),
        }
    }
}

/// Draws `scene` from `camera` as `params` says, on the process's GPU renderer; the
/// reference renderer's rows are watched by `watch` (a GPU frame is one step, and a
/// frame cancelled while the GPU drew it is dropped: [`Error::Cancelled`]).
pub fn render_preview(scene: &ShellScene, camera: &Camera, params: &PreviewParams, watch: Option<&Progress>) -> Result<Preview> {
    render_preview_with(scene, camera, params, watch, render_on_shared_gpu)
}

/// [`render_preview`] with the GPU step given: `gpu` draws with the slice renderer and
/// names its adapter, or says why it cannot.
pub fn render_preview_with(
    scene: &ShellScene,
    camera: &Camera,
    params: &PreviewParams,
    watch: Option<&Progress>,
    gpu: impl FnOnce(&ShellScene, &Camera, &SliceParams) -> std::result::Result<(Frame, String), String>,
) -> Result<Preview> {
    params.validate()?;
    let reference = |fallback: String| -> Result<Preview> {
        Ok(Preview { frame: render_watched(scene, camera, &params.reference, watch)?, renderer: "CPU reference renderer".into(), fallback })
    };
    let preview = match params.method.slice_mode() {
        None => reference(String::new())?,
        Some(mode) => match gpu(scene, camera, &SliceParams { mode, ..params.slices }) {
            Ok((frame, adapter)) => Preview { frame, renderer: format!("GPU slice renderer on {adapter}"), fallback: String::new() },
            Err(why) if params.method == RenderMethod::Auto => {
                reference(format!("the GPU slice renderer is unavailable ({why}); rendered on the CPU instead"))?
            }
            Err(why) => return Err(Error::Device(format!("the GPU slice renderer failed: {why}"))),
        },
    };
    if watch.is_some_and(Progress::is_cancelled) {
        return Err(Error::Cancelled);
    }
    Ok(preview)
}

/// The process's GPU renderer: created on first use; its creation error is kept (no
/// adapter does not appear later), a lost device is dropped so the next call retries.
static GPU: Mutex<Option<std::result::Result<GpuRenderer, String>>> = Mutex::new(None);

/// Draws with the process's slice renderer and names its adapter, or says why not.
pub fn render_on_shared_gpu(scene: &ShellScene, camera: &Camera, params: &SliceParams) -> std::result::Result<(Frame, String), String> {
    let mut gpu = GPU.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if gpu.is_none() {
        *gpu = Some(GpuRenderer::new().map_err(|e| e.to_string()));
    }
    let renderer = match gpu.as_mut().expect("set above") {
        Ok(r) => r,
        Err(e) => return Err(e.clone()),
    };
    let name = renderer.adapter_name();
    match renderer.render(scene, camera, params) {
        Ok(frame) => Ok((frame, name)),
        Err(e) => {
            *gpu = None;
            Err(e.to_string())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec2, Vec3};
    use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
    use thicket_core::testmeshes as tm;
    use thicket_core::texture::{TextureLayer, VolumeTexture};

    fn scene_and_camera() -> (ShellScene, Camera) {
        let mesh = tm::icosphere(1);
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let slab = VolumeTexture::from_fn([4, 4, 9], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
        let scene = ShellScene::new(&mesh, &shell, vec![TextureLayer { texture: slab, offset: Vec2::ZERO }], 1.0).unwrap();
        let view = Mat4::look_at_rh(Vec3::new(0.0, -4.0, 0.0), Vec3::ZERO, Vec3::Z);
        (scene, Camera::new(view, Mat4::perspective_rh_gl(0.8, 1.0, 0.1, 50.0), 24, 24).unwrap())
    }

    fn params(method: RenderMethod) -> PreviewParams {
        PreviewParams { method, slices: SliceParams::default(), reference: RenderParams::default() }
    }

    #[test]
    fn methods_and_mipmaps_parse_by_name_and_name_the_choices_otherwise() {
        for m in RenderMethod::ALL {
            assert_eq!(RenderMethod::parse(m.name()).unwrap(), m);
        }
        let err = RenderMethod::parse("raytrace").unwrap_err().to_string();
        assert!(err.contains("auto, interpolating, plain, reference"), "{err}");
        for m in [Mipmaps::Double, Mipmaps::Linear, Mipmaps::Off] {
            assert_eq!(Mipmaps::parse(m.name()).unwrap(), m);
        }
        assert!(Mipmaps::parse("trilinear").is_err());
        assert_eq!(RenderMethod::Plain.slice_mode(), Some(SliceMode::Plain));
        assert_eq!(RenderMethod::Reference.slice_mode(), None);
    }

    #[test]
    fn auto_falls_back_to_the_reference_saying_why_and_a_named_gpu_method_fails() {
        let (scene, camera) = scene_and_camera();
        let no_gpu = |_: &ShellScene, _: &Camera, _: &SliceParams| Err("no adapter".to_string());
        let auto = render_preview_with(&scene, &camera, &params(RenderMethod::Auto), None, no_gpu).unwrap();
        assert_eq!(auto.renderer, "CPU reference renderer");
        assert!(auto.fallback.contains("no adapter"), "{}", auto.fallback);
        assert!(auto.frame.rgba.iter().any(|c| c.w > 0.5), "the sphere is drawn");
        for method in [RenderMethod::Interpolating, RenderMethod::Plain] {
            let err = render_preview_with(&scene, &camera, &params(method), None, no_gpu).unwrap_err();
            assert!(matches!(err, Error::Device(ref m) if m.contains("no adapter")), "{err}");
        }
        // The reference never asks the GPU; a GPU that draws is named, in the method's mode.
        let must_not_run = |_: &ShellScene, _: &Camera, _: &SliceParams| -> std::result::Result<(Frame, String), String> { panic!("asked the GPU") };
        let reference = render_preview_with(&scene, &camera, &params(RenderMethod::Reference), None, must_not_run).unwrap();
        assert_eq!((reference.renderer.as_str(), reference.fallback.as_str()), ("CPU reference renderer", ""));
        let mut seen = None;
        let fake = |_: &ShellScene, _: &Camera, p: &SliceParams| {
            seen = Some(p.mode);
            Ok((reference.frame.clone(), "Test Adapter".to_string()))
        };
        let drawn = render_preview_with(&scene, &camera, &params(RenderMethod::Plain), None, fake).unwrap();
        assert_eq!((drawn.renderer.as_str(), seen), ("GPU slice renderer on Test Adapter", Some(SliceMode::Plain)));
        // Bad settings are refused before any renderer runs, not fallen back from.
        let bad = PreviewParams { slices: SliceParams { slices: 0, ..SliceParams::default() }, ..params(RenderMethod::Auto) };
        assert!(matches!(render_preview_with(&scene, &camera, &bad, None, must_not_run), Err(Error::InvalidParameter(_))));
        // A cancelled watch drops the frame: the reference's, and a GPU frame drawn while
        // the cancel came.
        let watch = Progress::default();
        watch.cancel();
        assert!(matches!(render_preview_with(&scene, &camera, &params(RenderMethod::Auto), Some(&watch), no_gpu), Err(Error::Cancelled)));
        let drawn_anyway = |_: &ShellScene, _: &Camera, _: &SliceParams| Ok((reference.frame.clone(), "Test Adapter".to_string()));
        assert!(matches!(render_preview_with(&scene, &camera, &params(RenderMethod::Plain), Some(&watch), drawn_anyway), Err(Error::Cancelled)));
    }
}
