use numpy::{IntoPyArray, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use thicket_core::glam::DVec3;
use thicket_core::polygonize::DEFAULT_MAX_BYTES;
use thicket_core::subdivision::budget;
use thicket_core::subdivision::detail::{self, Model};
use thicket_core::subdivision::{self, Boundary, Options};

use crate::arrays;
use crate::errors::{run_detached, to_py, InvalidInput};
use crate::keywords::Keywords;

/// subdivide(vertices, face_sizes, corners, levels=1, limit=False, uvs=None, *,
///           material_index=None, boundary_smooth="ALL") -> dict
///
/// Catmull-Clark subdivision as Blender's Subdivision Surface modifier makes it: `levels`
/// 1 to 6, `limit` its Use Limit Surface, `boundary_smooth` its Boundary Smooth ("ALL" or
/// "PRESERVE_CORNERS"). Returns vertices (m,3) float32, face_sizes and corners int32 (all
/// quads), source_face int32 (the base face of each face) and, when `material_index`
/// (int32 per base face) is given, material_index int32 per face. `uvs` (UV maps through
/// the levels) is not built yet and is refused.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, levels=1, limit=false, uvs=None, *, material_index=None, boundary_smooth="ALL"))]
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
) -> PyResult<Bound<'py, PyDict>> {
    if uvs.is_some_and(|u| !u.is_none()) {
        return Err(InvalidInput::new_err("subdivide: UV maps through the levels (uvs) are not built yet (issue 18); subdivide without them"));
    }
    let mesh = arrays::mesh(&vertices, face_sizes, corners)?;
    let materials = material_index.map(|m| arrays::indices(m, "material_index")).transpose()?;
    if let Some(m) = &materials {
        if m.len() != mesh.face_count() {
            return Err(InvalidInput::new_err(format!("material_index has {} entries for {} faces", m.len(), mesh.face_count())));
        }
    }
    let options = Options { levels, limit, boundary: Boundary::parse(boundary_smooth).map_err(to_py)? };
    if (1..=subdivision::MAX_LEVELS).contains(&levels) {
        budget::check_fits(&mesh, levels, DEFAULT_MAX_BYTES).map_err(to_py)?;
    }
    let out = run_detached(py, move || subdivision::subdivide(&mesh, &options))?;
    let per_face = materials.map(|m| out.source_face.iter().map(|&f| m[f as usize]).collect::<Vec<u32>>());
    let d = arrays::mesh_dict(py, out.mesh)?;
    d.set_item("source_face", arrays::u32_as_i32_array(py, out.source_face))?;
    if let Some(m) = per_face {
        d.set_item("material_index", arrays::u32_as_i32_array(py, m))?;
    }
    Ok(d)
}

/// procedural_detail(vertices, face_sizes, corners, model, levels, seed=0, params=None) -> dict
///
/// Procedural shape detail on Catmull-Clark levels (Velho, Perlin, Ying and Biermann,
/// sections 4 and 6.1): `model` "rock", "berry", "tentacle", "spur", "mushroom" or "fuse",
/// `levels` 1 to 6, `seed` the random values (and Poisson-disk seeds), `params` the
/// model's settings, lengths as fractions of the bounding-box diagonal, `seeds` base vertex
/// indices (Poisson-disk vertices of level 1 when empty): rock `amplitude` (0.02); berry
/// `radius` (0.15), `seeds` and `children` (3); tentacle `length` (0.01, the pull per
/// level, times the level), `theta` (0.0 radians, the turn), `seeds` and `spacing` (0.25);
/// spur `length` (0.01), `seeds` and `spacing` (0.25); mushroom `radius` (0.1, the vortex
/// ring's), `length` (0.04, the flow time per level, times the level) and `seeds` (placed
/// 2 radius apart); fuse `amplitude` (0.03), `span` (1.5, the profile's `|t|` at the
/// base's farthest vertex along the axis, at most 4), `center` (x, y, z in the mesh's
/// units; the bounding-box centre) and `axis` ((0, 0, 1)). Returns the finest level's
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
        "tentacle" => Model::Tentacle {
            length: settings.get("length", 0.01f64)? * diag,
            theta: settings.get("theta", 0.0f64)?,
            seeds: settings.get("seeds", Vec::<u32>::new())?,
            spacing: settings.get("spacing", 0.25f64)? * diag,
        },
        "spur" => Model::Spur {
            length: settings.get("length", 0.01f64)? * diag,
            seeds: settings.get("seeds", Vec::<u32>::new())?,
            spacing: settings.get("spacing", 0.25f64)? * diag,
        },
        "mushroom" => Model::Mushroom {
            radius: settings.get("radius", 0.1f64)? * diag,
            length: settings.get("length", 0.04f64)? * diag,
            seeds: settings.get("seeds", Vec::<u32>::new())?,
        },
        "fuse" => {
            let (low, high) = mesh.bounds();
            Model::Fuse {
                amplitude: settings.get("amplitude", 0.03f64)? * diag,
                span: settings.get("span", 1.5f64)?,
                center: DVec3::from(settings.get("center", (0.5 * (low + high)).as_dvec3().to_array())?),
                axis: DVec3::from(settings.get("axis", [0.0, 0.0, 1.0])?),
            }
        }
        _ => return Err(InvalidInput::new_err(format!("model must be 'rock', 'berry', 'tentacle', 'spur', 'mushroom' or 'fuse', not {model:?}"))),
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
