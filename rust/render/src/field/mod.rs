//! The GPU sphere tracer of field trees (issue 17): the tree's compiled tape translated to a flat
//! postfix program ([`program`]) interpreted per pixel by `shaders/field_trace.wgsl`
//! with the CPU tracer's rays, step rule and shading
//! ([`thicket_core::implicit::trace`]), so the two images agree (tests/field_gpu.rs
//! compares them tree by tree).

pub mod program;

use std::sync::mpsc;

use bytemuck::{Pod, Zeroable};
use glam::DVec3;
use rayon::prelude::*;
use thicket_core::implicit::trace::{Camera, Render, MAX_STEPS};
use thicket_core::implicit::FieldTree;
use thicket_core::{Error, Result};
use wgpu::util::DeviceExt;

use crate::gpu::device::Gpu;
pub use program::{Program, STACK};

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    width: u32,
    height: u32,
    length: u32,
    max_steps: u32,
    inv_lipschitz: f32,
    pad: [f32; 3],
}

/// One ray as the shader reads it: origin and start, direction and end, the pixel's
/// footprint (`near`, `grow`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct GpuRay {
    origin: [f32; 4],
    direction: [f32; 4],
    footprint: [f32; 4],
}

/// A GPU render: the CPU tracer's [`Render`] plus each hit's unit normal.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuRender {
    pub render: Render,
    pub normals: Vec<Option<DVec3>>,
}

/// The field tracer's device and pipeline, reusable across frames.
pub struct FieldTracer {
    gpu: Gpu,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

/// The part `[t0, t1]` of `[0, length]` of a ray inside the box, if any (the CPU
/// tracer's clip, on the same rays).
fn clip(origin: DVec3, direction: DVec3, length: f64, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, length);
    for a in 0..3 {
        let inv = 1.0 / direction[a];
        let (mut u, mut v) = ((lo[a] - origin[a]) * inv, (hi[a] - origin[a]) * inv);
        if u > v {
            std::mem::swap(&mut u, &mut v);
        }
        t0 = if u > t0 { u } else { t0 };
        t1 = if v < t1 { v } else { t1 };
    }
    (t0 <= t1).then_some((t0, t1))
}

