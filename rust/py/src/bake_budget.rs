//! Tiles grown to a bake's triangle budget: the core's `texture::bake::budget_scale`
//! and `texture::charts::budget_tile_size`, adapted.

use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;
use thicket_core::progress::Progress;
use thicket_core::texture::bake::BudgetFit;

use crate::errors::{run_detached, run_watched, InvalidInput};
use crate::texture::{BakeInputs, ShellArrays};

/// `work` with the GIL released, watched by `progress` (a callable, as `bake_texture`'s)
/// when given: `work` gets the core's progress to report to and stop by.
pub(crate) fn watched<T: Send>(
    py: Python<'_>,
    progress: Option<Bound<'_, PyAny>>,
    work: impl FnOnce(Option<Arc<Progress>>) -> thicket_core::Result<T> + Send,
) -> PyResult<T> {
    match progress {
        Some(callback) => {
            let watch = Arc::new(Progress::default());
            let given = watch.clone();
            run_watched(py, &callback, &watch, move || work(Some(given)))
        }
        None => run_detached(py, move || work(None)),
    }
}

/// A search's result as `fit_bake_tiles` and `TexturedShell.fit_budget` return it.
pub(crate) fn fit_dict<'py>(py: Python<'py>, fit: BudgetFit, tile_size: Option<f32>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("scale", fit.scale)?;
    d.set_item("tile_size", tile_size)?;
    d.set_item("triangles", fit.estimate.triangles)?;
    d.set_item("sampled", fit.estimate.sampled)?;
    d.set_item("fits", fit.fits)?;
    d.set_item("below", fit.below)?;
    d.set_item("estimates", (fit.estimates[0], fit.estimates[1]))?;
    Ok(d)
}

/// fit_bake_tiles(vertices, face_sizes, corners, base_offset, directors, textures, *,
///                tile_size=None, progress=None, **settings) -> dict
///
/// The tiles at which `bake_texture` with the same arguments is estimated within its
/// `triangle_budget` (the bake's own estimate, `estimate_bake`): the smallest such
/// growth of the tiles to within 5%. With `uvs`: `scale`, the factor the tiles grow
/// by (bake with `tiling / scale`). Without: `tile_size`, the start of World-Size
/// Tiles (`Mesh.with_world_size_uvs`), is required, and the dict's `tile_size` is
/// the fitted one (its start times `scale`). Also `triangles` and `sampled` (the
/// estimate there), `fits` (False: still over at the largest tiles tried), `below`
/// (the largest scale found over the budget, None where the tiles already fit) and
/// `estimates` (quick, full: how many the search made). An estimate fits within 5%
/// over the budget, where the bake would not say it is over. `progress`: as
/// `bake_texture`'s, over the search's estimates; False cancels
/// (thicket_native.Cancelled).
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, base_offset, directors, textures, *, tile_size=None, progress=None, **settings))]
#[allow(clippy::too_many_arguments)]
pub fn fit_bake_tiles<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    base_offset: PyReadonlyArray2<'py, f32>,
    directors: PyReadonlyArray2<'py, f32>,
    textures: &Bound<'py, PyAny>,
    tile_size: Option<f32>,
    progress: Option<Bound<'py, PyAny>>,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let has_uvs = settings.is_some_and(|s| s.get_item("uvs").ok().flatten().is_some_and(|u| !u.is_none()));
    if has_uvs == tile_size.is_some() {
        return Err(InvalidInput::new_err("fit_bake_tiles takes uvs (a UV map's tiles grow) or tile_size (World-Size Tiles grow from it), one of them"));
    }
    let inputs = BakeInputs::of_call("fit_bake_tiles", ShellArrays { vertices, face_sizes, corners, base_offset, directors, textures }, settings, true)?;
    let (size, fit) = watched(py, progress, move |watch| {
        let textured = inputs.build()?;
        let params = thicket_core::texture::BakeParams { progress: watch, ..textured.params.clone() };
        match tile_size {
            Some(start) => {
                thicket_core::texture::charts::budget_tile_size(&textured.mesh, &textured.shell, &textured.layers, &params, start).map(|(s, f)| (Some(s), f))
            }
            None => thicket_core::texture::bake::budget_scale(&textured.mesh, &textured.shell, &textured.layers, &params).map(|f| (None, f)),
        }
    })?;
    fit_dict(py, fit, size)
}
