use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use thicket_core::glam::{DVec3, Vec2};
use thicket_core::polygonize::DEFAULT_MAX_BYTES;
use thicket_core::subdivision::budget;
use thicket_core::subdivision::detail::Model;
use thicket_core::subdivision::multires::{self, Multires};
use thicket_core::subdivision::operations::{Alpha, AlphaSource, Levels, Local, Planet};
use thicket_core::subdivision::recipe::{self, Blend, Motion, Recipe};
use thicket_core::subdivision::{self, Boundary, Options, UvSmooth};
use thicket_core::Mesh;

use crate::arrays;
use crate::errors::{run_detached, run_maybe_watched, to_py, InvalidInput};
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

/// procedural_detail(vertices, face_sizes, corners, model, levels, seed=0, params=None, *,
///                   at=None, blend=None, local=None, shader=None) -> dict
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
/// units; the bounding-box centre) and `axis` ((0, 0, 1)). Operations (sections 5-6):
/// `at`, the levels the model adds detail at (all when None); `blend`, a second model
/// blended in, a dict of `model`, `params`, `seed` (0), `at`, and the alpha: `plane` (a
/// point and a direction; `width` a fraction of the diagonal, 0.2) or `weights` (one per
/// vertex, float32; `width` in weight units, at most 1.0), its transition halving per
/// level; `local`, a list of dicts of `center` (a vertex), `radius` (in base edges:
/// nothing that far or farther changes), `gain` (0 removes the detail, 2 doubles it) and
/// `levels` (all when absent); `shader`, a dict `{"name": "planet", "sea": 0.0, "snow":
/// 0.025, "sea_rate": 0.0, "snow_rate": 0.0}` (heights as fractions of the diagonal,
/// rates per unit of time) for the planet's colours. `time` (section 3) feeds the models
/// (params `spin`, the tentacle's turn in radians per unit of time, and `grow`, the time
/// all but the berry reach their full size from 0; both 0 by default), the blend's alpha
/// (blend `sweep`: how far the second model's side grows per unit of time, a fraction
/// of the diagonal for a plane, weight units for weights) and the shader. Returns the
/// finest level's vertices, face_sizes and corners (all quads), source_face (the base face
/// of each face), `scalar`, float32 per vertex: the detail the levels added along their
/// normals, `blend` (float32 per vertex, the blend parameter; 0 without a blend),
/// `limited` (the share of the vertices given rock or berry detail whose detail the fold
/// guard made smaller so the surface does not fold: a quarter of the local edge, half the
/// radius of curvature, domes clear of other parts; 0.0 when the model's sizes fit the
/// mesh; a local modification's gain above 1 scales the detail after the guard), `shrunk`
/// (the share of them whose detail lost more than a tenth of its size, a reduction one
/// sees) and, with a shader, `colors` (float32 (n, 4)
/// RGBA). `uvs`, one float32 (corners, 2) UV map or a list of them, are carried through
/// the levels by `uv_smooth` as `subdivide` does without the limit (the levels are control
/// meshes): `uvs` comes back in the same form, one UV per corner of the result. Levels
/// whose result would need more than 4 GB are refused before anything is made. `sculpt`,
/// a dict from [`analyze`] of this base (its `details` are read; `vertices` may be an
/// edited base), adds the analysed detail at its levels before each level's procedural
/// detail (section 2).
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, model, levels, seed=0, params=None, *, at=None, blend=None, local=None, shader=None, sculpt=None, uvs=None, uv_smooth="PRESERVE_BOUNDARIES", time=0.0))]
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
    at: Option<Vec<i64>>,
    blend: Option<&Bound<'py, PyDict>>,
    local: Option<Vec<Bound<'py, PyDict>>>,
    shader: Option<&Bound<'py, PyDict>>,
    sculpt: Option<&Bound<'py, PyDict>>,
    uvs: Option<&Bound<'py, PyAny>>,
    uv_smooth: &str,
    time: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let mesh = arrays::mesh(&vertices, face_sizes, corners)?;
    let (uvs, uv_list) = uv_maps(uvs, mesh.corners().len())?;
    let smooth = UvSmooth::parse(uv_smooth).map_err(to_py)?;
    let diag = mesh.bbox_diagonal() as f64;
    let (model, motion) = model_from(model, params, &mesh)?;
    let mut recipe = Recipe::of(model, seed);
    recipe.motion = motion;
    recipe.time = time;
    recipe.at = levels_from(at)?;
    recipe.blend = blend.map(|b| blend_from(b, &mesh)).transpose()?;
    recipe.local = local.unwrap_or_default().iter().map(local_from).collect::<PyResult<_>>()?;
    let planet = shader.map(|s| planet_from(s, diag, time)).transpose()?;
    recipe.sculpt = sculpt.map(sculpt_from).transpose()?;
    if (1..=subdivision::MAX_LEVELS).contains(&levels) {
        budget::check_fits(&mesh, levels, DEFAULT_MAX_BYTES).map_err(to_py)?;
    }
    let out = run_detached(py, move || {
        // The UVs first: their refinement's connectivity is gone before the synthesis starts.
        let uvs = match uvs.is_empty() {
            true => Vec::new(),
            false => subdivision::subdivide_uvs(&mesh, levels, smooth, &uvs.iter().map(Vec::as_slice).collect::<Vec<_>>())?,
        };
        let out = recipe::synthesize(&mesh, levels, &recipe)?;
        let colors = planet.map(|p| p.colors(&out.detailed.scalar, &out.blend));
        Ok((out, colors, uvs))
    })?;
    let (out, colors, out_uvs) = out;
    let d = arrays::mesh_dict(py, out.detailed.mesh)?;
    d.set_item("source_face", arrays::u32_as_i32_array(py, out.detailed.source_face))?;
    d.set_item("scalar", out.detailed.scalar.into_pyarray(py))?;
    d.set_item("blend", out.blend.into_pyarray(py))?;
    d.set_item("limited", out.tally.share())?;
    d.set_item("shrunk", out.tally.shrunk_share())?;
    if let Some(c) = colors {
        let n = c.len();
        d.set_item("colors", c.into_flattened().into_pyarray(py).reshape([n, 4])?)?;
    }
    let mut maps = out_uvs.into_iter().map(|uv| arrays::vec2_array(py, uv)).collect::<PyResult<Vec<_>>>()?;
    if uv_list {
        d.set_item("uvs", PyList::new(py, maps)?)?;
    } else if let Some(map) = maps.pop() {
        d.set_item("uvs", map)?;
    }
    Ok(d)
}

