//! Volumetric textures: procedural generation and the bake to geometry.

use numpy::{IntoPyArray, PyArray3, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use thicket_core::glam::Vec2;
use thicket_core::implicit::FieldTree;
use thicket_core::shell::Shell;
use thicket_core::texture::bake::{Cutter, MovedRegion};
use thicket_core::texture::{texture_from_field, BakeParams, Generator, Pattern, TextureLayer, TexturedShell, VolumeTexture};
use thicket_core::Mesh;

use crate::arrays;
use crate::errors::{run_detached, run_watched, to_py, InvalidInput};
use crate::keywords::Keywords;
use std::sync::Arc;
use thicket_core::progress::Progress;

/// texture(pattern, size=(64, 64, 32), seed=0, time=1.0, thickness=1.0) -> float32 (nz, ny, nx)
///
/// A procedural volumetric texture: "chain_mail", "weave", "rivets", "grass", "fur"
/// or "bubbles". `size` is (nx, ny, nz); the result is indexed [r, t, s], alpha in [0, 1].
/// `Texture.pattern(...)` makes the same texture as a handle, kept in Rust.
#[pyfunction]
#[pyo3(signature = (pattern, size=(64, 64, 32), seed=0, time=1.0, thickness=1.0))]
pub fn texture<'py>(py: Python<'py>, pattern: &str, size: (usize, usize, usize), seed: u32, time: f32, thickness: f32) -> PyResult<Bound<'py, PyArray3<f32>>> {
    volume_array(py, generate(py, pattern, size, seed, time, thickness)?)
}

/// The procedural texture `texture(...)` and `Texture.pattern(...)` make, generated
/// with the GIL released.
pub(crate) fn generate(py: Python<'_>, pattern: &str, size: (usize, usize, usize), seed: u32, time: f32, thickness: f32) -> PyResult<VolumeTexture> {
    let pattern = Pattern::parse(pattern).map_err(to_py)?;
    if size.0 * size.1 * size.2 > 512 * 512 * 256 {
        return Err(InvalidInput::new_err(format!("texture size {size:?} is too large")));
    }
    let g = Generator { pattern, seed, time, thickness };
    run_detached(py, move || g.generate([size.0, size.1, size.2]))
}

/// The texture `Texture.from_field(tree_json, resolution)` makes: the field tree read
/// and sampled over the unit texture cell with the GIL released (the core's
/// `texture::from_field`: tree point (x, y, z) = texture (s, t, r), alpha 1 inside,
/// 0 outside, a one-texel ramp between). Bad trees and sizes raise InvalidInput.
pub(crate) fn from_field(py: Python<'_>, tree_json: &str, resolution: (usize, usize, usize)) -> PyResult<VolumeTexture> {
    let text = tree_json.to_owned();
    let dims = [resolution.0, resolution.1, resolution.2];
    run_detached(py, move || texture_from_field(&FieldTree::from_json(&text)?, dims))
}

