//! `radiance-cache`: irradiance caching with radiance cache splatting (Gautron et al. 2005; chapter 4
//! of `research/seeds/002`, report §3) for one bounce of diffuse indirect light, with every step on
//! the GPU.
//!
//! Records {position, normal, irradiance, rotational and translational gradients, harmonic mean
//! distance R} persist across frames and views (they do not depend on the camera). Per frame: `direct
//! lighting` (the shared pass); `cache splat` adds every record to the pixels where its weight
//! 1 / (‖p − p_k‖ / R_k + √(1 − n·n_k)) reaches 1/a, in compute over per-tile record sets (the
//! thesis blends one quad per record); then `iterations` rounds of `cache miss detection` (pixels whose
//! summed weight is below a; one pick per candidate tile, compacted by a prefix sum in one workgroup —
//! the thesis does this on the CPU, with a readback), `record computation` (one workgroup per new
//! record: a stratified hemisphere of rays through the shared BVH, shaded with direct light) and a
//! `cache splat` of the new records; finally `cache shading` normalises Σ w E / Σ w and adds the
//! diffuse light to the direct light. The host never waits for the GPU: new records per frame are
//! bounded by a budget (`records_per_frame`, progressive mode) and the rounds that find no miss cost a
//! pass over the pixels.
//!
//! Glossy surfaces (a specular lobe with a roughness in [`glossy_min_roughness`, `glossy_roughness`))
//! get radiance records instead
//! (Křivánek et al. 2005; the thesis's §4.3): the record's cells projected onto HSH of its frame with
//! per-coefficient translational gradients, splatted (with `glossy_accuracy`) as their dot product with
//! the HSH BRDF tables (`brdf_tables`) at the pixel's outgoing direction, which carries the whole BRDF.
//! A record's hemisphere is read in the pixel's frame without rotation: exact between equal normals (a
//! wall), an error of the order of the normals' angle on curved surfaces, which the thesis removes by
//! rotating the coefficients.
//!
//! `radiance-cache` clears the cache when lights, the environment or geometry change.
//! `radiance-cache-temporal` (Gautron et al. 2006; chapter 5 of the thesis, report §4) keeps it over
//! an animation: the record pass also predicts each record one time step ahead (its hits moved with
//! their meshes and shaded under the next frame's lights, with this frame's visibility, reprojected
//! onto the record's hemisphere: [`super::NextPose`] from the renderer), the record's light is interpolated
//! towards the prediction over its life (extrapolated temporal gradients), and it lives a_t / (its
//! predicted relative change) frames, at most `max_lifespan`; then `cache aging` recomputes it where
//! it is if it served a pixel the frame before, or deletes it (the thesis's occlusion query). When the
//! deleted records reach a quarter of the cache, or it could not take a frame's budget of new records,
//! the live ones are moved down over them (`cache compaction`), so a long animation does not fill it.
//! The thesis's interpolated temporal gradients need the records of the future (two passes over a
//! predefined animation) and are not built.
//!
//! `photon-irradiance-cache` (the thesis's chapter 6, report §5) carries every diffuse bounce: a photon
//! map (`photon_map`) is built when the cache is cleared, and each record ray's hit adds the light the
//! photons there reflect towards the record to its direct light (Jensen's final gather, the first bounce
//! by the record's rays, the others by photon density). With `record_irradiance=photon_density` a
//! record takes its light from the photons around it alone, as the thesis's Algorithm 7 does (no
//! record rays; `photon_record.wgsl`). The thesis also places records at photons (Algorithm 6); rtgi
//! keeps its screen-space placement for both, so the view's cache misses decide where records go.

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::scene::{GpuLight, gpu_lights};
use crate::gpu::{GpuContext, Profiler, readback};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::brdf_tables::{BrdfTableShape, BrdfTables, LOOKUP_WGSL};
use super::compute::{self, storage_buffer_entry, storage_texture_entry, texture_entry, uniform_entry};
use super::direct::{DirectLighting, DirectOutput, with_direct_params};
use super::photon_map::{PHOTON_PARAMS, PhotonMap, PhotonSettings, photon_defines};
use super::{FrameContext, FrameNeeds, Measured, SceneChange, Technique, TechniqueInfo, TechniqueSetup};

#[cfg(test)]
mod tests;

const CACHE_WGSL: &str = include_str!("cache.wgsl");
const BINDINGS_WGSL: &str = include_str!("bindings.wgsl");

/// Pixels per edge of the tiles that hold per-record bit sets (`BIN_TILE` in splat.wgsl).
const BIN_TILE: u32 = 16;
/// The largest candidate tile of miss detection (the first round's); later rounds halve it down to
/// MIN_CANDIDATE_TILE.
const FIRST_CANDIDATE_TILE: u32 = 64;
const MIN_CANDIDATE_TILE: u32 = 4;
/// Threads per workgroup of the rectangle and bin passes.
const LINEAR_WORKGROUP: u32 = 64;
/// Hemisphere cells are held in workgroup memory (16 + 4 bytes each) within the 16 KiB every adapter has.
const MAX_HEMISPHERE_SAMPLES: i64 = 768;

