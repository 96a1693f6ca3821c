//! Volumetric textures from and to files: PNG slice stacks and OpenEXR volumes.

use std::path::PathBuf;

use numpy::{IntoPyArray, PyArray3, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use thicket_core::texture::{io, VolumeTexture};

use crate::errors::{run_detached, InvalidInput};

/// load_texture(path) -> float32 (nz, ny, nx)
///
/// A volumetric texture from a folder of PNG slices (natural name order, the first is
/// the base r = 0), a .png file (its folder's stack) or a .exr file (save_texture's
/// layout; other EXRs are one slice read from channel A, Y or R). Indexed [r, t, s]
/// like texture(); alpha in [0, 1].
#[pyfunction]
pub fn load_texture<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let t = run_detached(py, move || io::load(&path))?;
    let [nx, ny, nz] = t.dims();
    let flat = numpy::ndarray::Array1::from_vec(t.into_samples());
    let arr = flat.into_shape_with_order((nz, ny, nx)).map_err(|e| InvalidInput::new_err(e.to_string()))?;
    Ok(arr.into_pyarray(py))
}

/// save_texture(path, alpha) -> list[str]
///
/// Writes a float32 (nz, ny, nx) texture: one OpenEXR file when `path` ends in .exr,
/// otherwise 16-bit PNG slices slice_000.png, ... in the folder `path` (created if
/// missing). Returns the paths written.
#[pyfunction]
pub fn save_texture(py: Python<'_>, path: PathBuf, alpha: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    let named = |message: String| InvalidInput::new_err(format!("{}: {message}", path.display()));
    let a: PyReadonlyArray3<'_, f32> = alpha.extract().map_err(|_| named("a texture must be a float32 array of shape (nz, ny, nx)".into()))?;
    let shape = a.shape().to_vec();
    // In (nz, ny, nx) order whatever the memory layout (numpy's `as_slice` would also
    // take a Fortran-ordered array as it lies in memory).
    let view = a.as_array();
    let data = view.as_slice().map_or_else(|| view.iter().copied().collect(), <[f32]>::to_vec);
    let t = VolumeTexture::new([shape[2], shape[1], shape[0]], data).map_err(|e| named(e.to_string()))?;
    let exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let written = run_detached(py, move || if exr { io::save_exr(&t, &path).map(|()| vec![path]) } else { io::save_png_stack(&t, &path, "slice") })?;
    Ok(written.iter().map(|p| p.display().to_string()).collect())
}