/// A texture as numpy float32 (nz, ny, nx), indexed [r, t, s].
pub(crate) fn volume_array(py: Python<'_>, t: VolumeTexture) -> PyResult<Bound<'_, PyArray3<f32>>> {
    let [nx, ny, nz] = t.dims();
    let flat = numpy::ndarray::Array1::from_vec(t.into_samples());
    let arr = flat.into_shape_with_order((nz, ny, nx)).map_err(|e| InvalidInput::new_err(e.to_string()))?;
    Ok(arr.into_pyarray(py))
}

/// The samples of a float32 (nz, ny, nx) array and its dims (nx, ny, nz), copied
/// as they are: [`VolumeTexture::new`] checks them (without the GIL).
pub(crate) fn volume_samples(alpha: &Bound<'_, PyAny>) -> PyResult<([usize; 3], Vec<f32>)> {
    let a: PyReadonlyArray3<'_, f32> = alpha.extract().map_err(|_| InvalidInput::new_err("a texture must be a float32 array of shape (nz, ny, nx)"))?;
    let shape = a.shape().to_vec();
    // One copy either way: the texture owns its samples.
    // `as_slice` also accepts Fortran order (memory order): only C order is x fastest.
    let data = match a.as_slice() {
        Ok(s) if a.is_c_contiguous() => s.to_vec(),
        _ => a.as_array().iter().copied().collect(),
    };
    Ok(([shape[2], shape[1], shape[0]], data))
}

/// One texture of a `textures` argument: a `Texture` handle (checked already) or an
/// array's samples (checked when the textured shell is built, without the GIL).
enum Placed {
    Handle(Arc<VolumeTexture>),
    Samples([usize; 3], Vec<f32>),
}

impl Placed {
    fn of(alpha: &Bound<'_, PyAny>) -> PyResult<Self> {
        match alpha.cast::<crate::handles::Texture>() {
            Ok(handle) => Ok(Self::Handle(handle.get().inner.clone())),
            Err(_) => volume_samples(alpha).map(|(dims, data)| Self::Samples(dims, data)),
        }
    }

    /// The texture; a handle's samples are copied (the core's layers own theirs).
    fn texture(self) -> thicket_core::Result<VolumeTexture> {
        match self {
            Self::Handle(texture) => Ok(Arc::unwrap_or_clone(texture)),
            Self::Samples(dims, data) => VolumeTexture::new(dims, data),
        }
    }
}

/// The placed textures of a `textures` argument: `Texture` handles or float32
/// (nz, ny, nx) arrays, each alone or in a (texture, (ds, dt)) pair (the core's
/// [`TextureLayer`]s once built).
fn placed_textures(textures: &Bound<'_, PyAny>) -> PyResult<Vec<(Placed, Vec2)>> {
    let mut out = Vec::new();
    for item in textures.try_iter()? {
        let item = item?;
        let (alpha, offset) = match item.extract::<(Bound<'_, PyAny>, (f32, f32))>() {
            Ok((a, o)) => (a, Vec2::new(o.0, o.1)),
            Err(_) => (item, Vec2::ZERO),
        };
        out.push((Placed::of(&alpha)?, offset));
    }
    Ok(out)
}

/// A shell given by its base offsets and directors (depth r over vertex v at
/// v + base_offset + r * director), one row per vertex of an `n`-vertex mesh.
pub(crate) fn shell_of(base_offset: &PyReadonlyArray2<'_, f32>, directors: &PyReadonlyArray2<'_, f32>, n: usize) -> PyResult<Shell> {
    let base_offset = arrays::positions(base_offset)?;
    let directors = arrays::positions(directors)?;
    if base_offset.len() != n || directors.len() != n {
        return Err(InvalidInput::new_err("base_offset and directors need one row per vertex"));
    }
    for (name, rows) in [("base_offset", &base_offset), ("directors", &directors)] {
        if let Some(v) = rows.iter().position(|p| !p.is_finite()) {
            return Err(InvalidInput::new_err(format!("{name} of vertex {v} is not finite ({:?})", rows[v].to_array())));
        }
    }
    Ok(Shell::from_directors(base_offset, directors))
}

/// The arrays of a textured shell, the positional arguments `bake_texture`,
/// `estimate_bake`, `render_shell` and `TexturedShell` begin with: the base mesh, its
/// shell (base offsets and directors) and the textures.
pub(crate) struct ShellArrays<'a, 'py> {
    pub vertices: PyReadonlyArray2<'py, f32>,
    pub face_sizes: &'a Bound<'py, PyAny>,
    pub corners: &'a Bound<'py, PyAny>,
    pub base_offset: PyReadonlyArray2<'py, f32>,
    pub directors: PyReadonlyArray2<'py, f32>,
    pub textures: &'a Bound<'py, PyAny>,
}

/// A textured shell's settings besides its arrays: the keyword arguments that
/// `bake_texture`, `estimate_bake`, `render_shell` and `TexturedShell` share, each
/// named here once with its default (the stub's `_TextureSettings` and
/// `_BakeSettings`).
pub(crate) struct TextureSettings<'py> {
    uvs: Option<PyReadonlyArray2<'py, f32>>,
    tiling: f32,
    resolution: u32,
    depth_steps: u32,
    region: Option<Bound<'py, PyAny>>,
    base_layer: f32,
    holes: Option<Bound<'py, PyAny>>,
    cutter: Option<(PyReadonlyArray2<'py, f32>, Bound<'py, PyAny>)>,
    move_region: Option<Bound<'py, PyAny>>,
    move_offset: (f32, f32),
    follow_texture: bool,
    triangle_budget: usize,
    max_triangles: usize,
}

