//! Implicit field trees (issue 17): evaluation at points and meshing, from a tree's
//! JSON (the schema of `thicket_core::implicit`).

use numpy::{IntoPyArray, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use thicket_core::glam::Vec3;
use thicket_core::implicit::{FieldTree, ATTRIBUTE_COUNT, ATTRIBUTE_ID, ATTRIBUTE_TEXTURE};
use thicket_core::polygonize::dual::{mesh_dual_watched, DualMesh, DualParams};
use thicket_core::polygonize::grid::{Unculled, MAX_RESOLUTION};
use thicket_core::polygonize::{check_fits, estimate, mesh_field_watched, FieldMesh, GridParams, Mesher, Watch, DEFAULT_MAX_BYTES};
use thicket_core::Error;

use crate::arrays;
use crate::errors::{run_detached, run_maybe_watched, InvalidInput};

/// Float32 (n, 4) from rows of four.
fn rows4(py: Python<'_>, rows: Vec<[f32; 4]>) -> PyResult<Bound<'_, PyArray2<f32>>> {
    let n = rows.len();
    rows.into_iter().flatten().collect::<Vec<f32>>().into_pyarray(py).reshape([n, 4])
}

/// The points of a float32 (n, 3) array, all finite.
fn points(array: &Bound<'_, PyAny>) -> PyResult<Vec<Vec3>> {
    let array: PyReadonlyArray2<'_, f32> = array.extract().map_err(|_| InvalidInput::new_err("points must be a float32 array of shape (n, 3)"))?;
    if array.shape()[1] != 3 {
        return Err(InvalidInput::new_err(format!("points must have shape (n, 3), got {:?}", array.shape())));
    }
    let flat = array.as_slice().map_err(|_| InvalidInput::new_err("points must be a C-contiguous float32 array"))?;
    let points: Vec<Vec3> = flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    if let Some(i) = points.iter().position(|p| !p.is_finite()) {
        return Err(InvalidInput::new_err(format!("point {i} has a non-finite coordinate ({:?})", points[i].to_array())));
    }
    Ok(points)
}

/// field_eval(tree_json, points) -> dict
///
/// The field tree `tree_json` (a JSON string; schema: thicket_core::implicit) at each
/// point of `points`, float32 (n, 3): values (n,) (negative inside), gradients (n, 3)
/// (the tree's analytic gradient), colors (n, 4) (RGBA, blended through the
/// operations), texture (n,) (the texture functions' value, 0 where none) and
/// primitive_id (n,) int32 (the dominant building block, numbered in JSON order).
/// A tree that cannot be read or checked raises InvalidInput (a ThicketError) with
/// the core's message naming the node and field.
#[pyfunction]
pub fn field_eval<'py>(py: Python<'py>, tree_json: &str, points: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    let points = self::points(points)?;
    let text = tree_json.to_owned();
    let e = run_detached(py, move || Ok(FieldTree::from_json(&text)?.evaluate(&points)))?;
    let d = PyDict::new(py);
    d.set_item("values", e.values.into_pyarray(py))?;
    d.set_item("gradients", arrays::vec3_array(py, e.gradients)?)?;
    d.set_item("colors", rows4(py, e.colors)?)?;
    d.set_item("texture", e.textures.into_pyarray(py))?;
    d.set_item("primitive_id", arrays::u32_as_i32_array(py, e.ids))?;
    Ok(d)
}

/// Lattice cells added around the tree's own bound on each side, so the grid's faces
/// stay off the surface.
const MARGIN_CELLS: f32 = 2.0;

/// The box `bounds` (lowest, highest corner) or, without it, the tree's own bound
/// grown by [`MARGIN_CELLS`] cells of `resolution` along its longest side.
fn mesh_box(tree: &FieldTree, bounds: Option<[[f32; 3]; 2]>, resolution: u32) -> thicket_core::Result<(Vec3, Vec3)> {
    if let Some([lo, hi]) = bounds {
        return Ok((Vec3::from_array(lo), Vec3::from_array(hi)));
    }
    let (lo, hi) = tree.bounds().ok_or_else(|| {
        Error::InvalidParameter(
            "the field tree is unbounded (a plane, a complement, or a union with one of those): give bounds=((x0, y0, z0), (x1, y1, z1))".into(),
        )
    })?;
    let margin = MARGIN_CELLS * (hi - lo).max_element() / resolution as f32;
    Ok((lo - margin, hi + margin))
}

/// Bytes of output per triangle, roughly: its indices, half a vertex (position,
/// normal, six attributes, its weld key) and the arrays handed to Python.
const BYTES_PER_TRIANGLE: f64 = 100.0;

/// The resolution as the core takes it, or a clear refusal: more than
/// [`MAX_RESOLUTION`] cells would not fit in memory (a surface across the box makes
/// about 12 r² triangles).
fn checked_resolution(resolution: i64) -> PyResult<u32> {
    if (2..=i64::from(MAX_RESOLUTION)).contains(&resolution) {
        return Ok(resolution as u32);
    }
    if resolution < 2 {
        return Err(InvalidInput::new_err(format!("resolution must be at least 2 cells along the longest side, got {resolution}")));
    }
    let gigabytes = 12.0 * (resolution as f64).powi(2) * BYTES_PER_TRIANGLE / 1e9;
    Err(InvalidInput::new_err(format!(
        "resolution {resolution} is too fine: a surface across the box would need about {gigabytes:.0} GB; at most {MAX_RESOLUTION} cells along the longest side"
    )))
}

/// The bounds argument as the core takes it.
fn bounds_arg(bounds: Option<&Bound<'_, PyAny>>) -> PyResult<Option<[[f32; 3]; 2]>> {
    bounds
        .map(|b| b.extract::<[[f32; 3]; 2]>().map_err(|_| InvalidInput::new_err("bounds must be ((x0, y0, z0), (x1, y1, z1)), the lowest and highest corner")))
        .transpose()
}

/// The memory limit argument: bytes, positive; None: the core's default.
fn max_bytes_arg(max_bytes: Option<f64>) -> PyResult<u64> {
    match max_bytes {
        None => Ok(DEFAULT_MAX_BYTES),
        Some(b) if b.is_finite() && b >= 1.0 => Ok(b as u64),
        Some(b) => Err(InvalidInput::new_err(format!("max_bytes must be a positive number of bytes, got {b}"))),
    }
}

fn mesher(adaptive: bool) -> Mesher {
    if adaptive {
        Mesher::Dual
    } else {
        Mesher::Grid
    }
}

/// field_mesh(tree_json, bounds=None, resolution=128, adaptive=True, progress=None,
///            max_bytes=None) -> dict
///
/// The zero set of the field tree `tree_json` (a JSON string; schema:
/// thicket_core::implicit) as a closed, consistently oriented mesh; the solid is cut
/// by the box, so the mesh closes where it leaves it. `bounds`: ((x0, y0, z0), (x1,
/// y1, z1)), the box meshed; None: the tree's own bound grown by two cells each side
/// (an unbounded tree, such as a plane or a complement, needs bounds). `resolution`:
/// cells along the longest side of the box (2 to 2048). `adaptive=True`: manifold
/// dual contouring (thicket_core::polygonize::dual) on the cells that the tree's
/// interval bounds cannot rule out: quads, one vertex per piece of the surface in a
/// cell, placed on the tree's creases and corners from its analytic gradients.
/// Adaptive in where it works (an octree skips the space the surface does not
/// cross), not yet in cell size: every cell the surface crosses is of the finest
/// size, flat parts included.
/// `adaptive=False`: marching prisms on the whole grid (triangles, iso-vertices on
/// the lattice edges).
///
/// `progress`: a callable given the share done (0 to 1) about ten times a second;
/// returning False (or raising, or Ctrl-C) cancels and raises Cancelled. `max_bytes`:
/// the memory the build may take (None: 4 GB). A build whose estimate
/// (`field_mesh_estimate`) passes it is refused before anything big is made, and one
/// whose surface turns out finer than the estimate saw stops once it would pass it;
/// both raise OverLimit (an InvalidInput) naming the estimate and the limit.
///
/// Returns vertices (n, 3) float32, face_sizes and corners int32 (quads with
/// adaptive=True, their better split along corners 0-2; triangles otherwise), normals
/// (n, 3) (the field's unit gradient; the box face's normal where the box cut it),
/// colors (n, 4) float32, texture (n,) float32 and primitive_id (n,) int32 per vertex
/// (as field_eval gives them there), cells (nx, ny, nz) and bounds ((x0, y0, z0),
/// (x1, y1, z1)), the box meshed (the given one, or the tree's own grown by two
/// cells: what a dense grid of the same lattice needs). Bad trees, bounds and
/// resolutions, and trees that are not a number where sampled, raise InvalidInput (a
/// ThicketError) with a message saying what is wrong. The GIL is released while it
/// meshes.
#[pyfunction]
#[pyo3(signature = (tree_json, bounds=None, resolution=128, adaptive=true, progress=None, max_bytes=None))]
pub fn field_mesh<'py>(
    py: Python<'py>,
    tree_json: &str,
    bounds: Option<&Bound<'py, PyAny>>,
    resolution: i64,
    adaptive: bool,
    progress: Option<Bound<'py, PyAny>>,
    max_bytes: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let bounds = bounds_arg(bounds)?;
    let resolution = checked_resolution(resolution)?;
    let max_bytes = max_bytes_arg(max_bytes)?;
    let text = tree_json.to_owned();
    let mesh = run_maybe_watched(py, progress.as_ref(), move |progress| {
        let tree = FieldTree::from_json(&text)?;
        let bounds = mesh_box(&tree, bounds, resolution)?;
        check_fits(&tree, bounds, resolution, mesher(adaptive), max_bytes)?;
        let watch = Watch { progress, max_bytes: Some(max_bytes) };
        Ok((
            if adaptive {
                Meshed::Dual(mesh_dual_watched(&tree, &DualParams { bounds, resolution }, &watch)?)
            } else {
                Meshed::Grid(mesh_field_watched(&Unculled(&tree), &GridParams { bounds, resolution, refine: true }, &watch)?)
            },
            bounds,
        ))
    })?;
    let (mesh, (lo, hi)) = mesh;
    let d = match mesh {
        Meshed::Dual(m) => {
            let count = m.quads.len();
            let faces = Faces { sizes: vec![4; count], corners: m.quads.into_iter().flatten().collect() };
            mesh_dict(py, faces, m.positions, m.normals, m.attributes, m.attribute_count, m.cells.to_array())
        }
        Meshed::Grid(m) => {
            let count = m.triangles.len();
            let faces = Faces { sizes: vec![3; count], corners: m.triangles.into_iter().flatten().collect() };
            mesh_dict(py, faces, m.positions, m.normals, m.attributes, m.attribute_count, m.cells.to_array())
        }
    }?;
    d.set_item("bounds", (lo.to_array(), hi.to_array()))?;
    Ok(d)
}

