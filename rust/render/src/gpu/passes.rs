//! The render targets of one viewport size and the encoding of the three passes.

use std::ops::Range;

use super::pipeline::{self, Pipelines};

/// Per-pixel intermediate and output images.
pub struct Targets {
    pub width: u32,
    pub height: u32,
    /// T1: bitcast `(u, v, r)` and the cell and face code of the nearest inside fragment.
    first_hit: wgpu::TextureView,
    /// Z1: its depth along the view axis, at full precision (chapter 5.4).
    first_depth: wgpu::TextureView,
    /// T2: `(u, v, r)` and depth of the last outside fragment in front of T1.
    second_hit: wgpu::TextureView,
    /// The transparency pass's premultiplied colour and alpha.
    haze: wgpu::TextureView,
    depth_inside: wgpu::TextureView,
    depth_outside: wgpu::TextureView,
    pub color: wgpu::Texture,
    pub normal_depth: wgpu::Texture,
    color_view: wgpu::TextureView,
    normal_depth_view: wgpu::TextureView,
    pub first_group: wgpu::BindGroup,
    pub second_group: wgpu::BindGroup,
}

fn image(device: &wgpu::Device, label: &str, w: u32, h: u32, format: wgpu::TextureFormat, usage: wgpu::TextureUsages) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

impl Targets {
    pub fn new(device: &wgpu::Device, pipelines: &Pipelines, width: u32, height: u32) -> Self {
        use wgpu::TextureUsages as U;
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let sampled = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING;
        let first_hit = view(&image(device, "T1", width, height, pipeline::FIRST_HIT_FORMAT, sampled));
        let first_depth = view(&image(device, "Z1", width, height, pipeline::DEPTH_VALUE_FORMAT, sampled));
        let second_hit = view(&image(device, "T2", width, height, pipeline::SECOND_HIT_FORMAT, sampled));
        let haze = view(&image(device, "transparency", width, height, pipeline::HAZE_FORMAT, sampled));
        let depth_inside = view(&image(device, "depth 1", width, height, pipeline::DEPTH_FORMAT, U::RENDER_ATTACHMENT));
        let depth_outside = view(&image(device, "depth 2", width, height, pipeline::DEPTH_FORMAT, U::RENDER_ATTACHMENT));
        let out = U::RENDER_ATTACHMENT | U::COPY_SRC;
        let color = image(device, "colour", width, height, pipeline::OUTPUT_FORMAT, out);
        let normal_depth = image(device, "normal, depth", width, height, pipeline::OUTPUT_FORMAT, out);
        let first_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("first hit"),
            layout: &pipelines.first_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&first_hit) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&first_depth) },
            ],
        });
        let second_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("second hit"),
            layout: &pipelines.second_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&second_hit) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&haze) },
            ],
        });
        Self {
            width,
            height,
            color_view: view(&color),
            normal_depth_view: view(&normal_depth),
            first_hit,
            first_depth,
            second_hit,
            haze,
            depth_inside,
            depth_outside,
            color,
            normal_depth,
            first_group,
            second_group,
        }
    }
}

/// What the slice passes draw: the template and instance buffers, each family's
/// template vertices and instances.
pub struct Draws<'a> {
    pub templates: &'a wgpu::Buffer,
    pub instances: &'a wgpu::Buffer,
    /// Template vertex range and instance range, family by family.
    pub families: Vec<(Range<u32>, Range<u32>)>,
}

impl Draws<'_> {
    fn record(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_vertex_buffer(0, self.templates.slice(..));
        pass.set_vertex_buffer(1, self.instances.slice(..));
        for (vertices, instances) in &self.families {
            if !instances.is_empty() {
                pass.draw(vertices.clone(), instances.clone());
            }
        }
    }
}

fn clear_to_zero() -> wgpu::Operations<wgpu::Color> {
    wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store }
}

fn attachment(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment { view, depth_slice: None, resolve_target: None, ops: clear_to_zero() })
}

fn depth(view: &wgpu::TextureView, clear: f32) -> Option<wgpu::RenderPassDepthStencilAttachment<'_>> {
    Some(wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Discard }),
        stencil_ops: None,
    })
}

/// What the transparency pass draws: its layer template (three vertices a layer,
/// from the base outward) and its cells once per layer (see `gpu::haze`).
pub struct HazeDraws<'a> {
    pub layers: &'a wgpu::Buffer,
    pub layer_count: u32,
    pub instances: &'a wgpu::Buffer,
    /// The ranges of `instances` holding the cells facing away from the camera
    /// (drawn first, outer layer first) and those facing it (base layer first).
    pub away: Range<u32>,
    pub facing: Range<u32>,
}

/// Records the passes: inside, outside (`interpolating`; otherwise T2 is only
/// cleared), transparency (`haze`, double mipmaps; otherwise cleared) and shading.
pub fn encode(
    encoder: &mut wgpu::CommandEncoder,
    pipelines: &Pipelines,
    targets: &Targets,
    scene_group: &wgpu::BindGroup,
    draws: &Draws<'_>,
    interpolating: bool,
    haze: Option<&HazeDraws<'_>>,
) {
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("inside pass"),
            color_attachments: &[attachment(&targets.first_hit), attachment(&targets.first_depth)],
            depth_stencil_attachment: depth(&targets.depth_inside, 0.0),
            ..Default::default()
        });
        pass.set_pipeline(&pipelines.inside);
        pass.set_bind_group(0, scene_group, &[]);
        draws.record(&mut pass);
    }
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("outside pass"),
            color_attachments: &[attachment(&targets.second_hit)],
            depth_stencil_attachment: depth(&targets.depth_outside, 1.0),
            ..Default::default()
        });
        if interpolating {
            pass.set_pipeline(&pipelines.outside);
            pass.set_bind_group(0, scene_group, &[]);
            pass.set_bind_group(1, &targets.first_group, &[]);
            draws.record(&mut pass);
        }
    }
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("transparency pass"),
            color_attachments: &[attachment(&targets.haze)],
            ..Default::default()
        });
        if let Some(h) = haze {
            pass.set_pipeline(&pipelines.haze);
            pass.set_bind_group(0, scene_group, &[]);
            pass.set_bind_group(1, &targets.first_group, &[]);
            pass.set_vertex_buffer(0, h.layers.slice(..));
            pass.set_vertex_buffer(1, h.instances.slice(..));
            // Layer by layer, back to front: every cell's layer k before any layer
            // k + 1 (k counted from the camera's far side).
            for k in (0..h.layer_count).rev() {
                pass.draw(3 * k..3 * k + 3, h.away.clone());
            }
            for k in 0..h.layer_count {
                pass.draw(3 * k..3 * k + 3, h.facing.clone());
            }
        }
    }
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shading pass"),
            color_attachments: &[attachment(&targets.color_view), attachment(&targets.normal_depth_view)],
            ..Default::default()
        });
        pass.set_pipeline(&pipelines.shade);
        pass.set_bind_group(0, scene_group, &[]);
        pass.set_bind_group(1, &targets.first_group, &[]);
        pass.set_bind_group(2, &targets.second_group, &[]);
        pass.draw(0..3, 0..1);
    }
}