/// The parameters of both cache techniques, then `$extra`.
macro_rules! cache_params {
    ($($extra:expr),* $(,)?) => {
        with_direct_params![
    ParamSpec {
        name: "accuracy",
        kind: ParamKind::Float { min: 0.01, max: 1.0 },
        default: "0.3",
        doc: "a: a record reaches where its weight is at least 1/a (zone radius a·R); smaller = more records, less interpolation error (the thesis: 0.1-0.25 offline, 0.5 interactive)",
    },
    ParamSpec {
        name: "hemisphere_samples",
        kind: ParamKind::Int { min: 4, max: MAX_HEMISPHERE_SAMPLES },
        default: "256",
        doc: "rays per record, in M × N stratified cells with N ≈ πM (the thesis's 64×64 raster plane has 4096 texels)",
    },
    ParamSpec {
        name: "records",
        kind: ParamKind::Int { min: 32, max: 1 << 20 },
        default: "16384",
        doc: "cache capacity in records (rounded up to a multiple of 32); the cache stops growing when full",
    },
    ParamSpec {
        name: "records_per_frame",
        kind: ParamKind::Int { min: 1, max: 65535 },
        default: "4096",
        doc: "new records per frame at most (progressive mode: the thesis's interactive walkthrough used 100)",
    },
    ParamSpec {
        name: "iterations",
        kind: ParamKind::Int { min: 0, max: 16 },
        default: "4",
        doc: "rounds of miss detection, record computation and splatting per frame (candidate tiles of 64, 32, 16, 8, then 4 pixels)",
    },
    ParamSpec {
        name: "min_zone",
        kind: ParamKind::Float { min: 0.0, max: 1e4 },
        default: "3",
        doc: "smallest radius a·R of a record's zone, in pixels of the view that created it (R clamped; 0 = no floor)",
    },
    ParamSpec {
        name: "max_zone",
        kind: ParamKind::Float { min: 1.0, max: 1e6 },
        default: "128",
        doc: "largest radius a·R of a record's zone, in pixels of the view that created it",
    },
    ParamSpec {
        name: "gradients",
        kind: ParamKind::Bool,
        default: "true",
        doc: "extrapolate records by their rotational and translational gradients (Ward & Heckbert 1992)",
    },
    ParamSpec {
        name: "glossy_roughness",
        kind: ParamKind::Float { min: 0.0, max: 1.0 },
        default: "0.6",
        doc: "surfaces with a specular lobe (metallic or specular above 0) and a roughness below this get radiance records (HSH incoming radiance, the whole BRDF through HSH tables); others irradiance records (0, or not above glossy_min_roughness = irradiance only)",
    },
    ParamSpec {
        name: "glossy_min_roughness",
        kind: ParamKind::Float { min: 0.0, max: 1.0 },
        default: "0.4",
        doc: "sharper lobes keep irradiance records (their specular indirect light is missing): HSH of the orders built here ring on them (bumpy-glossy's normal-mapped 0.2-0.3 lobes come out speckled)",
    },
    ParamSpec {
        name: "glossy_accuracy",
        kind: ParamKind::Float { min: 0.01, max: 1.0 },
        default: "0.25",
        doc: "a of the radiance records (the thesis's glossy Cornell box: 0.25)",
    },
    ParamSpec {
        name: "hsh_order",
        kind: ParamKind::Int { min: 1, max: crate::hsh::MAX_GPU_ORDER as i64 },
        default: "5",
        doc: "bands of the radiance records' HSH (order² coefficients per colour, each with a 2-D translational gradient: 9·order² floats per record)",
    },
    ParamSpec {
        name: "seed",
        kind: ParamKind::Int { min: 0, max: u32::MAX as i64 },
        default: "0",
        doc: "seed of the hemisphere jitter and of the placement's tie breaks",
    },
            $($extra,)*
        ]
    };
}

const PARAMS: [ParamSpec; 21] = cache_params![];

const TEMPORAL_PARAMS: [ParamSpec; 24] = cache_params![
    ParamSpec {
        name: "temporal_accuracy",
        kind: ParamKind::Float { min: 0.001, max: 10.0 },
        default: "0.05",
        doc: "a_t: a record lives a_t / (its predicted relative change per time step) frames (Gautron et al. 2006 used 0.05)",
    },
    ParamSpec {
        name: "max_lifespan",
        kind: ParamKind::Int { min: 1, max: 100000 },
        default: "20",
        doc: "δt_max: frames a record lives at most, for changes its one-step prediction cannot see (1 = recompute every record every frame; the thesis: 5-20)",
    },
    ParamSpec {
        name: "temporal_gradients",
        kind: ParamKind::Bool,
        default: "true",
        doc: "interpolate each record's light towards its prediction over its life (extrapolated temporal gradients); false = hold the light it was computed with",
    },
];

const PHOTON_CACHE_PARAMS: [ParamSpec; 26] = cache_params![
    PHOTON_PARAMS[0],
    PHOTON_PARAMS[1],
    PHOTON_PARAMS[2],
    ParamSpec {
        name: "record_irradiance",
        kind: ParamKind::Choice(&["final_gather", "photon_density"]),
        default: "final_gather",
        doc: "final_gather: each record traces its hemisphere and adds the photons' light at the hits (first bounce by rays, the rest by photon density); photon_density: the thesis's Algorithm 7, records from the photons around them alone (no rays; area by a corrected convex hull, R from the photons' travelled distances)",
    },
    ParamSpec {
        name: "record_placement",
        kind: ParamKind::Choice(&["view", "photons"]),
        default: "view",
        doc: "view: records where the view's pixels miss the cache; photons: first at the photons the cache misses (the thesis's Algorithm 6, whole-scene and view-independent, within the frame's record budget), then the view fills what they left",
    },
];

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "radiance-cache",
    description: "irradiance caching by radiance cache splatting, records placed and computed on the GPU (one diffuse bounce)",
    params: &PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate,
    create,
};

pub const TEMPORAL_INFO: TechniqueInfo = TechniqueInfo {
    name: "radiance-cache-temporal",
    description: "temporal radiance caching: records kept where they are over an animation, each living as long as its predicted change allows (one diffuse bounce)",
    params: &TEMPORAL_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Temporal,
    validate: validate_temporal,
    create,
};

pub const PHOTON_INFO: TechniqueInfo = TechniqueInfo {
    name: "photon-irradiance-cache",
    description: "irradiance cache whose record rays gather a photon map at their hits: every diffuse bounce",
    params: &PHOTON_CACHE_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate,
    create,
};

/// Hemisphere cells of the temporal record pass: it holds the prediction beside the cells (40 bytes
/// each) in the 16 KiB of workgroup memory every adapter has.
const MAX_TEMPORAL_HEMISPHERE_SAMPLES: i64 = 384;

fn validate(p: &ParamValues) -> Result<(), String> {
    if p.float("min_zone") > p.float("max_zone") {
        return Err(format!(
            "min_zone ({}) is above max_zone ({})",
            p.float("min_zone"),
            p.float("max_zone")
        ));
    }
    Ok(())
}

fn validate_temporal(p: &ParamValues) -> Result<(), String> {
    validate(p)?;
    if p.int("hemisphere_samples") > MAX_TEMPORAL_HEMISPHERE_SAMPLES {
        return Err(format!(
            "hemisphere_samples ({}) is above {MAX_TEMPORAL_HEMISPHERE_SAMPLES}, the most the temporal record pass \
             holds with its prediction",
            p.int("hemisphere_samples")
        ));
    }
    Ok(())
}

/// The temporal technique's settings (`None` for `radiance-cache`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct TemporalSettings {
    accuracy: f32,
    max_lifespan: u32,
    gradients: bool,
}

impl TemporalSettings {
    fn from_params(p: &ParamValues) -> Option<Self> {
        p.get("max_lifespan")?;
        Some(TemporalSettings {
            accuracy: p.float("temporal_accuracy") as f32,
            max_lifespan: p.int("max_lifespan") as u32,
            gradients: p.bool("temporal_gradients"),
        })
    }
}

/// Mirrors `RecordDispatch` in place.wgsl: the indirect dispatch the compaction writes for the record
/// pass (`records`) and for the final gather's record rays (`rays`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
struct RecordDispatch {
    records: [u32; 3],
    _pad0: u32,
    rays: [u32; 3],
    _pad1: u32,
}

/// Mirrors `CacheUniforms` in bindings.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
struct CacheUniforms {
    order: u32,
    step: f32,
    lights_move: u32,
    _pad: u32,
}

/// Mirrors `Record` in cache.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct Record {
    pub position_radius: [f32; 4],
    pub normal: [f32; 4],
    pub irradiance: [f32; 4],
    pub rotation: [[f32; 4]; 3],
    pub translation: [[f32; 4]; 3],
}