impl<'py> TextureSettings<'py> {
    /// The settings among `keywords`. `budget`: whether the bake's `triangle_budget`
    /// and `max_triangles` are among them; a render takes neither (it draws every
    /// cell: no simplification, no limit).
    pub(crate) fn read(keywords: &Keywords<'_, 'py>, budget: bool) -> PyResult<Self> {
        let (triangle_budget, max_triangles) =
            if budget { (keywords.get("triangle_budget", 1_000_000)?, keywords.get("max_triangles", 20_000_000)?) } else { (0, usize::MAX) };
        Ok(Self {
            uvs: keywords.get("uvs", None)?,
            tiling: keywords.get("tiling", 1.0)?,
            resolution: keywords.get("resolution", 8)?,
            depth_steps: keywords.get_renamed("depth_steps", "layers", 16)?,
            region: keywords.get("region", None)?,
            base_layer: keywords.get("base_layer", 0.1)?,
            holes: keywords.get("holes", None)?,
            cutter: keywords.get("cutter", None)?,
            move_region: keywords.get("move_region", None)?,
            move_offset: keywords.get("move_offset", (0.0, 0.0))?,
            follow_texture: keywords.get("follow_texture", true)?,
            triangle_budget,
            max_triangles,
        })
    }
}

/// Everything a bake is given, read from Python and checked against the mesh; the
/// cutter's mesh is turned into a [`Cutter`] (a BVH) only once the GIL is released.
pub(crate) struct BakeInputs {
    mesh: Mesh,
    shell: Shell,
    textures: Vec<(Placed, Vec2)>,
    cutter: Option<(Vec<thicket_core::glam::Vec3>, Vec<u32>)>,
    params: BakeParams,
}

impl BakeInputs {
    /// The arrays and settings of a bake, estimate or render call, checked against
    /// each other.
    pub(crate) fn read(arrays: ShellArrays<'_, '_>, settings: TextureSettings<'_>) -> PyResult<Self> {
        let ShellArrays { vertices, face_sizes, corners, base_offset, directors, textures } = arrays;
        let mesh = arrays::mesh_with_uvs(&vertices, face_sizes, corners, settings.uvs.as_ref())?;
        let shell = shell_of(&base_offset, &directors, mesh.vertex_count())?;
        Self::with(mesh, shell, textures, settings)
    }

    /// The inputs given the mesh and its shell already read (handles), the textures
    /// and the settings (whose `uvs`, if any, are ignored: the mesh has its own).
    pub(crate) fn with(mesh: Mesh, shell: Shell, textures: &Bound<'_, PyAny>, settings: TextureSettings<'_>) -> PyResult<Self> {
        let n = mesh.vertex_count();
        if shell.directors.len() != n {
            return Err(InvalidInput::new_err("base_offset and directors need one row per vertex"));
        }
        let textures = placed_textures(textures)?;
        let region = settings.region.map(|r| arrays::per_vertex_or_scalar(&r, n, "region")).transpose()?;
        let holes = settings.holes.map(|r| arrays::per_vertex_or_scalar(&r, n, "holes")).transpose()?;
        let moved = settings
            .move_region
            .map(|r| arrays::per_vertex_or_scalar(&r, n, "move_region"))
            .transpose()?
            .map(|weights| MovedRegion { weights, offset: Vec2::new(settings.move_offset.0, settings.move_offset.1) });
        let cutter = match &settings.cutter {
            Some((v, t)) => Some((arrays::positions(v)?, arrays::indices(t, "cutter triangles")?)),
            None => None,
        };
        let params = BakeParams {
            resolution: settings.resolution,
            depth_steps: settings.depth_steps,
            follow_texture: settings.follow_texture,
            tiling: settings.tiling,
            region,
            base_layer: settings.base_layer,
            holes,
            cutter: None,
            moved,
            progress: None,
            triangle_budget: settings.triangle_budget,
            max_triangles: settings.max_triangles,
        };
        Ok(Self { mesh, shell, textures, cutter, params })
    }

