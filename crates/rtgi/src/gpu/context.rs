//! Headless device creation.

use serde::{Deserialize, Serialize};

/// Errors of the GPU layer.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter can run rtgi; `skipped` names each adapter found and why it was passed over.
    #[error(
        "no usable GPU adapter (wgpu backends: {backends}; {}). {}",
        skipped_list(skipped),
        advice(skipped)
    )]
    NoAdapter { backends: String, skipped: Vec<String> },
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

/// How [`usable_adapters`] says an adapter was left out for its name alone.
const NAME_MISMATCH: &str = "name does not contain";

fn skipped_list(skipped: &[String]) -> String {
    if skipped.is_empty() { "none found".into() } else { format!("skipped: {}", skipped.join("; ")) }
}

/// What to do about [`GpuError::NoAdapter`]: another name when only the name filter left adapters out,
/// else a driver rtgi can run on.
fn advice(skipped: &[String]) -> &'static str {
    if !skipped.is_empty() && skipped.iter().all(|s| s.contains(NAME_MISMATCH)) {
        "Choose one of these adapters by a part of its name"
    } else {
        "Install a Vulkan driver: scripts/ensure-vulkan.sh in the rtgi repository, or as root on \
         Debian/Ubuntu `apt-get install -y mesa-vulkan-drivers libvulkan1` (Mesa's lavapipe runs \
         Vulkan on the CPU)"
    }
}

/// Downlevel capabilities every rtgi run needs, with what needs them. (WebGPU compliance as a whole is
/// not required: it also asks for things rtgi never uses, such as surface view formats.)
const REQUIRED_DOWNLEVEL: [(wgpu::DownlevelFlags, &str); 4] = [
    (wgpu::DownlevelFlags::COMPUTE_SHADERS, "compute shaders"),
    // The scene bind group is visible to the raster passes' vertex and fragment stages.
    (wgpu::DownlevelFlags::VERTEX_STORAGE, "storage buffers in vertex shaders"),
    (wgpu::DownlevelFlags::FRAGMENT_STORAGE, "storage buffers in fragment shaders"),
    // Shadow-map lookups (`common/frame.wgsl`).
    (wgpu::DownlevelFlags::COMPARISON_SAMPLERS, "comparison samplers"),
];

/// Texture formats and the usages rtgi's passes put them to: the G-buffer (`frame::*_FORMAT`) and the
/// reflective shadow maps are render targets, depth and shadow maps are depth attachments that are
/// sampled, radiance accumulates in an `Rgba32Float` storage texture. (An adapter lacking one of them
/// could still run the techniques that do not use it — `path` renders no G-buffer — but rtgi picks
/// adapters that run every technique, so that a comparison never depends on which adapter was found.) `frame`'s tests check that its
/// formats are listed here (this layer cannot name them).
pub const REQUIRED_FORMAT_USAGES: [(wgpu::TextureFormat, wgpu::TextureUsages); 7] = {
    use wgpu::TextureFormat as F;
    use wgpu::TextureUsages as U;
    [
        (F::Rgba16Float, U::RENDER_ATTACHMENT),
        (F::Rg32Uint, U::RENDER_ATTACHMENT),
        (F::R32Float, U::RENDER_ATTACHMENT),
        (F::Rg32Float, U::RENDER_ATTACHMENT),
        (F::R32Uint, U::RENDER_ATTACHMENT),
        (F::Depth32Float, U::RENDER_ATTACHMENT.union(U::TEXTURE_BINDING)),
        (F::Rgba32Float, U::RENDER_ATTACHMENT.union(U::STORAGE_BINDING)),
    ]
};

/// What an adapter offers, as far as [`adapter_fit`] looks.
pub struct AdapterCapabilities<'a> {
    pub downlevel: wgpu::DownlevelCapabilities,
    pub limits: wgpu::Limits,
    /// What the device will let textures of a format do (see [`format_features_of`]).
    pub format_features: &'a dyn Fn(wgpu::TextureFormat) -> wgpu::TextureFormatFeatures,
}

