//! Sphere-traced renders of field trees (issue 17): `field_render`, from a tree's JSON
//! and a camera's matrices (the core's `implicit::trace`).

use numpy::{IntoPyArray, PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use thicket_core::glam::DMat4;
use thicket_core::implicit::trace::{render, Camera};
use thicket_core::implicit::FieldTree;
use thicket_render::field::render_rgba_on_shared_gpu;

use crate::errors::{run_detached, InvalidInput};

/// A 4x4 matrix given as four rows of four numbers (a `mathutils.Matrix`, nested
/// sequences, a numpy array).
fn matrix(value: &Bound<'_, PyAny>, name: &str) -> PyResult<DMat4> {
    let bad = || InvalidInput::new_err(format!("{name} must be a 4x4 matrix (four rows of four numbers)"));
    // Iterated rather than extracted as a sequence: numpy arrays and mathutils
    // matrices are iterable but not registered as `collections.abc.Sequence`.
    let numbers =
        |row: Bound<'_, PyAny>| -> PyResult<Vec<f64>> { row.try_iter().map_err(|_| bad())?.map(|v| v?.extract::<f64>().map_err(|_| bad())).collect() };
    let rows: Vec<Vec<f64>> = value.try_iter().map_err(|_| bad())?.map(|row| numbers(row?)).collect::<PyResult<_>>()?;
    if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
        return Err(bad());
    }
    let rows: [[f64; 4]; 4] = std::array::from_fn(|i| std::array::from_fn(|j| rows[i][j]));
    // Rows in, glam's columns: the transpose.
    Ok(DMat4::from_cols_array_2d(&rows).transpose())
}

/// field_render(tree_json, view, projection, width=512, height=512, device="cpu") -> ndarray
///
/// The field tree `tree_json` (a JSON string; schema: thicket_core::implicit)
/// sphere-traced as a camera sees it: `view` the world-to-camera matrix
/// (`cam.matrix_world.inverted()`), `projection` the camera-to-clip matrix
/// (`cam.calc_matrix_camera(depsgraph, x=width, y=height)`; perspective or
/// orthographic), both 4x4 (rows). Returns float32 (height, width, 4): linear RGBA,
/// rows top to bottom (flip them for `Image.pixels`, which start at the bottom), the
/// tree's colours under a headlight, alpha 0 where nothing is hit. A bad tree, a size
/// below 1 or above 16384, or a non-invertible camera raises InvalidInput (a
/// ThicketError) saying what is wrong. `device`: "cpu" (the CPU tracer, in double
/// precision), "gpu" (the wgpu tracer, the same rays, steps and shading in single
/// precision, colours returned through half precision; DeviceError without an adapter, InvalidInput for a tree deeper than
/// its stack of 16 results) or "auto" (a hardware GPU, falling back to the CPU where
/// there is none, the only adapter is a software rasterizer, or the GPU cannot
/// render the tree). Runs with the GIL released.
#[pyfunction]
#[pyo3(signature = (tree_json, view, projection, width=512, height=512, device="cpu"))]
pub fn field_render<'py>(
    py: Python<'py>,
    tree_json: &str,
    view: &Bound<'py, PyAny>,
    projection: &Bound<'py, PyAny>,
    width: i64,
    height: i64,
    device: &str,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let (view, projection) = (matrix(view, "view")?, matrix(projection, "projection")?);
    let size = |name: &str, v: i64| u32::try_from(v).map_err(|_| InvalidInput::new_err(format!("{name} must be 1 to 16384 pixels, got {v}")));
    let camera = Camera { view, projection, width: size("width", width)?, height: size("height", height)? };
    if !matches!(device, "cpu" | "gpu" | "auto") {
        return Err(InvalidInput::new_err(format!("device must be \"cpu\", \"gpu\" or \"auto\", got {device:?}")));
    }
    let (text, device) = (tree_json.to_owned(), device.to_owned());
    let out = run_detached(py, move || {
        let tree = FieldTree::from_json(&text)?;
        match device.as_str() {
            "cpu" => render(&tree, &camera).map(|r| r.rgba),
            "gpu" => render_rgba_on_shared_gpu(&tree, &camera, true),
            _ => render_rgba_on_shared_gpu(&tree, &camera, false).or_else(|_| render(&tree, &camera).map(|r| r.rgba)),
        }
    })?;
    let (h, w) = (camera.height as usize, camera.width as usize);
    out.into_pyarray(py).reshape([h, w, 4])
}
