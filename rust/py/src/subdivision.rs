use numpy::{IntoPyArray, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use thicket_core::polygonize::DEFAULT_MAX_BYTES;
use thicket_core::subdivision::budget;
use thicket_core::subdivision::detail::{self, Model};
use thicket_core::subdivision::{self, Boundary, Options, UvSmooth};

use crate::arrays;
use crate::errors::{run_detached, to_py, InvalidInput};
use crate::keywords::Keywords;

/// subdivide(vertices, face_sizes, corners, levels=1, limit=False, uvs=None, *,
///           material_index=None, boundary_smooth="ALL", uv_smooth="PRESERVE_BOUNDARIES") -> dict
///
/// Catmull-Clark subdivision as Blender's Subdivision Surface modifier makes it: `levels`
/// 1 to 6, `limit` its Use Limit Surface, `boundary_smooth` its Boundary Smooth ("ALL" or
/// "PRESERVE_CORNERS"), `uv_smooth` its UV Smooth ("PRESERVE_BOUNDARIES" or "NONE").
/// Returns vertices (m,3) float32, face_sizes and corners int32 (all quads), source_face
/// int32 (the base face of each face); when `material_index` (int32 per base face) is
/// given, material_index int32 per face; when `uvs` (float32 (corners, 2), one UV per base
/// corner) is given, uvs float32 (4^levels corners, 2), one per corner of the result.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, levels=1, limit=false, uvs=None, *, material_index=None, boundary_smooth="ALL", uv_smooth="PRESERVE_BOUNDARIES"))]
#[allow(clippy::too_many_arguments)]
pub fn subdivide<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    levels: u32,
    limit: bool,
    uvs: Option<&Bound<'py, PyAny>>,
    material_index: Option<&Bound<'py, PyAny>>,
    boundary_smooth: &str,
    uv_smooth: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = arrays::mesh(&vertices, face_sizes, corners)?;
    let uvs = match uvs.filter(|u| !u.is_none()) {
        Some(u) => {
            let array: PyReadonlyArray2<f32> = u.extract().map_err(|_| InvalidInput::new_err("uvs must be a float32 array of shape (corners, 2)"))?;
            Some(arrays::uvs(&array, mesh.corners().len())?)
        }
        None => None,
    };
    let materials = material_index.map(|m| arrays::indices(m, "material_index")).transpose()?;
    if let Some(m) = &materials {
        if m.len() != mesh.face_count() {
            return Err(InvalidInput::new_err(format!("material_index has {} entries for {} faces", m.len(), mesh.face_count())));
        }
    }
    let options = Options { levels, limit, boundary: Boundary::parse(boundary_smooth).map_err(to_py)? };
    let smooth = UvSmooth::parse(uv_smooth).map_err(to_py)?;
    if (1..=subdivision::MAX_LEVELS).contains(&levels) {
        budget::check_fits(&mesh, levels, DEFAULT_MAX_BYTES).map_err(to_py)?;
    }
    let (out, mut out_uvs) = run_detached(py, move || subdivision::subdivide_with_uvs(&mesh, &options, smooth, &Vec::from_iter(uvs.as_deref())))?;
    let per_face = materials.map(|m| out.source_face.iter().map(|&f| m[f as usize]).collect::<Vec<u32>>());
    let d = arrays::mesh_dict(py, out.mesh)?;
    d.set_item("source_face", arrays::u32_as_i32_array(py, out.source_face))?;
    if let Some(m) = per_face {
        d.set_item("material_index", arrays::u32_as_i32_array(py, m))?;
    }
    if let Some(uv) = out_uvs.pop() {
        d.set_item("uvs", arrays::vec2_array(py, uv)?)?;
    }
    Ok(d)
}

/// procedural_detail(vertices, face_sizes, corners, model, levels, seed=0, params=None) -> dict
///
/// Procedural shape detail on Catmull-Clark levels (Velho, Perlin, Ying and Biermann,
/// section 4): `model` "rock" or "berry", `levels` 1 to 6, `seed` the random values,
/// `params` the model's settings, lengths as fractions of the bounding-box diagonal:
/// rock `amplitude` (0.02); berry `radius` (0.15), `seeds` (base vertex
/// indices; Poisson-disk points when empty) and `children` (3). Returns the finest level's
/// vertices, face_sizes and corners (all quads), source_face (the base face of each face)
/// and `scalar`, float32 per vertex: the detail the levels added along their normals.
/// Levels whose result would need more than 4 GB are refused before anything is made.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, model, levels, seed=0, params=None))]
#[allow(clippy::too_many_arguments)]
pub fn procedural_detail<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    model: &str,
    levels: u32,
    seed: u64,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = arrays::mesh(&vertices, face_sizes, corners)?;
    let diag = mesh.bbox_diagonal() as f64;
    let settings = Keywords::new("procedural_detail", params);
    let model = match model {
        "rock" => Model::Rock { amplitude: settings.get("amplitude", 0.02f64)? * diag },
        "berry" => Model::Berry {
            radius: settings.get("radius", 0.15f64)? * diag,
            seeds: settings.get("seeds", Vec::<u32>::new())?,
            children: settings.get("children", 3u32)?,
        },
        "tentacle" | "spur" | "mushroom" | "fuse" => {
            return Err(InvalidInput::new_err(format!("the {model} model is not built yet (issue 18): rock and berry are")));
        }
        _ => return Err(InvalidInput::new_err(format!("model must be 'rock' or 'berry', not {model:?}"))),
    };
    settings.finish()?;
    if (1..=subdivision::MAX_LEVELS).contains(&levels) {
        budget::check_fits(&mesh, levels, DEFAULT_MAX_BYTES).map_err(to_py)?;
    }
    let out = run_detached(py, move || detail::procedural_detail(&mesh, levels, &model, seed))?;
    let d = arrays::mesh_dict(py, out.mesh)?;
    d.set_item("source_face", arrays::u32_as_i32_array(py, out.source_face))?;
    d.set_item("scalar", out.scalar.into_pyarray(py))?;
    Ok(d)
}