/// The capabilities of `adapter` the way a device created on it enforces them: its own per-format
/// capabilities where it lacks WebGPU's format guarantees (GL, downlevel) or offers adapter-specific
/// format features (which [`GpuContext::new`] requests), else WebGPU's guarantees.
pub(crate) fn format_features_of(
    adapter: &wgpu::Adapter,
    format: wgpu::TextureFormat,
) -> wgpu::TextureFormatFeatures {
    let own = adapter.features().contains(wgpu::Features::TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES)
        || !adapter
            .get_downlevel_capabilities()
            .flags
            .contains(wgpu::DownlevelFlags::WEBGPU_TEXTURE_FORMAT_SUPPORT);
    if own {
        adapter.get_texture_format_features(format)
    } else {
        format.guaranteed_format_features(adapter.features())
    }
}

fn flag_names<T>(names: impl Iterator<Item = (&'static str, T)>) -> String {
    names.map(|(name, _)| name).collect::<Vec<_>>().join(" | ")
}

/// Whether rtgi can run on an adapter with `caps`: `Err` says what it lacks (every shortfall, in
/// words). The device request itself cannot fail on features or limits (it asks for what the adapter
/// offers), so this is where an unsuitable adapter is recognised, before any resource creation fails
/// with a wgpu validation error.
pub fn adapter_fit(caps: &AdapterCapabilities) -> Result<(), String> {
    let mut missing = Vec::new();
    for (flag, what) in REQUIRED_DOWNLEVEL {
        if !caps.downlevel.flags.contains(flag) {
            missing.push(format!("no {what} (downlevel flag {})", flag_names(flag.iter_names())));
        }
    }
    if caps.downlevel.shader_model < wgpu::ShaderModel::Sm5 {
        missing.push(format!("shader model {:?} below Sm5", caps.downlevel.shader_model));
    }
    for (format, usages) in REQUIRED_FORMAT_USAGES {
        let lacking = usages - (caps.format_features)(format).allowed_usages;
        if !lacking.is_empty() {
            missing.push(format!("no {} on {format:?} textures", flag_names(lacking.iter_names())));
        }
    }
    // Every pipeline binds the scene's storage buffers (techniques add their own).
    let scene_buffers = super::scene::SCENE_STORAGE_BUFFERS;
    if caps.limits.max_storage_buffers_per_shader_stage < scene_buffers {
        missing.push(format!(
            "max_storage_buffers_per_shader_stage {} below the scene's {scene_buffers}",
            caps.limits.max_storage_buffers_per_shader_stage
        ));
    }
    if missing.is_empty() { Ok(()) } else { Err(missing.join(", ")) }
}

/// What rtgi reports about the adapter it runs on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    /// Loop iterations the driver lets one shader invocation run in all, where it stops them
    /// (`kernel::loop_iteration_limit`: lavapipe's 65535): a pass that needs more computes less there.
    #[serde(default)]
    pub loop_iteration_limit: Option<u32>,
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

/// Options for [`GpuContext::new`]. The default takes `bvh_tables` from `$RTGI_BVH_TABLES` when set
/// (so that a whole test run can be made to use one kind, e.g. buffers on lavapipe), else `auto`.
#[derive(Clone, Debug)]
pub struct GpuOptions {
    /// Only consider adapters whose name contains this (case-insensitive).
    pub adapter_filter: Option<String>,
    /// Where BVHs keep their node and triangle tables (`auto`: the faster kind for the adapter).
    pub bvh_tables: super::bvh::BvhTables,
}

/// `$RTGI_BVH_TABLES`, parsed, if set.
fn env_bvh_tables() -> Option<Result<super::bvh::BvhTables, String>> {
    std::env::var("RTGI_BVH_TABLES").ok().map(|v| v.parse())
}

impl Default for GpuOptions {
    fn default() -> Self {
        // A value that does not parse is reported by GpuContext::new.
        let bvh_tables = env_bvh_tables().and_then(Result::ok).unwrap_or_default();
        GpuOptions { adapter_filter: None, bvh_tables }
    }
}

/// The device every rtgi pass runs on. Cloning is cheap and shares the device.
#[derive(Clone)]
pub struct GpuContext {
    /// The instance the adapter came from: a viewer creates its window surface with it.
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub summary: AdapterSummary,
    /// Timestamp queries inside command encoders are available (their values may still be wrong; see
    /// [`crate::gpu::profiler`]).
    pub has_timestamps: bool,
    /// Where BVHs uploaded to this device keep their tables, as asked ([`GpuOptions::bvh_tables`]).
    pub bvh_tables: super::bvh::BvhTables,
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

/// The adapters among `adapters` that match the name filter and [`adapter_fit`]; the others are
/// described in `skipped` as `'name' (backend, device type): reason`.
fn usable_adapters(
    adapters: impl Iterator<Item = wgpu::Adapter>,
    options: &GpuOptions,
    skipped: &mut Vec<String>,
) -> Vec<wgpu::Adapter> {
    let filter = options.adapter_filter.as_ref().map(|f| f.to_lowercase());
    adapters
        .filter(|adapter| {
            let info = adapter.get_info();
            let label = format!("'{}' ({:?}, {:?})", info.name, info.backend, info.device_type);
            if let Some(f) = &filter
                && !info.name.to_lowercase().contains(f)
            {
                skipped.push(format!("{label}: {NAME_MISMATCH} '{f}'"));
                return false;
            }
            let format_features = |format| format_features_of(adapter, format);
            let caps = AdapterCapabilities {
                downlevel: adapter.get_downlevel_capabilities(),
                limits: adapter.limits(),
                format_features: &format_features,
            };
            match adapter_fit(&caps) {
                Ok(()) => true,
                Err(reason) => {
                    skipped.push(format!("{label}: {reason}"));
                    false
                }
            }
        })
        .collect()
}

impl GpuContext {
    /// Creates a headless device: prefers a discrete GPU, falls back to integrated, virtual and CPU
    /// adapters (lavapipe), among the adapters rtgi can run on ([`adapter_fit`]); the error without
    /// one lists every adapter found and why it was skipped. `WGPU_BACKEND` selects backends (default:
    /// Vulkan, Metal, DX12, and GL only when none of them offers a usable adapter).
    pub fn new(options: &GpuOptions) -> Result<Self, GpuError> {
        if let Some(Err(e)) = env_bvh_tables() {
            return Err(GpuError::Other(format!("RTGI_BVH_TABLES: {e}")));
        }
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // GL is a last resort (no f16, texture atomics or float32 filtering) and probing EGL prints
        // noise on headless machines: try it only when asked for or when no other backend offers a
        // usable adapter.
        if wgpu::Backends::from_env().is_none() {
            descriptor.backends = wgpu::Backends::PRIMARY;
        }
        let mut backends = descriptor.backends;
        let instance = wgpu::Instance::new(descriptor);
        let adapters = pollster::block_on(instance.enumerate_adapters(backends));
        let mut skipped = Vec::new();
        let mut usable = usable_adapters(adapters.into_iter(), options, &mut skipped);
        let mut instance = instance;
        if usable.is_empty() && backends == wgpu::Backends::PRIMARY {
            let mut gl = wgpu::InstanceDescriptor::new_without_display_handle();
            gl.backends = wgpu::Backends::GL;
            instance = wgpu::Instance::new(gl);
            let gl_adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::GL));
            usable = usable_adapters(gl_adapters.into_iter(), options, &mut skipped);
            backends |= wgpu::Backends::GL;
        }
        // Vulkan before GL on the same device: GL lacks f16, texture atomics and float32 filtering.
        usable.sort_by_key(|a| {
            let info = a.get_info();
            (device_rank(info.device_type), u32::from(info.backend != wgpu::Backend::Vulkan))
        });
        // An adapter whose device cannot be created (NVIDIA's headless EGL: "Parent device is lost") is
        // skipped like an unfit one, so the next usable adapter gets its turn.
        for adapter in usable {
            match Self::open(&adapter) {
                Ok((device, queue, has_timestamps)) => {
                    let info = adapter.get_info();
                    let summary = AdapterSummary {
                        name: info.name.clone(),
                        backend: format!("{:?}", info.backend),
                        device_type: format!("{:?}", info.device_type),
                        driver: info.driver.clone(),
                        driver_info: info.driver_info.clone(),
                        loop_iteration_limit: None,
                    };
                    let mut ctx = GpuContext {
                        instance,
                        adapter,
                        device,
                        queue,
                        summary,
                        has_timestamps,
                        bvh_tables: options.bvh_tables,
                        shader_compilations: Default::default(),
                    };
                    ctx.summary.loop_iteration_limit = super::kernel::loop_iteration_limit(&ctx)?;
                    return Ok(ctx);
                }
                Err(message) => {
                    let info = adapter.get_info();
                    skipped.push(format!(
                        "'{}' ({:?}, {:?}): could not create a device: {message}",
                        info.name, info.backend, info.device_type
                    ));
                }
            }
        }
        Err(GpuError::NoAdapter { backends: flag_names(backends.iter_names()), skipped })
    }

    /// The device and queue of `adapter`, with every optional feature rtgi can use that it offers, and
    /// whether timestamps are among them.
    fn open(adapter: &wgpu::Adapter) -> Result<(wgpu::Device, wgpu::Queue, bool), String> {
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
        .map_err(|e| e.to_string())?;
        Ok((device, queue, has_timestamps))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(storage_buffers: u32) -> wgpu::Limits {
        wgpu::Limits { max_storage_buffers_per_shader_stage: storage_buffers, ..Default::default() }
    }

    #[test]
    fn a_webgpu_capable_adapter_fits() {
        let guaranteed = |f: wgpu::TextureFormat| f.guaranteed_format_features(wgpu::Features::empty());
        let caps = AdapterCapabilities {
            downlevel: wgpu::DownlevelCapabilities::default(),
            limits: limits(16),
            format_features: &guaranteed,
        };
        adapter_fit(&caps).expect("WebGPU's guarantees and 16 storage buffers are enough");
    }

    /// The GL adapter of Mesa (llvmpipe): no render target of R32Float, no storage buffers in vertex
    /// shaders; every shortfall is named.
    #[test]
    fn a_downlevel_adapter_is_refused_with_every_reason() {
        let r32float_not_renderable = |f: wgpu::TextureFormat| {
            let mut features = f.guaranteed_format_features(wgpu::Features::empty());
            if f == wgpu::TextureFormat::R32Float {
                features.allowed_usages -= wgpu::TextureUsages::RENDER_ATTACHMENT;
            }
            features
        };
        let mut downlevel = wgpu::DownlevelCapabilities::default();
        downlevel.flags -= wgpu::DownlevelFlags::VERTEX_STORAGE;
        downlevel.shader_model = wgpu::ShaderModel::Sm4;
        let caps =
            AdapterCapabilities { downlevel, limits: limits(4), format_features: &r32float_not_renderable };
        let reason = adapter_fit(&caps).unwrap_err();
        for part in [
            "no storage buffers in vertex shaders (downlevel flag VERTEX_STORAGE)",
            "shader model Sm4 below Sm5",
            "no RENDER_ATTACHMENT on R32Float textures",
            "max_storage_buffers_per_shader_stage 4 below the scene's 7",
        ] {
            assert!(reason.contains(part), "'{part}' missing in: {reason}");
        }
        assert!(!reason.contains("compute"), "{reason}");
    }

    #[test]
    fn the_no_adapter_error_lists_each_adapter_and_the_driver_to_install() {
        let e = GpuError::NoAdapter {
            backends: "GL".into(),
            skipped: vec![
                "'llvmpipe' (Gl, Cpu): no RENDER_ATTACHMENT on R32Float textures".into(),
                "'other' (Gl, Cpu): name does not contain 'x'".into(),
            ],
        }
        .to_string();
        assert!(!e.contains('\n'), "one line: {e}");
        for part in [
            "skipped: 'llvmpipe' (Gl, Cpu): no RENDER_ATTACHMENT on R32Float textures; 'other'",
            "scripts/ensure-vulkan.sh",
            "mesa-vulkan-drivers libvulkan1",
        ] {
            assert!(e.contains(part), "'{part}' missing in: {e}");
        }
        let none = GpuError::NoAdapter { backends: "VULKAN".into(), skipped: vec![] }.to_string();
        assert!(
            none.contains("wgpu backends: VULKAN; none found") && none.contains("ensure-vulkan.sh"),
            "{none}"
        );
        // Only the name filter left adapters out: installing drivers would not help.
        let filtered = GpuError::NoAdapter {
            backends: "VULKAN".into(),
            skipped: vec![format!("'llvmpipe' (Vulkan, Cpu): {NAME_MISMATCH} 'nvidia'")],
        }
        .to_string();
        assert!(
            filtered.contains("Choose one of these adapters") && !filtered.contains("ensure-vulkan"),
            "{filtered}"
        );
    }

    /// The adapter the tests run on (lavapipe) fits, with the capabilities it really reports.
    #[test]
    fn the_test_adapter_fits() {
        let ctx = GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (lavapipe)");
        let format_features = |format| format_features_of(&ctx.adapter, format);
        let caps = AdapterCapabilities {
            downlevel: ctx.adapter.get_downlevel_capabilities(),
            limits: ctx.adapter.limits(),
            format_features: &format_features,
        };
        adapter_fit(&caps).expect("the adapter GpuContext::new chose");
    }
}