/// analyze(vertices, face_sizes, corners, fine_vertices, levels, fine_face_sizes=None, fine_corners=None, progress=None) -> dict
///
/// Multiresolution analysis (Velho, Perlin, Ying and Biermann, section 2, Figure 1):
/// `fine_vertices` (float32 (m, 3)) are the positions of `levels` (1 to 6) Catmull-Clark
/// subdivisions of the base faces (`vertices` gives the base's vertex count; its positions
/// are not read) in `procedural_detail`'s numbering. With `fine_corners` (and
/// `fine_face_sizes`, all 4 when left out) the fine mesh's faces are checked against that
/// numbering (in any order, each from any first corner, winding kept), and a mesh
/// numbered otherwise is refused instead of analysed as noise.
/// Refused with OverLimit where the analysis would need more memory than allowed
/// (`budget::ANALYSIS_BYTES_PER_FACE` per fine face). Returns the coarse mesh (vertices,
/// face_sizes, corners) and `details`, a list of float64 (n_l, 3) arrays, one per level,
/// each vertex's offset in its local frame (tangent, bitangent, normal) of the subdivided
/// coarser level. `synthesize_multires` of the result gives `fine_vertices` back.
/// `progress`: a callable given the share done (0 to 1) about ten times a second;
/// returning False (or raising) cancels with `Cancelled`, as for `shell()`.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, fine_vertices, levels, fine_face_sizes=None, fine_corners=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn analyze<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    fine_vertices: PyReadonlyArray2<'py, f32>,
    levels: u32,
    fine_face_sizes: Option<&Bound<'py, PyAny>>,
    fine_corners: Option<&Bound<'py, PyAny>>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let base = arrays::mesh(&vertices, face_sizes, corners)?;
    let fine = arrays::positions(&fine_vertices)?;
    let fine_faces = match (fine_face_sizes, fine_corners) {
        (None, None) => None,
        (sizes, Some(c)) => {
            let c = arrays::indices(c, "fine_corners")?;
            let sizes = match sizes {
                Some(s) => arrays::indices(s, "fine_face_sizes")?,
                None => vec![4; c.len() / 4 + (c.len() % 4 != 0) as usize],
            };
            Some((sizes, c))
        }
        (Some(_), None) => return Err(InvalidInput::new_err("fine_face_sizes was given without fine_corners")),
    };
    if (1..=subdivision::MAX_LEVELS).contains(&levels) {
        budget::check_analysis_fits(&base, levels, DEFAULT_MAX_BYTES).map_err(to_py)?;
    }
    let m = run_maybe_watched(py, progress.as_ref(), move |watch| match fine_faces {
        None => multires::analyze_positions_watched(fine, &base, levels, watch),
        Some((sizes, c)) => multires::analyze_watched(&Mesh::new(fine, &sizes, c, None)?, &base, levels, watch),
    })?;
    multires_dict(py, m)
}

