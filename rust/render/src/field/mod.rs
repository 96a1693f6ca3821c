//! The GPU sphere tracer of field trees (issue 17): the tree's compiled tape translated to a flat
//! postfix program ([`program`]) interpreted per pixel by `shaders/field_trace.wgsl`
//! with the CPU tracer's rays, step rule and shading
//! ([`thicket_core::implicit::trace`]), so the two images agree (tests/field_gpu.rs
//! compares them tree by tree).
//!
//! A frame uploads a uniform of 128 bytes (the camera as homogeneous points made in
//! double precision, the tree's box) and the program where it changed; each pixel
//! makes its ray and clips it to the box on the GPU. Colours come back as four f16 a
//! pixel; depths and normals (8 bytes more) only for [`FieldTracer::render`], not for
//! [`FieldTracer::render_rgba`] (the Python binding's). The buffers of the last image
//! size stay between frames, so a warm frame allocates nothing on the device.

pub mod program;

use std::sync::{mpsc, Mutex, MutexGuard};
use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::{DVec3, DVec4};
use rayon::prelude::*;
use thicket_core::implicit::trace::{Camera, Render, MAX_STEPS};
use thicket_core::implicit::FieldTree;
use thicket_core::{Error, Result};

use crate::gpu::device::Gpu;
pub use program::{Program, STACK};

/// The shader's uniform (`Params` in `field_trace.wgsl`): the camera as homogeneous
/// points, the tree's box, sizes and the step rule.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
struct Params {
    near0: [f32; 4],
    far0: [f32; 4],
    dx: [f32; 4],
    dy: [f32; 4],
    lo: [f32; 4],
    hi: [f32; 4],
    width: u32,
    height: u32,
    length: u32,
    max_steps: u32,
    inv_lipschitz: f32,
    flags: u32,
    pad: [u32; 2],
}

/// `Params::flags`: write each hit's depth and normal (`geometry`) besides colours.
const GEOMETRY: u32 = 1;
/// Bytes per pixel of the colour buffer (four f16) and of the geometry buffer (f32
/// depth, octahedral normal in two snorm16).
const COLOR_BYTES: u64 = 8;
const GEOMETRY_BYTES: u64 = 8;

/// A GPU render: the CPU tracer's [`Render`] plus each hit's unit normal.
#[derive(Debug, Clone, PartialEq)]
pub struct GpuRender {
    pub render: Render,
    pub normals: Vec<Option<DVec3>>,
}

/// Where a frame's time went, in milliseconds of wall-clock time: `prepare` (compiling
/// the program, the camera's uniform, buffers: nothing allocated on a warm frame of
/// the same size), `gpu` (from submitting the trace and the copies to the readback
/// buffers until the GPU is done: the device's time for the frame), `readback`
/// (mapping and unpacking the pixels into the caller's arrays).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameTimes {
    pub prepare: f64,
    pub gpu: f64,
    pub readback: f64,
    /// Whether the buffers were (re)allocated for this frame.
    pub allocated: bool,
}

/// The buffers of one image size, kept between frames.
struct Frame {
    width: u32,
    height: u32,
    uniform: wgpu::Buffer,
    /// The program's words (grown as needed) and the words it holds now.
    program: wgpu::Buffer,
    words: Vec<f32>,
    colors: wgpu::Buffer,
    colors_read: wgpu::Buffer,
    /// Made on the first frame that asks for depths and normals.
    geometry: Option<(wgpu::Buffer, wgpu::Buffer, wgpu::BindGroup)>,
    /// A one-pixel stand-in bound as `geometry` when only colours are wanted.
    bind_colors: wgpu::BindGroup,
}

/// The field tracer's device and pipeline, reusable across frames; the buffers of the
/// last image size are kept, so a frame of the same size allocates nothing.
pub struct FieldTracer {
    gpu: Gpu,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    frame: Mutex<Option<Frame>>,
    times: Mutex<Option<FrameTimes>>,
}

