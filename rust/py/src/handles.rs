//! Opaque handles for a mesh, its shell and volumetric textures (the pattern of
//! polars' `PyDataFrame`): read from numpy (or made in Rust) and checked once, then
//! passed on (shell, textured shell, bake, estimate, render) without going back
//! through numpy; numpy again only where a caller asks for arrays.

use numpy::{PyArray3, PyReadonlyArray2};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;
use thicket_core::shell::{self as core, shell_geometry, Side};
use thicket_core::texture::{io, VolumeTexture};
use thicket_core::Mesh as CoreMesh;

use crate::arrays;
use crate::errors::{run_detached, run_maybe_watched};
use crate::keywords::Keywords;
use crate::offset::parse_output;
use crate::texture::{from_field, generate, volume_array, volume_samples, BakeInputs, TextureSettings};
use crate::textured_shell::TexturedShell;

/// Mesh(vertices, face_sizes, corners, uvs=None)
///
/// A polygon mesh checked once (indices in range, faces of at least 3 corners, finite
/// coordinates, one UV per corner), the check with the GIL released: `vertices`
/// float32 (n, 3), `face_sizes` and `corners` int32/uint32, `uvs` float32 (corners, 2).
/// `shell(...)` builds its L_p shell as a `Shell` handle.
#[pyclass(module = "thicket_native", frozen)]
pub struct Mesh {
    pub(crate) inner: Arc<CoreMesh>,
}

#[pymethods]
impl Mesh {
    #[new]
    #[pyo3(signature = (vertices, face_sizes, corners, uvs=None))]
    fn new<'py>(
        py: Python<'py>,
        vertices: PyReadonlyArray2<'py, f32>,
        face_sizes: &Bound<'py, PyAny>,
        corners: &Bound<'py, PyAny>,
        uvs: Option<PyReadonlyArray2<'py, f32>>,
    ) -> PyResult<Self> {
        let (positions, sizes, corners) = (arrays::positions(&vertices)?, arrays::indices(face_sizes, "face_sizes")?, arrays::indices(corners, "corners")?);
        let uvs = uvs.map(|uv| arrays::uvs(&uv, corners.len())).transpose()?;
        let inner = run_detached(py, move || CoreMesh::new(positions, &sizes, corners, uvs))?;
        Ok(Self { inner: Arc::new(inner) })
    }

    #[getter]
    fn vertex_count(&self) -> usize {
        self.inner.vertex_count()
    }

    #[getter]
    fn face_count(&self) -> usize {
        self.inner.face_count()
    }

    /// arrays() -> dict: vertices, face_sizes, corners (and uvs where it has them).
    fn arrays<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = arrays::mesh_dict(py, (*self.inner).clone())?;
        if let Some(uvs) = self.inner.uvs() {
            d.set_item("uvs", arrays::vec2_array(py, uvs.to_vec())?)?;
        }
        Ok(d)
    }

    /// world_size_uvs(tile_size) -> dict
    ///
    /// Texture coordinates for a mesh without a UV map (the core's `texture::Charts`):
    /// faces grouped into charts that project flat without folding, one texture tile
    /// every `tile_size` units of the mesh's coordinates along the surface. `uvs` float32 (corners, 2), `chart_of_face`
    /// int32 (faces,), `chart_count`. A tile size that is not a positive finite length
    /// raises `InvalidInput`.
    fn world_size_uvs<'py>(&self, py: Python<'py>, tile_size: f32) -> PyResult<Bound<'py, PyDict>> {
        let mesh = self.inner.clone();
        let charts = run_detached(py, move || thicket_core::texture::Charts::of(&mesh, tile_size))?;
        let d = PyDict::new(py);
        d.set_item("chart_count", charts.count)?;
        d.set_item("uvs", arrays::vec2_array(py, charts.corner_st)?)?;
        d.set_item("chart_of_face", arrays::u32_as_i32_array(py, charts.chart_of_face))?;
        Ok(d)
    }

    /// with_world_size_uvs(tile_size) -> Mesh
    ///
    /// This mesh with `world_size_uvs(tile_size)["uvs"]` as its UV map (the core's
    /// `texture::with_world_size_uvs`), made without the arrays crossing into Python.
    fn with_world_size_uvs(&self, py: Python<'_>, tile_size: f32) -> PyResult<Self> {
        let mesh = self.inner.clone();
        let inner = run_detached(py, move || thicket_core::texture::with_world_size_uvs(&mesh, tile_size))?;
        Ok(Self { inner: Arc::new(inner) })
    }

    /// uvs -> float32 (corners, 2) or None: the mesh's UV map, one (s, t) per corner.
    #[getter]
    fn uvs<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, numpy::PyArray2<f32>>>> {
        self.inner.uvs().map(|uvs| arrays::vec2_array(py, uvs.to_vec())).transpose()
    }

    /// vertex_normals() -> float32 (n, 3)
    ///
    /// Unit vertex normals as Blender computes them (the core's `mesh::vertex_normals`):
    /// each face's Newell normal weighted by the corner angle at the vertex; zero for a
    /// vertex on no face or only on degenerate faces.
    fn vertex_normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, numpy::PyArray2<f32>>> {
        let mesh = self.inner.clone();
        let normals = run_detached(py, move || Ok(thicket_core::mesh::vertex_normals(&mesh)))?;
        arrays::vec3_array(py, normals)
    }

    /// shell(thickness, side="exterior", relative=False, factors=None, p=3.0,
    ///       progress=None) -> Shell
    ///
    /// The L_p-field shell of this mesh, as `thicket_native.shell` builds it (same
    /// arguments, same directors), kept as a handle: `geometry(...)` gives its surfaces
    /// and `textured(...)` a `TexturedShell`, neither reading the mesh again.
    #[pyo3(signature = (thickness, side="exterior", relative=false, factors=None, p=3.0, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn shell<'py>(
        &self,
        py: Python<'py>,
        thickness: f32,
        side: &str,
        relative: bool,
        factors: Option<&Bound<'py, PyAny>>,
        p: f64,
        progress: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Shell> {
        let mesh = self.inner.clone();
        let factors = factors.map(|f| arrays::per_vertex_or_scalar(f, mesh.vertex_count(), "factors")).transpose()?;
        let side = Side::parse(side).map_err(crate::errors::to_py)?;
        let thickness = if relative { core::Thickness::relative(thickness) } else { core::Thickness::absolute(thickness) };
        let built = mesh.clone();
        let inner = run_maybe_watched(py, progress.as_ref(), move |watch| {
            let target = thickness.per_vertex(&built, factors.as_deref())?;
            core::build_shell_watched(&built, &target, side, &crate::shell::params(p), watch)
        })?;
        Ok(Shell { mesh, inner: Arc::new(inner) })
    }
}