impl Record {
    fn position(&self) -> Vec3 {
        Vec3::from_slice(&self.position_radius[..3])
    }

    fn normal(&self) -> Vec3 {
        Vec3::from_slice(&self.normal[..3])
    }

    /// Ward's error term at (p, n), the twin of `record_error`: the record reaches where it is ≤ a.
    pub fn error(&self, p: Vec3, n: Vec3) -> f32 {
        (p - self.position()).length() / self.position_radius[3]
            + (1.0 - n.dot(self.normal())).max(0.0).sqrt()
    }

    /// Frames the record lives (temporal mode), the twin of `record_lifespan`.
    pub fn lifespan_frames(&self) -> u32 {
        let created = self.translation[0][3] as u32;
        let expiry = self.translation[1][3] as u32;
        expiry.wrapping_sub(created) & 0xff_ffff
    }

    /// The twin of `record_weight_of_error`.
    pub fn weight_of_error(e: f32) -> f32 {
        1.0 / e.max(1.0 / MAX_WEIGHT)
    }

    /// Irradiance extrapolated to (p, n) by the gradients, the twin of `record_irradiance`.
    pub fn irradiance_at(&self, p: Vec3, n: Vec3) -> Vec3 {
        let axis = self.normal().cross(n);
        let dp = p - self.position();
        let delta = Vec3::from(std::array::from_fn(|c| {
            axis.dot(Vec3::from_slice(&self.rotation[c][..3]))
                + dp.dot(Vec3::from_slice(&self.translation[c][..3]))
        }));
        (Vec3::from_slice(&self.irradiance[..3]) + delta).max(Vec3::ZERO)
    }
}

/// `MAX_WEIGHT` in cache.wgsl.
const MAX_WEIGHT: f32 = 1e4;

/// Mirrors `CacheState` in cache.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Eq)]
pub struct CacheState {
    pub count: u32,
    pub splat_begin: u32,
    pub iteration: u32,
    pub created_this_frame: u32,
    pub missing_tiles: u32,
    pub unserved_tiles: u32,
    pub created_total: u32,
    pub refreshed_this_frame: u32,
    pub refreshed_total: u32,
    pub deleted_total: u32,
    pub rounds_total: u32,
    pub compacted_total: u32,
    pub photon_round: u32,
    pub photon_placed: u32,
}

/// The passes of photon placement (`record_placement=photons`).
struct PhotonPlacement {
    detect: wgpu::ComputePipeline,
    compact: wgpu::ComputePipeline,
    record: wgpu::ComputePipeline,
    /// The final gather's record rays at the picked photons (`None` without a final gather).
    rays: Option<wgpu::ComputePipeline>,
    end: wgpu::ComputePipeline,
}

/// The stratification of `samples` hemisphere rays: (M, N) cells in θ and φ with N ≈ πM, as Ward &
/// Heckbert recommend, M·N as close to `samples` as that allows.
pub fn hemisphere_cells(samples: u32) -> (u32, u32) {
    let m = ((f64::from(samples) / std::f64::consts::PI).sqrt().round() as u32).max(1);
    let n = ((f64::from(samples) / f64::from(m)).round() as u32).max(1);
    (m, n)
}

/// Per cell (j, c) of the `cells` stratification (index j·N + c, as record.wgsl) and HSH coefficient i
/// of `order`, three numbers (index 3(cell·order² + i)): ∫_cell H_i dω; sin θ_j− cos θ_j− ∫ H_i(θ_j−, φ) dφ
/// over the cell's φ range (its lower θ boundary); ∫ H_i(θ, φ_c−) dθ over its θ range (its lower φ
/// boundary). The record pass weighs cell radiance with them (Gauss–Legendre, 8 nodes per dimension:
/// the cells are narrow and the bases smooth).
pub fn cell_harmonics(cells: (u32, u32), order: usize) -> Vec<f32> {
    use std::f64::consts::PI;
    let (m, n) = (f64::from(cells.0), f64::from(cells.1));
    let count = crate::hsh::count(order);
    let (nodes, weights) = crate::sh::gauss_legendre(8);
    // The rule on [a, b].
    let rule = |a: f64, b: f64| {
        nodes.iter().zip(&weights).map(move |(x, w)| (0.5 * (a + b) + 0.5 * (b - a) * x, 0.5 * (b - a) * w))
    };
    let direction = |theta: f64, phi: f64| {
        glam::DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    };
    let mut out = vec![0.0f32; cells.0 as usize * cells.1 as usize * count * 3];
    for j in 0..cells.0 {
        let theta_minus = (f64::from(j) / m).sqrt().asin();
        let theta_plus = ((f64::from(j) + 1.0) / m).min(1.0).sqrt().asin();
        for c in 0..cells.1 {
            let (phi_minus, phi_plus) = (2.0 * PI * f64::from(c) / n, 2.0 * PI * (f64::from(c) + 1.0) / n);
            let mut sums = vec![[0.0f64; 3]; count];
            for (theta, wt) in rule(theta_minus, theta_plus) {
                for (phi, wp) in rule(phi_minus, phi_plus) {
                    for (s, h) in sums.iter_mut().zip(crate::hsh::hsh(order, direction(theta, phi))) {
                        s[0] += wt * wp * theta.sin() * h;
                    }
                }
                for (s, h) in sums.iter_mut().zip(crate::hsh::hsh(order, direction(theta, phi_minus))) {
                    s[2] += wt * h;
                }
            }
            if j > 0 {
                let arc = theta_minus.sin() * theta_minus.cos();
                for (phi, wp) in rule(phi_minus, phi_plus) {
                    for (s, h) in sums.iter_mut().zip(crate::hsh::hsh(order, direction(theta_minus, phi))) {
                        s[1] += arc * wp * h;
                    }
                }
            }
            let cell = (j * cells.1 + c) as usize;
            for (i, s) in sums.iter().enumerate() {
                for (v, x) in s.iter().enumerate() {
                    out[3 * (cell * count + i) + v] = *x as f32;
                }
            }
        }
    }
    out
}

