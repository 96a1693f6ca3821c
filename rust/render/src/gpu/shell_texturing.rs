//! Shell texturing, the peer the slice renderer is measured against: the technique
//! games and Blender users use today for fur and grass. `N` copies of the base mesh,
//! copy `k` offset along the vertex normals by `(k + ½)/N` of the per-vertex
//! thickness, each fragment alpha-tested (`alpha >= 0.5`) against the same 3D texture
//! at `(s, t, r_k)`, `r_k = (k + ½)/N`, depth-tested and opaque
//! (`shaders/shell_texturing.wgsl`).
//!
//! `(s, t)` come from the same mapping as the slice renderer's cells
//! ([`TextureCoordinates`] and [`TriangleCells`]: the UV map times the tiling, or one
//! tile per face); the texture layers are united (max alpha) as
//! [`crate::ShellScene::alpha`] does. The device, the output targets' formats, the
//! readback and the frame timings are the slice renderer's.

use std::borrow::Cow;
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use thicket_core::mesh::vertex_normals;
use thicket_core::texture::{TextureCoordinates, TextureLayer, TriangleCells};
use thicket_core::{Error, Mesh, Result};
use wgpu::util::DeviceExt;

use super::device::Gpu;
use super::pipeline::{DEPTH_FORMAT, MAX_LAYERS, OUTPUT_FORMAT};
use super::scene_data::f16_bits;
use super::{readback, FrameTimings, SliceParams, GL_TO_WGPU};
use crate::image_out::Frame;
use thicket_core::raycast::Camera;

/// The shell-texturing shaders.
pub const SHELL_TEXTURING_WGSL: &str = include_str!("../../../../shaders/shell_texturing.wgsl");

/// The most shells drawn.
pub const MAX_SHELLS: u32 = 1024;

/// The texture's alpha on the GPU (filterable on every adapter).
const ALPHA_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;

/// One corner of a base triangle, as `Corner` in the shader.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct ShellCorner {
    /// Base point; `s` in `w`.
    pub base: [f32; 4],
    /// Vertex normal times the vertex's thickness; `t` in `w`.
    pub offset: [f32; 4],
    /// Unit vertex normal (zero where the vertex has none).
    pub normal: [f32; 4],
}

/// The base mesh as the shells draw it: three corners per triangle (not shared, since
/// one tile per face makes `(s, t)` jump across every edge) and the texture layers.
#[derive(Debug, Clone)]
pub struct ShellTexturingScene {
    pub corners: Vec<ShellCorner>,
    pub textures: Vec<TextureLayer>,
}

impl ShellTexturingScene {
    /// `mesh` with one signed `thickness` per vertex (the shell's target thickness,
    /// e.g. [`thicket_core::shell::Thickness::per_vertex`]), offsets along the
    /// angle-weighted vertex normals; `textures` united, each shifted by its offset;
    /// `(s, t)` as [`crate::ShellScene::new`] maps them at `tiling`.
    pub fn new(mesh: &Mesh, thickness: &[f32], textures: Vec<TextureLayer>, tiling: f32) -> Result<Self> {
        let bad = |m: String| Err(Error::InvalidParameter(m));
        mesh.require_faces()?;
        if thickness.len() != mesh.vertex_count() {
            return bad(format!("{} thickness values for {} vertices", thickness.len(), mesh.vertex_count()));
        }
        if !thickness.iter().all(|t| t.is_finite()) {
            return bad("the thickness must be finite".into());
        }
        if textures.is_empty() {
            return bad("no texture to render".into());
        }
        if textures.len() > MAX_LAYERS {
            return bad(format!("{} texture layers: shell texturing unites at most {MAX_LAYERS}", textures.len()));
        }
        if !(tiling > 0.0 && tiling.is_finite()) {
            return bad("tiling must be a positive number".into());
        }
        let normals = vertex_normals(mesh);
        let cells = TriangleCells::new(mesh, &TextureCoordinates::of(mesh, tiling));
        let p = mesh.positions();
        let mut corners = Vec::with_capacity(3 * cells.triangles.len());
        for (tri, st) in cells.triangles.iter().zip(&cells.st) {
            for (v, st) in tri.iter().zip(st) {
                let v = *v as usize;
                corners.push(ShellCorner {
                    base: p[v].extend(st.x).to_array(),
                    offset: (normals[v] * thickness[v]).extend(st.y).to_array(),
                    normal: normals[v].extend(0.0).to_array(),
                });
            }
        }
        Ok(Self { corners, textures })
    }

