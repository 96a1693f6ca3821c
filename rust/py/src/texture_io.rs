//! Volumetric textures from and to files: PNG slice stacks and OpenEXR volumes.

use std::path::PathBuf;

use std::sync::Arc;

use numpy::PyArray3;
use pyo3::prelude::*;
use thicket_core::texture::{io, VolumeTexture};

use crate::errors::{run_detached, InvalidInput};
use crate::handles::Texture;
use crate::texture::volume_samples;

/// load_texture(path) -> float32 (nz, ny, nx)
///
/// A volumetric texture from a folder of PNG slices (natural name order, the first is
/// the base r = 0), a .png file (its folder's stack) or a .exr file (save_texture's
/// layout; other EXRs are one slice read from channel A, Y or R). Indexed [r, t, s]
/// like texture(); alpha in [0, 1].
#[pyfunction]
pub fn load_texture<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let t = run_detached(py, move || io::load(&path))?;
    crate::texture::volume_array(py, t)
}

/// save_texture(path, alpha) -> list[str]
///
/// Writes a texture, a float32 (nz, ny, nx) array or a `Texture`: one OpenEXR file
/// when `path` ends in .exr, otherwise 16-bit PNG slices slice_000.png, ... in the
/// folder `path` (created if missing). Returns the paths written.
#[pyfunction]
pub fn save_texture(py: Python<'_>, path: PathBuf, alpha: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    let named = |message: String| InvalidInput::new_err(format!("{}: {message}", path.display()));
    let t = match alpha.cast::<Texture>() {
        Ok(handle) => handle.get().inner.clone(),
        Err(_) => {
            let (dims, data) = volume_samples(alpha).map_err(|_| named("a texture must be a float32 array of shape (nz, ny, nx) or a Texture".into()))?;
            Arc::new(VolumeTexture::new(dims, data).map_err(|e| named(e.to_string()))?)
        }
    };
    let exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    let written = run_detached(py, move || if exr { io::save_exr(&t, &path).map(|()| vec![path]) } else { io::save_png_stack(&t, &path, "slice") })?;
    Ok(written.iter().map(|p| p.display().to_string()).collect())
}