/// field_mesh_estimate(tree_json, bounds=None, resolution=128, adaptive=True,
///                     max_bytes=None) -> dict
///
/// What `field_mesh` with the same arguments would make, estimated in milliseconds
/// without meshing (the crossings of the same tree counted on a lattice of at most 64
/// cells along the longest side, scaled to `resolution`; exact up to 64): vertices,
/// faces (quads with adaptive=True, triangles otherwise), triangles, peak_bytes (the
/// most memory the build would hold), max_bytes (the limit: the argument, or 4 GB),
/// fits (peak_bytes <= max_bytes: `field_mesh` would not refuse it), resolution_within
/// (about the most cells that fit the limit) and cells (nx, ny, nz). Detail finer than
/// the counted lattice is not seen (`field_mesh` then stops at the limit while
/// meshing). Bad trees, bounds and resolutions raise InvalidInput as for `field_mesh`.
#[pyfunction]
#[pyo3(signature = (tree_json, bounds=None, resolution=128, adaptive=true, max_bytes=None))]
pub fn field_mesh_estimate<'py>(
    py: Python<'py>,
    tree_json: &str,
    bounds: Option<&Bound<'py, PyAny>>,
    resolution: i64,
    adaptive: bool,
    max_bytes: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let bounds = bounds_arg(bounds)?;
    let resolution = checked_resolution(resolution)?;
    let max_bytes = max_bytes_arg(max_bytes)?;
    let text = tree_json.to_owned();
    let e = run_detached(py, move || {
        let tree = FieldTree::from_json(&text)?;
        let bounds = mesh_box(&tree, bounds, resolution)?;
        estimate(&tree, bounds, resolution, mesher(adaptive))
    })?;
    let d = PyDict::new(py);
    d.set_item("vertices", e.vertices)?;
    d.set_item("faces", e.faces)?;
    d.set_item("triangles", e.triangles)?;
    d.set_item("peak_bytes", e.peak_bytes)?;
    d.set_item("max_bytes", max_bytes)?;
    d.set_item("fits", e.peak_bytes <= max_bytes)?;
    d.set_item("resolution_within", e.resolution_within(max_bytes))?;
    d.set_item("cells", e.cells.to_array())?;
    Ok(d)
}

