//! `IncrementalShell`: a field shell kept between edits of its base mesh (thick
//! surfaces 7.1), for interactive deformation. The core does the work; this class
//! holds it between calls and converts arrays.

use pyo3::prelude::*;
use pyo3::types::PyDict;
use thicket_core::shell::incremental::{IncrementalShell as Core, DEFAULT_TOLERANCE};
use thicket_core::shell::{shell_geometry, ShellOutput, Side, Thickness};

use crate::arrays;
use crate::errors::{run_detached, run_maybe_watched, InvalidInput};
use crate::offset::ShellRequest;
use crate::shell::{params, shell_dict};

/// IncrementalShell(vertices, face_sizes, corners, thickness, side="exterior",
///                  relative=False, factors=None, output="outer", surfaces=None, p=3.0,
///                  tolerance=0.03, progress=None)
///
/// The shell of `shell()`, kept for updates: `update(vertices, factors=None)` moves
/// the base vertices (same faces) and retraces only the directors the change can
/// reach; `result()` returns the same dict as `shell()`. `tolerance` is the largest
/// relative change of the field a kept director may see (0: retrace everything
/// within the field's support). `progress`: the first build's, as in `shell()`.
#[pyclass(module = "thicket_native")]
pub struct IncrementalShell {
    inner: Option<Core>,
    thickness: Thickness,
    output: ShellOutput,
}

impl IncrementalShell {
    fn core(&self) -> PyResult<&Core> {
        self.inner.as_ref().ok_or_else(failed)
    }
    fn core_mut(&mut self) -> PyResult<&mut Core> {
        self.inner.as_mut().ok_or_else(failed)
    }
}

fn failed() -> PyErr {
    InvalidInput::new_err("this IncrementalShell failed in an earlier update; create a new one")
}

#[pymethods]
impl IncrementalShell {
    #[new]
    #[pyo3(signature = (vertices, face_sizes, corners, thickness, side="exterior", relative=false, factors=None, output="outer", surfaces=None, p=3.0, tolerance=DEFAULT_TOLERANCE, progress=None, *, layers=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        vertices: numpy::PyReadonlyArray2<'_, f32>,
        face_sizes: &Bound<'_, PyAny>,
        corners: &Bound<'_, PyAny>,
        thickness: f32,
        side: &str,
        relative: bool,
        factors: Option<&Bound<'_, PyAny>>,
        output: &str,
        surfaces: Option<u32>,
        p: f64,
        tolerance: f64,
        progress: Option<Bound<'_, PyAny>>,
        layers: Option<u32>,
    ) -> PyResult<Self> {
        let surfaces = crate::keywords::renamed_argument(py, "IncrementalShell", ("surfaces", surfaces), ("layers", layers), 1)?;
        if !(tolerance >= 0.0 && tolerance.is_finite()) {
            return Err(InvalidInput::new_err(format!("tolerance must be a finite number >= 0, got {tolerance}")));
        }
        let req = ShellRequest::new(&vertices, face_sizes, corners, thickness, relative, factors, output, surfaces)?;
        let side = Side::parse(side).map_err(crate::errors::to_py)?;
        let (spec, output) = (req.thickness, req.output);
        let mut inner = run_maybe_watched(py, progress.as_ref(), move |watch| {
            let t = req.per_vertex()?;
            Core::new_watched(req.mesh, t, side, params(p), watch)
        })?;
        inner.tolerance = tolerance;
        Ok(Self { inner: Some(inner), thickness: spec, output })
    }

    /// update(vertices, factors=None) -> dict(changed, retraced, kept, rebuilt)
    ///
    /// New positions for all base vertices (float32 (n,3)) and, for a shell with
    /// per-vertex factors, their new values. Errors leave the shell as it was, except
    /// an internal failure (a panic), after which the object refuses further use.
    #[pyo3(signature = (vertices, factors=None))]
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        vertices: numpy::PyReadonlyArray2<'py, f32>,
        factors: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = self.core()?.mesh().vertex_count();
        let positions = arrays::positions(&vertices)?;
        if positions.len() != n {
            return Err(InvalidInput::new_err(format!("{} vertices given for a shell of {n}: the topology changed, build a new shell", positions.len())));
        }
        let factors = factors.map(|f| arrays::per_vertex_or_scalar(f, n, "factors")).transpose()?;
        let rule = self.thickness;
        let mut inner = self.inner.take().expect("checked above");
        // A refused update hands the shell back unchanged; a panic loses it.
        let (inner, stats) = run_detached(py, move || {
            let stats = inner.update_with(&positions, &rule, factors.as_deref());
            Ok((inner, stats))
        })?;
        self.inner = Some(inner);
        let stats = stats.map_err(crate::errors::to_py)?;
        let d = PyDict::new(py);
        d.set_item("changed", stats.changed)?;
        d.set_item("retraced", stats.retraced)?;
        d.set_item("kept", stats.kept)?;
        d.set_item("resettled", stats.resettled)?;
        d.set_item("rebuilt", stats.rebuilt)?;
        d.set_item("field_rebuilt", stats.field_rebuilt)?;
        Ok(d)
    }

    /// result() -> dict: the shell's geometry and per-vertex arrays, as `shell()`.
    fn result<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let core = self.core()?;
        let (mesh, shell, output) = (core.mesh(), core.shell(), self.output);
        let geometry = run_detached(py, move || shell_geometry(mesh, shell, output))?;
        shell_dict(py, geometry, shell.clone())
    }

    /// Number of base vertices.
    #[getter]
    fn vertex_count(&self) -> PyResult<usize> {
        Ok(self.core()?.mesh().vertex_count())
    }

    #[getter]
    fn tolerance(&self) -> PyResult<f64> {
        Ok(self.core()?.tolerance)
    }
    #[setter]
    fn set_tolerance(&mut self, tolerance: f64) -> PyResult<()> {
        if !(tolerance >= 0.0 && tolerance.is_finite()) {
            return Err(InvalidInput::new_err(format!("tolerance must be a finite number >= 0, got {tolerance}")));
        }
        self.core_mut()?.tolerance = tolerance;
        Ok(())
    }
}
