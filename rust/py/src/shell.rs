use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use thicket_core::glam::Vec3;
use thicket_core::shell::{
    self as core,
    report::{self_intersecting_faces, shell_report as core_shell_report},
    shell_geometry, ShellParams, Side,
};
use thicket_core::Mesh;

use crate::arrays;
use crate::errors::{run_detached, run_maybe_watched, InvalidInput};
use crate::offset::ShellRequest;

fn triangle_mesh(vertices: &PyReadonlyArray2<'_, f32>, triangles: &Bound<'_, PyAny>) -> PyResult<Mesh> {
    let positions = arrays::positions(vertices)?;
    let corners = arrays::indices(triangles, "triangles")?;
    if corners.len() % 3 != 0 {
        return Err(InvalidInput::new_err("triangles must have shape (m, 3)"));
    }
    Mesh::new(positions, &vec![3; corners.len() / 3], corners, None).map_err(crate::errors::to_py)
}

pub fn params(p: f64) -> ShellParams {
    ShellParams { p, ..ShellParams::default() }
}

/// build_shell(vertices, triangles, thickness, side, progress=None) -> directors
///
/// The L_p-field shell (thick surfaces, chapter 4): `vertices` float32 (n,3),
/// `triangles` int32/uint32 (m,3), `thickness` a float or float32 (n,) (absolute
/// lengths), `side` "exterior" | "interior" | "envelope". Returns float32 (n,3): the
/// outer shell position of each vertex is `vertex + director`. `progress`: as in
/// `shell`.
#[pyfunction]
#[pyo3(signature = (vertices, triangles, thickness, side, progress=None))]
pub fn build_shell<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    triangles: &Bound<'py, PyAny>,
    thickness: &Bound<'py, PyAny>,
    side: &str,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let mesh = triangle_mesh(&vertices, triangles)?;
    let thickness = arrays::per_vertex_or_scalar(thickness, mesh.vertex_count(), "thickness")?;
    let side = Side::parse(side).map_err(crate::errors::to_py)?;
    let shell = run_maybe_watched(py, progress.as_ref(), move |watch| core::build_shell_watched(&mesh, &thickness, side, &ShellParams::default(), watch))?;
    let outer: Vec<Vec3> = shell.base_offset.iter().zip(&shell.directors).map(|(b, d)| *b + *d).collect();
    arrays::vec3_array(py, outer)
}

/// shell(vertices, face_sizes, corners, thickness, side="exterior", relative=False,
///       factors=None, output="outer", surfaces=None, p=3.0, progress=None) -> dict
///
/// The L_p-field shell of a polygon mesh with shell geometry, as `offset_shell` but
/// with field-integrated directors. Returns the geometry arrays plus base_offset and
/// directors (n,3) (depth r over vertex v at v + base_offset + r * director), achieved
/// and target thickness (n,), source_vertex and layer per output vertex, source_corner
/// and source_face per output corner and face. `progress`: a callable given the share
/// done (vertices traced, then the repair) in [0, 1] at once, about ten times a second
/// and 1.0 at the end, while the work runs on another thread; returning False, raising
/// or Ctrl-C cancels it (`Cancelled`, a `ThicketError`, or the exception raised).
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, thickness, side="exterior", relative=false, factors=None, output="outer", surfaces=None, p=3.0, progress=None, *, layers=None))]
#[allow(clippy::too_many_arguments)]
pub fn shell<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    thickness: f32,
    side: &str,
    relative: bool,
    factors: Option<&Bound<'py, PyAny>>,
    output: &str,
    surfaces: Option<u32>,
    p: f64,
    progress: Option<Bound<'py, PyAny>>,
    layers: Option<u32>,
) -> PyResult<Bound<'py, PyDict>> {
    let surfaces = crate::keywords::renamed_argument(py, "shell", ("surfaces", surfaces), ("layers", layers), 1)?;
    let req = ShellRequest::new(&vertices, face_sizes, corners, thickness, relative, factors, output, surfaces)?;
    let side = Side::parse(side).map_err(crate::errors::to_py)?;
    let (geometry, shell) = run_maybe_watched(py, progress.as_ref(), move |watch| {
        let shell = core::build_shell_watched(&req.mesh, &req.per_vertex()?, side, &params(p), watch)?;
        Ok((shell_geometry(&req.mesh, &shell, req.output)?, shell))
    })?;
    shell_dict(py, geometry, shell)
}

