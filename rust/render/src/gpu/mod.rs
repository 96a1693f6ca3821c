//! The GPU slice renderer (thick surfaces, chapter 5) on wgpu, headless.
//!
//! - [`device`]: instance, adapter and device; errors and device loss are recorded
//!   and returned, never panicked on.
//! - [`slices`]: the slice templates of a triangle prism and the per-cell choice of
//!   the family of slices facing the view.
//! - [`scene_data`]: cells, per-corner gradient transforms, the neighbours' texture
//!   coordinates across each side face and the volume textures (alpha and its
//!   gradient) as the shaders read them.
//! - [`pipeline`]: the shader (`shaders/slices.wgsl`), bind group layouts, pipelines.
//! - [`passes`]: render targets and the three passes.
//! - [`readback`]: output targets to a [`Frame`].
//!
//! Two modes, compared in the paper's figure 5.2: [`SliceMode::Plain`] is the simple
//! slice-based iso-surface renderer (alpha test, nearest inside slice, its gradient),
//! [`SliceMode::Interpolating`] adds the second pass and interpolates the texture
//! coordinates of the last outside and the first inside slice by their alphas before
//! looking up the gradient, which removes the normal discontinuities at slice
//! boundaries and places the surface between the slices.

pub mod device;
pub mod passes;
pub mod pipeline;
pub mod readback;
pub mod scene_data;
pub mod slices;

use std::time::{Duration, Instant};

use glam::{DMat4, DVec4, Vec3};
use thicket_core::texture::bake::TextureLayer;
use thicket_core::texture::{CellMap, VolumeTexture};
use thicket_core::{Error, Result};
use wgpu::util::DeviceExt;

use crate::camera::Camera;
use crate::image_out::Frame;
use crate::scene::ShellScene;
use device::Gpu;
use passes::{Draws, Targets};
use pipeline::{Globals, Pipelines, LAYER_BINDINGS, MAX_LAYERS};
use scene_data::{GpuCell, GpuFrames};
use slices::{Eye, Family, Templates};

/// Plain slicing or chapter 5's interpolating two-pass algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SliceMode {
    Plain,
    Interpolating,
}

/// Settings of the slice renderer; the shading matches the reference renderer's:
/// `albedo * (ambient + (1 − ambient) max(0, n · light))`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SliceParams {
    /// Slices per cell, in `[2, 1024]`, the cell's two end faces included.
    pub slices: u32,
    pub mode: SliceMode,
    /// Direction toward the light, world space (normalized here; must not be zero).
    pub light: Vec3,
    /// Ambient share of the light, in `[0, 1]`.
    pub ambient: f32,
    /// Linear surface colour.
    pub albedo: Vec3,
}

impl Default for SliceParams {
    fn default() -> Self {
        Self {
            slices: 16,
            mode: SliceMode::Interpolating,
            light: Vec3::new(0.3, -0.5, 0.8),
            ambient: 0.25,
            albedo: Vec3::splat(0.8),
        }
    }
}

impl SliceParams {
    fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidParameter(m));
        if !(slices::MIN_SLICES..=slices::MAX_SLICES).contains(&self.slices) {
            return bad(format!(
                "{} slices per cell: between {} and {} are supported",
                self.slices,
                slices::MIN_SLICES,
                slices::MAX_SLICES
            ));
        }
        if !self.light.is_finite() || self.light.length_squared() < 1e-20 {
            return bad("the light direction must be a finite, non-zero vector".into());
        }
        if !(0.0..=1.0).contains(&self.ambient) {
            return bad("ambient must be between 0 and 1".into());
        }
        if !self.albedo.is_finite() || self.albedo.min_element() < 0.0 {
            return bad("the albedo must be finite and not negative".into());
        }
        Ok(())
    }
}

/// Where the time of the last frame went.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameTimings {
    /// Uploads (the scene when it changed), the per-cell choice of slices, encoding.
    pub prepare: Duration,
    /// The three passes on the GPU, from submission to completion.
    pub draw: Duration,
    /// Copying the outputs to a mappable buffer, mapping it and unpacking the frame.
    pub readback: Duration,
}

impl FrameTimings {
    pub fn total(&self) -> Duration {
        self.prepare + self.draw + self.readback
    }
}

/// The scene on the GPU, with what it was made from (to tell when it changed).
struct SceneResources {
    cells: Vec<CellMap>,
    layers: Vec<TextureLayer>,
    group: wgpu::BindGroup,
    // Kept alive for the bind group.
    _buffers: [wgpu::Buffer; 3],
    _volumes: Vec<wgpu::Texture>,
}