    /// The inputs of a call given `arrays` and keyword `settings`, read as `function`
    /// reads them (`budget`: see [`TextureSettings::read`]); the keywords it does not
    /// take are refused before any array is read.
    pub(crate) fn of_call<'py>(function: &'static str, arrays: ShellArrays<'_, 'py>, settings: Option<&Bound<'py, PyDict>>, budget: bool) -> PyResult<Self> {
        let keywords = Keywords::new(function, settings);
        let settings = TextureSettings::read(&keywords, budget)?;
        keywords.finish()?;
        Self::read(arrays, settings)
    }

    /// `work` given the [`TexturedShell`] of the inputs, the cutter built first
    /// (heavy: call without the GIL).
    pub(crate) fn run<T>(self, work: impl FnOnce(&TexturedShell) -> thicket_core::Result<T>) -> thicket_core::Result<T> {
        work(&self.build()?)
    }

    /// The checked textured shell (its cutter built), to keep.
    pub(crate) fn build(mut self) -> thicket_core::Result<TexturedShell> {
        if let Some((v, t)) = self.cutter.take() {
            if t.len() % 3 != 0 {
                return Err(thicket_core::Error::InvalidParameter("cutter triangles: three indices per triangle".into()));
            }
            self.params.cutter = Some(Cutter::new(&v, &t.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect::<Vec<_>>())?);
        }
        let textures =
            self.textures.into_iter().map(|(placed, offset)| Ok(TextureLayer { texture: placed.texture()?, offset })).collect::<thicket_core::Result<_>>()?;
        TexturedShell::new(self.mesh, self.shell, textures, self.params)
    }
}

/// bake_texture(vertices, face_sizes, corners, base_offset, directors, textures, *,
///              progress=None, **settings) -> dict
///
/// Bakes the alpha = 0.5 iso-surface of volumetric textures mapped into a shell (depth
/// r over vertex v at v + base_offset + r * director) into one closed, crack-free mesh.
/// `textures`: a list of `Texture` handles or float32 (nz, ny, nx) arrays, each
/// alone or in a (texture, (ds, dt)) pair, united. `settings` (keywords, the same for `estimate_bake`, `TexturedShell` and,
/// but for the last two, `render_shell`): uvs=None, tiling=1.0, resolution=8,
/// depth_steps=16, region=None, base_layer=0.1, holes=None, cutter=None,
/// move_region=None, move_offset=(0.0, 0.0), follow_texture=True,
/// triangle_budget=1_000_000, max_triangles=20_000_000.
/// `depth_steps`: lattice steps across the shell, base to outer surface (formerly
/// `layers`, still taken with a DeprecationWarning for one release).
/// `uvs`: float32 (corners, 2) or None (one tile per face). `region`: float32
/// (n,) where the texture exists (elsewhere a thin base slab). `holes`: float32 (n,)
/// where the texture is cut away. `cutter`: (vertices float32 (k,3), triangles (t,3))
/// of a closed mesh in the same coordinates; the texture is cut away inside it.
/// `move_region`: float32 (n,), the piece of texture moved by `move_offset` (UV
/// units; needs `uvs`), its trace showing the base. `follow_texture`: sample at the
/// texture's own texel spacing (at least `resolution` steps per cell edge and
/// `depth_steps` across the shell), so features a texel wide survive; False: exactly those steps.
/// `triangle_budget`: simplify toward this many triangles without moving the surface
/// by more than a quarter of a lattice step (0: keep every triangle).
/// `max_triangles`: the most triangles the lattice may make before simplification; a
/// texture-following lattice is coarsened to fit, a bake over it even at `resolution`
/// steps is refused. Returns vertices, face_sizes, corners, normals (n,3),
/// texcoords (n,3) = (s, t, r), corner_texcoords (corners,3) = (s, t, r) of each
/// corner in its own cell (UV seams and tile edges kept apart), source_face
/// (triangles,) = the base face each triangle grew from, per_face_tiles,
/// lattice_steps (per cell edge, across the shell), texture_finer_than_lattice
/// (thin features may be lost), over_budget (more triangles than triangle_budget: the
/// simplification stopped at its largest error) and simplify_error (that error, in
/// lattice steps). `progress`: a callable given the share of cells baked
/// (0 to 1) about ten times a second; returning False cancels the bake (as does an
/// exception from it, raised once the bake stops, or Ctrl-C), which then raises
/// thicket_native.Cancelled (a ThicketError, message "cancelled").
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, base_offset, directors, textures, *, progress=None, **settings))]
#[allow(clippy::too_many_arguments)]
pub fn bake_texture<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    base_offset: PyReadonlyArray2<'py, f32>,
    directors: PyReadonlyArray2<'py, f32>,
    textures: &Bound<'py, PyAny>,
    progress: Option<Bound<'py, PyAny>>,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let mut inputs = BakeInputs::of_call("bake_texture", ShellArrays { vertices, face_sizes, corners, base_offset, directors, textures }, settings, true)?;
    let out = match progress {
        Some(callback) => {
            let watch = Arc::new(Progress::default());
            inputs.params.progress = Some(watch.clone());
            run_watched(py, &callback, &watch, move || inputs.run(TexturedShell::bake))?
        }
        None => run_detached(py, move || inputs.run(TexturedShell::bake))?,
    };
    baked_dict(py, out)
}

