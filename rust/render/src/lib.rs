//! Renderers for volume-textured shells (thick surfaces, chapters 5 and 6).
//!
//! - [`Camera`]: a pinhole or orthographic camera given by Blender's own view and
//!   projection matrices, from [`thicket_core::raycast`] (the rays through its pixels,
//!   one convention for every ray caster).
//! - [`scene`]: a shell with its texture, ready to render (cells, bounds).
//! - [`reference`]: the CPU reference renderer, ray marching through the shell map with
//!   exact root bracketing of `alpha = 0.5`; ground truth and fallback.
//! - [`gpu`]: the wgpu slice renderer (chapter 5): plain slicing and the two-pass
//!   slice interpolation, headless on any Vulkan, Metal or DirectX 12 adapter.
//! - [`field`]: the GPU sphere tracer of field trees (issue 17), the CPU tracer's
//!   twin in WGSL.
//! - [`mipmap`]: double mipmaps for distant views (chapter 6): occupancy levels, then
//!   transparency levels with directional alpha and normal-distribution ellipsoids.
//! - [`image_out`]: the rendered frame (colour, alpha, depth, normal) and its PNG and
//!   OpenEXR outputs.
//! - [`preview`]: a preview by the method asked for (`auto`, `interpolating`,
//!   `plain`, `reference`), with the one GPU-to-CPU fallback policy every caller shares.
//! - [`silhouette`]: pixel coverage of a mesh or a frame and their intersection over
//!   union: a bake's fidelity to the reference render of its shell.

pub mod field;
pub mod gpu;
pub mod image_out;
pub mod mipmap;
pub mod preview;
pub mod reference;
pub mod scene;
pub mod silhouette;

pub use image_out::Frame;
pub use scene::ShellScene;
pub use thicket_core::raycast::Camera;
