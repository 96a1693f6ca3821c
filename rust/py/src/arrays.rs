//! numpy <-> core conversions. Inputs are borrowed read-only; outputs move Rust
//! vectors into numpy without copying.

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use thicket_core::glam::{Vec2, Vec3};
use thicket_core::Mesh;

use crate::errors::InvalidInput;

/// Positions from a contiguous float32 (n, 3) array.
pub fn positions(array: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<Vec3>> {
    if array.shape()[1] != 3 {
        return Err(InvalidInput::new_err(format!("vertices must have shape (n, 3), got {:?}", array.shape())));
    }
    let flat = array.as_slice().map_err(|_| InvalidInput::new_err("vertices must be a C-contiguous float32 array"))?;
    Ok(flat.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
}

/// An index array given as int32 or uint32 (negative entries are rejected).
pub fn indices(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<u32>> {
    if let Ok(a) = obj.extract::<PyReadonlyArray1<'_, u32>>() {
        return Ok(a.as_slice().map_err(|_| not_contiguous(what))?.to_vec());
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, u32>>() {
        return Ok(a.as_slice().map_err(|_| not_contiguous(what))?.to_vec());
    }
    let signed: Vec<i32> = if let Ok(a) = obj.extract::<PyReadonlyArray1<'_, i32>>() {
        a.as_slice().map_err(|_| not_contiguous(what))?.to_vec()
    } else if let Ok(a) = obj.extract::<PyReadonlyArray2<'_, i32>>() {
        a.as_slice().map_err(|_| not_contiguous(what))?.to_vec()
    } else {
        return Err(InvalidInput::new_err(format!("{what} must be a numpy array of int32 or uint32")));
    };
    signed.iter().map(|&i| u32::try_from(i).map_err(|_| InvalidInput::new_err(format!("{what} contains the negative index {i}")))).collect()
}

/// Per-vertex float32 values, or one float broadcast to every vertex.
pub fn per_vertex_or_scalar(obj: &Bound<'_, PyAny>, n: usize, what: &str) -> PyResult<Vec<f32>> {
    if let Ok(v) = obj.extract::<f64>() {
        return Ok(vec![v as f32; n]);
    }
    let a =
        obj.extract::<PyReadonlyArray1<'_, f32>>().map_err(|_| InvalidInput::new_err(format!("{what} must be a float or a float32 array of shape (n,)")))?;
    let s = a.as_slice().map_err(|_| not_contiguous(what))?;
    if s.len() != n {
        return Err(InvalidInput::new_err(format!("{what} has {} values for {n} vertices", s.len())));
    }
    Ok(s.to_vec())
}

fn not_contiguous(what: &str) -> PyErr {
    InvalidInput::new_err(format!("{what} must be a C-contiguous array"))
}

/// A polygon mesh from Blender-style arrays: vertices (n, 3), loop totals per face,
/// and the flat corner -> vertex indices.
pub fn mesh(vertices: &PyReadonlyArray2<'_, f32>, face_sizes: &Bound<'_, PyAny>, corners: &Bound<'_, PyAny>) -> PyResult<Mesh> {
    mesh_with_uvs(vertices, face_sizes, corners, None)
}

/// [`mesh`] with per-corner UVs, float32 (corners, 2).
pub fn mesh_with_uvs(
    vertices: &PyReadonlyArray2<'_, f32>,
    face_sizes: &Bound<'_, PyAny>,
    corners: &Bound<'_, PyAny>,
    uvs: Option<&PyReadonlyArray2<'_, f32>>,
) -> PyResult<Mesh> {
    let positions = positions(vertices)?;
    let sizes = indices(face_sizes, "face_sizes")?;
    let corners = indices(corners, "corners")?;
    let uvs = uvs.map(|uv| self::uvs(uv, corners.len())).transpose()?;
    Mesh::new(positions, &sizes, corners, uvs).map_err(crate::errors::to_py)
}

/// Per-corner UVs, float32 (corners, 2).
pub fn uvs(uv: &PyReadonlyArray2<'_, f32>, corners: usize) -> PyResult<Vec<Vec2>> {
    let uv = uv.as_array();
    if uv.shape() != [corners, 2] {
        return Err(InvalidInput::new_err(format!("uvs must have shape ({corners}, 2)")));
    }
    Ok(uv.rows().into_iter().map(|r| Vec2::new(r[0], r[1])).collect())
}

// The cast in `vec3_array` relies on this layout; a glam build that changed it
// (padding, alignment) stops the compile here instead of corrupting arrays.
const _: () = assert!(std::mem::size_of::<Vec3>() == 12 && std::mem::align_of::<Vec3>() == 4);

/// Moves `Vec<Vec3>` into a float32 (n, 3) array without copying the data.
pub fn vec3_array<'py>(py: Python<'py>, v: Vec<Vec3>) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let n = v.len();
    let mut v = std::mem::ManuallyDrop::new(v);
    // SAFETY: glam's Vec3 is #[repr(C)] { x, y, z: f32 } with align 4 and size 12, so a
    // buffer of `cap` Vec3 is exactly a buffer of `3 * cap` f32 with the same layout.
    let flat = unsafe { Vec::from_raw_parts(v.as_mut_ptr() as *mut f32, n * 3, v.capacity() * 3) };
    flat.into_pyarray(py).reshape([n, 3])
}

/// Float32 (n, 2) from 2-vectors.
pub fn vec2_array<'py>(py: Python<'py>, v: Vec<Vec2>) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let n = v.len();
    v.into_iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>().into_pyarray(py).reshape([n, 2])
}

pub fn u32_as_i32_array<'py>(py: Python<'py>, v: Vec<u32>) -> Bound<'py, PyArray1<i32>> {
    // Blender's index attributes are int32; meshes beyond 2^31 corners are refused earlier.
    v.into_iter().map(|i| i as i32).collect::<Vec<_>>().into_pyarray(py)
}

/// The mesh as a dict of Blender-ready arrays: vertices (n,3) float32, face_sizes and
/// corners int32.
pub fn mesh_dict<'py>(py: Python<'py>, mesh: Mesh) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let d = pyo3::types::PyDict::new(py);
    let sizes = mesh.face_sizes();
    let (positions, corners) = mesh.into_parts();
    d.set_item("vertices", vec3_array(py, positions)?)?;
    d.set_item("face_sizes", u32_as_i32_array(py, sizes))?;
    d.set_item("corners", u32_as_i32_array(py, corners))?;
    Ok(d)
}
