//! `thicket_native`: the pyo3 adapter over `thicket-core`.
//!
//! Only type and error adaptation lives here: numpy arrays in (float32 positions,
//! int32/uint32 indices, read without copying when contiguous), numpy arrays out (Rust
//! vectors handed over without copying), core errors as `ThicketError` subclasses
//! (`InvalidInput` and its `OverLimit`, `FileError`, `DeviceError`, `Cancelled`), Rust panics caught and
//! reported as `InternalError` so Blender never goes down. Heavy work runs
//! with the GIL released.

mod arrays;
mod bake_budget;
mod errors;
mod field;
mod field_render;
mod handles;
mod incremental;
mod keywords;
mod offset;
mod render;
mod report;
mod shell;
mod subdivision;
mod texture;
mod texture_io;
mod textured_shell;

use pyo3::prelude::*;

#[pymodule]
fn thicket_native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("ThicketError", m.py().get_type::<errors::ThicketError>())?;
    m.add("InvalidInput", m.py().get_type::<errors::InvalidInput>())?;
    m.add("OverLimit", m.py().get_type::<errors::OverLimit>())?;
    m.add("FileError", m.py().get_type::<errors::FileError>())?;
    m.add("DeviceError", m.py().get_type::<errors::DeviceError>())?;
    m.add("Cancelled", m.py().get_type::<errors::Cancelled>())?;
    m.add("InternalError", m.py().get_type::<errors::InternalError>())?;
    m.add_function(wrap_pyfunction!(report::mesh_report, m)?)?;
    m.add_class::<handles::Mesh>()?;
    m.add_class::<handles::Shell>()?;
    m.add_class::<handles::Texture>()?;
    m.add_function(wrap_pyfunction!(offset::offset_shell, m)?)?;
    m.add_function(wrap_pyfunction!(shell::build_shell, m)?)?;
    m.add_function(wrap_pyfunction!(shell::shell, m)?)?;
    m.add_function(wrap_pyfunction!(shell::shell_report, m)?)?;
    m.add_function(wrap_pyfunction!(shell::self_intersections, m)?)?;
    m.add_class::<incremental::IncrementalShell>()?;
    m.add_function(wrap_pyfunction!(texture::texture, m)?)?;
    m.add_function(wrap_pyfunction!(texture::bake_texture, m)?)?;
    m.add_function(wrap_pyfunction!(texture::estimate_bake, m)?)?;
    m.add_function(wrap_pyfunction!(bake_budget::fit_bake_tiles, m)?)?;
    m.add_class::<textured_shell::TexturedShell>()?;
    m.add_function(wrap_pyfunction!(texture_io::load_texture, m)?)?;
    m.add_function(wrap_pyfunction!(texture_io::save_texture, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_shell, m)?)?;
    m.add_function(wrap_pyfunction!(render::save_render, m)?)?;
    m.add_function(wrap_pyfunction!(field::field_eval, m)?)?;
    m.add_function(wrap_pyfunction!(field::field_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(field::field_mesh_estimate, m)?)?;
    m.add_function(wrap_pyfunction!(field_render::field_render, m)?)?;
    m.add_function(wrap_pyfunction!(subdivision::subdivide, m)?)?;
    m.add_function(wrap_pyfunction!(subdivision::procedural_detail, m)?)?;
    m.add_function(wrap_pyfunction!(subdivision::subdivision_estimate, m)?)?;
    m.add_function(wrap_pyfunction!(subdivision::analyze, m)?)?;
    m.add_function(wrap_pyfunction!(subdivision::synthesize_multires, m)?)?;
    m.add_function(wrap_pyfunction!(subdivision::match_subdivision, m)?)?;
    Ok(())
}
