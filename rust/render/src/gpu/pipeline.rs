//! The shader module, bind group layouts and the three render pipelines: the inside
//! pass (alpha test, nearest), the outside pass (reversed depth test) and the shading
//! pass.

use std::borrow::Cow;

use bytemuck::{Pod, Zeroable};

/// The slice shaders (all three passes).
pub const SLICES_WGSL: &str = include_str!("../../../../shaders/slices.wgsl");

/// Formats of the intermediate and output targets.
pub const FIRST_HIT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;
pub const DEPTH_VALUE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
pub const SECOND_HIT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
pub const VOLUME_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The transparency pass's target: blendable on every adapter (32-bit floats are not).
pub const HAZE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The most texture layers the shaders unite (`Globals::layers`, one 3D texture
/// binding each).
pub const MAX_LAYERS: usize = 4;

/// The bindings of the texture layers in group 0, layer 0 first.
pub const LAYER_BINDINGS: [u32; MAX_LAYERS] = [3, 6, 7, 8];

/// The bindings of the transparency chain's three textures in group 0: directional
/// alpha, the ellipsoids' diagonal and off-diagonal entries.
pub const HAZE_BINDINGS: [u32; 3] = [9, 10, 11];

/// The binding of the cells' effects (region and hole weights) in group 0.
pub const EFFECTS_BINDING: u32 = 12;

/// The bindings of the moved region's mask (a 2D texture read texel by texel) and
/// the cutter's triangles and bins (storage) in group 0
/// ([`super::scene_data::EffectFields`]).
pub const MOVED_BINDING: u32 = 13;
pub const CUTTER_TRIANGLES_BINDING: u32 = 14;
pub const CUTTER_BINS_BINDING: u32 = 15;

/// The mask's format: read with `textureLoad`, so it need not be filterable.
pub const FIELD_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

/// `Globals` in the shader.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Globals {
    pub view_proj: [[f32; 4]; 4],
    pub inv_view_proj: [[f32; 4]; 4],
    pub view_z: [f32; 4],
    pub light: [f32; 4],
    pub albedo: [f32; 4],
    /// Per texture layer: offset `(s, t)`, texel rows `nz` across the shell, and
    /// `sqrt(nx ny)` (texels per tile side, for the mip level).
    pub layers: [[f32; 4]; MAX_LAYERS],
    /// The number of texture layers in `x`.
    pub layer_count: [u32; 4],
    pub viewport: [f32; 4],
    /// Pixel size per unit depth, perspective (1) or not, mipmap mode, layers drawn.
    pub mip: [f32; 4],
    /// The transparency chain's finest size and its transition level.
    pub haze: [f32; 4],
    /// Per-vertex effects drawn (1 or 0), the base slab's top in `r` and the layers
    /// across the shell ([`super::scene_data::GpuEffects`]).
    pub effects: [f32; 4],
    /// The moved region: its mask's first texel `(s, t)`, 1 / texel size, and 1 where
    /// there is one.
    pub moved: [f32; 4],
    /// How far it moved, `(s, t)`.
    pub moved_offset: [f32; 4],
    /// The cutter's bins: their first `(x, y)`, bin size, and 1 where there is a
    /// cutter.
    pub cutter: [f32; 4],
    /// Bins per side in `x`.
    pub cutter_bins: [u32; 4],
}

pub struct Pipelines {
    /// Group 0: globals, cells, frames, volume textures (one per layer), sampler,
    /// neighbours.
    pub scene_layout: wgpu::BindGroupLayout,
    /// Group 1: T1 and Z1 of the inside pass.
    pub first_layout: wgpu::BindGroupLayout,
    /// Group 2: T2 of the outside pass.
    pub second_layout: wgpu::BindGroupLayout,
    pub inside: wgpu::RenderPipeline,
    pub outside: wgpu::RenderPipeline,
    pub shade: wgpu::RenderPipeline,
    pub haze: wgpu::RenderPipeline,
    pub sampler: wgpu::Sampler,
}

fn entry(binding: u32, visibility: wgpu::ShaderStages, ty: wgpu::BindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry { binding, visibility, ty, count: None }
}

fn storage() -> wgpu::BindingType {
    wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only: true }, has_dynamic_offset: false, min_binding_size: None }
}

fn texture_2d(sample_type: wgpu::TextureSampleType) -> wgpu::BindingType {
    wgpu::BindingType::Texture { sample_type, view_dimension: wgpu::TextureViewDimension::D2, multisampled: false }
}

/// A volume texture layer, sampled in the fragment shaders.
fn volume(binding: u32) -> wgpu::BindGroupLayoutEntry {
    entry(
        binding,
        wgpu::ShaderStages::FRAGMENT,
        wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: wgpu::TextureViewDimension::D3,
            multisampled: false,
        },
    )
}

/// The volume textures' sampler: repeating in s and t (the texture tiles), clamped
/// across the shell, trilinear between texels and mip levels.
pub(super) fn volume_sampler(device: &wgpu::Device) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("volume"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        address_mode_w: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    })
}

fn target(format: wgpu::TextureFormat) -> Option<wgpu::ColorTargetState> {
    Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })
}