/// The camera as the shader's homogeneous points: `inverse(projection * view)` applied
/// in double precision to normalized device coordinates, as functions of pixel
/// coordinates (`x` right, `y` down from the top left corner, the CPU's `Rays`):
/// the near (z = -1) and far (z = 1) planes' points at (0, 0) and the change per pixel
/// along x and y. Rounded to f32 only here, after the far plane's cancellation (a far
/// plane 1e3 times the near one's distance loses 3 digits in w) happened in f64.
fn camera_params(camera: &Camera) -> [[f32; 4]; 4] {
    let inverse = (camera.projection * camera.view).inverse();
    let at = |x: f64, y: f64, z: f64| inverse * DVec4::new(x, y, z, 1.0);
    let near0 = at(-1.0, 1.0, -1.0);
    let far0 = at(-1.0, 1.0, 1.0);
    let dx = inverse.x_axis * (2.0 / f64::from(camera.width));
    let dy = -inverse.y_axis * (2.0 / f64::from(camera.height));
    [near0, far0, dx, dy].map(|v| v.as_vec4().to_array())
}

/// The shader's box: the tree's solid box grown by the CPU tracer's margin (w = 1), or
/// none (w = 0: the camera's near-to-far segment).
fn box_params(tree: &FieldTree) -> ([f32; 4], [f32; 4]) {
    let bounds = tree.solid_box().filter(|b| b.lo.is_finite() && b.hi.is_finite()).map(|b| {
        let margin = 1e-3 * (b.hi - b.lo).length() + 1e-9;
        (b.lo - margin, b.hi + margin)
    });
    match bounds {
        // Rounded outward to f32.
        Some((lo, hi)) => {
            let down = |v: f64| {
                let f = v as f32;
                if f64::from(f) > v {
                    f.next_down()
                } else {
                    f
                }
            };
            let up = |v: f64| {
                let f = v as f32;
                if f64::from(f) < v {
                    f.next_up()
                } else {
                    f
                }
            };
            ([down(lo.x), down(lo.y), down(lo.z), 1.0], [up(hi.x), up(hi.y), up(hi.z), 1.0])
        }
        None => ([0.0; 4], [0.0; 4]),
    }
}

/// An f16's value (IEEE binary16: subnormals, infinities and NaN included).
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = (h >> 10) & 0x1f;
    let frac = f32::from(h & 0x3ff);
    sign * match exp {
        0 => frac * (1.0 / (1u32 << 24) as f32),
        31 if frac == 0.0 => f32::INFINITY,
        31 => f32::NAN,
        e => (1.0 + frac / 1024.0) * f32::powi(2.0, i32::from(e) - 15),
    }
}

/// The unit vector of octahedral coordinates packed as two snorm16 (the shader's
/// `octahedral`, `pack2x16snorm`).
fn unpack_normal(word: u32) -> DVec3 {
    let snorm = |v: u16| (f64::from(v as i16) / 32767.0).max(-1.0);
    let (u, v) = (snorm(word as u16), snorm((word >> 16) as u16));
    let z = 1.0 - u.abs() - v.abs();
    let (x, y) = if z >= 0.0 { (u, v) } else { ((1.0 - v.abs()) * u.signum(), (1.0 - u.abs()) * v.signum()) };
    DVec3::new(x, y, z).normalize()
}

/// Blocks until `buffer` is mapped for reading.
fn map_read(gpu: &Gpu, buffer: &wgpu::Buffer) -> Result<()> {
    let (tx, rx) = mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    match rx.recv() {
        Ok(Ok(())) => Ok(()),
        Ok(Err(e)) => Err(Error::Device(format!("reading the GPU field render back failed: {e}"))),
        Err(_) => Err(Error::Device("reading the GPU field render back never finished".into())),
    }
}

