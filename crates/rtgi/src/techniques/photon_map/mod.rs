//! The photon map (Jensen 2001) on the GPU, a sub-pass of `photon-irradiance-cache`: light paths from
//! the sources (the `light_paths` sub-pass `igi` uses, one set of quasi-random paths), whose vertices 2
//! and deeper (light that has bounced at least once) are photons, sorted into a hashed grid of cells
//! two lookup radii wide by a counting sort (`grid.wgsl`). Passes read it through `lookup.wgsl`: the
//! radiance the photons near a point reflect (a density estimate over a disc of the lookup radius).
//!
//! Built once and kept until the technique asks again (the cache rebuilds it when it is cleared).

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::gpu::{GpuContext, Profiler, readback};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute::{self, storage_buffer_entry, uniform_entry};
use super::light_paths::{GpuVpl, LightPaths, MAX_DEPTH, VPL_WGSL, mean_albedo, scene_sphere, set_layout};
use super::{FrameContext, TechniqueSetup};

const PHOTON_WGSL: &str = include_str!("photon.wgsl");
const GRID_WGSL: &str = include_str!("grid.wgsl");
/// The density estimate; its includer binds `photons` and `photon_grid` (see the file).
pub const LOOKUP_WGSL: &str = include_str!("lookup.wgsl");

/// Photons count towards a lookup only on surfaces whose shading normal is within this cosine of the
/// query's (a photon on a wall meeting the floor in a corner is not floor light).
pub(crate) const NORMAL_COS: f32 = 0.7;
/// The most buckets of the hashed grid: its scan is one workgroup of 256 threads, each walking its
/// B / 256 buckets twice, within the 65535 loop iterations lavapipe allows an invocation.
const MAX_BUCKETS: u32 = 1 << 21;

/// Mirrors `Photon` in photon.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuPhoton {
    pub position: [f32; 3],
    pub source: u32,
    pub flux: [f32; 3],
    pub travelled: f32,
    pub incoming: [f32; 3],
    pub _pad1: u32,
    pub normal: [f32; 3],
    pub _pad2: u32,
}

/// Mirrors `PhotonBuild` in grid.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct PhotonBuild {
    first: u32,
    end: u32,
    depth: u32,
    _pad: u32,
    offsets: [u32; 12],
}

/// The parameters of a technique that builds a photon map.
pub const PHOTON_PARAMS: [ParamSpec; 3] = [
    ParamSpec {
        name: "photon_paths",
        kind: ParamKind::Int { min: 64, max: 1 << 22 },
        default: "262144",
        doc: "light paths traced for the photon map (each stores a photon at its second and deeper surface hits)",
    },
    ParamSpec {
        name: "photon_depth",
        kind: ParamKind::Int { min: 2, max: MAX_DEPTH as i64 },
        default: "8",
        doc: "surface hits per light path at most: photons carry light that has bounced 1 to photon_depth - 1 times",
    },
    ParamSpec {
        name: "photon_radius",
        kind: ParamKind::Float { min: 1e-4, max: 0.25 },
        default: "0.04",
        doc: "radius of the photon density estimate, as a fraction of the scene's bounding-sphere radius (larger = smoother and more biased at corners)",
    },
];

/// A photon map's settings from `PHOTON_PARAMS` (`None` when the technique has none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonSettings {
    pub paths: u32,
    pub depth: u32,
    pub radius_fraction: f32,
}

impl PhotonSettings {
    pub fn from_params(p: &ParamValues) -> Option<Self> {
        p.get("photon_paths")?;
        Some(PhotonSettings {
            paths: p.int("photon_paths") as u32,
            depth: p.int("photon_depth") as u32,
            radius_fraction: p.float("photon_radius") as f32,
        })
    }
}

/// The defines `photon.wgsl` and `lookup.wgsl` read; a technique without a photon map gets harmless
/// values (its lookups are never called).
pub fn photon_defines(defines: Defines, map: Option<&PhotonMap>) -> Defines {
    let (radius, buckets) = map.map_or((1.0, 1), |m| (m.radius, m.buckets));
    grid_defines(defines, radius, buckets)
}

fn grid_defines(defines: Defines, radius: f32, buckets: u32) -> Defines {
    defines
        .f32("PHOTON_RADIUS", radius)
        .f32("PHOTON_CELL", 2.0 * radius)
        .u32("PHOTON_BUCKETS", buckets)
        .f32("PHOTON_NORMAL_COS", NORMAL_COS)
}

/// The source of a pass that reads the photon map: the photon struct, hashing and the lookup.
pub fn lookup_source() -> String {
    format!("{PHOTON_WGSL}\n{LOOKUP_WGSL}")
}

pub struct PhotonMap {
    light_paths: LightPaths,
    vpls: wgpu::Buffer,
    /// The photons, bucket by bucket.
    pub photons: wgpu::Buffer,
    /// Bucket starts [0, B] then the scatter cursors (B of them).
    pub grid: wgpu::Buffer,
    group: wgpu::BindGroup,
    count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    place: wgpu::ComputePipeline,
    /// The VPL slots that may hold photons start at `first` (read by the tests); `slots` of them.
    #[cfg_attr(not(test), allow(dead_code))]
    first: u32,
    /// Slot of vertex j of path 0 (`u32::MAX` where not stored), as the build reads it.
    #[cfg_attr(not(test), allow(dead_code))]
    vertex_offsets: [u32; 12],
    slots: u32,
    paths: u32,
    buckets: u32,
    /// The lookup radius (world units).
    pub radius: f32,
}