pub(crate) struct RadianceCache {
    direct: DirectLighting,
    _direct_texture: wgpu::Texture,
    // Σ w E, Σ w per pixel (read back by the tests).
    #[cfg_attr(not(test), allow(dead_code))]
    splat_texture: wgpu::Texture,
    records: wgpu::Buffer,
    /// Radiance records' HSH coefficients and gradients (4 bytes when no surface is glossy).
    radiance: wgpu::Buffer,
    /// The HSH BRDF tables of radiance records (absent when no surface can be glossy).
    brdf_tables: Option<BrdfTables>,
    state: wgpu::Buffer,
    rects: wgpu::Buffer,
    bins: wgpu::Buffer,
    candidates: wgpu::Buffer,
    new_pixels: wgpu::Buffer,
    record_dispatch: wgpu::Buffer,
    cache_group: wgpu::BindGroup,
    dispatch_group: wgpu::BindGroup,
    rects_pipeline: wgpu::ComputePipeline,
    bins_pipeline: wgpu::ComputePipeline,
    splat_pipeline: wgpu::ComputePipeline,
    detect_pipeline: wgpu::ComputePipeline,
    compact_pipeline: wgpu::ComputePipeline,
    record_pipeline: wgpu::ComputePipeline,
    /// `photon-irradiance-cache`'s final gather: the record rays, one invocation each, before the
    /// record pass (`None` where the record pass traces its own rays or has none).
    record_rays_pipeline: Option<wgpu::ComputePipeline>,
    /// Their results (16 bytes when unused).
    _gathered_cells: wgpu::Buffer,
    shade_pipeline: wgpu::ComputePipeline,
    uniforms: wgpu::Buffer,
    uniforms_written: CacheUniforms,
    /// What `radiance-cache-temporal` adds (`None` for `radiance-cache`).
    temporal: Option<Temporal>,
    /// `photon-irradiance-cache`'s photon map, and whether it needs building (after a clear).
    photon_map: Option<PhotonMap>,
    photons_stale: bool,
    /// Records from the photons alone (`record_irradiance=photon_density`).
    photon_records: bool,
    /// Records placed at photons first (`record_placement=photons`).
    photon_placement: Option<PhotonPlacement>,
    max_lifespan: u32,
    capacity: u32,
    cells: (u32, u32),
    iterations: u32,
    bin_tiles: [u32; 2],
    clear_pending: bool,
    /// Frames rendered since the cache was last cleared, and clears of a cache that held records.
    frames_since_clear: u32,
    restarts: u32,
    width: u32,
    height: u32,
}

/// Temporal mode's resources: the next frame's lights and per-mesh motion (written only when they
/// change), the per-frame counters and the passes that age records and refresh the expired ones.
struct Temporal {
    next_lights: wgpu::Buffer,
    next_motion: wgpu::Buffer,
    lights_written: Vec<GpuLight>,
    motion_written: Vec<Mat4>,
    counters: wgpu::Buffer,
    age_pipeline: wgpu::ComputePipeline,
    compaction_pipeline: wgpu::ComputePipeline,
    refresh_dispatch_pipeline: wgpu::ComputePipeline,
    refresh_pipeline: wgpu::ComputePipeline,
}

impl Temporal {
    /// Writes the next frame's pose (the current one, held, when none is known) and returns the
    /// uniforms' step and whether the lights move.
    fn write_next_pose(&mut self, fc: &FrameContext) -> (f32, bool) {
        let (step, motion, lights) = match fc.next {
            Some(next) => (next.time_step, next.mesh_motion.clone(), gpu_lights(&next.lights)),
            None => (0.0, vec![Mat4::IDENTITY; self.motion_written.len()], fc.gpu_scene.lights.clone()),
        };
        if motion != self.motion_written && motion.len() == self.motion_written.len() {
            fc.ctx.queue.write_buffer(&self.next_motion, 0, bytemuck::cast_slice(&motion));
            self.motion_written = motion;
        }
        let bytes = |l: &[GpuLight]| bytemuck::cast_slice::<GpuLight, u8>(l).to_vec();
        if !lights.is_empty()
            && lights.len() == fc.gpu_scene.lights.len()
            && bytes(&lights) != bytes(&self.lights_written)
        {
            fc.ctx.queue.write_buffer(&self.next_lights, 0, bytemuck::cast_slice(&lights));
            self.lights_written = lights;
        }
        let moves = bytes(&self.lights_written) != bytes(&fc.gpu_scene.lights);
        (step, moves)
    }
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    Ok(Box::new(RadianceCache::new(setup)?))
}

/// The defines every pass of the cache shares.
fn cache_defines(
    p: &ParamValues,
    capacity: u32,
    cells: (u32, u32),
    bin_tiles_x: u32,
    photon_map: Option<&PhotonMap>,
) -> Defines {
    let temporal = TemporalSettings::from_params(p);
    photon_defines(brdf_table_shape(p).defines(Defines::new()), photon_map)
        .bool("PHOTONS", photon_map.is_some())
        .bool("PHOTON_RECORDS", photon_records(p))
        .f32("MAX_GATHER_RADII", MAX_GATHER_RADII)
        .u32("PHOTON_CANDIDATES", PHOTON_CANDIDATES)
        .u32("PHOTON_PICKS", PHOTON_PICKS)
        .u32("RAY_THREADS", RAY_THREADS)
        .f32("PLACEMENT_CELL", photon_map.map_or(1.0, |m| PLACEMENT_CELL_RADII * m.radius))
        .f32("ACCURACY", p.float("accuracy") as f32)
        .f32("GLOSSY_ACCURACY", p.float("glossy_accuracy") as f32)
        .f32("GLOSSY_ROUGHNESS", p.float("glossy_roughness") as f32)
        .f32("GLOSSY_MIN_ROUGHNESS", p.float("glossy_min_roughness") as f32)
        .u32("CAPACITY", capacity)
        .u32("BIN_TILE", BIN_TILE)
        .u32("BIN_WORDS", capacity / 32)
        .u32("BIN_TILES_X", bin_tiles_x)
        .u32("FIRST_CANDIDATE_TILE", FIRST_CANDIDATE_TILE)
        .u32("MIN_CANDIDATE_TILE", MIN_CANDIDATE_TILE)
        .u32("RECORDS_PER_FRAME", p.int("records_per_frame") as u32)
        .u32("SAMPLES_THETA", cells.0)
        .u32("SAMPLES_PHI", cells.1)
        .f32("MIN_ZONE_PIXELS", p.float("min_zone") as f32)
        .f32("MAX_ZONE_PIXELS", p.float("max_zone") as f32)
        .bool("GRADIENTS", p.bool("gradients"))
        .u32("SEED", p.int("seed") as u32)
        .bool("TEMPORAL", temporal.is_some())
        .bool("TEMPORAL_GRADIENTS", temporal.is_some_and(|t| t.gradients))
        .f32("TEMPORAL_ACCURACY", temporal.map_or(0.0, |t| t.accuracy))
        .u32("MAX_LIFESPAN", temporal.map_or(1, |t| t.max_lifespan))
        .u32("NEXT_CELLS", if temporal.is_some() { cells.0 * cells.1 } else { 1 })
}

/// Invocations per workgroup of the final gather's record-ray pass.
const RAY_THREADS: u32 = 64;

/// A photon-density record gathers within at most this many photon radii (its query reads up to
/// (MAX_GATHER_RADII + 1)³ grid cells).
const MAX_GATHER_RADII: f32 = 4.0;

/// Photon placement (`record_placement=photons`): photons tested against the cache per round (every
/// stride-th of the map), the world-grid cells a round picks at most one of them in (hashed), the
/// first round's cell edge in photon radii (halving each round) and the rounds.
const PHOTON_CANDIDATES: u32 = 16384;
const PHOTON_PICKS: u32 = 4096;
const PLACEMENT_CELL_RADII: f32 = 16.0;
const PHOTON_PLACEMENT_ROUNDS: u32 = 8;