/// The dict `shell()` returns: geometry arrays plus the shell's per-vertex arrays.
pub fn shell_dict<'py>(py: Python<'py>, geometry: core::ShellMesh, shell: core::Shell) -> PyResult<Bound<'py, PyDict>> {
    let d = crate::offset::shell_mesh_dict(py, geometry)?;
    d.set_item("base_offset", arrays::vec3_array(py, shell.base_offset)?)?;
    d.set_item("directors", arrays::vec3_array(py, shell.directors)?)?;
    d.set_item("check", check_dict(py, &shell.check)?)?;
    d.set_item("achieved", shell.achieved.into_pyarray(py))?;
    d.set_item("target", shell.target.into_pyarray(py))?;
    Ok(d)
}

/// What the repair and the final check did: clean (no defect left), repair_rounds,
/// check_rounds, check_shortened (vertices the final check shortened),
/// base_crossing_faces (faces of the base crossing another part of it).
fn check_dict<'py>(py: Python<'py>, c: &core::ShellCheck) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("clean", c.clean)?;
    d.set_item("repair_rounds", c.rounds)?;
    d.set_item("check_rounds", c.check_rounds)?;
    d.set_item("check_shortened", c.check_shortened)?;
    d.set_item("base_crossing_faces", c.base_crossing_faces)?;
    Ok(d)
}

/// self_intersections(vertices, face_sizes, corners) -> dict
///
/// The mesh's own intersections: `pairs` (crossing triangle pairs that share no
/// vertex) and `faces` (int32 array of the faces involved, sorted).
#[pyfunction]
pub fn self_intersections<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = arrays::mesh(&vertices, face_sizes, corners)?;
    let (pairs, faces) = run_detached(py, move || Ok(self_intersecting_faces(&mesh)))?;
    let d = PyDict::new(py);
    d.set_item("pairs", pairs)?;
    d.set_item("faces", arrays::u32_as_i32_array(py, faces))?;
    Ok(d)
}

/// shell_report(vertices, face_sizes, corners, directors, target, base_offset=None,
///              side="exterior") -> dict
///
/// Quality figures of any shell given by its directors (e.g. from Solidify: outer
/// position minus base): outer_self_intersections, outer_base_intersections (skins:
/// the outer layer, an envelope's inner layer too, and the side walls over an open
/// mesh's boundary), inverted_cells, enclosing_cells (cells holding another
/// connected part of the mesh wholly inside),
/// inherited_intersections (crossings involving faces where the base crosses
/// itself, not counted in the first two), base_self_intersections,
/// compressed_vertices (below 95% of the target), min_ratio, mean_ratio,
/// min_ratio_normal_valid, normal_valid_vertices, normal_valid_at_95,
/// considered_vertices.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, directors, target, base_offset=None, side="exterior"))]
#[allow(clippy::too_many_arguments)]
pub fn shell_report<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    directors: PyReadonlyArray2<'py, f32>,
    target: &Bound<'py, PyAny>,
    base_offset: Option<PyReadonlyArray2<'py, f32>>,
    side: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = arrays::mesh(&vertices, face_sizes, corners)?;
    let n = mesh.vertex_count();
    let directors = arrays::positions(&directors)?;
    let base_offset = match base_offset {
        Some(b) => arrays::positions(&b)?,
        None => vec![Vec3::ZERO; n],
    };
    if directors.len() != n || base_offset.len() != n {
        return Err(InvalidInput::new_err(format!("directors and base_offset need one row per vertex ({n})")));
    }
    let target = arrays::per_vertex_or_scalar(target, n, "target")?;
    let side = Side::parse(side).map_err(crate::errors::to_py)?;
    let achieved = directors.iter().map(|d| d.length()).collect();
    let shell = core::Shell { side, base_offset, directors, achieved, target, check: Default::default() };
    let r = run_detached(py, move || Ok(core_shell_report(&mesh, &shell)))?;
    let d = PyDict::new(py);
    d.set_item("outer_self_intersections", r.outer_self_intersections)?;
    d.set_item("outer_base_intersections", r.outer_base_intersections)?;
    d.set_item("inverted_cells", r.inverted_cells)?;
    d.set_item("enclosing_cells", r.enclosing_cells)?;
    d.set_item("inherited_intersections", r.inherited_intersections)?;
    d.set_item("base_self_intersections", r.base_self_intersections)?;
    d.set_item("compressed_vertices", r.compressed_vertices)?;
    d.set_item("min_ratio", r.min_ratio)?;
    d.set_item("mean_ratio", r.mean_ratio)?;
    d.set_item("min_ratio_normal_valid", r.min_ratio_normal_valid)?;
    d.set_item("normal_valid_vertices", r.normal_valid_vertices)?;
    d.set_item("normal_valid_at_95", r.normal_valid_at_95)?;
    d.set_item("considered_vertices", r.considered_vertices)?;
    Ok(d)
}