/// The mapped words of `buffer`, handed to `f`, then unmapped.
fn read_words<T>(buffer: &wgpu::Buffer, f: impl FnOnce(&[u32]) -> T) -> Result<T> {
    let out = {
        let view = buffer.get_mapped_range(..).map_err(|e| Error::Device(format!("reading the GPU field render back failed: {e}")))?;
        f(bytemuck::cast_slice(&view))
    };
    buffer.unmap();
    Ok(out)
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
                entry(2, storage(false)),
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
        Ok(Self { gpu, pipeline, layout, frame: Mutex::new(None), times: Mutex::new(None) })
    }

    pub fn adapter_name(&self) -> String {
        self.gpu.adapter_name()
    }

    /// Whether the adapter is a software rasterizer (lavapipe, llvmpipe, WARP).
    pub fn is_software(&self) -> bool {
        self.gpu.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Where the last frame's time went (see [`FrameTimes`]); `None` before the first.
    pub fn last_times(&self) -> Option<FrameTimes> {
        *self.times.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Renders `tree` as `camera` sees it: the CPU tracer's image, traced on the GPU in
    /// single precision, with each hit point (the ray's, at the depth the GPU found)
    /// and normal. A tree deeper than the shader's stack ([`STACK`]) or a bad camera
    /// is an error.
    pub fn render(&self, tree: &FieldTree, camera: &Camera) -> Result<GpuRender> {
        let mut frame = self.trace(tree, camera, true)?;
        let rays = camera.rays()?;
        let start = Instant::now();
        let f = frame.as_ref().expect("traced");
        let read = || -> Result<GpuRender> {
            let geometry_read = &f.geometry.as_ref().expect("asked for").1;
            map_read(&self.gpu, &f.colors_read)?;
            map_read(&self.gpu, geometry_read)?;
            let rgba = read_words(&f.colors_read, unpack_colors)?;
            let w = camera.width as usize;
            let (hits, normals) = read_words(geometry_read, |words| {
                words
                    .par_chunks_exact(2)
                    .enumerate()
                    .map(|(i, px)| {
                        let t = f32::from_bits(px[0]);
                        if t.is_nan() || t < 0.0 {
                            return (None, None);
                        }
                        let Some(ray) = rays.ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5) else { return (None, None) };
                        (Some(ray.origin + f64::from(t) * ray.direction), Some(unpack_normal(px[1])))
                    })
                    .unzip()
            })?;
            Ok(GpuRender { render: Render { width: camera.width, height: camera.height, rgba, hits }, normals })
        };
        let out = read();
        self.finish(&mut frame, start, out.is_ok());
        out
    }

    /// The colours of [`FieldTracer::render`] alone (linear RGBA, rows top to bottom, 4
    /// floats a pixel, alpha 0 where nothing is hit; through f16, a relative error of
    /// at most 2^-11): 8 bytes a pixel read back instead of 16.
    pub fn render_rgba(&self, tree: &FieldTree, camera: &Camera) -> Result<Vec<f32>> {
        let mut frame = self.trace(tree, camera, false)?;
        let start = Instant::now();
        let f = frame.as_ref().expect("traced");
        let out = map_read(&self.gpu, &f.colors_read).and_then(|()| read_words(&f.colors_read, unpack_colors));
        self.finish(&mut frame, start, out.is_ok());
        out
    }

    /// Records the readback's time; after a failed readback the kept buffers are
    /// dropped (one may still be mapped).
    fn finish(&self, frame: &mut MutexGuard<'_, Option<Frame>>, readback: Instant, ok: bool) {
        if !ok {
            **frame = None;
        }
        if let Some(t) = self.times.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
            t.readback = readback.elapsed().as_secs_f64() * 1e3;
        }
    }

    /// Traces a frame into the kept buffers (made or grown first) and copies the
    /// colours (and with `geometry` depths and normals) into the readback buffers,
    /// waiting for the GPU; the caller maps them. Holds the buffers' lock throughout.
    fn trace(&self, tree: &FieldTree, camera: &Camera, geometry: bool) -> Result<MutexGuard<'_, Option<Frame>>> {
        let start = Instant::now();
        let program = Program::compile(tree)?;
        camera.rays()?;
        let lipschitz = tree.lipschitz();
        let inv_lipschitz = if lipschitz.is_finite() && lipschitz > 0.0 { 1.0 / lipschitz } else { 0.0 };
        let [near0, far0, dx, dy] = camera_params(camera);
        let (lo, hi) = box_params(tree);
        let params = Params {
            near0,
            far0,
            dx,
            dy,
            lo,
            hi,
            width: camera.width,
            height: camera.height,
            length: program.words.len() as u32,
            max_steps: MAX_STEPS as u32,
            inv_lipschitz: inv_lipschitz as f32,
            flags: if geometry { GEOMETRY } else { 0 },
            pad: [0; 2],
        };
        let mut guard = self.frame.lock().unwrap_or_else(|e| e.into_inner());
        let mut allocated = false;
        if guard.as_ref().is_none_or(|f| f.width != camera.width || f.height != camera.height || f.words.len() < program.words.len()) {
            // Drop the old buffers first: a size change frees before it allocates.
            *guard = None;
            *guard = Some(self.allocate(camera.width, camera.height, program.words.len()));
            allocated = true;
        }
        let f = guard.as_mut().expect("made above");
        if geometry && f.geometry.is_none() {
            f.geometry = Some(self.allocate_geometry(f));
            allocated = true;
        }
        let queue = &self.gpu.queue;
        queue.write_buffer(&f.uniform, 0, bytemuck::bytes_of(&params));
        // Bits, not values: -0.0 == 0.0, and a NaN word would re-upload every frame.
        if !f.words[..program.words.len()].iter().zip(&program.words).all(|(a, b)| a.to_bits() == b.to_bits()) {
            queue.write_buffer(&f.program, 0, bytemuck::cast_slice(&program.words));
            f.words[..program.words.len()].copy_from_slice(&program.words);
        }
        let pixels = u64::from(camera.width) * u64::from(camera.height);
        let mut encoder = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("field_trace") });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("field_trace"), timestamp_writes: None });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, if geometry { &f.geometry.as_ref().expect("made above").2 } else { &f.bind_colors }, &[]);
            pass.dispatch_workgroups(camera.width.div_ceil(8), camera.height.div_ceil(8), 1);
        }
        encoder.copy_buffer_to_buffer(&f.colors, 0, &f.colors_read, 0, pixels * COLOR_BYTES);
        if geometry {
            let (g, g_read, _) = f.geometry.as_ref().expect("made above");
            encoder.copy_buffer_to_buffer(g, 0, g_read, 0, pixels * GEOMETRY_BYTES);
        }
        let prepare = start.elapsed().as_secs_f64() * 1e3;
        let submitted = Instant::now();
        queue.submit([encoder.finish()]);
        if let Err(e) = self.gpu.wait() {
            *guard = None;
            return Err(e);
        }
        let gpu = submitted.elapsed().as_secs_f64() * 1e3;
        *self.times.lock().unwrap_or_else(|e| e.into_inner()) = Some(FrameTimes { prepare, gpu, readback: 0.0, allocated });
        Ok(guard)
    }

    fn storage(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: size.max(16), usage, mapped_at_creation: false })
    }

    /// The buffers of a `width` x `height` image and a program of `words` words.
    fn allocate(&self, width: u32, height: u32, words: usize) -> Frame {
        use wgpu::BufferUsages as U;
        let pixels = u64::from(width) * u64::from(height);
        let uniform = self.storage("field params", std::mem::size_of::<Params>() as u64, U::UNIFORM | U::COPY_DST);
        // Room for twice the words (a bigger tree of the same image keeps the buffers),
        // never empty.
        let capacity = (2 * words).max(64);
        let program = self.storage("field program", 4 * capacity as u64, U::STORAGE | U::COPY_DST);
        let colors = self.storage("field colours", pixels * COLOR_BYTES, U::STORAGE | U::COPY_SRC);
        let colors_read = self.storage("field colours readback", pixels * COLOR_BYTES, U::COPY_DST | U::MAP_READ);
        let spare = self.storage("field geometry stand-in", 16, U::STORAGE);
        let bind_colors = self.bind(&uniform, &program, &colors, &spare);
        // NaN words: the first comparison with a program uploads it.
        Frame { width, height, uniform, program, words: vec![f32::NAN; capacity], colors, colors_read, geometry: None, bind_colors }
    }

    fn allocate_geometry(&self, f: &Frame) -> (wgpu::Buffer, wgpu::Buffer, wgpu::BindGroup) {
        use wgpu::BufferUsages as U;
        let pixels = u64::from(f.width) * u64::from(f.height);
        let geometry = self.storage("field geometry", pixels * GEOMETRY_BYTES, U::STORAGE | U::COPY_SRC);
        let read = self.storage("field geometry readback", pixels * GEOMETRY_BYTES, U::COPY_DST | U::MAP_READ);
        let bind = self.bind(&f.uniform, &f.program, &f.colors, &geometry);
        (geometry, read, bind)
    }

    fn bind(&self, uniform: &wgpu::Buffer, program: &wgpu::Buffer, colors: &wgpu::Buffer, geometry: &wgpu::Buffer) -> wgpu::BindGroup {
        let entries = [uniform, program, colors, geometry]
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
            .collect::<Vec<_>>();
        self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("field_trace"), layout: &self.layout, entries: &entries })
    }
}

