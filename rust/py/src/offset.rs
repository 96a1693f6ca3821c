use numpy::{IntoPyArray, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use thicket_core::shell::{build_geometry, normal_offset_directors, ShellOutput, Thickness};

use crate::arrays;
use crate::errors::run_detached;
use crate::keywords::renamed_argument;

/// The inputs every shell-building function shares, converted once: the mesh,
/// per-vertex factors, requested output and thickness.
pub struct ShellRequest {
    pub mesh: thicket_core::Mesh,
    pub factors: Option<Vec<f32>>,
    pub output: ShellOutput,
    pub thickness: Thickness,
}

impl ShellRequest {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        vertices: &PyReadonlyArray2<'_, f32>,
        face_sizes: &Bound<'_, PyAny>,
        corners: &Bound<'_, PyAny>,
        thickness: f32,
        relative: bool,
        factors: Option<&Bound<'_, PyAny>>,
        output: &str,
        surfaces: u32,
    ) -> PyResult<Self> {
        let mesh = arrays::mesh(vertices, face_sizes, corners)?;
        let factors = factors.map(|f| arrays::per_vertex_or_scalar(f, mesh.vertex_count(), "factors")).transpose()?;
        let output = parse_output(output, surfaces)?;
        let thickness = if relative { Thickness::relative(thickness) } else { Thickness::absolute(thickness) };
        Ok(Self { mesh, factors, output, thickness })
    }

    /// Signed target thickness per vertex.
    pub fn per_vertex(&self) -> thicket_core::Result<Vec<f32>> {
        self.thickness.per_vertex(&self.mesh, self.factors.as_deref())
    }
}

/// The shell output `output` names; `surfaces`: how many evenly spaced surfaces
/// "layers" makes (the core's `ShellOutput::Layers` count).
pub fn parse_output(output: &str, surfaces: u32) -> PyResult<ShellOutput> {
    ShellOutput::parse(output, surfaces).map_err(crate::errors::to_py)
}

/// offset_shell(vertices, face_sizes, corners, thickness, relative=False, factors=None,
///              output="outer", surfaces=1) -> dict
///
/// Offset Shell (normal displacement): each vertex moves along its angle-weighted
/// normal by `thickness` (a length, or a fraction of the bounding-box diagonal when
/// `relative`), times its entry of `factors` (float32 (n,), e.g. vertex-group
/// weights). Negative thickness offsets inward. `output` is "outer" (offset surface),
/// "solid" (closed: offset + reversed base + rims) or "layers" (`surfaces` evenly
/// spaced copies of the base, the last one the offset surface). `layers`: the former
/// name of `surfaces`, taken with a DeprecationWarning for one release.
///
/// Returns vertices (m,3) float32, face_sizes and corners int32, source_vertex int32
/// (base vertex of each output vertex), layer float32 (r in [0,1]), source_corner
/// and source_face int32 (the base corner and face each output corner and face comes
/// from: UV maps and material indices carry over) and directors (n,3) float32 for the
/// base vertices.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, thickness, relative=false, factors=None, output="outer", surfaces=None, *, layers=None))]
#[allow(clippy::too_many_arguments)]
pub fn offset_shell<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    thickness: f32,
    relative: bool,
    factors: Option<&Bound<'py, PyAny>>,
    output: &str,
    surfaces: Option<u32>,
    layers: Option<u32>,
) -> PyResult<Bound<'py, PyDict>> {
    let surfaces = renamed_argument(py, "offset_shell", ("surfaces", surfaces), ("layers", layers), 1)?;
    let req = ShellRequest::new(&vertices, face_sizes, corners, thickness, relative, factors, output, surfaces)?;
    let (shell, directors) = run_detached(py, move || {
        let directors = normal_offset_directors(&req.mesh, &req.per_vertex()?);
        Ok((build_geometry(&req.mesh, &directors, req.output)?, directors))
    })?;
    let d = shell_mesh_dict(py, shell)?;
    d.set_item("directors", arrays::vec3_array(py, directors)?)?;
    Ok(d)
}

/// Shell geometry as a dict: the mesh arrays and where each part came from
/// (source_vertex, layer, source_corner, source_face).
pub fn shell_mesh_dict(py: Python<'_>, shell: thicket_core::shell::ShellMesh) -> PyResult<Bound<'_, PyDict>> {
    let d = arrays::mesh_dict(py, shell.mesh)?;
    d.set_item("source_vertex", arrays::u32_as_i32_array(py, shell.source_vertex))?;
    d.set_item("layer", shell.layer.into_pyarray(py))?;
    d.set_item("source_corner", arrays::u32_as_i32_array(py, shell.source_corner))?;
    d.set_item("source_face", arrays::u32_as_i32_array(py, shell.source_face))?;
    Ok(d)
}
