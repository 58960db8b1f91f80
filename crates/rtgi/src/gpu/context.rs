//! Headless device creation.

use serde::Serialize;

/// Errors of the GPU layer.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (wgpu backends: {backends}). Install a Vulkan driver, e.g. on Debian: \
         apt-get install -y mesa-vulkan-drivers libvulkan1"
    )]
    NoAdapter { backends: String },
    #[error("could not create a device on '{adapter}': {message}")]
    Device { adapter: String, message: String },
    /// The scene or a resource is larger than the device allows; the message names the limit.
    #[error("{0}")]
    OverLimit(String),
    /// A technique needs an optional capability the device lacks ([`crate::gpu::features::require`]).
    #[error("{who} needs {missing}, which the device on '{adapter}' does not offer")]
    MissingFeature { who: String, missing: String, adapter: String },
    #[error("GPU error: {0}")]
    Other(String),
}

impl GpuError {
    /// `what` needs `bytes`, more than the device's limit `name` of `limit` bytes.
    pub(crate) fn buffer_over_limit(what: &str, bytes: u64, name: &str, limit: u64) -> GpuError {
        let mib = |b: u64| b as f64 / 1_048_576.0;
        GpuError::OverLimit(format!(
            "{what} needs {:.1} MiB, over the device's {name} of {:.1} MiB",
            mib(bytes),
            mib(limit)
        ))
    }
}

/// What rtgi reports about the adapter it runs on.
#[derive(Clone, Debug, Serialize)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
}

/// Memory in use: the process's resident set and wgpu's own count of GPU objects and bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct MemoryReport {
    /// Resident set size of the process (Linux `/proc/self/statm`; `None` elsewhere).
    pub rss_bytes: Option<u64>,
    pub gpu_buffers: u64,
    pub gpu_textures: u64,
    pub gpu_bind_groups: u64,
    pub gpu_buffer_bytes: u64,
    pub gpu_texture_bytes: u64,
    /// Device memory allocations (wgpu suballocates, so this is not one per resource).
    pub gpu_allocations: u64,
}

fn resident_set_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    // The page size of every Linux target rtgi runs on; `statm` counts pages.
    Some(pages * 4096)
}

/// Options for [`GpuContext::new`].
#[derive(Clone, Debug, Default)]
pub struct GpuOptions {
    /// Only consider adapters whose name contains this (case-insensitive).
    pub adapter_filter: Option<String>,
}

/// The device every rtgi pass runs on. Cloning is cheap and shares the device.
#[derive(Clone)]
pub struct GpuContext {
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub summary: AdapterSummary,
    /// Timestamp queries inside command encoders are available (their values may still be wrong; see
    /// [`crate::gpu::profiler`]).
    pub has_timestamps: bool,
    /// Shader modules compiled on this device (each feeds one pipeline): the renderer reports how many
    /// a run created, so per-frame recompilation shows.
    shader_compilations: std::sync::Arc<std::sync::atomic::AtomicU64>,
}

fn device_rank(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

impl GpuContext {
    /// Creates a headless device: prefers a discrete GPU, falls back to integrated, virtual and CPU
    /// adapters (lavapipe). `WGPU_BACKEND` selects backends (default: all that are compiled in).
    pub fn new(options: &GpuOptions) -> Result<Self, GpuError> {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // GL is a last resort (no f16, texture atomics or float32 filtering) and probing EGL prints
        // noise on headless machines: try it only when asked for or when nothing else exists.
        if wgpu::Backends::from_env().is_none() {
            descriptor.backends = wgpu::Backends::PRIMARY;
        }
        let backends = descriptor.backends;
        let instance = wgpu::Instance::new(descriptor);
        let mut adapters = pollster::block_on(instance.enumerate_adapters(backends));
        if adapters.is_empty() && backends == wgpu::Backends::PRIMARY {
            let mut gl = wgpu::InstanceDescriptor::new_without_display_handle();
            gl.backends = wgpu::Backends::GL;
            adapters = pollster::block_on(wgpu::Instance::new(gl).enumerate_adapters(wgpu::Backends::GL));
        }
        if let Some(filter) = &options.adapter_filter {
            let f = filter.to_lowercase();
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(&f));
        }
        // Vulkan before GL on the same device: GL lacks f16, texture atomics and float32 filtering.
        adapters.sort_by_key(|a| {
            let info = a.get_info();
            (device_rank(info.device_type), u32::from(info.backend != wgpu::Backend::Vulkan))
        });
        let adapter = adapters
            .into_iter()
            .next()
            .ok_or_else(|| GpuError::NoAdapter { backends: format!("{backends:?}") })?;
        let info = adapter.get_info();
        let summary = AdapterSummary {
            name: info.name.clone(),
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver: info.driver.clone(),
            driver_info: info.driver_info.clone(),
        };

        let available = adapter.features();
        // Every optional feature techniques may declare (`features::Need`) is requested where offered;
        // none is required, so `features::require` reports what a technique misses instead.
        let wanted = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
            | super::features::optional_features();
        let features = available & wanted;
        let has_timestamps = features
            .contains(wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);
        // Ask for everything the adapter offers: scene buffers are bounded by
        // max_storage_buffer_binding_size, which is far above the WebGPU default on every driver.
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("rtgi"),
            required_features: features,
            required_limits: limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::Device { adapter: info.name.clone(), message: e.to_string() })?;
        Ok(GpuContext {
            adapter,
            device,
            queue,
            summary,
            has_timestamps,
            shader_compilations: Default::default(),
        })
    }

    pub(crate) fn count_shader_compilation(&self) {
        self.shader_compilations.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }

    /// Shader modules compiled on this device so far (by every user of this context and its clones).
    pub fn shader_compilations(&self) -> u64 {
        self.shader_compilations.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Process and GPU memory now (wgpu's counters count live objects and their bytes).
    pub fn memory_report(&self) -> MemoryReport {
        let hal = self.device.get_internal_counters().hal;
        let count = |value: isize| value.max(0) as u64;
        MemoryReport {
            rss_bytes: resident_set_bytes(),
            gpu_buffers: count(hal.buffers.read()),
            gpu_textures: count(hal.textures.read()),
            gpu_bind_groups: count(hal.bind_groups.read()),
            gpu_buffer_bytes: count(hal.buffer_memory.read()),
            gpu_texture_bytes: count(hal.texture_memory.read()),
            gpu_allocations: count(hal.memory_allocations.read()),
        }
    }

    pub fn limits(&self) -> wgpu::Limits {
        self.device.limits()
    }

    /// Blocks until all submitted work is done.
    pub fn wait_idle(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::Other(format!("waiting for the device: {e}")))
    }

    /// Runs `f` inside validation and out-of-memory error scopes, so a device error becomes a
    /// [`GpuError`] naming `what` instead of wgpu's default panic.
    pub fn checked<R>(&self, what: &str, f: impl FnOnce() -> R) -> Result<R, GpuError> {
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let result = f();
        let v = pollster::block_on(validation.pop());
        let o = pollster::block_on(oom.pop());
        match v.or(o) {
            Some(e) => Err(GpuError::Other(format!("{what}: {e}"))),
            None => Ok(result),
        }
    }

    /// Checks that a storage buffer of `bytes` fits the device, naming `what` in the error.
    pub fn check_storage_size(&self, what: &str, bytes: u64) -> Result<(), GpuError> {
        let limit = self.limits().max_storage_buffer_binding_size;
        if bytes > limit {
            return Err(GpuError::buffer_over_limit(what, bytes, "max_storage_buffer_binding_size", limit));
        }
        Ok(())
    }
}
