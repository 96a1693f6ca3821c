//! Rendering volume-textured shells without baking: the GPU slice renderer (one per
//! process, created on first use) with the CPU reference renderer as ground truth and
//! fallback, and the rendered frame written to PNG or OpenEXR.

use numpy::{IntoPyArray, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use thicket_core::glam::{Mat4, Vec3, Vec4};
use thicket_render::gpu::SliceParams;
use thicket_render::mipmap::Mipmaps;
use thicket_render::preview::{render_preview, Preview, PreviewParams, RenderMethod};
use thicket_render::reference::RenderParams;
use thicket_render::{Camera, Frame, ShellScene};

use crate::errors::{run_detached, run_maybe_watched, to_py, InternalError, InvalidInput};
use crate::keywords::Keywords;
use crate::texture::{BakeInputs, ShellArrays, TextureSettings};

/// Pixels the renderer accepts in one frame (16384 x 16384).
const MAX_PIXELS: u64 = 1 << 28;

/// A 4x4 matrix given row-major (numpy's layout of a Blender `Matrix`: `m[row][col]`),
/// as float32 or float64 numpy or nested sequences; glam stores columns.
fn matrix(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Mat4> {
    let shape_error = || InvalidInput::new_err(format!("{what} must be a 4x4 matrix (numpy float32/float64 or nested lists)"));
    let rows: Vec<f64> = if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, f64>>() {
        if a.shape() != [4, 4] {
            return Err(shape_error());
        }
        // Logical (row-major) order, whatever the memory layout.
        a.as_array().iter().copied().collect()
    } else if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, f32>>() {
        if a.shape() != [4, 4] {
            return Err(shape_error());
        }
        a.as_array().iter().map(|v| *v as f64).collect()
    } else if let Ok(m) = obj.extract::<[[f64; 4]; 4]>() {
        m.iter().flatten().copied().collect()
    } else {
        return Err(shape_error());
    };
    if rows.iter().any(|v| !v.is_finite()) {
        return Err(InvalidInput::new_err(format!("{what} has a non-finite entry")));
    }
    let mut cols = [0.0f32; 16];
    for (c, r) in cols.iter_mut().zip(&rows) {
        *c = *r as f32;
    }
    // Row-major data read as columns is the transpose.
    Ok(Mat4::from_cols_array(&cols).transpose())
}

/// render_shell(vertices, face_sizes, corners, base_offset, directors, textures,
///              view, projection, width, height, *, progress=None, **settings)
///              -> dict
///
/// Renders the alpha = 0.5 iso-surface of volumetric textures mapped into a shell
/// (depth r over vertex v at v + base_offset + r * director) without baking it.
/// `settings` (keywords): how to draw, method="auto", slices=16,
/// light=(0.3, -0.5, 0.8), ambient=0.25, step=0.05, mipmaps="double" (as for
/// `TexturedShell.render`), and `bake_texture`'s settings but `triangle_budget` and
/// `max_triangles` (uvs, tiling, resolution, depth_steps, region, base_layer, holes,
/// cutter, move_region, move_offset, follow_texture): the frame shows what the bake
/// makes of them (partial region, holes, cut and moved texture; the slice renderer
/// draws all four, as the reference does).
/// `method`: "interpolating" or "plain" (the GPU slice renderer of chapter 5, `slices`
/// slices per cell), "reference" (CPU ray marching with exact root bracketing; `step`
/// as a fraction of the mean shell thickness), or "auto" (interpolating slices, the
/// reference when no GPU adapter exists or the device is lost). `mipmaps` (slices
/// only): "double" (chapter 6: far textures become semi-transparent instead of
/// vanishing), "linear" (averaged mipmaps, for comparison) or "off" (the full
/// texture everywhere; the reference always uses it). `textures`: a list
/// of float32 (nz, ny, nx) arrays or (array, (ds, dt)) pairs, united. `view` (world
/// to camera) and `projection` (camera to OpenGL clip space, as
/// `Object.calc_matrix_camera` gives it): 4x4, row-major as `numpy.array(matrix)` of
/// a Blender Matrix. `light`: direction toward the light (world). Returns rgba
/// float32 (height, width, 4) (linear colour, straight alpha, row 0 at the top),
/// depth float32 (height, width) (distance along the view axis, inf where empty),
/// normal float32 (height, width, 3), per_face_tiles, renderer (what drew it) and
/// fallback (why the GPU was not used, or "").
/// `progress`: as for `bake_texture` (rows of the CPU reference; a GPU frame is one
/// step and is not interrupted); returning False cancels with `Cancelled`.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, base_offset, directors, textures, view, projection, width, height, *, progress=None, **settings))]
#[allow(clippy::too_many_arguments)]
pub fn render_shell<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    base_offset: PyReadonlyArray2<'py, f32>,
    directors: PyReadonlyArray2<'py, f32>,
    textures: &Bound<'py, PyAny>,
    view: &Bound<'py, PyAny>,
    projection: &Bound<'py, PyAny>,
    width: u32,
    height: u32,
    progress: Option<Bound<'py, PyAny>>,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    // The bake's own inputs: the preview applies the same region, holes, cutter and
    // moved region as the bake (`thicket_core::texture::bake::effects`).
    let keywords = Keywords::new("render_shell", settings);
    let texture = TextureSettings::read(&keywords, false)?;
    let frame = FrameSettings::read(&keywords)?;
    keywords.finish()?;
    let inputs = BakeInputs::read(ShellArrays { vertices, face_sizes, corners, base_offset, directors, textures }, texture)?;
    let request = FrameRequest::read(view, projection, width, height, frame)?;
    let (preview, per_face_tiles) = run_maybe_watched(py, progress.as_ref(), move |watch| {
        let scene = inputs.run(ShellScene::of)?;
        Ok((request.render(&scene, watch)?, scene.per_face_tiles))
    })?;
    frame_dict(py, preview, per_face_tiles)
}

/// How to draw a frame: the keyword arguments that `render_shell` and
/// `TexturedShell.render` share, each named here once with its default (the stub's
/// `_FrameSettings`).
pub(crate) struct FrameSettings {
    method: String,
    slices: u32,
    light: (f32, f32, f32),
    ambient: f32,
    step: f32,
    mipmaps: String,
}

impl FrameSettings {
    pub(crate) fn read(keywords: &Keywords<'_, '_>) -> PyResult<Self> {
        Ok(Self {
            method: keywords.get("method", "auto".to_owned())?,
            slices: keywords.get("slices", 16)?,
            light: keywords.get("light", (0.3, -0.5, 0.8))?,
            ambient: keywords.get("ambient", 0.25)?,
            step: keywords.get("step", 0.05)?,
            mipmaps: keywords.get("mipmaps", "double".to_owned())?,
        })
    }
}

/// A frame asked for: the camera and how to draw, checked before any work.
pub(crate) struct FrameRequest {
    view: Mat4,
    projection: Mat4,
    width: u32,
    height: u32,
    params: PreviewParams,
}

impl FrameRequest {
    pub(crate) fn read(view: &Bound<'_, PyAny>, projection: &Bound<'_, PyAny>, width: u32, height: u32, settings: FrameSettings) -> PyResult<Self> {
        let FrameSettings { method, slices, light, ambient, step, mipmaps } = settings;
        let mipmaps = Mipmaps::parse(&mipmaps).map_err(to_py)?;
        let method = RenderMethod::parse(&method).map_err(to_py)?;
        let view = matrix(view, "view")?;
        let projection = matrix(projection, "projection")?;
        if width as u64 * height as u64 > MAX_PIXELS {
            return Err(InvalidInput::new_err(format!("{width}x{height} pixels are too many for one frame")));
        }
        let light = Vec3::new(light.0, light.1, light.2);
        let params = PreviewParams {
            method,
            slices: SliceParams { slices, light, ambient, mipmaps, ..Default::default() },
            reference: RenderParams { step, light, ambient, ..Default::default() },
        };
        // Bad settings are the caller's error, not a reason to fall back to the CPU.
        params.validate().map_err(to_py)?;
        Ok(Self { view, projection, width, height, params })
    }

    /// Draws `scene` (the slice renderer draws every effect the bake applies: region,
    /// holes, cutter, moved region, as the reference does).
    pub(crate) fn render(&self, scene: &ShellScene, watch: Option<&thicket_core::progress::Progress>) -> thicket_core::Result<Preview> {
        let camera = Camera::new(self.view, self.projection, self.width, self.height)?;
        render_preview(scene, &camera, &self.params, watch)
    }
}

/// A drawn frame as `render_shell` returns it.
pub(crate) fn frame_dict(py: Python<'_>, preview: Preview, per_face_tiles: bool) -> PyResult<Bound<'_, PyDict>> {
    let Preview { frame, renderer, fallback } = preview;
    let (w, h) = (frame.width as usize, frame.height as usize);
    let shaped = |data: Vec<f32>, channels: usize| {
        let flat = numpy::ndarray::Array1::from_vec(data);
        flat.into_shape_with_order((h, w, channels)).map_err(|e| InternalError::new_err(e.to_string()))
    };
    let rgba = shaped(frame.rgba.iter().flat_map(|c| c.to_array()).collect(), 4)?;
    let normal = shaped(frame.normal.iter().flat_map(|c| c.to_array()).collect(), 3)?;
    let depth = numpy::ndarray::Array1::from_vec(frame.depth).into_shape_with_order((h, w)).map_err(|e| InternalError::new_err(e.to_string()))?;
    let d = PyDict::new(py);
    d.set_item("rgba", rgba.into_pyarray(py))?;
    d.set_item("depth", depth.into_pyarray(py))?;
    d.set_item("normal", normal.into_pyarray(py))?;
    d.set_item("per_face_tiles", per_face_tiles)?;
    d.set_item("renderer", renderer)?;
    d.set_item("fallback", fallback)?;
    Ok(d)
}

/// save_render(path, rgba, depth=None, normal=None)
///
/// Writes a rendered frame (arrays as `render_shell` returns them, row 0 at the top):
/// an OpenEXR file with R, G, B, A, Z and N.X, N.Y, N.Z channels when `path` ends in
/// .exr, else an 8-bit sRGB PNG.
#[pyfunction]
#[pyo3(signature = (path, rgba, depth=None, normal=None))]
pub fn save_render(
    py: Python<'_>,
    path: std::path::PathBuf,
    rgba: numpy::PyReadonlyArray3<'_, f32>,
    depth: Option<PyReadonlyArray2<'_, f32>>,
    normal: Option<numpy::PyReadonlyArray3<'_, f32>>,
) -> PyResult<()> {
    let shape = rgba.shape().to_vec();
    if shape[2] != 4 || shape[0] == 0 || shape[1] == 0 {
        return Err(InvalidInput::new_err("rgba must be a float32 (height, width, 4) array"));
    }
    let (h, w) = (shape[0], shape[1]);
    let mut frame = Frame::empty(w as u32, h as u32);
    // Read in logical order straight into the frame (one pass, no intermediate copy).
    frame.rgba = rgba.as_array().rows().into_iter().map(|p| Vec4::new(p[0], p[1], p[2], p[3])).collect();
    if let Some(d) = depth {
        if d.shape() != [h, w] {
            return Err(InvalidInput::new_err("depth must be (height, width)"));
        }
        frame.depth = d.as_array().iter().copied().collect();
    }
    if let Some(n) = normal {
        if n.shape() != [h, w, 3] {
            return Err(InvalidInput::new_err("normal must be (height, width, 3)"));
        }
        frame.normal = n.as_array().rows().into_iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
    }
    let exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    run_detached(py, move || if exr { frame.save_exr(&path) } else { frame.save_png(&path) })
}