/// synthesize_multires(vertices, face_sizes, corners, details) -> dict
///
/// Multiresolution synthesis (section 2): subdivides the base once per entry of `details`
/// (a list of (n_l, 3) float64 or float32 arrays, as `analyze` returns), adding each
/// level's offsets in the local frames of the subdivided coarser level. Returns the finest
/// mesh's vertices, face_sizes and corners (all quads).
#[pyfunction]
pub fn synthesize_multires<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    details: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let base = arrays::mesh(&vertices, face_sizes, corners)?;
    let details = details_from(details)?;
    if (1..=subdivision::MAX_LEVELS as usize).contains(&details.len()) {
        budget::check_fits(&base, details.len() as u32, DEFAULT_MAX_BYTES).map_err(to_py)?;
    }
    let mesh = run_detached(py, move || multires::synthesize(&Multires { base, details }))?;
    arrays::mesh_dict(py, mesh)
}

/// match_subdivision(vertices, face_sizes, corners, levels, subdivided_vertices, tolerance=1e-4) -> int32 array
///
/// Blender's numbering of `levels` subdivisions of the base, from `subdivided_vertices`:
/// the positions its Subdivision Surface modifier makes (Use Limit Surface, Boundary
/// Smooth "All"; a Multires modifier's evaluated mesh at as many levels shares its
/// numbering). Returns `order`, int32: Thicket's vertex `i` is Blender's `order[i]`, so
/// `blender_positions[order]` is in the numbering `analyze` takes. Matched by nearest limit
/// position within `tolerance` times the base's bounding-box diagonal; refused unless one
/// to one.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, levels, subdivided_vertices, tolerance=1e-4))]
pub fn match_subdivision<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    levels: u32,
    subdivided_vertices: PyReadonlyArray2<'py, f32>,
    tolerance: f64,
) -> PyResult<Bound<'py, numpy::PyArray1<i32>>> {
    let base = arrays::mesh(&vertices, face_sizes, corners)?;
    let theirs = arrays::positions(&subdivided_vertices)?;
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(InvalidInput::new_err(format!("tolerance must be above 0, not {tolerance}")));
    }
    if let Some(k) = theirs.iter().position(|p| !p.is_finite()) {
        return Err(InvalidInput::new_err(format!("subdivided vertex {k} is not finite")));
    }
    if (1..=subdivision::MAX_LEVELS).contains(&levels) {
        budget::check_fits(&base, levels, DEFAULT_MAX_BYTES).map_err(to_py)?;
    }
    let order = run_detached(py, move || {
        let ours = multires::limit_positions(&base, levels)?;
        multires::match_points(&theirs, &ours, tolerance * base.bbox_diagonal() as f64)
    })?;
    Ok(arrays::u32_as_i32_array(py, order))
}