/// Whether records take their light from the photons around them alone (no record rays).
fn photon_records(p: &ParamValues) -> bool {
    p.get("record_irradiance").is_some() && p.choice("record_irradiance") == "photon_density"
}

/// The record pass: hemisphere cells traced, or gathered from the photon map.
const RECORD_WGSL: &str = concat!(include_str!("record.wgsl"), "\n", include_str!("photon_record.wgsl"));

/// The composed source of a cache pass: the records, the cache's bindings, the BRDF table lookup, then
/// the pass.
fn cache_source(pass: &str) -> String {
    let photons = super::photon_map::lookup_source();
    format!("{CACHE_WGSL}\n{BINDINGS_WGSL}\n{LOOKUP_WGSL}\n{photons}\n{pass}")
}

/// The HSH BRDF tables of radiance records, at env-harmonics' defaults (its measurements show 32² texels,
/// 512 samples and 9 roughnesses are below the orders' own error).
fn brdf_table_shape(p: &ParamValues) -> BrdfTableShape {
    BrdfTableShape {
        hsh: true,
        order: p.int("hsh_order") as u32,
        size: 32,
        roughness_levels: 9,
        samples: 512,
    }
}

/// Whether any surface can get radiance records.
fn glossy_enabled(p: &ParamValues) -> bool {
    p.float("glossy_roughness") > p.float("glossy_min_roughness")
}

impl RadianceCache {
    pub(crate) fn new(setup: &TechniqueSetup) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let p = setup.params;
        let (width, height) = (setup.frame.width, setup.frame.height);
        let capacity = (p.int("records") as u32).next_multiple_of(32);
        let cells = hemisphere_cells(p.int("hemisphere_samples") as u32);
        let bin_tiles = [width.div_ceil(BIN_TILE), height.div_ceil(BIN_TILE)];
        let words = u64::from(capacity / 32);
        let bin_bytes = u64::from(bin_tiles[0] * bin_tiles[1]) * words * 4;
        let temporal = TemporalSettings::from_params(p);
        // Temporal mode keeps each record's prediction beside it (a second plane).
        let planes = if temporal.is_some() { 2 } else { 1 };
        let record_bytes = planes * u64::from(capacity) * size_of::<Record>() as u64;
        ctx.check_storage_size("the radiance cache's records", record_bytes)?;
        let glossy = glossy_enabled(p);
        let shape = brdf_table_shape(p);
        let radiance_bytes =
            if glossy { planes * u64::from(capacity) * u64::from(shape.coefficients()) * 9 * 4 } else { 4 };
        ctx.check_storage_size(
            "the radiance cache's HSH radiance records (lower records or hsh_order)",
            radiance_bytes,
        )?;
        ctx.check_storage_size("the radiance cache's per-tile record sets", bin_bytes)?;
        let per_frame = (p.int("records_per_frame") as u32).min(capacity);
        let candidate_count =
            u64::from(width.div_ceil(MIN_CANDIDATE_TILE) * height.div_ceil(MIN_CANDIDATE_TILE))
                .max(u64::from(PHOTON_PICKS));