    /// The same corners and texture layers.
    fn same(&self, other: &Self) -> bool {
        self.corners == other.corners
            && self.textures.len() == other.textures.len()
            && self.textures.iter().zip(&other.textures).all(|(a, b)| a.offset == b.offset && a.texture == b.texture)
    }
}

/// Settings of the shell-texturing renderer; shading as the slice renderer's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShellTexturingParams {
    /// Copies of the mesh, in `[1, MAX_SHELLS]`.
    pub shells: u32,
    /// Direction toward the light, world space (normalized here; must not be zero).
    pub light: Vec3,
    /// Ambient share of the light, in `[0, 1]`.
    pub ambient: f32,
    /// Linear surface colour.
    pub albedo: Vec3,
}

impl Default for ShellTexturingParams {
    fn default() -> Self {
        let s = SliceParams::default();
        Self { shells: 16, light: s.light, ambient: s.ambient, albedo: s.albedo }
    }
}

impl ShellTexturingParams {
    /// Settings in range, before any GPU work.
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_SHELLS).contains(&self.shells) {
            return Err(Error::InvalidParameter(format!("{} shells: between 1 and {MAX_SHELLS} are supported", self.shells)));
        }
        // The shading settings are the slice renderer's.
        SliceParams { light: self.light, ambient: self.ambient, albedo: self.albedo, ..Default::default() }.validate()
    }
}

/// `Globals` in the shader.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    view_z: [f32; 4],
    eye: [f32; 4],
    light: [f32; 4],
    albedo: [f32; 4],
    layers: [[f32; 4]; MAX_LAYERS],
    counts: [u32; 4],
}

/// The scene on the GPU with what it was made from.
struct Uploaded {
    scene: ShellTexturingScene,
    vertices: wgpu::Buffer,
    group: wgpu::BindGroup,
    _volumes: Vec<wgpu::Texture>,
}

/// Output images of one viewport size and their readback buffer.
struct Targets {
    width: u32,
    height: u32,
    color: wgpu::Texture,
    normal_depth: wgpu::Texture,
    depth: wgpu::TextureView,
    readback: wgpu::Buffer,
}

/// The shell-texturing renderer: create once, render many frames (the scene is
/// uploaded again only when it changes).
pub struct ShellTexturingRenderer {
    gpu: Gpu,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    globals: wgpu::Buffer,
    scene: Option<Uploaded>,
    targets: Option<Targets>,
    timings: Option<FrameTimings>,
}

