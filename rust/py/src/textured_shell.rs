//! A textured shell kept in Rust: read from numpy and checked once, then baked,
//! estimated and rendered as often as wanted without passing the arrays again
//! (the add-on estimates and bakes one, a live preview renders one frame after frame).

use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Arc, Mutex};
use thicket_core::progress::Progress;
use thicket_core::texture::TexturedShell as Core;
use thicket_render::ShellScene;

use crate::errors::{run_detached, run_maybe_watched, run_watched};
use crate::render::{frame_dict, FrameRequest};
use crate::texture::{baked_dict, BakeInputs};

/// TexturedShell(vertices, face_sizes, corners, base_offset, directors, textures,
///               uvs=None, tiling=1.0, resolution=8, layers=16, region=None,
///               base_layer=0.1, holes=None, cutter=None, move_region=None,
///               move_offset=(0.0, 0.0), follow_texture=True,
///               triangle_budget=1_000_000, max_triangles=20_000_000)
///
/// The arguments of `bake_texture` (without `progress`), read and checked once (with
/// the GIL released): bad input raises here. `bake()`, `estimate()` and `render(...)`
/// then give what `bake_texture`, `estimate_bake` and `render_shell` give for the same
/// arguments; the renderers' scene is made on the first `render` and kept.
#[pyclass(module = "thicket_native", frozen)]
pub struct TexturedShell {
    inner: Arc<Core>,
    scene: Arc<Mutex<Option<Arc<ShellScene>>>>,
}

#[pymethods]
impl TexturedShell {
    #[new]
    #[pyo3(signature = (vertices, face_sizes, corners, base_offset, directors, textures, uvs=None, tiling=1.0, resolution=8, layers=16, region=None, base_layer=0.1, holes=None, cutter=None, move_region=None, move_offset=(0.0, 0.0), follow_texture=true, triangle_budget=1_000_000, max_triangles=20_000_000))]
    #[allow(clippy::too_many_arguments)]
    fn new<'py>(
        py: Python<'py>,
        vertices: PyReadonlyArray2<'py, f32>,
        face_sizes: &Bound<'py, PyAny>,
        corners: &Bound<'py, PyAny>,
        base_offset: PyReadonlyArray2<'py, f32>,
        directors: PyReadonlyArray2<'py, f32>,
        textures: &Bound<'py, PyAny>,
        uvs: Option<PyReadonlyArray2<'py, f32>>,
        tiling: f32,
        resolution: u32,
        layers: u32,
        region: Option<&Bound<'py, PyAny>>,
        base_layer: f32,
        holes: Option<&Bound<'py, PyAny>>,
        cutter: Option<(PyReadonlyArray2<'py, f32>, Bound<'py, PyAny>)>,
        move_region: Option<&Bound<'py, PyAny>>,
        move_offset: (f32, f32),
        follow_texture: bool,
        triangle_budget: usize,
        max_triangles: usize,
    ) -> PyResult<Self> {
        let inputs = BakeInputs::read(
            &vertices,
            face_sizes,
            corners,
            &base_offset,
            &directors,
            textures,
            uvs.as_ref(),
            (tiling, resolution, layers),
            region,
            base_layer,
            holes,
            cutter.as_ref(),
            move_region,
            move_offset,
            (follow_texture, triangle_budget, max_triangles),
        )?;
        let inner = run_detached(py, move || inputs.build())?;
        Ok(Self { inner: Arc::new(inner), scene: Arc::new(Mutex::new(None)) })
    }

    /// bake(progress=None) -> dict: `bake_texture`'s result for this shell.
    #[pyo3(signature = (progress=None))]
    fn bake<'py>(&self, py: Python<'py>, progress: Option<Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyDict>> {
        let inner = self.inner.clone();
        let out = match progress {
            Some(callback) => {
                let watch = Arc::new(Progress::default());
                let watched = watch.clone();
                run_watched(py, &callback, &watch, move || inner.bake_watched(Some(watched)))?
            }
            None => run_detached(py, move || inner.bake_watched(None))?,
        };
        baked_dict(py, out)
    }

    /// estimate() -> int: `estimate_bake`'s count for this shell.
    fn estimate(&self, py: Python<'_>) -> PyResult<usize> {
        let inner = self.inner.clone();
        run_detached(py, move || Ok(inner.estimate()?.triangles))
    }

    /// render(view, projection, width, height, method="auto", slices=16,
    ///        light=(0.3, -0.5, 0.8), ambient=0.25, step=0.05, mipmaps="double",
    ///        progress=None) -> dict: `render_shell`'s frame of this shell.
    #[pyo3(signature = (view, projection, width, height, method="auto", slices=16, light=(0.3, -0.5, 0.8), ambient=0.25, step=0.05, mipmaps="double", progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        view: &Bound<'py, PyAny>,
        projection: &Bound<'py, PyAny>,
        width: u32,
        height: u32,
        method: &str,
        slices: u32,
        light: (f32, f32, f32),
        ambient: f32,
        step: f32,
        mipmaps: &str,
        progress: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let request = FrameRequest::read(view, projection, width, height, method, slices, light, ambient, step, mipmaps)?;
        let (inner, cache) = (self.inner.clone(), self.scene.clone());
        let (preview, per_face_tiles) = run_maybe_watched(py, progress.as_ref(), move |watch| {
            let kept = cache.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).clone();
            let scene = match kept {
                Some(scene) => scene,
                None => {
                    let scene = Arc::new(ShellScene::of(&inner)?);
                    *cache.lock().unwrap_or_else(|poisoned| poisoned.into_inner()) = Some(scene.clone());
                    scene
                }
            };
            Ok((request.render(&scene, watch)?, scene.per_face_tiles))
        })?;
        frame_dict(py, preview, per_face_tiles)
    }

    /// Vertices of the base mesh.
    #[getter]
    fn vertex_count(&self) -> usize {
        self.inner.mesh.vertex_count()
    }
}