        let device = &ctx.device;
        let storage = |label: &str, size: u64| compute::storage_buffer(ctx, label, size);
        let records = storage("radiance cache records", record_bytes);
        let radiance = storage("radiance cache hsh radiance", radiance_bytes);
        let brdf_tables = glossy.then(|| BrdfTables::new(setup, shape, "radiance-cache")).transpose()?;
        let no_tables = storage("radiance cache no brdf tables", 4);
        let cell_harmonics = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("radiance cache cell harmonics"),
            contents: bytemuck::cast_slice(&if glossy {
                cell_harmonics(cells, shape.order as usize)
            } else {
                vec![0.0f32]
            }),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let uniforms_written = CacheUniforms { order: shape.order, step: 0.0, lights_move: 0, _pad: 0 };
        let uniforms = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("radiance cache uniforms"),
            contents: bytemuck::bytes_of(&uniforms_written),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        // Temporal mode's buffers (4 bytes each otherwise: the passes declare them either way).
        let temporal_bytes = |bytes: u64| if temporal.is_some() { bytes.max(4) } else { 4 };
        let record_used = storage("radiance cache record use", temporal_bytes(u64::from(capacity) * 4));
        let scene_lights = &setup.gpu_scene.lights;
        let next_lights =
            storage("radiance cache next lights", (scene_lights.len().max(1) * size_of::<GpuLight>()) as u64);
        if temporal.is_some() && !scene_lights.is_empty() {
            ctx.queue.write_buffer(&next_lights, 0, bytemuck::cast_slice(scene_lights));
        }
        let mesh_count = setup.gpu_scene.mesh_ranges.len();
        let next_motion = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("radiance cache next motion"),
            contents: bytemuck::cast_slice(&vec![Mat4::IDENTITY; mesh_count.max(1)]),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let temporal_counters = storage("radiance cache temporal counters", 8);
        let mesh_starts = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("radiance cache mesh starts"),
            contents: bytemuck::cast_slice(&crate::frame::mesh_starts(&setup.gpu_scene.mesh_ranges)),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let state = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("radiance cache state"),
            contents: bytemuck::bytes_of(&CacheState::zeroed()),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        });
        let rects = storage("radiance cache rectangles", u64::from(capacity) * 16);
        let bins = storage("radiance cache record sets", bin_bytes);
        let candidates = storage("radiance cache candidates", candidate_count * 4);
        let new_pixels = storage("radiance cache new pixels", u64::from(per_frame) * 4);
        let record_dispatch = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("radiance cache record dispatch"),
            size: size_of::<RecordDispatch>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
            mapped_at_creation: false,
        });
        let splat_texture =
            compute::storage_texture(ctx, "radiance cache splat", width, height, OUTPUT_FORMAT);
        let direct_texture =
            compute::storage_texture(ctx, "radiance cache direct", width, height, OUTPUT_FORMAT);
        let direct = DirectLighting::new(setup, &direct_texture, DirectOutput::Accumulate)?;
        let photon_map = PhotonSettings::from_params(p).map(|s| PhotonMap::new(setup, s)).transpose()?;
        let no_photons =
            storage("radiance cache no photons", size_of::<super::photon_map::GpuPhoton>() as u64);
        let no_photon_grid = storage("radiance cache no photon grid", 8);
        // The final gather's record rays, a round's worth (at most the frame's record budget).
        let final_gather = photon_map.is_some() && !photon_records(p);
        let gathered_bytes =
            if final_gather { u64::from(per_frame) * u64::from(cells.0 * cells.1) * 16 } else { 16 };
        ctx.check_storage_size(
            "the photon cache's final-gather rays (lower records_per_frame or hemisphere_samples)",
            gathered_bytes,
        )?;
        let gathered_cells = storage("radiance cache gathered cells", gathered_bytes);

        let rw = wgpu::StorageTextureAccess::ReadWrite;
        let cache_layout = compute::layout(
            ctx,
            "radiance cache",
            &[
                storage_buffer_entry(0, false),
                storage_buffer_entry(1, false),
                storage_buffer_entry(2, false),
                storage_buffer_entry(3, false),
                storage_buffer_entry(4, false),
                storage_buffer_entry(5, false),
                storage_texture_entry(6, OUTPUT_FORMAT, rw),
                texture_entry(7, wgpu::TextureSampleType::Float { filterable: false }),
                storage_texture_entry(8, OUTPUT_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
                storage_buffer_entry(9, false),
                uniform_entry(10),
                storage_buffer_entry(11, true),
                storage_buffer_entry(12, true),
                storage_buffer_entry(13, false),
                storage_buffer_entry(14, true),
                storage_buffer_entry(15, true),
                storage_buffer_entry(16, false),
                storage_buffer_entry(17, true),
                storage_buffer_entry(18, true),
                storage_buffer_entry(19, true),
                storage_buffer_entry(20, false),
            ],
        );
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (splat_view, direct_view, output_view) =
            (view(&splat_texture), view(&direct_texture), view(setup.output));
        let cache_group = compute::bind_group(
            ctx,
            "radiance cache",
            &cache_layout,
            &[
                records.as_entire_binding(),
                state.as_entire_binding(),
                rects.as_entire_binding(),
                bins.as_entire_binding(),
                candidates.as_entire_binding(),
                new_pixels.as_entire_binding(),
                wgpu::BindingResource::TextureView(&splat_view),
                wgpu::BindingResource::TextureView(&direct_view),
                wgpu::BindingResource::TextureView(&output_view),
                radiance.as_entire_binding(),
                uniforms.as_entire_binding(),
                brdf_tables.as_ref().map_or(&no_tables, |t| &t.buffer).as_entire_binding(),
                cell_harmonics.as_entire_binding(),
                record_used.as_entire_binding(),
                next_lights.as_entire_binding(),
                next_motion.as_entire_binding(),
                temporal_counters.as_entire_binding(),
                mesh_starts.as_entire_binding(),
                photon_map.as_ref().map_or(&no_photons, |m| &m.photons).as_entire_binding(),
                photon_map.as_ref().map_or(&no_photon_grid, |m| &m.grid).as_entire_binding(),
                gathered_cells.as_entire_binding(),
            ],
        );
        let dispatch_layout =
            compute::layout(ctx, "radiance cache dispatch", &[storage_buffer_entry(0, false)]);
        let dispatch_group = compute::bind_group(
            ctx,
            "radiance cache dispatch",
            &dispatch_layout,
            &[record_dispatch.as_entire_binding()],
        );

        let defines = cache_defines(p, capacity, cells, bin_tiles[0], photon_map.as_ref());
        let groups = [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &cache_layout];
        let pipeline = |name: &str, pass: &str, entry: &str, layouts: &[&wgpu::BindGroupLayout]| {
            compute::pipeline(
                ctx,
                name,
                &cache_source(pass),
                setup.gpu_scene.bvh_defines(defines.clone()),
                entry,
                layouts,
            )
        };
        let splat = include_str!("splat.wgsl");
        let place = include_str!("place.wgsl");
        let rects_pipeline = pipeline("radiance cache rectangles", splat, "splat_rects", &groups)?;
        let bins_pipeline = pipeline("radiance cache record sets", splat, "splat_bins", &groups)?;
        let splat_pipeline = pipeline("radiance cache splat", splat, "splat", &groups)?;
        let detect_pipeline = pipeline("radiance cache miss detection", place, "detect_misses", &groups)?;
        let record_pipeline = pipeline("radiance cache records", RECORD_WGSL, "compute_record", &groups)?;
        let rays_pipeline = |name: &str, entry: &str| {
            final_gather.then(|| pipeline(name, RECORD_WGSL, entry, &groups)).transpose()
        };
        let record_rays_pipeline = rays_pipeline("radiance cache record rays", "trace_record_rays")?;
        let shade_pipeline =
            pipeline("radiance cache shading", include_str!("shade.wgsl"), "shade", &groups)?;
        // The compaction (and temporal mode's refresh dispatch) alone write the record pass's dispatch
        // arguments (group 3).
        let with_dispatch = [groups[0], groups[1], groups[2], &dispatch_layout];
        let compact_pipeline = pipeline("radiance cache compaction", place, "compact", &with_dispatch)?;
        let photon_placement = if p.get("record_placement").is_some()
            && p.choice("record_placement") == "photons"
        {
            Some(PhotonPlacement {
                detect: pipeline("photon placement misses", place, "detect_photon_misses", &groups)?,
                compact: pipeline("photon placement compaction", place, "compact_photons", &with_dispatch)?,
                record: pipeline("photon placement records", RECORD_WGSL, "compute_photon_record", &groups)?,
                rays: rays_pipeline("photon placement record rays", "trace_photon_record_rays")?,
                end: pipeline("photon placement end", place, "end_photon_placement", &groups)?,
            })
        } else {
            None
        };
        let temporal = match temporal {
            Some(_) => {
                let aging = include_str!("temporal.wgsl");
                Some(Temporal {
                    next_lights,
                    next_motion,
                    lights_written: setup.gpu_scene.lights.clone(),
                    motion_written: vec![Mat4::IDENTITY; mesh_count],
                    counters: temporal_counters,
                    age_pipeline: pipeline("radiance cache aging", aging, "age_records", &groups)?,
                    compaction_pipeline: pipeline(
                        "radiance cache compaction of deleted records",
                        aging,
                        "compact_records",
                        &groups,
                    )?,
                    refresh_dispatch_pipeline: pipeline(
                        "radiance cache refresh dispatch",
                        aging,
                        "refresh_dispatch",
                        &with_dispatch,
                    )?,
                    refresh_pipeline: pipeline(
                        "radiance cache refresh",
                        RECORD_WGSL,
                        "refresh_record",
                        &groups,
                    )?,
                })
            }
            None => None,
        };

        Ok(RadianceCache {
            direct,
            _direct_texture: direct_texture,
            splat_texture,
            records,
            radiance,
            brdf_tables,
            state,
            rects,
            bins,
            candidates,
            new_pixels,
            record_dispatch,
            cache_group,
            dispatch_group,
            rects_pipeline,
            bins_pipeline,
            splat_pipeline,
            detect_pipeline,
            compact_pipeline,
            record_pipeline,
            record_rays_pipeline,
            _gathered_cells: gathered_cells,
            shade_pipeline,
            uniforms,
            uniforms_written,
            max_lifespan: TemporalSettings::from_params(p).map_or(1, |t| t.max_lifespan),
            temporal,
            photon_map,
            photons_stale: true,
            photon_records: photon_records(p),
            photon_placement,
            capacity,
            cells,
            iterations: p.int("iterations") as u32,
            bin_tiles,
            clear_pending: false,
            frames_since_clear: 0,
            restarts: 0,
            width,
            height,
        })
    }

    fn groups<'a>(&'a self, fc: &'a FrameContext) -> [&'a wgpu::BindGroup; 3] {
        [&fc.gpu_scene.bind_group, &fc.frame.bind_group, &self.cache_group]
    }

    /// Adds the records [splat_begin, count) to the splat buffer (rebuilding it when splat_begin is 0).
    fn splat(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let groups = self.groups(fc);
        profiler.pass(fc.ctx, "cache splat", |encoder| {
            let linear = self.capacity.div_ceil(LINEAR_WORKGROUP);
            compute::dispatch(encoder, "cache rectangles", &self.rects_pipeline, &groups, [linear, 1, 1]);
            let words = (self.capacity / 32).div_ceil(LINEAR_WORKGROUP);
            compute::dispatch(
                encoder,
                "cache record sets",
                &self.bins_pipeline,
                &groups,
                [words, self.bin_tiles[0], self.bin_tiles[1]],
            );
            compute::dispatch_pixels(
                encoder,
                "cache splat",
                &self.splat_pipeline,
                &groups,
                self.width,
                self.height,
            );
        })?;
        Ok(())
    }

    /// The thesis's Algorithm 6 (`record_placement=photons`), once after the photon map is built: rounds
    /// of photon misses → picks → new records, then the frame's splat takes them all.
    fn place_at_photons(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let Some(placement) = &self.photon_placement else {
            return Ok(());
        };
        let groups = self.groups(fc);
        let with_dispatch = [groups[0], groups[1], groups[2], &self.dispatch_group];
        for _ in 0..PHOTON_PLACEMENT_ROUNDS {
            profiler.pass(fc.ctx, "photon placement", |encoder| {
                encoder.clear_buffer(&self.candidates, 0, None);
                let candidates = PHOTON_CANDIDATES.div_ceil(64);
                compute::dispatch(encoder, "photon misses", &placement.detect, &groups, [candidates, 1, 1]);
                compute::dispatch(encoder, "photon picks", &placement.compact, &with_dispatch, [1, 1, 1]);
            })?;
            self.compute_picked_records(fc, profiler, placement.rays.as_ref(), &placement.record)?;
        }
        profiler.pass(fc.ctx, "photon placement", |encoder| {
            compute::dispatch(encoder, "photon placement end", &placement.end, &groups, [1, 1, 1]);
        })?;
        Ok(())
    }

    /// One round of placement: misses → picks → new records → their splats.
    fn place_records(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let groups = self.groups(fc);
        profiler.pass(fc.ctx, "cache miss detection", |encoder| {
            encoder.clear_buffer(&self.candidates, 0, None);
            compute::dispatch_pixels(
                encoder,
                "cache miss detection",
                &self.detect_pipeline,
                &groups,
                self.width,
                self.height,
            );
            compute::dispatch(
                encoder,
                "cache compaction",
                &self.compact_pipeline,
                &[groups[0], groups[1], groups[2], &self.dispatch_group],
                [1, 1, 1],
            );
        })?;
        self.compute_picked_records(fc, profiler, self.record_rays_pipeline.as_ref(), &self.record_pipeline)?;
        self.splat(fc, profiler)
    }

    /// The record pass over the round's picks (`pipeline`: at pixels or at photons), as many workgroups
    /// as the compaction wrote into the record dispatch, after the final gather's record rays (`rays`).
    fn compute_picked_records(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        rays: Option<&wgpu::ComputePipeline>,
        pipeline: &wgpu::ComputePipeline,
    ) -> Result<(), RenderError> {
        let groups = self.groups(fc);
        profiler.pass(fc.ctx, "record computation", |encoder| {
            if let Some(rays) = rays {
                let rays_offset = std::mem::offset_of!(RecordDispatch, rays) as u64;
                crate::gpu::dispatch::dispatch_indirect(
                    encoder,
                    "record rays",
                    rays,
                    &groups,
                    &self.record_dispatch,
                    rays_offset,
                );
            }
            crate::gpu::dispatch::dispatch_indirect(
                encoder,
                "record computation",
                pipeline,
                &groups,
                &self.record_dispatch,
                0,
            );
        })?;
        Ok(())
    }

    /// Temporal mode, before the frame's splat: the next frame's pose for the record pass, then
    /// expired records refreshed in place (or deleted when nothing used them).
    fn age_and_refresh(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let Some(temporal) = self.temporal.as_mut() else {
            return Ok(());
        };
        let (step, lights_move) = temporal.write_next_pose(fc);
        let uniforms = CacheUniforms { step, lights_move: u32::from(lights_move), ..self.uniforms_written };
        if uniforms != self.uniforms_written {
            fc.ctx.queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&uniforms));
            self.uniforms_written = uniforms;
        }
        let temporal = self.temporal.as_ref().expect("temporal mode");
        let groups = self.groups(fc);
        // Before aging: the refresh list it writes holds record indices.
        profiler.pass(fc.ctx, "cache compaction", |encoder| {
            compute::dispatch(encoder, "cache compaction", &temporal.compaction_pipeline, &groups, [1, 1, 1]);
        })?;
        profiler.pass(fc.ctx, "cache aging", |encoder| {
            encoder.clear_buffer(&temporal.counters, 0, None);
            compute::dispatch(
                encoder,
                "cache aging",
                &temporal.age_pipeline,
                &groups,
                [self.capacity.div_ceil(LINEAR_WORKGROUP), 1, 1],
            );
            compute::dispatch(
                encoder,
                "cache refresh dispatch",
                &temporal.refresh_dispatch_pipeline,
                &[groups[0], groups[1], groups[2], &self.dispatch_group],
                [1, 1, 1],
            );
        })?;
        profiler.pass(fc.ctx, "record refresh", |encoder| {
            crate::gpu::dispatch::dispatch_indirect(
                encoder,
                "record refresh",
                &temporal.refresh_pipeline,
                &groups,
                &self.record_dispatch,
                0,
            );
        })?;
        Ok(())
    }

    /// The cache's counters, read back.
    pub(crate) fn read_state(&self, ctx: &GpuContext) -> Result<CacheState, RenderError> {
        let bytes = readback::read_buffer(ctx, &self.state, 0, size_of::<CacheState>() as u64)?;
        Ok(*bytemuck::from_bytes(&bytes))
    }

    /// Temporal mode: the predictions (plane 1) of the first `count` records, read back.
    #[cfg(test)]
    pub(crate) fn read_predictions(&self, ctx: &GpuContext, count: u32) -> Result<Vec<Record>, RenderError> {
        let size = size_of::<Record>() as u64;
        let bytes = readback::read_buffer(
            ctx,
            &self.records,
            u64::from(self.capacity) * size,
            u64::from(count) * size,
        )?;
        Ok(bytemuck::cast_slice(&bytes).to_vec())
    }

    /// The first `count` records, read back.
    pub(crate) fn read_records(&self, ctx: &GpuContext, count: u32) -> Result<Vec<Record>, RenderError> {
        if count == 0 {
            return Ok(Vec::new());
        }
        let bytes =
            readback::read_buffer(ctx, &self.records, 0, u64::from(count) * size_of::<Record>() as u64)?;
        Ok(bytemuck::cast_slice(&bytes).to_vec())
    }
}