impl ShellTexturingRenderer {
    /// A renderer on the best GPU adapter found; an error when there is none.
    pub fn new() -> Result<Self> {
        let gpu = Gpu::new()?;
        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("shell_texturing.wgsl"),
            source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(SHELL_TEXTURING_WGSL)),
        });
        let entry = |binding, visibility, ty| wgpu::BindGroupLayoutEntry { binding, visibility, ty, count: None };
        let volume = |binding| {
            entry(
                binding,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D3,
                    multisampled: false,
                },
            )
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shell texturing"),
            entries: &[
                entry(
                    0,
                    wgpu::ShaderStages::VERTEX_FRAGMENT,
                    wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
                ),
                entry(1, wgpu::ShaderStages::FRAGMENT, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)),
                volume(2),
                volume(3),
                volume(4),
                volume(5),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shell texturing"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let attributes = wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x4, 2 => Float32x4];
        let target = |format| Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shells"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_shell"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<ShellCorner>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                })],
            },
            // Both sides of every shell: strands are seen from any side.
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                // Reversed depth (near is 1), as the slice renderer's.
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_shell"),
                compilation_options: Default::default(),
                targets: &[target(OUTPUT_FORMAT), target(OUTPUT_FORMAT)],
            }),
            multiview_mask: None,
            cache: None,
        });
        let sampler = super::pipeline::volume_sampler(device);
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shell texturing globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        gpu.wait()?;
        Ok(Self { gpu, pipeline, layout, sampler, globals, scene: None, targets: None, timings: None })
    }

    /// The adapter's name and backend.
    pub fn adapter_name(&self) -> String {
        self.gpu.adapter_name()
    }

    /// Timings of the last successful frame.
    pub fn last_timings(&self) -> Option<FrameTimings> {
        self.timings
    }

    /// Renders `scene` seen by `camera`: colour (alpha 1 where a shell fragment passed
    /// the alpha test), depth along the view axis and the vertex normal facing the
    /// camera, per pixel. Bad input is an error, not a panic.
    pub fn render(&mut self, scene: &ShellTexturingScene, camera: &Camera, params: &ShellTexturingParams) -> Result<Frame> {
        self.gpu.check_alive()?;
        params.validate()?;
        self.validate(scene, camera)?;
        let start = Instant::now();
        self.upload_scene(scene);
        self.prepare_targets(camera.width, camera.height);
        let g = globals(scene, camera, params);
        self.gpu.queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&g));
        let (Some(uploaded), Some(targets)) = (&self.scene, &self.targets) else {
            return Err(Error::InvalidParameter("the shell-texturing renderer is not set up".into()));
        };
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (color, normal_depth) = (view(&targets.color), view(&targets.normal_depth));
        let clear = wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store };
        let attachment = |view| Some(wgpu::RenderPassColorAttachment { view, depth_slice: None, resolve_target: None, ops: clear });
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shells"),
                color_attachments: &[attachment(&color), attachment(&normal_depth)],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &targets.depth,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                ..Default::default()
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &uploaded.group, &[]);
            pass.set_vertex_buffer(0, uploaded.vertices.slice(..));
            pass.draw(0..scene.corners.len() as u32, 0..params.shells);
        }
        self.gpu.queue.submit([encoder.finish()]);
        let prepare = start.elapsed();
        self.gpu.wait()?;
        let draw = start.elapsed() - prepare;
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        readback::copy(&mut encoder, &targets.color, &targets.normal_depth, &targets.readback);
        self.gpu.queue.submit([encoder.finish()]);
        let frame = readback::read(&self.gpu, &targets.readback, camera.width, camera.height)?;
        let readback = start.elapsed() - prepare - draw;
        self.timings = Some(FrameTimings { prepare, draw, readback });
        Ok(frame)
    }

    /// Input this GPU cannot draw, as errors.
    fn validate(&self, scene: &ShellTexturingScene, camera: &Camera) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidParameter(m));
        let limits = self.gpu.device.limits();
        if camera.width == 0 || camera.height == 0 {
            return bad(format!("the viewport is {}x{}: nothing to render", camera.width, camera.height));
        }
        if camera.width.max(camera.height) > limits.max_texture_dimension_2d {
            return bad(format!("the viewport {}x{} is larger than this GPU allows", camera.width, camera.height));
        }
        if !camera.view.is_finite() || !camera.projection.is_finite() || !camera.view_projection().inverse().is_finite() {
            return bad("the camera matrices are not invertible".into());
        }
        if scene.corners.is_empty() || scene.textures.is_empty() || scene.textures.len() > MAX_LAYERS {
            return bad(format!("{} triangles, {} texture layers: nothing to render", scene.corners.len() / 3, scene.textures.len()));
        }
        let bytes = std::mem::size_of_val(scene.corners.as_slice()) as u64;
        if bytes > limits.max_buffer_size {
            return bad(format!("{} triangles do not fit in this GPU's buffers", scene.corners.len() / 3));
        }
        for layer in &scene.textures {
            let dims = layer.texture.dims();
            if dims.iter().any(|&n| n > limits.max_texture_dimension_3d as usize) {
                return bad(format!("the texture {dims:?} is larger than this GPU's largest 3D texture"));
            }
            if !layer.offset.is_finite() {
                return bad("the texture offset is not finite".into());
            }
        }
        Ok(())
    }

    fn upload_scene(&mut self, scene: &ShellTexturingScene) {
        if self.scene.as_ref().is_some_and(|u| u.scene.same(scene)) {
            return;
        }
        self.scene = None;
        let device = &self.gpu.device;
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shell corners"),
            contents: bytemuck::cast_slice(&scene.corners),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let volumes: Vec<wgpu::Texture> = scene.textures.iter().map(|l| self.upload_alpha(&l.texture)).collect();
        let views: Vec<wgpu::TextureView> = volumes.iter().map(|v| v.create_view(&Default::default())).collect();
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: self.globals.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
        ];
        // Slots past the last layer hold layer 0 again; the shader skips them.
        for slot in 0..MAX_LAYERS {
            let view = views.get(slot).unwrap_or(&views[0]);
            entries.push(wgpu::BindGroupEntry { binding: 2 + slot as u32, resource: wgpu::BindingResource::TextureView(view) });
        }
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("shell texturing"), layout: &self.layout, entries: &entries });
        self.scene = Some(Uploaded { scene: scene.clone(), vertices, group, _volumes: volumes });
    }

    /// The texture's alpha as a 3D texture of half floats (the values the slice
    /// renderer's volume textures hold in their alpha channel).
    fn upload_alpha(&self, texture: &thicket_core::texture::VolumeTexture) -> wgpu::Texture {
        let [w, h, d] = texture.dims().map(|n| n as u32);
        let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: d };
        let volume = self.gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("alpha"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: ALPHA_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let halves: Vec<u16> = texture.samples().iter().map(|a| f16_bits(*a)).collect();
        self.gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo { texture: &volume, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
            bytemuck::cast_slice(&halves),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(2 * w), rows_per_image: Some(h) },
            size,
        );
        volume
    }

    fn prepare_targets(&mut self, width: u32, height: u32) {
        if self.targets.as_ref().is_some_and(|t| t.width == width && t.height == height) {
            return;
        }
        self.targets = None;
        let device = &self.gpu.device;
        let image = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let out = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        self.targets = Some(Targets {
            width,
            height,
            color: image("colour", OUTPUT_FORMAT, out),
            normal_depth: image("normal, depth", OUTPUT_FORMAT, out),
            depth: image("depth", DEPTH_FORMAT, wgpu::TextureUsages::RENDER_ATTACHMENT).create_view(&Default::default()),
            readback: readback::buffer(device, width, height),
        });
    }
}

