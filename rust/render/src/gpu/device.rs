//! The headless wgpu device: instance, adapter (the best one found: a discrete GPU
//! first, a software one such as Mesa's lavapipe last), device and queue, with every
//! wgpu error and a lost device recorded instead of panicking.

use std::sync::{Arc, Mutex};

use thicket_core::{Error, Result};

pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// Errors wgpu reported since the last [`Gpu::take_error`].
    errors: Arc<Mutex<Vec<String>>>,
    /// Why the device was lost, once it was.
    lost: Arc<Mutex<Option<String>>>,
}

/// Adapters in order of preference.
fn rank(kind: wgpu::DeviceType) -> u8 {
    match kind {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

impl Gpu {
    /// The best adapter of any backend this build supports (`WGPU_BACKEND` and the
    /// other wgpu environment variables apply), or an error saying none was found.
    pub fn new() -> Result<Self> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        let adapter = match adapters.into_iter().min_by_key(|a| rank(a.get_info().device_type)) {
            Some(a) => a,
            None => pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                apply_limit_buckets: false,
            }))
            .map_err(|e| {
                Error::Device(format!(
                    "no GPU adapter found ({e}); install a Vulkan driver (on Linux without a GPU: \
                     Mesa's lavapipe, package mesa-vulkan-drivers) or use the CPU reference renderer"
                ))
            })?,
        };
        let info = adapter.get_info();
        let limits = adapter.limits();
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("thicket slice renderer"),
            required_features: wgpu::Features::empty(),
            // Everything the adapter offers: large shells need big storage buffers.
            required_limits: limits,
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .map_err(|e| Error::Device(format!("the GPU adapter {} refused to open a device: {e}", info.name)))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let lost = Arc::new(Mutex::new(None));
        let sink = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut l) = sink.lock() {
                *l = Some(format!("{reason:?}: {message}"));
            }
        });
        Ok(Self { device, queue, info, errors, lost })
    }

    /// The adapter's name and backend, e.g. `"llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)"`.
    pub fn adapter_name(&self) -> String {
        format!("{} ({:?})", self.info.name, self.info.backend)
    }

    /// An error when the device was lost.
    pub fn check_alive(&self) -> Result<()> {
        match self.lost.lock().ok().and_then(|l| l.clone()) {
            Some(why) => Err(Error::Device(format!("the GPU device was lost ({why}); render on the CPU"))),
            None => Ok(()),
        }
    }

    /// The first wgpu error reported since the last call (all are cleared), or the
    /// device loss.
    pub fn take_error(&self) -> Result<()> {
        self.check_alive()?;
        let first = self.errors.lock().ok().and_then(|mut v| {
            let first = v.first().cloned();
            v.clear();
            first
        });
        match first {
            Some(e) => Err(Error::Device(format!("the GPU renderer failed: {e}"))),
            None => Ok(()),
        }
    }

    /// Blocks until the queue is idle.
    pub fn wait(&self) -> Result<()> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| Error::Device(format!("waiting for the GPU failed: {e}")))?;
        self.take_error()
    }
}