/// A bake's result as `bake_texture` returns it.
pub(crate) fn baked_dict(py: Python<'_>, out: thicket_core::texture::BakedMesh) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    let count = out.triangles.len();
    d.set_item("vertices", arrays::vec3_array(py, out.positions)?)?;
    d.set_item("face_sizes", arrays::u32_as_i32_array(py, vec![3; count]))?;
    d.set_item("corners", arrays::u32_as_i32_array(py, out.triangles.into_iter().flatten().collect()))?;
    d.set_item("normals", arrays::vec3_array(py, out.normals)?)?;
    d.set_item("texcoords", arrays::vec3_array(py, out.texcoords)?)?;
    d.set_item("corner_texcoords", arrays::vec3_array(py, out.corner_texcoords.into_iter().flatten().collect())?)?;
    d.set_item("source_face", arrays::u32_as_i32_array(py, out.source_face))?;
    d.set_item("per_face_tiles", out.per_face_tiles)?;
    d.set_item("lattice_steps", (out.lattice[0], out.lattice[1]))?;
    d.set_item("texture_finer_than_lattice", out.texture_finer_than_lattice)?;
    d.set_item("over_budget", out.over_budget)?;
    d.set_item("simplify_error", out.simplify_error)?;
    Ok(d)
}

/// estimate_bake(vertices, face_sizes, corners, base_offset, directors, textures,
///               **settings) -> int
///
/// The triangle count `bake_texture` is expected to make when given the same
/// arguments (checked alike, refused alike), before baking: the bake's own lattice,
/// field and simplification on a sample of its cells.
#[pyfunction]
#[pyo3(signature = (vertices, face_sizes, corners, base_offset, directors, textures, **settings))]
#[allow(clippy::too_many_arguments)]
pub fn estimate_bake<'py>(
    py: Python<'py>,
    vertices: PyReadonlyArray2<'py, f32>,
    face_sizes: &Bound<'py, PyAny>,
    corners: &Bound<'py, PyAny>,
    base_offset: PyReadonlyArray2<'py, f32>,
    directors: PyReadonlyArray2<'py, f32>,
    textures: &Bound<'py, PyAny>,
    settings: Option<&Bound<'py, PyDict>>,
) -> PyResult<usize> {
    let inputs = BakeInputs::of_call("estimate_bake", ShellArrays { vertices, face_sizes, corners, base_offset, directors, textures }, settings, true)?;
    run_detached(py, move || inputs.run(|textured| Ok(textured.estimate()?.triangles)))
}