/// The dict `analyze` returns: the base mesh and its details.
fn multires_dict(py: Python<'_>, m: Multires) -> PyResult<Bound<'_, PyDict>> {
    let d = arrays::mesh_dict(py, m.base)?;
    let levels = PyList::empty(py);
    for level in m.details {
        let n = level.len();
        let flat: Vec<f64> = level.into_iter().flat_map(|v| v.to_array()).collect();
        levels.append(flat.into_pyarray(py).reshape([n, 3])?)?;
    }
    d.set_item("details", levels)?;
    Ok(d)
}

/// Per-level details: a sequence of (n_l, 3) float64 or float32 arrays.
fn details_from(details: &Bound<'_, PyAny>) -> PyResult<Vec<Vec<DVec3>>> {
    let bad = || InvalidInput::new_err("details must be a list of (n, 3) float64 or float32 arrays, one per level");
    let list: Vec<Bound<'_, PyAny>> = details.extract().map_err(|_| bad())?;
    list.iter()
        .map(|level| {
            let flat: Vec<f64> = if let Ok(a) = level.extract::<PyReadonlyArray2<'_, f64>>() {
                if a.shape()[1] != 3 {
                    return Err(bad());
                }
                a.as_slice().map_err(|_| bad())?.to_vec()
            } else if let Ok(a) = level.extract::<PyReadonlyArray2<'_, f32>>() {
                if a.shape()[1] != 3 {
                    return Err(bad());
                }
                a.as_slice().map_err(|_| bad())?.iter().map(|&x| x as f64).collect()
            } else {
                return Err(bad());
            };
            Ok(flat.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect())
        })
        .collect()
}

/// `procedural_detail`'s `sculpt` dict: its `details`.
fn sculpt_from(s: &Bound<'_, PyDict>) -> PyResult<Vec<Vec<DVec3>>> {
    match s.get_item("details")? {
        Some(d) => details_from(&d),
        None => Err(InvalidInput::new_err("sculpt must be the dict thicket_native.analyze returns (with its 'details')")),
    }
}

/// `procedural_detail`'s `uvs`: one float32 (corners, 2) array or a list (or tuple) of
/// them, as UV maps, and whether a list was given (None: no maps, not a list).
fn uv_maps(uvs: Option<&Bound<'_, PyAny>>, corners: usize) -> PyResult<(Vec<Vec<Vec2>>, bool)> {
    let one = |u: &Bound<'_, PyAny>| {
        let array: PyReadonlyArray2<f32> =
            u.extract().map_err(|_| InvalidInput::new_err("uvs must be a float32 array of shape (corners, 2) or a list of them"))?;
        arrays::uvs(&array, corners)
    };
    match uvs.filter(|u| !u.is_none()) {
        None => Ok((Vec::new(), false)),
        Some(u) if u.is_instance_of::<PyList>() || u.is_instance_of::<PyTuple>() => Ok((u.try_iter()?.map(|m| one(&m?)).collect::<PyResult<_>>()?, true)),
        Some(u) => Ok((vec![one(u)?], false)),
    }
}

/// A model from its name and `params` (lengths as fractions of `mesh`'s diagonal), and how
/// time moves it (`spin` for the tentacle, `grow` for all but the berry).
fn model_from(model: &str, params: Option<&Bound<'_, PyDict>>, mesh: &Mesh) -> PyResult<(Model, Motion)> {
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
    let motion = Motion {
        spin: if matches!(model, Model::Tentacle { .. }) { settings.get("spin", 0.0f64)? } else { 0.0 },
        grow: if matches!(model, Model::Berry { .. }) { 0.0 } else { settings.get("grow", 0.0f64)? },
    };
    settings.finish()?;
    Ok((model, motion))
}

/// The levels a model or a modification acts at: all when None; an empty list is refused.
fn levels_from(at: Option<Vec<i64>>) -> PyResult<Levels> {
    let Some(at) = at else { return Ok(Levels::ALL) };
    if at.is_empty() {
        return Err(InvalidInput::new_err("levels must name at least one level (None: all of them)"));
    }
    let at: Vec<u32> =
        at.iter().map(|&l| u32::try_from(l).map_err(|_| InvalidInput::new_err(format!("levels must be 1 to 31, not {l}")))).collect::<PyResult<_>>()?;
    Levels::of(&at).map_err(to_py)
}