/// The slice renderer. Create it once ([`GpuRenderer::new`]) and render many frames:
/// the scene is uploaded again only when it changes.
pub struct GpuRenderer {
    gpu: Gpu,
    pipelines: Pipelines,
    globals: wgpu::Buffer,
    scene: Option<SceneResources>,
    templates: Option<(Templates, wgpu::Buffer)>,
    targets: Option<(Targets, wgpu::Buffer)>,
    instances: Option<(wgpu::Buffer, u64)>,
    timings: Option<FrameTimings>,
    /// Set when a render panicked inside wgpu: the renderer is not used again.
    broken: bool,
}

impl GpuRenderer {
    /// A renderer on the best GPU adapter found; an error when there is none (render
    /// with [`crate::reference`] then).
    pub fn new() -> Result<Self> {
        let gpu = Gpu::new()?;
        let pipelines = Pipelines::new(&gpu.device);
        let globals = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        gpu.wait()?;
        Ok(Self {
            gpu,
            pipelines,
            globals,
            scene: None,
            templates: None,
            targets: None,
            instances: None,
            timings: None,
            broken: false,
        })
    }

    /// The adapter's name and backend.
    pub fn adapter_name(&self) -> String {
        self.gpu.adapter_name()
    }

    /// The adapter's type (discrete, integrated, CPU...).
    pub fn adapter_type(&self) -> wgpu::DeviceType {
        self.gpu.info.device_type
    }

    /// Timings of the last successful frame.
    pub fn last_timings(&self) -> Option<FrameTimings> {
        self.timings
    }

