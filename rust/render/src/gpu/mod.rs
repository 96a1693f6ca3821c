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
pub mod haze;
pub mod passes;
pub mod pipeline;
pub mod readback;
pub mod scene_data;
pub mod shell_texturing;
pub mod slices;

use std::time::{Duration, Instant};

use bytemuck::Zeroable;

use glam::{DMat4, DVec4, Vec3};
use thicket_core::texture::CellMap;
use thicket_core::texture::TextureLayer;
use thicket_core::{Error, Result};
use wgpu::util::DeviceExt;

use crate::image_out::Frame;
use crate::mipmap::{Level, MipmapSet, Mipmaps};
use crate::scene::ShellScene;
use device::Gpu;
use passes::{Draws, HazeDraws, Targets};
use pipeline::{Globals, Pipelines, CUTTER_BINS_BINDING, CUTTER_TRIANGLES_BINDING, EFFECTS_BINDING, HAZE_BINDINGS, LAYER_BINDINGS, MAX_LAYERS, MOVED_BINDING};
use scene_data::{GpuCell, GpuFrames};
use slices::{Eye, Family, Templates};
use thicket_core::raycast::Camera;

pub use shell_texturing::{ShellTexturingParams, ShellTexturingRenderer, ShellTexturingScene};

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
    /// Filtering for distant views (chapter 6); double mipmaps by default.
    pub mipmaps: Mipmaps,
}

impl Default for SliceParams {
    fn default() -> Self {
        Self { slices: 16, mode: SliceMode::Interpolating, light: Vec3::new(0.3, -0.5, 0.8), ambient: 0.25, albedo: Vec3::splat(0.8), mipmaps: Mipmaps::Double }
    }
}