/// `procedural_detail`'s `blend` dict.
fn blend_from(b: &Bound<'_, PyDict>, mesh: &Mesh) -> PyResult<Blend> {
    let diag = mesh.bbox_diagonal() as f64;
    let k = Keywords::new("procedural_detail blend", Some(b));
    let Some(name): Option<String> = k.get("model", None)? else {
        return Err(InvalidInput::new_err("blend needs the second model's name ('model')"));
    };
    let params: Option<Bound<'_, PyDict>> = k.get("params", None)?;
    let seed = k.get("seed", 0u64)?;
    let at = levels_from(k.get("at", None)?)?;
    let plane: Option<([f64; 3], [f64; 3])> = k.get("plane", None)?;
    let weights: Option<Bound<'_, PyAny>> = k.get("weights", None)?;
    let source = match (plane, weights) {
        (Some((point, direction)), None) => AlphaSource::Plane { point: DVec3::from(point), direction: DVec3::from(direction) },
        (None, Some(w)) => AlphaSource::Painted { weights: arrays::per_vertex_or_scalar(&w, mesh.vertex_count(), "blend weights")? },
        _ => {
            return Err(InvalidInput::new_err(
                "blend needs its alpha from either 'plane' (point, direction) or 'weights' (one per vertex), not both or neither",
            ))
        }
    };
    let width = match source {
        AlphaSource::Plane { .. } => k.get("width", 0.2f64)? * diag,
        AlphaSource::Painted { .. } => k.get("width", 1.0f64)?,
    };
    let sweep = match source {
        AlphaSource::Plane { .. } => k.get("sweep", 0.0f64)? * diag,
        AlphaSource::Painted { .. } => k.get("sweep", 0.0f64)?,
    };
    k.finish()?;
    let (model, motion) = model_from(&name, params.as_ref(), mesh)?;
    Ok(Blend { model, seed, at, alpha: Alpha { source, width, sweep }, motion })
}

/// One of `procedural_detail`'s `local` dicts.
fn local_from(l: &Bound<'_, PyDict>) -> PyResult<Local> {
    let k = Keywords::new("procedural_detail local", Some(l));
    let Some(center) = k.get("center", None)? else {
        return Err(InvalidInput::new_err("a local modification needs its center vertex ('center')"));
    };
    let local = Local { center, radius: k.get("radius", 2.0f64)?, gain: k.get("gain", 0.0f64)?, levels: levels_from(k.get("levels", None)?)? };
    k.finish()?;
    Ok(local)
}

/// `procedural_detail`'s `shader` dict (heights as fractions of `diag`), at `time`.
fn planet_from(s: &Bound<'_, PyDict>, diag: f64, time: f64) -> PyResult<Planet> {
    let k = Keywords::new("procedural_detail shader", Some(s));
    let name: String = k.get("name", "planet".to_string())?;
    if name != "planet" {
        return Err(InvalidInput::new_err(format!("shader name must be 'planet', not {name:?}")));
    }
    let planet = Planet {
        scale: diag,
        sea: k.get("sea", 0.0f64)?,
        snow: k.get("snow", 0.025f64)?,
        sea_rate: k.get("sea_rate", 0.0f64)?,
        snow_rate: k.get("snow_rate", 0.0f64)?,
        ..Planet::default()
    }
    .at_time(time);
    k.finish()?;
    planet.validate().map_err(to_py)?;
    Ok(planet)
}

/// What `levels` Catmull-Clark levels (1 or more) of a mesh with these `face_sizes` make,
/// before anything is made: `faces` (all quads) and `bytes`, the peak memory `subdivide`
/// and `procedural_detail` hold for them (what their 4 GB check reads).
#[pyfunction]
pub fn subdivision_estimate<'py>(py: Python<'py>, face_sizes: &Bound<'py, PyAny>, levels: u32) -> PyResult<Bound<'py, PyDict>> {
    if !(1..=subdivision::MAX_LEVELS).contains(&levels) {
        return Err(InvalidInput::new_err(format!("levels must be 1 to {}, not {levels}", subdivision::MAX_LEVELS)));
    }
    let corners = arrays::indices(face_sizes, "face_sizes")?.iter().map(|&n| u64::from(n)).sum();
    let faces = budget::faces_from_corners(corners, levels);
    let d = PyDict::new(py);
    d.set_item("faces", faces)?;
    d.set_item("bytes", faces.saturating_mul(budget::BYTES_PER_FACE))?;
    Ok(d)
}
