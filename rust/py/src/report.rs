use numpy::PyReadonlyArray2;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// mesh_report(vertices, face_sizes, corners) -> dict
///
/// Counts what is odd about a mesh: vertices, faces, triangles, ngons,
/// degenerate_faces, loose_vertices, boundary_edges, non_manifold_edges.
/// Raises InvalidInput (a ThicketError) for structurally invalid input (bad indices, NaN coordinates).
#[pyfunction]
pub fn mesh_report<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = crate::arrays::mesh(&vertices, face_sizes, corners)?;
    let r = crate::errors::run_detached(py, || Ok(mesh.report()))?;
    let d = PyDict::new(py);
    for (k, v) in [
        ("vertices", r.vertices),
        ("faces", r.faces),
        ("triangles", r.triangles),
        ("ngons", r.ngons),
        ("degenerate_faces", r.degenerate_faces),
        ("loose_vertices", r.loose_vertices),
        ("boundary_edges", r.boundary_edges),
        ("non_manifold_edges", r.non_manifold_edges),
    ] {
        d.set_item(k, v)?;
    }
    d.set_item("closed_manifold", r.is_closed_manifold())?;
    Ok(d)
}