/// Four f16 a pixel (two words) to four f32.
fn unpack_colors(words: &[u32]) -> Vec<f32> {
    let mut rgba = vec![0.0f32; words.len() * 2];
    rgba.par_chunks_mut(4096).zip(words.par_chunks(2048)).for_each(|(out, words)| {
        for (o, w) in out.chunks_exact_mut(2).zip(words) {
            o[0] = f16_to_f32(*w as u16);
            o[1] = f16_to_f32((*w >> 16) as u16);
        }
    });
    rgba
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
    with_shared_tracer(software, |t| t.render(tree, camera))
}

/// [`render_on_shared_gpu`]'s colours alone ([`FieldTracer::render_rgba`]: what
/// `thicket_native.field_render` returns), with the same errors.
pub fn render_rgba_on_shared_gpu(tree: &FieldTree, camera: &Camera, software: bool) -> Result<Vec<f32>> {
    with_shared_tracer(software, |t| t.render_rgba(tree, camera))
}

fn with_shared_tracer<T>(software: bool, f: impl FnOnce(&FieldTracer) -> Result<T>) -> Result<T> {
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
    let out = f(t);
    if t.gpu.check_alive().is_err() {
        *tracer = None;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_values() {
        let cases = [
            (0x0000, 0.0),
            (0x3c00, 1.0),
            (0xc000, -2.0),
            (0x3800, 0.5),
            (0x7bff, 65504.0),
            (0x0001, 2f32.powi(-24)),
            (0x0400, 2f32.powi(-14)),
            (0x3555, 0.333_251_95),
            (0x7c00, f32::INFINITY),
        ];
        for (bits, value) in cases {
            assert_eq!(f16_to_f32(bits), value, "{bits:#06x}");
        }
        assert!(f16_to_f32(0x7e00).is_nan());
        assert_eq!(unpack_colors(&[0x3c00_3800, 0xc000_0000]), [0.5, 1.0, 0.0, -2.0]);
    }

    /// The shader's `octahedral` and `pack2x16snorm`, in f64.
    fn pack_normal(n: DVec3) -> u32 {
        let p = DVec3::new(n.x, n.y, 0.0) / (n.x.abs() + n.y.abs() + n.z.abs());
        let (u, v) = if n.z >= 0.0 { (p.x, p.y) } else { ((1.0 - p.y.abs()) * p.x.signum(), (1.0 - p.x.abs()) * p.y.signum()) };
        let snorm = |x: f64| u32::from((x.clamp(-1.0, 1.0) * 32767.0).round() as i16 as u16);
        snorm(u) | (snorm(v) << 16)
    }

    #[test]
    fn normals_round_trip_within_a_thousandth_of_a_radian() {
        let mut worst = 0.0f64;
        for i in 0..2000 {
            // A spiral over the sphere, the axes and octant borders included.
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 2000.0;
            let a = i as f64 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            for n in [DVec3::new(r * a.cos(), r * a.sin(), z), DVec3::X, DVec3::NEG_Y, DVec3::NEG_Z, DVec3::new(1.0, -1.0, -1.0).normalize()] {
                worst = worst.max(unpack_normal(pack_normal(n)).angle_between(n));
            }
        }
        assert!(worst < 1e-3, "{worst}");
    }
}