/// What either mesher made.
enum Meshed {
    Dual(DualMesh),
    Grid(FieldMesh),
}

/// Faces as Blender takes them: a size per face, then every face's corners.
struct Faces {
    sizes: Vec<u32>,
    corners: Vec<u32>,
}

/// A meshed tree as `field_mesh` returns it.
fn mesh_dict(
    py: Python<'_>,
    faces: Faces,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    attributes: Vec<f32>,
    attribute_count: usize,
    cells: [u32; 3],
) -> PyResult<Bound<'_, PyDict>> {
    debug_assert_eq!(attribute_count, ATTRIBUTE_COUNT);
    let rows = attributes.chunks_exact(ATTRIBUTE_COUNT);
    let colors: Vec<[f32; 4]> = rows.clone().map(|a| [a[0], a[1], a[2], a[3]]).collect();
    let texture: Vec<f32> = rows.clone().map(|a| a[ATTRIBUTE_TEXTURE]).collect();
    let ids: Vec<u32> = rows.map(|a| a[ATTRIBUTE_ID] as u32).collect();
    let d = PyDict::new(py);
    d.set_item("vertices", arrays::vec3_array(py, positions)?)?;
    d.set_item("face_sizes", arrays::u32_as_i32_array(py, faces.sizes))?;
    d.set_item("corners", arrays::u32_as_i32_array(py, faces.corners))?;
    d.set_item("normals", arrays::vec3_array(py, normals)?)?;
    d.set_item("colors", rows4(py, colors)?)?;
    d.set_item("texture", texture.into_pyarray(py))?;
    d.set_item("primitive_id", arrays::u32_as_i32_array(py, ids))?;
    d.set_item("cells", cells)?;
    Ok(d)
}