impl FieldTracer {
    /// Opens the best adapter (see [`Gpu::new`]) and builds the pipeline.
    pub fn new() -> Result<Self> {
        let gpu = Gpu::new()?;
        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("field_trace"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../../../../shaders/field_trace.wgsl").into()),
        });
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry { binding, visibility: wgpu::ShaderStages::COMPUTE, ty, count: None };
        let storage =
            |read_only| wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only }, has_dynamic_offset: false, min_binding_size: None };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("field_trace"),
            entries: &[
                entry(0, wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None }),
                entry(1, storage(true)),
                entry(2, storage(true)),
                entry(3, storage(false)),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("field_trace"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("field_trace"),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        gpu.take_error()?;
        Ok(Self { gpu, pipeline, layout })
    }

    pub fn adapter_name(&self) -> String {
        self.gpu.adapter_name()
    }

    /// Whether the adapter is a software rasterizer (lavapipe, llvmpipe, WARP).
    pub fn is_software(&self) -> bool {
        self.gpu.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Renders `tree` as `camera` sees it: the CPU tracer's image, traced on the GPU in
    /// single precision. A tree deeper than the shader's stack ([`STACK`]) or a bad
    /// camera is an error.
    pub fn render(&self, tree: &FieldTree, camera: &Camera) -> Result<GpuRender> {
        let program = Program::compile(tree)?;
        let rays = camera.rays()?;
        let (w, h) = (camera.width as usize, camera.height as usize);
        let lipschitz = tree.lipschitz();
        let inv_lipschitz = if lipschitz.is_finite() && lipschitz > 0.0 { 1.0 / lipschitz } else { 0.0 };
        let bounds = tree.solid_box().filter(|b| b.lo.is_finite() && b.hi.is_finite()).map(|b| {
            let margin = 1e-3 * (b.hi - b.lo).length() + 1e-9;
            (b.lo - margin, b.hi + margin)
        });
        let none = GpuRay { origin: [0.0, 0.0, 0.0, 1.0], direction: [0.0; 4], footprint: [0.0; 4] };
        let gpu_rays: Vec<GpuRay> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let Some(ray) = rays.ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5) else { return none };
                let span = match bounds {
                    Some((lo, hi)) => clip(ray.origin, ray.direction, ray.length, lo, hi),
                    None => Some((0.0, ray.length)),
                };
                let Some((t0, t1)) = span else { return none };
                let (o, d) = (ray.origin.as_vec3(), ray.direction.as_vec3());
                GpuRay { origin: [o.x, o.y, o.z, t0 as f32], direction: [d.x, d.y, d.z, t1 as f32], footprint: [ray.near as f32, ray.grow as f32, 0.0, 0.0] }
            })
            .collect();
        let device = &self.gpu.device;
        let params = Params {
            width: camera.width,
            height: camera.height,
            length: program.words.len() as u32,
            max_steps: MAX_STEPS as u32,
            inv_lipschitz: inv_lipschitz as f32,
            pad: [0.0; 3],
        };
        let buffer = |label, contents: &[u8], usage| device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage });
        let uniform = buffer("field params", bytemuck::bytes_of(&params), wgpu::BufferUsages::UNIFORM);
        // An empty storage buffer is not allowed: one spare word.
        let mut words = program.words.clone();
        words.push(-1.0);
        let program_buf = buffer("field program", bytemuck::cast_slice(&words), wgpu::BufferUsages::STORAGE);
        let ray_buf = buffer("field rays", bytemuck::cast_slice(&gpu_rays), wgpu::BufferUsages::STORAGE);
        let size = (w * h * 48) as u64;
        let pixels = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("field pixels"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("field readback"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("field_trace"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: program_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: ray_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: pixels.as_entire_binding() },
            ],
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("field_trace") });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("field_trace"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(camera.width.div_ceil(8), camera.height.div_ceil(8), 1);
        }
        encoder.copy_buffer_to_buffer(&pixels, 0, &readback, 0, size);
        self.gpu.queue.submit([encoder.finish()]);
        let (tx, rx) = mpsc::channel();
        readback.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.gpu.wait()?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(Error::Device(format!("reading the GPU field render back failed: {e}"))),
            Err(_) => return Err(Error::Device("reading the GPU field render back never finished".into())),
        }
        let data: Vec<f32> = {
            let view = readback.get_mapped_range(..).map_err(|e| Error::Device(format!("reading the GPU field render back failed: {e}")))?;
            bytemuck::cast_slice(&view).to_vec()
        };
        let mut rgba = Vec::with_capacity(w * h * 4);
        let mut hits = Vec::with_capacity(w * h);
        let mut normals = Vec::with_capacity(w * h);
        for px in data.chunks_exact(12) {
            rgba.extend_from_slice(&px[..4]);
            let hit = px[7] == 1.0;
            hits.push(hit.then(|| DVec3::new(px[4] as f64, px[5] as f64, px[6] as f64)));
            normals.push(hit.then(|| DVec3::new(px[8] as f64, px[9] as f64, px[10] as f64)));
        }
        Ok(GpuRender { render: Render { width: camera.width, height: camera.height, rgba, hits }, normals })
    }
}

/// The process's field tracer: created on first use; its creation error is kept (no
/// adapter does not appear later), a lost device is dropped so the next call retries.
static TRACER: std::sync::Mutex<Option<std::result::Result<FieldTracer, String>>> = std::sync::Mutex::new(None);

/// Renders with the process's field tracer. Errors: [`Error::Device`] when there is no
/// adapter, the device failed, or the only adapter is a software rasterizer and
/// `software` is false (lavapipe traces a 512x512 frame about 27x slower than the
/// CPU tracer: `field_trace_gpu_bench`); [`Error::InvalidParameter`] for a tree too
/// deep for the shader's stack or a bad camera.
pub fn render_on_shared_gpu(tree: &FieldTree, camera: &Camera, software: bool) -> Result<GpuRender> {
    let mut tracer = TRACER.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if tracer.is_none() {
        *tracer = Some(FieldTracer::new().map_err(|e| e.to_string()));
    }
    let t = match tracer.as_ref().expect("set above") {
        Ok(t) => t,
        Err(e) => return Err(Error::Device(e.clone())),
    };
    if !software && t.is_software() {
        return Err(Error::Device(format!("the only adapter, {}, is a software rasterizer", t.adapter_name())));
    }
    let out = t.render(tree, camera);
    if t.gpu.check_alive().is_err() {
        *tracer = None;
    }
    out
}
