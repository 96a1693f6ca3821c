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
use crate::keywords::Keywords;
use crate::render::{frame_dict, FrameRequest, FrameSettings};
use crate::texture::{baked_dict, BakeInputs, ShellArrays};

/// TexturedShell(vertices, face_sizes, corners, base_offset, directors, textures,
///               **settings)
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

impl TexturedShell {
    /// The textured shell of checked inputs (the cutter built with the GIL released).
    pub(crate) fn of_inputs(py: Python<'_>, inputs: BakeInputs) -> PyResult<Self> {
        let inner = run_detached(py, move || inputs.build())?;
        Ok(Self { inner: Arc::new(inner), scene: Arc::new(Mutex::new(None)) })
    }
}

#[pymethods]
impl TexturedShell {
    #[new]
    #[pyo3(signature = (vertices, face_sizes, corners, base_offset, directors, textures, **settings))]
    #[allow(clippy::too_many_arguments)]
    fn new<'py>(
        py: Python<'py>,
        vertices: PyReadonlyArray2<'py, f32>,
        face_sizes: &Bound<'py, PyAny>,
        corners: &Bound<'py, PyAny>,
        base_offset: PyReadonlyArray2<'py, f32>,
        directors: PyReadonlyArray2<'py, f32>,
        textures: &Bound<'py, PyAny>,
        settings: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Self> {
        let inputs = BakeInputs::of_call("TexturedShell", ShellArrays { vertices, face_sizes, corners, base_offset, directors, textures }, settings, true)?;
        Self::of_inputs(py, inputs)
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

    /// fit_budget(progress=None) -> dict: `fit_bake_tiles`'s result for this shell,
    /// whose mesh must have UVs (its own, or generated World-Size Tiles: their tile
    /// size grows by `scale` too); `tile_size` is None.
    #[pyo3(signature = (progress=None))]
    fn fit_budget<'py>(&self, py: Python<'py>, progress: Option<Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyDict>> {
        let inner = self.inner.clone();
        let fit = crate::bake_budget::watched(py, progress, move |watch| inner.budget_fit(watch))?;
        crate::bake_budget::fit_dict(py, fit, None)
    }

    /// render(view, projection, width, height, *, progress=None, **settings) -> dict:
    /// `render_shell`'s frame of this shell. `settings`: how to draw (keywords),
    /// method="auto", slices=16, light=(0.3, -0.5, 0.8), ambient=0.25, step=0.05,
    /// mipmaps="double" (see `render_shell`).
    #[pyo3(signature = (view, projection, width, height, *, progress=None, **settings))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        view: &Bound<'py, PyAny>,
        projection: &Bound<'py, PyAny>,
        width: u32,
        height: u32,
        progress: Option<Bound<'py, PyAny>>,
        settings: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let keywords = Keywords::new("TexturedShell.render", settings);
        let frame = FrameSettings::read(&keywords)?;
        keywords.finish()?;
        let request = FrameRequest::read(view, projection, width, height, frame)?;
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