fn globals(scene: &ShellTexturingScene, camera: &Camera, params: &ShellTexturingParams) -> Globals {
    let view = camera.view.as_dmat4();
    let view_proj = GL_TO_WGPU * camera.projection.as_dmat4() * view;
    let eye = if camera.is_orthographic() { camera.view.inverse().transform_vector3(Vec3::NEG_Z).extend(0.0) } else { camera.position().extend(1.0) };
    let mut layers = [[0.0; 4]; MAX_LAYERS];
    for (info, layer) in layers.iter_mut().zip(&scene.textures) {
        *info = [layer.offset.x, layer.offset.y, layer.texture.dims()[2] as f32, 0.0];
    }
    Globals {
        view_proj: view_proj.as_mat4().to_cols_array_2d(),
        view_z: view.row(2).as_vec4().to_array(),
        eye: eye.to_array(),
        light: params.light.normalize().extend(params.ambient).to_array(),
        albedo: params.albedo.extend(1.0).to_array(),
        layers,
        counts: [scene.textures.len().min(MAX_LAYERS) as u32, params.shells, 0, 0],
    }
}

#[cfg(test)]
mod tests {
    //! These need a GPU adapter and FAIL without one, as `tests/gpu.rs`: `make
    //! test-rust` installs Mesa's lavapipe where no Vulkan driver exists.

    use std::sync::{Mutex, MutexGuard, OnceLock};

    use glam::{Mat4, Vec2};
    use thicket_core::shell::{build_shell, ShellParams, Side, Thickness};
    use thicket_core::testmeshes as tm;
    use thicket_core::texture::{Generator, Pattern, VolumeTexture};

    use super::*;
    use crate::reference::{self, RenderParams};
    use crate::silhouette::{coverage, frame_coverage, iou};
    use crate::ShellScene;