impl Technique for RadianceCache {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        // A temporal cache whose records were interpolated towards a pose that did not come starts
        // again, as the per-frame cache does on every change.
        if self.temporal.is_some() && !fc.prediction_held {
            self.clear_pending = true;
        }
        // Per frame: splat from the first record, first round, nothing created yet; the count and the
        // totals stay unless the cache is cleared.
        let fresh = CacheState::zeroed();
        let bytes = bytemuck::bytes_of(&fresh);
        let per_frame =
            std::mem::offset_of!(CacheState, splat_begin)..std::mem::offset_of!(CacheState, missing_tiles);
        let written = if std::mem::take(&mut self.clear_pending) {
            if self.frames_since_clear > 0 {
                self.restarts += 1;
            }
            self.frames_since_clear = 0;
            0..bytes.len()
        } else {
            per_frame
        };
        self.frames_since_clear += 1;
        fc.ctx.queue.write_buffer(&self.state, written.start as u64, &bytes[written]);
        if let Some(tables) = self.brdf_tables.as_mut() {
            tables.build_once(fc, profiler)?;
        }
        self.direct.render(fc, profiler)?;
        if let Some(map) = &self.photon_map
            && std::mem::take(&mut self.photons_stale)
        {
            map.build(fc, profiler)?;
            self.place_at_photons(fc, profiler)?;
        }
        if self.temporal.is_some() {
            self.age_and_refresh(fc, profiler)?;
        }
        self.splat(fc, profiler)?;
        for _ in 0..self.iterations {
            self.place_records(fc, profiler)?;
        }
        compute::frame_pass(fc, profiler, "cache shading", &self.shade_pipeline, &self.cache_group)
    }

    fn counters(
        &mut self,
        ctx: &GpuContext,
        measured: &Measured,
    ) -> Result<BTreeMap<String, f64>, RenderError> {
        let s = self.read_state(ctx)?;
        let pixels = f64::from(self.width * self.height);
        let mut c = BTreeMap::from([
            ("records".to_string(), f64::from(s.count)),
            ("record_capacity".to_string(), f64::from(self.capacity)),
            (
                "records_created_last_frame".to_string(),
                f64::from(s.created_this_frame - s.refreshed_this_frame),
            ),
            ("missing_tiles_last_round".to_string(), f64::from(s.missing_tiles)),
            ("unserved_tiles_last_round".to_string(), f64::from(s.unserved_tiles)),
            ("hemisphere_rays_per_record".to_string(), f64::from(self.cells.0 * self.cells.1)),
            ("record_bytes".to_string(), self.records.size() as f64),
            ("radiance_record_bytes".to_string(), self.radiance.size() as f64),
            (
                "brdf_table_bytes".to_string(),
                self.brdf_tables.as_ref().map_or(0.0, |t| t.shape.bytes() as f64),
            ),
            ("record_set_bytes".to_string(), (self.bins.size() + self.rects.size()) as f64),
            ("candidate_bytes".to_string(), (self.candidates.size() + self.new_pixels.size()) as f64),
            ("splat_bytes_per_pixel".to_string(), 16.0),
            ("direct_bytes_per_pixel".to_string(), 16.0),
            ("output_bytes_per_pixel".to_string(), 16.0),
            ("pixels".to_string(), pixels),
            ("cache_restarts".to_string(), f64::from(self.restarts)),
        ]);
        if let Some(map) = &self.photon_map {
            c.extend(map.counters(ctx)?);
        }
        if self.photon_placement.is_some() {
            c.insert("records_placed_at_photons".into(), f64::from(s.photon_placed));
        }
        if let Some(ms) = measured.pass_mean_ms("record computation") {
            c.insert("record_computation_ms_per_round".into(), ms);
        }
        if self.temporal.is_some() {
            c.insert("records_refreshed_last_frame".into(), f64::from(s.refreshed_this_frame));
            c.insert("records_refreshed".into(), f64::from(s.refreshed_total));
            c.insert("records_created".into(), f64::from(s.created_total));
            c.insert("records_deleted".into(), f64::from(s.deleted_total));
            c.insert("records_live".into(), f64::from(s.count - (s.deleted_total - s.compacted_total)));
            c.insert("records_compacted".into(), f64::from(s.compacted_total));
            let records = self.read_records(ctx, s.count)?;
            let live: Vec<&Record> = records.iter().filter(|r| r.normal[3] > -0.5).collect();
            if !live.is_empty() {
                let n = live.len() as f64;
                let lifespans = live.iter().map(|r| f64::from(r.lifespan_frames()));
                c.insert("mean_record_lifespan_frames".into(), lifespans.sum::<f64>() / n);
                let full = live.iter().filter(|r| r.lifespan_frames() >= self.max_lifespan).count();
                c.insert("records_at_max_lifespan".into(), full as f64);
            }
        }
        Ok(c)
    }

    // Records hold light that no longer holds after any change: `radiance-cache` clears the cache
    // and refills it; the temporal cache keeps its records over a change it predicted (they age out
    // by their lifespans) and clears them after one it did not (`FrameContext::prediction_held`).
    fn scene_changed(
        &mut self,
        ctx: &GpuContext,
        gpu_scene: &crate::gpu::GpuScene,
        _: SceneChange,
    ) -> Result<bool, RenderError> {
        self.clear_pending = self.temporal.is_none();
        self.photons_stale = true;
        Ok(self.photon_map.as_mut().is_none_or(|m| m.update_entries(ctx, gpu_scene)))
    }

    fn predicts_next_frame(&self) -> bool {
        self.temporal.is_some()
    }

    fn warnings(&self) -> Vec<String> {
        if self.photon_map.is_some() {
            let density = if self.photon_records {
                format!(
                    "records take their light from the photons within a·R (at most {MAX_GATHER_RADII} photon radii) over their convex hull; cells no photon reached are dark"
                )
            } else {
                "photon density at the record rays' hits is estimated over discs (biased low in corners)"
                    .into()
            };
            return vec![format!(
                "photon-irradiance-cache: specular lobes outside [glossy_min_roughness, glossy_roughness), and dielectric specular layers of diffuse-classed surfaces, get no indirect light; {density}"
            )];
        }
        vec!["radiance-cache: records carry one bounce; specular lobes outside [glossy_min_roughness, glossy_roughness), and dielectric specular layers of diffuse-classed surfaces, get no indirect light".into()]
    }
}