    /// Renders `scene` seen by `camera`: colour (alpha 1 on the surface), depth along
    /// the view axis and the unit world normal facing the camera, per pixel. The
    /// scene's textures are united, as [`ShellScene::alpha`] does: up to
    /// [`MAX_LAYERS`] of them (more are an error). Errors (bad input, no memory, a lost
    /// device) are returned, never panicked on.
    pub fn render(&mut self, scene: &ShellScene, camera: &Camera, params: &SliceParams) -> Result<Frame> {
        if self.broken {
            return Err(Error::InvalidParameter("the GPU renderer failed earlier; render on the CPU".into()));
        }
        self.gpu.check_alive()?;
        params.validate()?;
        validate(scene, camera, &self.gpu.device.limits())?;
        let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.render_checked(scene, camera, params)));
        match run {
            Ok(Ok(frame)) => Ok(frame),
            Ok(Err(e)) => {
                // What was built may be invalid (out of memory, say): start afresh.
                self.scene = None;
                self.templates = None;
                self.targets = None;
                self.instances = None;
                Err(e)
            }
            Err(panic) => {
                self.broken = true;
                let why = panic
                    .downcast_ref::<String>()
                    .map(String::as_str)
                    .or_else(|| panic.downcast_ref::<&str>().copied())
                    .unwrap_or("unknown");
                Err(Error::InvalidParameter(format!("the GPU renderer failed ({why}); render on the CPU")))
            }
        }
    }

    fn render_checked(&mut self, scene: &ShellScene, camera: &Camera, params: &SliceParams) -> Result<Frame> {
        let start = Instant::now();
        self.upload_scene(scene);
        self.prepare_templates(params.slices);
        self.prepare_targets(camera.width, camera.height);
        let grouping = slices::group_cells(&scene.cells, eye(camera));
        self.upload_instances(&grouping.order);
        self.gpu.queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals(scene, camera, params)));

        let (Some(scene_res), Some((templates, template_buffer)), Some((targets, readback)), Some((instances, _))) =
            (&self.scene, &self.templates, &self.targets, &self.instances)
        else {
            return Err(Error::InvalidParameter("the GPU renderer is not set up".into()));
        };
        let draws = Draws {
            templates: template_buffer,
            instances,
            families: Family::ALL.iter().map(|f| (templates.ranges[*f as usize].clone(), grouping.range(*f))).collect(),
        };
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        passes::encode(
            &mut encoder,
            &self.pipelines,
            targets,
            &scene_res.group,
            &draws,
            params.mode == SliceMode::Interpolating,
        );
        self.gpu.queue.submit([encoder.finish()]);
        let prepare = start.elapsed();
        self.gpu.wait()?;
        let draw = start.elapsed() - prepare;

        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        readback::copy(&mut encoder, &targets.color, &targets.normal_depth, readback);
        self.gpu.queue.submit([encoder.finish()]);
        let frame = readback::read(&self.gpu, readback, camera.width, camera.height)?;
        let readback = start.elapsed() - prepare - draw;
        self.timings = Some(FrameTimings { prepare, draw, readback });
        Ok(frame)
    }

    /// Uploads the cells, their frames and the texture layers, unless they are the
    /// ones uploaded last.
    fn upload_scene(&mut self, scene: &ShellScene) {
        if let Some(s) = &self.scene {
            let same_layers = s.layers.len() == scene.textures.len()
                && s.layers.iter().zip(&scene.textures).all(|(a, b)| a.offset == b.offset && a.texture == b.texture);
            if same_layers && s.cells == scene.cells {
                return;
            }
        }
        self.scene = None;
        let device = &self.gpu.device;
        let cells: Vec<GpuCell> = scene.cells.iter().map(GpuCell::new).collect();
        let frames: Vec<GpuFrames> = scene.cells.iter().map(GpuFrames::new).collect();
        let storage = |label: &str, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let cell_buffer = storage("cells", bytemuck::cast_slice(&cells));
        let frame_buffer = storage("cell frames", bytemuck::cast_slice(&frames));
        let neighbour_buffer = storage("neighbours", bytemuck::cast_slice(&scene_data::neighbours(&scene.cells)));
        let volumes: Vec<wgpu::Texture> = scene.textures.iter().map(|l| self.upload_volume(&l.texture)).collect();
        let views: Vec<wgpu::TextureView> = volumes.iter().map(|v| v.create_view(&Default::default())).collect();
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: self.globals.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: cell_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: frame_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&self.pipelines.sampler) },
            wgpu::BindGroupEntry { binding: 5, resource: neighbour_buffer.as_entire_binding() },
        ];
        // The slots past the last layer hold layer 0 again; the shaders skip them.
        for (k, binding) in LAYER_BINDINGS.iter().enumerate() {
            let view = views.get(k).unwrap_or(&views[0]);
            entries
                .push(wgpu::BindGroupEntry { binding: *binding, resource: wgpu::BindingResource::TextureView(view) });
        }
        let group = self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene"),
            layout: &self.pipelines.scene_layout,
            entries: &entries,
        });
        self.scene = Some(SceneResources {
            cells: scene.cells.clone(),
            layers: scene.textures.clone(),
            group,
            _buffers: [cell_buffer, frame_buffer, neighbour_buffer],
            _volumes: volumes,
        });
    }

    /// A volume texture with its gradient, on the GPU.
    fn upload_volume(&self, texture: &VolumeTexture) -> wgpu::Texture {
        let [nx, ny, nz] = texture.dims().map(|n| n as u32);
        let size = wgpu::Extent3d { width: nx, height: ny, depth_or_array_layers: nz };
        let volume = self.gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("volume texture"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: pipeline::VOLUME_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let texels = scene_data::volume_texels(texture);
        self.gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &volume,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&texels),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(8 * nx), rows_per_image: Some(ny) },
            size,
        );
        volume
    }

    fn prepare_templates(&mut self, slices: u32) {
        if self.templates.as_ref().is_some_and(|(t, _)| t.slices == slices) {
            return;
        }
        let t = slices::templates(slices);
        let buffer = self.gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("slice templates"),
            contents: bytemuck::cast_slice(&t.vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        self.templates = Some((t, buffer));
    }

    fn prepare_targets(&mut self, width: u32, height: u32) {
        if self.targets.as_ref().is_some_and(|(t, _)| t.width == width && t.height == height) {
            return;
        }
        self.targets = None;
        let targets = Targets::new(&self.gpu.device, &self.pipelines, width, height);
        let buffer = readback::buffer(&self.gpu.device, width, height);
        self.targets = Some((targets, buffer));
    }

    fn upload_instances(&mut self, order: &[u32]) {
        let bytes: &[u8] = bytemuck::cast_slice(order);
        let needed = (bytes.len() as u64).max(4);
        if self.instances.as_ref().is_none_or(|(_, capacity)| *capacity < needed) {
            let capacity = needed.next_power_of_two();
            let buffer = self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("cell instances"),
                size: capacity,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            self.instances = Some((buffer, capacity));
        }
        if let Some((buffer, _)) = &self.instances {
            if !bytes.is_empty() {
                self.gpu.queue.write_buffer(buffer, 0, bytes);
            }
        }
    }
}