impl Pipelines {
    pub fn new(device: &wgpu::Device) -> Self {
        let module = device
            .create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("slices.wgsl"), source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(SLICES_WGSL)) });
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scene"),
            entries: &[
                entry(0, vf, wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None }),
                entry(1, vf, storage()),
                entry(2, wgpu::ShaderStages::FRAGMENT, storage()),
                entry(4, wgpu::ShaderStages::FRAGMENT, wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering)),
                entry(5, wgpu::ShaderStages::FRAGMENT, storage()),
                entry(EFFECTS_BINDING, wgpu::ShaderStages::FRAGMENT, storage()),
                volume(LAYER_BINDINGS[0]),
                volume(LAYER_BINDINGS[1]),
                volume(LAYER_BINDINGS[2]),
                volume(LAYER_BINDINGS[3]),
                volume(HAZE_BINDINGS[0]),
                volume(HAZE_BINDINGS[1]),
                volume(HAZE_BINDINGS[2]),
                entry(MOVED_BINDING, wgpu::ShaderStages::FRAGMENT, texture_2d(wgpu::TextureSampleType::Float { filterable: false })),
                entry(CUTTER_TRIANGLES_BINDING, wgpu::ShaderStages::FRAGMENT, storage()),
                entry(CUTTER_BINS_BINDING, wgpu::ShaderStages::FRAGMENT, storage()),
            ],
        });
        let first_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("first hit"),
            entries: &[
                entry(0, wgpu::ShaderStages::FRAGMENT, texture_2d(wgpu::TextureSampleType::Uint)),
                entry(1, wgpu::ShaderStages::FRAGMENT, texture_2d(wgpu::TextureSampleType::Float { filterable: false })),
            ],
        });
        let second_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("second hit"),
            entries: &[
                entry(0, wgpu::ShaderStages::FRAGMENT, texture_2d(wgpu::TextureSampleType::Float { filterable: false })),
                entry(1, wgpu::ShaderStages::FRAGMENT, texture_2d(wgpu::TextureSampleType::Float { filterable: false })),
            ],
        });
        let layout = |label: &str, groups: &[Option<&wgpu::BindGroupLayout>]| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some(label), bind_group_layouts: groups, immediate_size: 0 })
        };
        let inside_layout = layout("inside", &[Some(&scene_layout)]);
        let outside_layout = layout("outside", &[Some(&scene_layout), Some(&first_layout)]);
        let shade_layout = layout("shade", &[Some(&scene_layout), Some(&first_layout), Some(&second_layout)]);

        // Template vertices (u, v, r, face) per vertex; the cell index per instance.
        let template_attributes = wgpu::vertex_attr_array![0 => Float32x4];
        let instance_attributes = wgpu::vertex_attr_array![1 => Uint32];
        let buffers = [
            Some(wgpu::VertexBufferLayout { array_stride: 16, step_mode: wgpu::VertexStepMode::Vertex, attributes: &template_attributes }),
            Some(wgpu::VertexBufferLayout { array_stride: 4, step_mode: wgpu::VertexStepMode::Instance, attributes: &instance_attributes }),
        ];
        let slice_pipeline =
            |label: &str, layout: &wgpu::PipelineLayout, fragment: &str, targets: &[Option<wgpu::ColorTargetState>], compare: Option<wgpu::CompareFunction>| {
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(label),
                    layout: Some(layout),
                    vertex: wgpu::VertexState { module: &module, entry_point: Some("vs_slice"), compilation_options: Default::default(), buffers: &buffers },
                    primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
                    depth_stencil: compare.map(|compare| wgpu::DepthStencilState {
                        format: DEPTH_FORMAT,
                        depth_write_enabled: Some(true),
                        depth_compare: Some(compare),
                        stencil: Default::default(),
                        bias: Default::default(),
                    }),
                    multisample: Default::default(),
                    fragment: Some(wgpu::FragmentState { module: &module, entry_point: Some(fragment), compilation_options: Default::default(), targets }),
                    multiview_mask: None,
                    cache: None,
                })
            };
        let inside = slice_pipeline(
            "inside pass",
            &inside_layout,
            "fs_inside",
            &[target(FIRST_HIT_FORMAT), target(DEPTH_VALUE_FORMAT)],
            // Reversed depth (near is 1): the nearest fragment has the largest depth.
            Some(wgpu::CompareFunction::Greater),
        );
        let outside = slice_pipeline(
            "outside pass",
            &outside_layout,
            "fs_outside",
            &[target(SECOND_HIT_FORMAT)],
            // The reversed depth test: the farthest fragment wins.
            Some(wgpu::CompareFunction::Less),
        );
        // Premultiplied "over", drawn from the base outward (chapter 6.5.2); no depth
        // buffer: the shader hides what lies behind Z1.
        let over =
            wgpu::BlendComponent { src_factor: wgpu::BlendFactor::One, dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha, operation: wgpu::BlendOperation::Add };
        let haze = slice_pipeline(
            "transparency pass",
            &outside_layout,
            "fs_haze",
            &[Some(wgpu::ColorTargetState {
                format: HAZE_FORMAT,
                blend: Some(wgpu::BlendState { color: over, alpha: over }),
                write_mask: wgpu::ColorWrites::ALL,
            })],
            None,
        );
        let shade = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shading pass"),
            layout: Some(&shade_layout),
            vertex: wgpu::VertexState { module: &module, entry_point: Some("vs_fullscreen"), compilation_options: Default::default(), buffers: &[] },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_shade"),
                compilation_options: Default::default(),
                targets: &[target(OUTPUT_FORMAT), target(OUTPUT_FORMAT)],
            }),
            multiview_mask: None,
            cache: None,
        });
        let sampler = volume_sampler(device);
        Self { scene_layout, first_layout, second_layout, inside, outside, shade, haze, sampler }
    }
}