impl PhotonMap {
    pub fn new(setup: &TechniqueSetup, settings: PhotonSettings) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let survival = mean_albedo(setup.scene);
        // Slots for `paths` paths: vertex 0 (on the lights) is not stored; vertex 1 (direct light) is,
        // and not used.
        let expected: f64 = (1..=settings.depth).map(|j| f64::from(survival).powi(j as i32)).sum();
        let slots = (f64::from(settings.paths) * expected).ceil() as u32;
        let layout = set_layout(slots, survival, settings.depth, 0, false);
        let (first, end, paths) = match &layout {
            Some(l) => (l.offset.get(2).copied().flatten().unwrap_or(l.used), l.used, l.paths),
            None => (0, 0, 0),
        };
        const _: () =
            assert!((MAX_DEPTH as usize) < 12, "PhotonBuild.offsets holds every vertex 0..=MAX_DEPTH");
        let mut offsets = [u32::MAX; 12];
        for (o, stored) in offsets.iter_mut().zip(layout.iter().flat_map(|l| &l.offset)) {
            *o = stored.unwrap_or(u32::MAX);
        }
        let vpl_bytes = u64::from(slots.max(1)) * size_of::<GpuVpl>() as u64;
        ctx.check_storage_size("the photon map's light-path vertices (lower photon_paths)", vpl_bytes)?;
        let capacity = (end - first).max(1);
        let photon_bytes = u64::from(capacity) * size_of::<GpuPhoton>() as u64;
        ctx.check_storage_size("the photon map (lower photon_paths)", photon_bytes)?;
        let buckets = (2 * capacity).next_power_of_two().clamp(64, MAX_BUCKETS);
        let vpls = compute::storage_buffer(ctx, "photon map light-path vertices", vpl_bytes);
        let light_paths = LightPaths::new(setup, &vpls, 1, slots, settings.depth, layout.as_ref())?;
        let photons = compute::storage_buffer(ctx, "photon map photons", photon_bytes);
        let keys = compute::storage_buffer(ctx, "photon map keys", u64::from(capacity) * 4);
        let grid = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("photon map grid"),
            size: u64::from(2 * buckets + 1) * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let build = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("photon map build"),
            contents: bytemuck::bytes_of(&PhotonBuild {
                first,
                end,
                depth: settings.depth,
                _pad: 0,
                offsets,
            }),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let layout = compute::layout(
            ctx,
            "photon map build",
            &[
                storage_buffer_entry(0, true),
                storage_buffer_entry(1, false),
                storage_buffer_entry(2, false),
                uniform_entry(3),
                storage_buffer_entry(4, false),
            ],
        );
        let group = compute::bind_group(
            ctx,
            "photon map build",
            &layout,
            &[
                vpls.as_entire_binding(),
                photons.as_entire_binding(),
                grid.as_entire_binding(),
                build.as_entire_binding(),
                keys.as_entire_binding(),
            ],
        );
        let (_, scene_radius) = scene_sphere(setup.scene);
        let radius = settings.radius_fraction * scene_radius;
        let source = format!("{VPL_WGSL}\n{PHOTON_WGSL}\n{GRID_WGSL}");
        let defines = grid_defines(Defines::new(), radius, buckets);
        let layouts = [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout];
        let pipeline = |entry: &str| {
            compute::pipeline(ctx, &format!("photon map {entry}"), &source, defines.clone(), entry, &layouts)
        };
        Ok(PhotonMap {
            light_paths,
            count: pipeline("count_photons")?,
            scan: pipeline("scan_buckets")?,
            scatter: pipeline("scatter_photons")?,
            place: pipeline("place_photons")?,
            vpls,
            photons,
            grid,
            group,
            first,
            vertex_offsets: offsets,
            slots: end - first,
            paths,
            buckets,
            radius,
        })
    }

    /// Traces the light paths and sorts their photons into the grid.
    pub fn build(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        self.light_paths.dispatch(fc, profiler, "photon tracing")?;
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group, &self.group];
        let per_slot = [self.slots.div_ceil(64).max(1), 1, 1];
        profiler.pass(fc.ctx, "photon grid", |encoder| {
            encoder.clear_buffer(&self.grid, 0, None);
            compute::dispatch(encoder, "photon count", &self.count, &groups, per_slot);
            compute::dispatch(encoder, "photon bucket scan", &self.scan, &groups, [1, 1, 1]);
            compute::dispatch(encoder, "photon scatter", &self.scatter, &groups, per_slot);
            compute::dispatch(encoder, "photon placement", &self.place, &groups, per_slot);
        })?;
        Ok(())
    }

    /// Rewrites the light entries (see `LightPaths::update_entries`).
    pub fn update_entries(&mut self, ctx: &GpuContext, gpu_scene: &crate::gpu::GpuScene) -> bool {
        self.light_paths.update_entries(ctx, gpu_scene)
    }

    /// Photons in the map (read back).
    pub fn stored(&self, ctx: &GpuContext) -> Result<u32, RenderError> {
        let bytes = readback::read_buffer(ctx, &self.grid, u64::from(self.buckets) * 4, 4)?;
        Ok(bytemuck::pod_read_unaligned(&bytes[..4]))
    }

    /// The map's counters: paths, photons, radius, bytes.
    pub fn counters(&self, ctx: &GpuContext) -> Result<Vec<(String, f64)>, RenderError> {
        Ok(vec![
            ("photon_paths".into(), f64::from(self.paths)),
            ("photons".into(), f64::from(self.stored(ctx)?)),
            ("photon_radius".into(), f64::from(self.radius)),
            ("photon_grid_buckets".into(), f64::from(self.buckets)),
            ("photon_map_bytes".into(), (self.vpls.size() + self.photons.size() + self.grid.size()) as f64),
        ])
    }
}

#[cfg(test)]
mod tests;