impl SliceParams {
    /// Settings in range (slices, light, ambient), before any GPU work.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidParameter(m));
        if !(slices::MIN_SLICES..=slices::MAX_SLICES).contains(&self.slices) {
            return bad(format!("{} slices per cell: between {} and {} are supported", self.slices, slices::MIN_SLICES, slices::MAX_SLICES));
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
    mipmaps: Mipmaps,
    effects: Vec<scene_data::GpuEffects>,
    fields: scene_data::EffectFields,
    /// Transparency chain: finest size, transition level and layers drawn (§6.5.2).
    haze_dims: [usize; 3],
    transition: u32,
    haze_layers: u32,
    group: wgpu::BindGroup,
    // Kept alive for the bind group.
    _buffers: [wgpu::Buffer; 6],
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
    /// The transparency pass's layer template and its layer count.
    haze_template: Option<(u32, wgpu::Buffer)>,
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
        Ok(Self { gpu, pipelines, globals, scene: None, templates: None, targets: None, instances: None, haze_template: None, timings: None, broken: false })
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
            return Err(Error::Device("the GPU renderer failed earlier; render on the CPU".into()));
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
                let why = panic.downcast_ref::<String>().map(String::as_str).or_else(|| panic.downcast_ref::<&str>().copied()).unwrap_or("unknown");
                Err(Error::Device(format!("the GPU renderer failed ({why}); render on the CPU")))
            }
        }
    }

    fn render_checked(&mut self, scene: &ShellScene, camera: &Camera, params: &SliceParams) -> Result<Frame> {
        let start = Instant::now();
        self.upload_scene(scene, params.mipmaps);
        self.prepare_templates(params.slices);
        let haze_layers = self.scene.as_ref().map_or(0, |s| s.haze_layers);
        let double = params.mipmaps == Mipmaps::Double && haze_layers > 0;
        if double {
            self.prepare_haze_template(haze_layers);
        }
        self.prepare_targets(camera.width, camera.height);
        let grouping = slices::group_cells(&scene.cells, eye(camera));
        // The transparency pass's cells follow the slice passes' in the instances.
        let haze_order = match &self.scene {
            Some(s) if double => {
                let texels = ((s.haze_dims[0] * s.haze_dims[1]) as f32).sqrt();
                haze::draw_order(&scene.cells, &scene.bounds, camera, texels, s.transition as f32 - 1.0)
            }
            _ => haze::HazeOrder::default(),
        };
        let slice_instances = grouping.order.len() as u32;
        let away_end = slice_instances + haze_order.away.len() as u32;
        let facing_end = away_end + haze_order.facing.len() as u32;
        self.upload_instances(&[grouping.order.as_slice(), &haze_order.away, &haze_order.facing].concat());
        let (haze_dims, transition) = self.scene.as_ref().map_or(([1; 3], 0), |s| (s.haze_dims, s.transition));
        let fields = self.scene.as_ref().map(|s| &s.fields);
        let g = globals(scene, fields.unwrap_or(&scene_data::EffectFields::default()), camera, params, haze_dims, transition, haze_layers);
        self.gpu.queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&g));

        let (Some(scene_res), Some((templates, template_buffer)), Some((targets, readback)), Some((instances, _))) =
            (&self.scene, &self.templates, &self.targets, &self.instances)
        else {
            return Err(Error::InvalidParameter("the GPU renderer is not set up".into()));
        };
        let haze = match (&self.haze_template, double && facing_end > slice_instances) {
            (Some((count, layers)), true) => {
                Some(HazeDraws { layers, layer_count: *count, instances, away: slice_instances..away_end, facing: away_end..facing_end })
            }
            _ => None,
        };
        let draws = Draws {
            templates: template_buffer,
            instances,
            families: Family::ALL.iter().map(|f| (templates.ranges[*f as usize].clone(), grouping.range(*f))).collect(),
        };
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        passes::encode(&mut encoder, &self.pipelines, targets, &scene_res.group, &draws, params.mode == SliceMode::Interpolating, haze.as_ref());
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

    /// Uploads the cells, their frames and the texture layers' mipmaps, unless they
    /// are the ones uploaded last.
    fn upload_scene(&mut self, scene: &ShellScene, mipmaps: Mipmaps) {
        if let Some(s) = &self.scene {
            let same_layers =
                s.layers.len() == scene.textures.len() && s.layers.iter().zip(&scene.textures).all(|(a, b)| a.offset == b.offset && a.texture == b.texture);
            if same_layers && s.cells == scene.cells && s.mipmaps == mipmaps && s.effects == scene_data::effects(scene) && s.fields.are_of(scene) {
                return;
            }
        }
        self.scene = None;
        let device = &self.gpu.device;
        let cells: Vec<GpuCell> = scene.cells.iter().map(GpuCell::new).collect();
        let frames: Vec<GpuFrames> = scene.cells.iter().map(GpuFrames::new).collect();
        let storage = |label: &str, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage: wgpu::BufferUsages::STORAGE })
        };
        let cell_buffer = storage("cells", bytemuck::cast_slice(&cells));
        let frame_buffer = storage("cell frames", bytemuck::cast_slice(&frames));
        let neighbour_buffer = storage("neighbours", bytemuck::cast_slice(&scene_data::neighbours(&scene.cells)));
        let effects = scene_data::effects(scene);
        // A storage buffer may not be empty: one unused element without effects.
        let unused = [scene_data::GpuEffects::zeroed()];
        let effect_buffer = storage("effects", bytemuck::cast_slice(if effects.is_empty() { &unused[..] } else { &effects[..] }));
        let fields = scene_data::effect_fields(scene);
        let moved = match &fields.moved {
            Some(m) => self.upload_mask("moved region", m.size, &m.value),
            None => self.upload_mask("no moved region", [1, 1], &[0.0]),
        };
        let (cutter_tris, cutter_bins) = match &fields.cutter {
            Some(c) => (bytemuck::cast_slice(&c.corners), bytemuck::cast_slice(&c.bins)),
            None => (bytemuck::cast_slice(&unused[..]), bytemuck::cast_slice(&unused[..])),
        };
        let (cutter_tris, cutter_bins) = (storage("cutter triangles", cutter_tris), storage("cutter bins", cutter_bins));
        let moved_view = moved.create_view(&Default::default());
        let set = MipmapSet::build(&scene.textures, mipmaps);
        let mut volumes: Vec<wgpu::Texture> =
            set.occupancy.iter().map(|chain| self.upload_chain("volume texture", chain.iter().map(|l| (l.dims, l.texels.iter().copied())))).collect();
        let haze = self.upload_haze(&set);
        let views: Vec<wgpu::TextureView> = volumes.iter().map(|v| v.create_view(&Default::default())).collect();
        let haze_views: Vec<wgpu::TextureView> = haze.iter().map(|v| v.create_view(&Default::default())).collect();
        let mut entries = vec![
            wgpu::BindGroupEntry { binding: 0, resource: self.globals.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: cell_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: frame_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&self.pipelines.sampler) },
            wgpu::BindGroupEntry { binding: 5, resource: neighbour_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: EFFECTS_BINDING, resource: effect_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: MOVED_BINDING, resource: wgpu::BindingResource::TextureView(&moved_view) },
            wgpu::BindGroupEntry { binding: CUTTER_TRIANGLES_BINDING, resource: cutter_tris.as_entire_binding() },
            wgpu::BindGroupEntry { binding: CUTTER_BINS_BINDING, resource: cutter_bins.as_entire_binding() },
        ];
        // The slots past the last layer hold layer 0 again; the shaders skip them.
        for (k, binding) in LAYER_BINDINGS.iter().enumerate() {
            let view = views.get(k).unwrap_or(&views[0]);
            entries.push(wgpu::BindGroupEntry { binding: *binding, resource: wgpu::BindingResource::TextureView(view) });
        }
        for (view, binding) in haze_views.iter().zip(HAZE_BINDINGS) {
            entries.push(wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) });
        }
        let group =
            self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("scene"), layout: &self.pipelines.scene_layout, entries: &entries });
        let haze_dims = set.transparency_dims();
        let haze_layers = if set.transparency.is_empty() { 0 } else { haze_layer_count(haze_dims[2], set.transition) };
        volumes.extend(haze);
        volumes.push(moved);
        self.scene = Some(SceneResources {
            cells: scene.cells.clone(),
            layers: scene.textures.clone(),
            mipmaps,
            effects,
            fields,
            haze_dims,
            transition: set.transition,
            haze_layers,
            group,
            _buffers: [cell_buffer, frame_buffer, neighbour_buffer, effect_buffer, cutter_tris, cutter_bins],
            _volumes: volumes,
        });
    }

    /// A 3D texture with the given mip levels (size and RGBA texels each).
    fn upload_chain<I: Iterator<Item = [f32; 4]>>(&self, label: &str, levels: impl ExactSizeIterator<Item = ([usize; 3], I)>) -> wgpu::Texture {
        let mut levels = levels.peekable();
        let [nx, ny, nz] = levels.peek().map_or([1; 3], |l| l.0).map(|n| n as u32);
        let volume = self.gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: nx, height: ny, depth_or_array_layers: nz },
            mip_level_count: levels.len().max(1) as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format: pipeline::VOLUME_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        for (level, (dims, texels)) in levels.enumerate() {
            let [w, h, d] = dims.map(|n| n as u32);
            let halves: Vec<u16> = texels.flat_map(|t| t.map(scene_data::f16_bits)).collect();
            self.gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo { texture: &volume, mip_level: level as u32, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
                bytemuck::cast_slice(&halves),
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(8 * w), rows_per_image: Some(h) },
                wgpu::Extent3d { width: w, height: h, depth_or_array_layers: d },
            );
        }
        volume
    }

    /// A one-channel 32-bit float 2D texture of `size` texels, row by row.
    fn upload_mask(&self, label: &str, size: [usize; 2], value: &[f32]) -> wgpu::Texture {
        let [w, h] = size.map(|n| n as u32);
        let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        let texture = self.gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: pipeline::FIELD_FORMAT,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        self.gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo { texture: &texture, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
            bytemuck::cast_slice(value),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * w), rows_per_image: Some(h) },
            size,
        );
        texture
    }

    /// The transparency chain as three textures (directional alpha, the ellipsoids'
    /// diagonal and off-diagonal entries); single empty texels without one.
    fn upload_haze(&self, set: &MipmapSet) -> Vec<wgpu::Texture> {
        type Pick = fn(&crate::mipmap::Haze) -> [f32; 4];
        let picks: [Pick; 3] =
            [|h| h.alpha.to_array(), |h| [h.ndf.x_axis.x, h.ndf.y_axis.y, h.ndf.z_axis.z, 0.0], |h| [h.ndf.x_axis.y, h.ndf.x_axis.z, h.ndf.y_axis.z, 0.0]];
        let empty = [Level { dims: [1; 3], texels: vec![crate::mipmap::Haze { alpha: glam::Vec4::ZERO, ndf: glam::Mat3::ZERO }] }];
        let chain: &[Level<crate::mipmap::Haze>] = if set.transparency.is_empty() { &empty } else { &set.transparency };
        picks.map(|pick| self.upload_chain("transparency texture", chain.iter().map(|l| (l.dims, l.texels.iter().map(pick))))).into()
    }

    fn prepare_haze_template(&mut self, count: u32) {
        if self.haze_template.as_ref().is_some_and(|(c, _)| *c == count) {
            return;
        }
        let vertices = slices::haze_layers(count);
        let buffer = self.gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("transparency layers"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        self.haze_template = Some((count, buffer));
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
        return bad(format!("{} texture layers are more than the GPU renderer unites ({MAX_LAYERS}); merge some first", scene.textures.len()));
    }
    let frames = scene.cells.len() as u64 * std::mem::size_of::<GpuFrames>() as u64;
    if frames > limits.max_storage_buffer_binding_size || frames > limits.max_buffer_size {
        return bad(format!("{} cells do not fit in this GPU's storage buffers", scene.cells.len()));
    }
    for layer in &scene.textures {
        let dims = layer.texture.dims();
        if dims.iter().any(|&n| n > limits.max_texture_dimension_3d as usize) {
            return bad(format!("the texture {dims:?} is larger than this GPU's largest 3D texture ({} a side)", limits.max_texture_dimension_3d));
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
const GL_TO_WGPU: DMat4 =
    DMat4::from_cols(DVec4::new(1.0, 0.0, 0.0, 0.0), DVec4::new(0.0, 1.0, 0.0, 0.0), DVec4::new(0.0, 0.0, -0.5, 0.0), DVec4::new(0.0, 0.0, 0.5, 1.0));

/// Transparency layers drawn (§6.5.2): the mean of the rows across the shell of the
/// transition level and the next, at least two.
fn haze_layer_count(nz: usize, transition: u32) -> u32 {
    let rows = |l: u32| (nz >> l.min(63)).max(1) as f32;
    ((rows(transition) + rows(transition + 1)) / 2.0).round().max(2.0) as u32
}

fn globals(
    scene: &ShellScene,
    fields: &scene_data::EffectFields,
    camera: &Camera,
    params: &SliceParams,
    haze_dims: [usize; 3],
    transition: u32,
    haze_layers: u32,
) -> Globals {
    let view = camera.view.as_dmat4();
    let view_proj = GL_TO_WGPU * camera.projection.as_dmat4() * view;
    let mut layers = [[0.0; 4]; MAX_LAYERS];
    for (info, layer) in layers.iter_mut().zip(&scene.textures) {
        let [nx, ny, nz] = layer.texture.dims().map(|n| n as f32);
        *info = [layer.offset.x, layer.offset.y, nz, (nx * ny).sqrt()];
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
        mip: [
            // World size of a pixel: 2 / (P[1][1] height) per unit of depth (or flat).
            2.0 / (camera.projection.y_axis.y * h),
            if camera.is_orthographic() { 0.0 } else { 1.0 },
            match params.mipmaps {
                Mipmaps::Off => 0.0,
                Mipmaps::Linear => 1.0,
                Mipmaps::Double => 2.0,
            },
            haze_layers as f32,
        ],
        haze: [haze_dims[0] as f32, haze_dims[1] as f32, haze_dims[2] as f32, transition as f32],
        effects: {
            let (top, layers) = scene.effects.base_slab();
            [if scene.effects.is_none() { 0.0 } else { 1.0 }, top, layers, 0.0]
        },
        moved: fields.moved.as_ref().map_or([0.0; 4], |m| [m.lo[0], m.lo[1], 1.0 / m.texel, 1.0]),
        moved_offset: fields.moved.as_ref().map_or([0.0; 4], |m| [m.offset[0], m.offset[1], 0.0, 0.0]),
        cutter: fields.cutter.as_ref().map_or([0.0; 4], |c| [c.first[0], c.first[1], c.cell, 1.0]),
        cutter_bins: [fields.cutter.as_ref().map_or(0, |c| c.side), 0, 0, 0],
    }
}