    fn renderer() -> MutexGuard<'static, ShellTexturingRenderer> {
        static R: OnceLock<Mutex<ShellTexturingRenderer>> = OnceLock::new();
        R.get_or_init(|| {
            let r = ShellTexturingRenderer::new().unwrap_or_else(|e| panic!("no GPU adapter (make test-rust installs lavapipe): {e}"));
            Mutex::new(r)
        })
        .lock()
        .unwrap_or_else(|e| e.into_inner())
    }

    /// The reference render and the shell-texturing render of `texture` in an
    /// exterior shell of 10% over an icosphere, seen whole or (`close`) a part of it
    /// facing the camera.
    fn both(texture: VolumeTexture, shells: u32, close: bool) -> (Frame, Frame) {
        let mesh = tm::icosphere(3);
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let shell = build_shell(&mesh, &t, Side::Exterior, &ShellParams::default()).unwrap();
        let layers = vec![TextureLayer { texture, offset: Vec2::ZERO }];
        let scene = ShellScene::new(&mesh, &shell, layers.clone(), 1.0).unwrap();
        let copies = ShellTexturingScene::new(&mesh, &t, layers, 1.0).unwrap();
        let (target, fov) = if close { (Vec3::new(0.35, -0.85, 0.45), 0.25) } else { (Vec3::ZERO, 0.8) };
        let view = Mat4::look_at_rh(Vec3::new(1.2, -3.0, 1.5), target, Vec3::Z);
        let camera = Camera::new(view, Mat4::perspective_rh_gl(fov, 1.0, 0.01, 100.0), 96, 96).unwrap();
        let reference = reference::render(&scene, &camera, &RenderParams { step: 0.02, ..Default::default() }).unwrap();
        let params = ShellTexturingParams { shells, ..Default::default() };
        let frame = renderer().render(&copies, &camera, &params).unwrap();
        (reference, frame)
    }

    #[test]
    fn shells_draw_the_shell_and_nothing_else() {
        // A slab (alpha 1 below r = 0.5): the shells below the middle draw the whole
        // sphere, slightly smaller than the reference's surface at r = 0.5.
        let slab = VolumeTexture::from_fn([4, 4, 33], |c| if c.z < 0.5 { 1.0 } else { 0.0 }).unwrap();
        let (reference, frame) = both(slab, 16, false);
        let (a, b) = (frame_coverage(&reference), frame_coverage(&frame));
        assert!(coverage(&a) > 0.2, "the reference sees too little: {}", coverage(&a));
        let score = iou(&a, &b);
        eprintln!("slab IoU {score}");
        assert!(score > 0.95, "slab IoU {score}");
        // Every covered pixel has a depth and a unit normal facing the camera.
        for i in (0..b.len()).filter(|i| b[*i]) {
            assert!(frame.depth[i].is_finite() && frame.depth[i] > 0.0);
            assert!((frame.normal[i].length() - 1.0).abs() < 1e-3);
        }
        // Chain mail: the shells see the rings where the reference does.
        let chain = Generator::new(Pattern::ChainMail).generate([32, 32, 16]).unwrap();
        let (reference, frame) = both(chain, 16, true);
        let score = iou(&frame_coverage(&reference), &frame_coverage(&frame));
        eprintln!("chain mail IoU {score}");
        assert!(score > 0.85, "chain mail IoU {score}");
    }

    #[test]
    fn an_empty_texture_draws_nothing() {
        let empty = VolumeTexture::from_fn([4, 4, 8], |_| 0.0).unwrap();
        let (reference, frame) = both(empty, 16, false);
        assert_eq!(reference.coverage(), 0.0);
        assert_eq!(frame.coverage(), 0.0);
        // A full texture covers at least the base mesh's silhouette.
        let full = VolumeTexture::from_fn([4, 4, 8], |_| 1.0).unwrap();
        let (reference, frame) = both(full, 4, false);
        let score = iou(&frame_coverage(&reference), &frame_coverage(&frame));
        eprintln!("full IoU {score}");
        assert!(score > 0.9, "full IoU {score}");
    }

    #[test]
    fn bad_input_is_an_error() {
        let mesh = tm::icosphere(1);
        let t = vec![0.1; mesh.vertex_count()];
        let tex = VolumeTexture::from_fn([4, 4, 4], |_| 1.0).unwrap();
        let layers = vec![TextureLayer { texture: tex, offset: Vec2::ZERO }];
        assert!(ShellTexturingScene::new(&mesh, &t[1..], layers.clone(), 1.0).is_err());
        assert!(ShellTexturingScene::new(&mesh, &t, vec![], 1.0).is_err());
        assert!(ShellTexturingScene::new(&mesh, &t, layers.clone(), 0.0).is_err());
        let scene = ShellTexturingScene::new(&mesh, &t, layers, 1.0).unwrap();
        assert_eq!(scene.corners.len(), 3 * mesh.face_count());
        assert!(ShellTexturingParams { shells: 0, ..Default::default() }.validate().is_err());
        assert!(ShellTexturingParams { ambient: 2.0, ..Default::default() }.validate().is_err());
        assert!(ShellTexturingParams::default().validate().is_ok());
    }
}