/// Shell(mesh, base_offset, directors)
///
/// A shell of `mesh` (a `Mesh`) kept in Rust: built by `Mesh.shell`, or given by its
/// base offsets and directors, float32 (n, 3) each (read back from Blender).
#[pyclass(module = "thicket_native", frozen)]
pub struct Shell {
    mesh: Arc<CoreMesh>,
    inner: Arc<core::Shell>,
}

#[pymethods]
impl Shell {
    #[new]
    fn new<'py>(mesh: &Mesh, base_offset: PyReadonlyArray2<'py, f32>, directors: PyReadonlyArray2<'py, f32>) -> PyResult<Self> {
        let inner = crate::texture::shell_of(&base_offset, &directors, mesh.inner.vertex_count())?;
        Ok(Self { mesh: mesh.inner.clone(), inner: Arc::new(inner) })
    }

    /// The mesh this shell belongs to.
    #[getter]
    fn mesh(&self) -> Mesh {
        Mesh { inner: self.mesh.clone() }
    }

    /// geometry(output="outer", surfaces=1) -> dict
    ///
    /// What `thicket_native.shell` returns for the same arguments: the surfaces
    /// (`output` "outer", "solid" or "layers", the Stacked Surfaces) and the shell's
    /// per-vertex arrays (base_offset, directors, achieved, target, check).
    #[pyo3(signature = (output="outer", surfaces=1))]
    fn geometry<'py>(&self, py: Python<'py>, output: &str, surfaces: u32) -> PyResult<Bound<'py, PyDict>> {
        let output = parse_output(output, surfaces)?;
        let (mesh, shell) = (self.mesh.clone(), self.inner.clone());
        let geometry = run_detached(py, move || shell_geometry(&mesh, &shell, output))?;
        crate::shell::shell_dict(py, geometry, (*self.inner).clone())
    }

    /// textured(textures, **settings) -> TexturedShell
    ///
    /// `TexturedShell(vertices, face_sizes, corners, base_offset, directors, textures,
    /// **settings)` for this shell and its mesh, without passing them again. `uvs` is
    /// the mesh's own (give it to `Mesh`), so it is not among the settings.
    #[pyo3(signature = (textures, **settings))]
    fn textured<'py>(&self, py: Python<'py>, textures: &Bound<'py, PyAny>, settings: Option<&Bound<'py, PyDict>>) -> PyResult<TexturedShell> {
        if settings.is_some_and(|s| s.contains("uvs").unwrap_or(false)) {
            return Err(PyTypeError::new_err("Shell.textured() got an unexpected keyword argument 'uvs': the mesh's own are used (pass uvs to Mesh(...))"));
        }
        let keywords = Keywords::new("Shell.textured", settings);
        let settings = TextureSettings::read(&keywords, true)?;
        keywords.finish()?;
        let inputs = BakeInputs::with((*self.mesh).clone(), (*self.inner).clone(), textures, settings)?;
        TexturedShell::of_inputs(py, inputs)
    }
}