/// Input the GPU cannot draw, as errors.
fn validate(scene: &ShellScene, camera: &Camera, limits: &wgpu::Limits) -> Result<()> {
    let bad = |m: String| Err(Error::InvalidParameter(m));
    if camera.width == 0 || camera.height == 0 {
        return bad(format!("the viewport is {}x{}: nothing to render", camera.width, camera.height));
    }
    if camera.width > limits.max_texture_dimension_2d || camera.height > limits.max_texture_dimension_2d {
        return bad(format!(
            "the viewport {}x{} is larger than this GPU's largest image ({} pixels a side)",
            camera.width, camera.height, limits.max_texture_dimension_2d
        ));
    }
    if !camera.view.is_finite() || !camera.projection.is_finite() || !camera.view_projection().inverse().is_finite() {
        return bad("the camera matrices are not invertible".into());
    }
    if scene.cells.is_empty() {
        return bad("the shell has no cells: nothing to render".into());
    }
    if scene.cells.len() >= 1 << 28 {
        return bad(format!("{} cells are more than the GPU renderer handles", scene.cells.len()));
    }
    let thick = |c: &CellMap| c.director[..3].iter().any(|d| d.is_finite() && d.length_squared() > 0.0);
    if !scene.cells.iter().any(thick) {
        return bad("the shell has no thickness: nothing to render".into());
    }
    if scene.cells.iter().any(|c| c.count != 3) {
        return bad("the GPU renderer draws triangle cells only; this scene has quad cells".into());
    }
    if scene.textures.is_empty() {
        return bad("no texture to render".into());
    }
    if scene.textures.len() > MAX_LAYERS {
        return bad(format!(
            "{} texture layers are more than the GPU renderer unites ({MAX_LAYERS}); merge some first",
            scene.textures.len()
        ));
    }
    let frames = scene.cells.len() as u64 * std::mem::size_of::<GpuFrames>() as u64;
    if frames > limits.max_storage_buffer_binding_size || frames > limits.max_buffer_size {
        return bad(format!("{} cells do not fit in this GPU's storage buffers", scene.cells.len()));
    }
    for layer in &scene.textures {
        let dims = layer.texture.dims();
        if dims.iter().any(|&n| n > limits.max_texture_dimension_3d as usize) {
            return bad(format!(
                "the texture {dims:?} is larger than this GPU's largest 3D texture ({} a side)",
                limits.max_texture_dimension_3d
            ));
        }
        if !layer.offset.is_finite() {
            return bad("the texture offset is not finite".into());
        }
    }
    Ok(())
}

/// The camera as seen by the choice of slices.
fn eye(camera: &Camera) -> Eye {
    let inverse = camera.view.inverse();
    if camera.is_orthographic() {
        Eye::Direction(inverse.transform_vector3(Vec3::NEG_Z))
    } else {
        Eye::Point(inverse.transform_point3(Vec3::ZERO))
    }
}

/// OpenGL clip space (z in [−1, 1], near to far) to wgpu's with reversed depth (z in
/// [0, 1], far to near): with a float depth buffer the depth resolution is then about
/// 2^-24 of the distance at any distance, whatever the near plane, so the two copies
/// of a shared face (a thousandth of the cell apart) are always told apart.
const GL_TO_WGPU: DMat4 = DMat4::from_cols(
    DVec4::new(1.0, 0.0, 0.0, 0.0),
    DVec4::new(0.0, 1.0, 0.0, 0.0),
    DVec4::new(0.0, 0.0, -0.5, 0.0),
    DVec4::new(0.0, 0.0, 0.5, 1.0),
);

fn globals(scene: &ShellScene, camera: &Camera, params: &SliceParams) -> Globals {
    let view = camera.view.as_dmat4();
    let view_proj = GL_TO_WGPU * camera.projection.as_dmat4() * view;
    let mut layers = [[0.0; 4]; MAX_LAYERS];
    for (info, layer) in layers.iter_mut().zip(&scene.textures) {
        *info = [layer.offset.x, layer.offset.y, layer.texture.dims()[2] as f32, 0.0];
    }
    let light = params.light.normalize();
    let mode = if params.mode == SliceMode::Interpolating { 1.0 } else { 0.0 };
    let (w, h) = (camera.width as f32, camera.height as f32);
    Globals {
        view_proj: view_proj.as_mat4().to_cols_array_2d(),
        inv_view_proj: view_proj.inverse().as_mat4().to_cols_array_2d(),
        view_z: view.row(2).as_vec4().to_array(),
        light: light.extend(params.ambient).to_array(),
        albedo: params.albedo.extend(mode).to_array(),
        layers,
        layer_count: [scene.textures.len().min(MAX_LAYERS) as u32, 0, 0, 0],
        viewport: [w, h, 1.0 / w, 1.0 / h],
    }
}