/// Texture(alpha)
///
/// A volumetric texture kept in Rust: a float32 (nz, ny, nx) alpha array (indexed
/// [r, t, s], as `texture()` returns) checked once with the GIL released (NaN
/// refused, values clamped to [0, 1]), or made without numpy by `Texture.pattern`
/// (`texture()`'s arguments) or `Texture.load` (`load_texture`'s). Wherever a list of
/// textures is taken (`bake_texture`, `estimate_bake`, `render_shell`,
/// `TexturedShell`, `Shell.textured`), a handle stands for its array, alone or in a
/// (texture, (ds, dt)) pair; so does `save_texture`'s `alpha`.
#[pyclass(module = "thicket_native", frozen)]
pub struct Texture {
    pub(crate) inner: Arc<VolumeTexture>,
}

#[pymethods]
impl Texture {
    #[new]
    fn new(py: Python<'_>, alpha: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (dims, data) = volume_samples(alpha)?;
        let inner = run_detached(py, move || VolumeTexture::new(dims, data))?;
        Ok(Self { inner: Arc::new(inner) })
    }

    /// pattern(pattern, size=(64, 64, 32), seed=0, time=1.0, thickness=1.0) -> Texture:
    /// `texture(...)`'s texture for the same arguments, kept in Rust.
    #[staticmethod]
    #[pyo3(signature = (pattern, size=(64, 64, 32), seed=0, time=1.0, thickness=1.0))]
    fn pattern(py: Python<'_>, pattern: &str, size: (usize, usize, usize), seed: u32, time: f32, thickness: f32) -> PyResult<Self> {
        Ok(Self { inner: Arc::new(generate(py, pattern, size, seed, time, thickness)?) })
    }

    /// from_field(tree_json, resolution=(64, 64, 32)) -> Texture: the field tree
    /// `tree_json` sampled over the unit texture cell, tree point (x, y, z) = texture
    /// (s, t, r): alpha 1 where the tree is <= 0, 0 outside, a ramp one texel wide
    /// between (alpha only: colours are not kept). `resolution` is (nx, ny, nz).
    #[staticmethod]
    #[pyo3(signature = (tree_json, resolution=(64, 64, 32)))]
    fn from_field(py: Python<'_>, tree_json: &str, resolution: (usize, usize, usize)) -> PyResult<Self> {
        Ok(Self { inner: Arc::new(from_field(py, tree_json, resolution)?) })
    }

    /// load(path) -> Texture: `load_texture(path)`'s texture, kept in Rust.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        Ok(Self { inner: Arc::new(run_detached(py, move || io::load(&path))?) })
    }

    /// (nx, ny, nz): texels along s and t, and slices across the shell.
    #[getter]
    fn size(&self) -> (usize, usize, usize) {
        let [nx, ny, nz] = self.inner.dims();
        (nx, ny, nz)
    }

    /// array() -> float32 (nz, ny, nx): the samples (a copy), as `texture()` returns them.
    fn array<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f32>>> {
        volume_array(py, (*self.inner).clone())
    }
}
