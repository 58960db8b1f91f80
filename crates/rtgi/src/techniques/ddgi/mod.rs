//! `ddgi`: dynamic diffuse global illumination with ray-traced irradiance probes (Majercik et al.
//! 2019, the fourth article of `research/seeds/003`; its errata are in the report's §4 and §6).
//!
//! A grid of probes over the scene's bounds, or centred on the camera and scrolling with it in whole
//! cells (`volume=camera`). Per frame: `probe state` resets the probes of cells that entered the
//! volume and relocates and classifies the probes as RTXGI does (out of geometry, away from nearby
//! surfaces; off where inside geometry or with no surface within a cell); `probe trace` casts `rays`
//! rays from every active probe of this frame's update (all, or a rotating `probes_per_frame` subset) on
//! a randomly rotated spherical Fibonacci pattern and shades their hits like camera pixels (direct
//! light through shadow rays + the previous frame's probes, so bounces add up over frames); `probe
//! irradiance update` and `probe distance update` blend them into octahedral atlases with hysteresis;
//! `direct lighting` is the shared direct pass; `probe sampling` adds the probes' diffuse light to
//! every pixel through the 8-probe cage with the paper's visibility weights, and the specular light of
//! glossy surfaces through one traced reflection ray (`reflection_ray`).
//!
//! Where the light of emitters and the environment goes is a parameter: with `emitters=direct` (the
//! default) camera pixels and probe-ray hits sample them with shadow rays and the probes carry only
//! light that bounced at least once, so area lights keep sharp shadows; with `emitters=probes` (the
//! paper's way for area lights and skies) the probes carry them too and only analytic lights are direct.
//!
//! The probes are world-space history: a camera cut does not clear them (nothing they hold depends on
//! the view); they are created with the technique and follow moving lights, objects and skies through
//! the hysteresis blend.

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Quat, Vec2, Vec3};
use wgpu::util::DeviceExt;

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::features::{Need, has};
use crate::gpu::scene::{oct_decode, oct_encode};
use crate::gpu::{GpuContext, Profiler, readback};
use crate::params::{GridCounts, ParamKind, ParamSpec};
use crate::scene::Aabb;
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute::{self, storage_buffer_entry, storage_texture_entry, texture_entry, uniform_entry};
use super::direct::{DirectLighting, DirectOutput, LightSamples, with_direct_params};
use super::{FrameContext, FrameNeeds, Measured, SceneChange, Technique, TechniqueInfo, TechniqueSetup};

#[cfg(test)]
mod tests;

const VOLUME_WGSL: &str = include_str!("volume.wgsl");
const QUERY_WGSL: &str = include_str!("query.wgsl");

/// Threads per workgroup of the probe-ray pass (`WORKGROUP` in trace.wgsl).
const TRACE_WORKGROUP: u32 = 64;
/// Workgroup edge of the atlas update passes (`@workgroup_size(8, 8)` in update.wgsl).
const UPDATE_TILE: u32 = 8;

/// Irradiance atlas formats (`format`); the paper compares R11G11B10F and RGB10A2 with 16-bit floats.
const IRRADIANCE_FORMATS: &[&str] = &["rgba16float", "rgba32float", "rg11b10ufloat", "rgb10a2unorm"];

/// Rays per probe of the relocation and classification pass (`CLASSIFY_RAYS` in state.wgsl; RTXGI's
/// fixed rays are 32 too).
const CLASSIFY_RAYS: u32 = 32;
/// Frames the probe state pass relocates and classifies after the probes were created, the geometry
/// moved or the volume scrolled. One frame resolves what its rays see (out of geometry, away from the
/// nearest surface or back to the lattice point); a move can bring another surface into view, so a few
/// frames let such chains settle (measured on cornell and atrium: no probe changes after the 9th frame).
const SETTLE_FRAMES: u32 = 16;
/// A probe stands inside geometry when more than this fraction of its classification rays hit back faces.
const BACKFACE_THRESHOLD: f32 = 0.25;
/// How close to a surface relocation lets a probe stand, as a fraction of the smallest probe spacing.
const MIN_SURFACE_DISTANCE: f32 = 0.1;

const DDGI_PARAMS: [ParamSpec; 29] = with_direct_params![
    ParamSpec {
        name: "probe_count",
        kind: ParamKind::GridCounts { min: 2, max: 64 },
        default: "8",
        doc: "probes along the scene's longest axis, the other axes getting about the same spacing (at least 2 probes), or XxYxZ probes exactly (e.g. 32x8x32); all centred in their cells of the scene's bounds",
    },
    ParamSpec {
        name: "volume",
        kind: ParamKind::Choice(&["scene", "camera"]),
        default: "scene",
        doc: "where the probes stand: over the scene's bounds (scene), or a volume of the same probe counts centred on the camera that scrolls with it in whole cells, reusing the probes of the cells it leaves for those it enters (camera, for scenes larger than one volume)",
    },
    ParamSpec {
        name: "probe_spacing",
        kind: ParamKind::Float { min: 0.0, max: 1.0e6 },
        default: "0",
        doc: "with volume=camera, the distance between probes in world units (0: the spacing of the scene's grid)",
    },
    ParamSpec {
        name: "probes_per_frame",
        kind: ParamKind::Int { min: 0, max: 262_144 },
        default: "0",
        doc: "probes traced and updated per frame, a rotating subset (0: every probe every frame)",
    },
    ParamSpec {
        name: "relocation",
        kind: ParamKind::Bool,
        default: "true",
        doc: "move probes out of geometry and away from nearby surfaces, within relocation_limit of their lattice points",
    },
    ParamSpec {
        name: "relocation_limit",
        kind: ParamKind::Float { min: 0.0, max: 0.5 },
        default: "0.45",
        doc: "farthest a probe is relocated along each axis, as a fraction of the probe spacing",
    },
    ParamSpec {
        name: "classification",
        kind: ParamKind::Bool,
        default: "true",
        doc: "switch off probes inside geometry or with no surface within one spacing (not traced, updated or interpolated)",
    },
    ParamSpec {
        name: "rays",
        kind: ParamKind::Int { min: 1, max: 1024 },
        default: "64",
        doc: "rays per probe and frame (the paper's largest scenes use 64)",
    },
    ParamSpec {
        name: "hysteresis",
        kind: ParamKind::Float { min: 0.0, max: 0.999 },
        default: "0.95",
        doc: "weight α of the previous value when a frame's rays are blended in, E = α·E_prev + (1 − α)·E_new (the paper uses 0.85–0.98)",
    },
    ParamSpec {
        name: "irradiance_texels",
        kind: ParamKind::Int { min: 2, max: 32 },
        default: "8",
        doc: "edge of a probe's octahedral irradiance tile, without its one-texel gutter",
    },
    ParamSpec {
        name: "distance_texels",
        kind: ParamKind::Int { min: 2, max: 64 },
        default: "16",
        doc: "edge of a probe's octahedral distance-moment tile, without its one-texel gutter",
    },
    ParamSpec {
        name: "distance_exponent",
        kind: ParamKind::Float { min: 1.0, max: 1000.0 },
        default: "50",
        doc: "power of the cosine lobe that blends hit distances into a distance texel (sharper = less blurred visibility)",
    },
    ParamSpec {
        name: "format",
        kind: ParamKind::Choice(IRRADIANCE_FORMATS),
        default: "rgba16float",
        doc: "storage format of the irradiance atlas (the distance atlas is rg16float where the adapter can write it, else rgba16float)",
    },
    ParamSpec {
        name: "emitters",
        kind: ParamKind::Choice(&["direct", "probes"]),
        default: "direct",
        doc: "light of emissive surfaces and the environment: sampled with shadow rays at pixels and probe hits, the probes carrying only bounced light (direct), or carried by the probes (probes, as the paper does for area lights)",
    },
    ParamSpec {
        name: "reflection_ray",
        kind: ParamKind::Bool,
        default: "true",
        doc: "trace one GGX-sampled reflection ray per pixel and frame for the specular light of surfaces smoother than reflection_roughness (shaded at its hit with direct light and the probes)",
    },
    ParamSpec {
        name: "reflection_roughness",
        kind: ParamKind::Float { min: 0.0, max: 1.0 },
        default: "0.6",
        doc: "surfaces below this roughness get the reflection ray; rougher ones get no indirect specular light",
    },
    ParamSpec {
        name: "backface_weight",
        kind: ParamKind::Bool,
        default: "true",
        doc: "weight probes by a wrapped cosine of the direction to them (soft backface test)",
    },
    ParamSpec {
        name: "chebyshev",
        kind: ParamKind::Bool,
        default: "true",
        doc: "weight probes by the Chebyshev bound of their distance moments (visibility)",
    },
    ParamSpec {
        name: "low_weight_crush",
        kind: ParamKind::Bool,
        default: "true",
        doc: "crush probe weights below 0.2 (cubic), against faint leaks",
    },
    ParamSpec {
        name: "normal_bias",
        kind: ParamKind::Float { min: 0.0, max: 1.0 },
        default: "0.05",
        doc: "offset of the lookup point along the surface normal, as a fraction of the smallest probe spacing",
    },
    ParamSpec {
        name: "view_bias",
        kind: ParamKind::Float { min: 0.0, max: 1.0 },
        default: "0.2",
        doc: "offset of the lookup point towards the viewer, as a fraction of the smallest probe spacing",
    },
];

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "ddgi",
    description: "dynamic diffuse GI: ray-traced irradiance probes with hysteresis and Chebyshev visibility",
    params: &DDGI_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Temporal,
    validate,
    create,
};

fn validate(p: &crate::params::ParamValues) -> Result<(), String> {
    if p.choice("volume") == "scene" && p.float("probe_spacing") > 0.0 {
        return Err(
            "probe_spacing applies to volume=camera; the scene's grid is spaced by probe_count".into()
        );
    }
    Ok(())
}

/// Mirrors `ProbeFrame` in volume.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ProbeFrame {
    /// Columns of the ray pattern's rotation (mat3x3f: each column padded to 16 bytes).
    pub rotation: [[f32; 4]; 3],
    pub scroll: [i32; 3],
    pub hysteresis: f32,
    pub previous_scroll: [i32; 3],
    pub update_start: u32,
    pub update_count: u32,
    /// 1 when the probe state pass traces its classification rays this frame (relocation and
    /// classification), 0 when the probes keep the states they settled into.
    pub classify: u32,
    pub _pad: [u32; 2],
}

/// Mirrors `ProbeState` in volume.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ProbeState {
    pub offset: [f32; 3],
    pub flags: u32,
}

/// Bits of `ProbeState::flags` (defined for the shaders too, see `flag_defines`). Active: traced,
/// updated and interpolated (classification turns it off).
pub const PROBE_ACTIVE: u32 = 1;
/// Its atlas texels hold its light once this frame's update has run (clear: never updated since it was
/// created or scrolled into the volume, so interpolation skips it).
pub const PROBE_VALID: u32 = 2;
/// This frame's update blends into its texels with the hysteresis (clear: the update replaces them).
pub const PROBE_BLEND: u32 = 4;
/// Most of its classification rays hit back faces: it stands inside geometry.
pub const PROBE_INSIDE: u32 = 8;

fn flag_defines(defines: Defines) -> Defines {
    defines
        .u32("PROBE_ACTIVE", PROBE_ACTIVE)
        .u32("PROBE_VALID", PROBE_VALID)
        .u32("PROBE_BLEND", PROBE_BLEND)
        .u32("PROBE_INSIDE", PROBE_INSIDE)
}

/// Where the probes stand: `counts` probes per axis, the first at `first`, `spacing` apart.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeGrid {
    pub counts: [u32; 3],
    pub first: Vec3,
    pub spacing: Vec3,
}

impl ProbeGrid {
    /// `along_longest` probes on the longest axis of `bounds`, about the same spacing on the others
    /// (at least 2 probes each, so every point has a cage), each probe at the centre of its cell: probes
    /// on the bounds would sit in the outer walls.
    pub fn fit(bounds: Aabb, along_longest: u32) -> ProbeGrid {
        let extent = (bounds.max - bounds.min).max(Vec3::splat(1e-3));
        let cell = extent.max_element() / along_longest as f32;
        let counts = extent.to_array().map(|e| ((e / cell).round() as u32).clamp(2, along_longest.max(2)));
        Self::with_counts(bounds, counts)
    }

    /// `counts` probes over `bounds`, each centred in its cell.
    pub fn with_counts(bounds: Aabb, counts: [u32; 3]) -> ProbeGrid {
        let extent = (bounds.max - bounds.min).max(Vec3::splat(1e-3));
        let spacing = extent / Vec3::from(counts.map(|c| c as f32));
        ProbeGrid { counts, first: bounds.min + spacing * 0.5, spacing }
    }

    pub fn probes(&self) -> u32 {
        self.counts.iter().product()
    }

    pub fn position(&self, g: [u32; 3]) -> Vec3 {
        self.first + Vec3::from(g.map(|c| c as f32)) * self.spacing
    }

    /// The first lattice cell of a volume of `counts` probes centred on `camera` (whole cells, so that
    /// the probes stay put in the world while the camera moves within a cell).
    pub fn scroll_for(&self, camera: Vec3) -> [i32; 3] {
        let centre = (camera - self.first) / self.spacing;
        let half = Vec3::from(self.counts.map(|c| (c - 1) as f32 * 0.5));
        (centre - half).round().to_array().map(|c| c as i32)
    }

    /// Farthest a probe's distance moments look: 1.5 cell diagonals (misses are recorded there).
    pub fn max_distance(&self) -> f32 {
        1.5 * self.spacing.length()
    }
}

/// How probe tiles are packed into an atlas: a near-square grid of tiles `interior + 2` texels wide.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasLayout {
    pub columns: u32,
    pub rows: u32,
    pub interior: u32,
}

impl AtlasLayout {
    pub fn new(probes: u32, interior: u32, columns: u32) -> Self {
        AtlasLayout { columns, rows: probes.div_ceil(columns), interior }
    }

    pub fn size(&self) -> (u32, u32) {
        let edge = self.interior + 2;
        (self.columns * edge, self.rows * edge)
    }

    /// The texel of the atlas that holds interior texel `texel` of `probe`.
    pub fn texel(&self, probe: u32, texel: [u32; 2]) -> [u32; 2] {
        let edge = self.interior + 2;
        [(probe % self.columns) * edge + 1 + texel[0], (probe / self.columns) * edge + 1 + texel[1]]
    }
}

/// The CPU twin of `gutter_source` in volume.wgsl: the interior texel a tile texel holds.
pub fn gutter_source(t: [u32; 2], interior: u32) -> [u32; 2] {
    let last = interior + 1;
    let (on_x, on_y) = (t[0] == 0 || t[0] == last, t[1] == 0 || t[1] == last);
    let flip = |c: u32| interior - c;
    match (on_x, on_y) {
        (true, true) => [if t[0] == 0 { interior - 1 } else { 0 }, if t[1] == 0 { interior - 1 } else { 0 }],
        (false, true) => [flip(t[0]), if t[1] == 0 { 0 } else { interior - 1 }],
        (true, false) => [if t[0] == 0 { 0 } else { interior - 1 }, flip(t[1])],
        (false, false) => [t[0] - 1, t[1] - 1],
    }
}

/// The CPU twin of `texel_direction` (volume.wgsl).
pub fn texel_direction(texel: [u32; 2], interior: u32) -> Vec3 {
    oct_decode(Vec2::from(texel.map(|c| (c as f32 + 0.5) / interior as f32 * 2.0 - 1.0)))
}

/// The interior texel whose cell holds direction `dir` (what a nearest lookup returns).
pub fn direction_texel(dir: Vec3, interior: u32) -> [u32; 2] {
    oct_encode(dir).to_array().map(|c| (((c * 0.5 + 0.5) * interior as f32) as u32).min(interior - 1))
}

/// A uniformly random rotation (Shoemake's quaternion from three uniform numbers) for frame `frame`.
pub fn ray_rotation(seed: u32, frame: u32) -> Mat3 {
    let mut state = (u64::from(seed) << 32 | u64::from(frame)) ^ 0x6464_6769_0000_0000;
    let mut next = || {
        // SplitMix64.
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    let (u1, u2, u3) = (next(), next(), next());
    let tau = std::f32::consts::TAU;
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let q = Quat::from_xyzw(
        a * (tau * u2).sin(),
        a * (tau * u2).cos(),
        b * (tau * u3).sin(),
        b * (tau * u3).cos(),
    );
    Mat3::from_quat(q.normalize())
}

fn wgsl_format_name(format: wgpu::TextureFormat) -> &'static str {
    match format {
        wgpu::TextureFormat::Rgba16Float => "rgba16float",
        wgpu::TextureFormat::Rgba32Float => "rgba32float",
        wgpu::TextureFormat::Rg11b10Ufloat => "rg11b10ufloat",
        wgpu::TextureFormat::Rgb10a2Unorm => "rgb10a2unorm",
        wgpu::TextureFormat::Rg16Float => "rg16float",
        other => unreachable!("no atlas of format {other:?}"),
    }
}

fn irradiance_format(name: &str) -> wgpu::TextureFormat {
    match name {
        "rgba32float" => wgpu::TextureFormat::Rgba32Float,
        "rg11b10ufloat" => wgpu::TextureFormat::Rg11b10Ufloat,
        "rgb10a2unorm" => wgpu::TextureFormat::Rgb10a2Unorm,
        _ => wgpu::TextureFormat::Rgba16Float,
    }
}

/// How the update pass rounds an atlas format's values (`blend_stored` in update.wgsl): for the 16- and
/// 11-bit floats stochastically to multiples of (relative step × the value's power of two, at least the
/// absolute step below the smallest normal), for rgb10a2unorm one step of 1/1023 towards the target where
/// a blend would stall; rgba32float needs neither.
struct StorageRounding {
    stochastic: bool,
    relative: f32,
    absolute: f32,
    min_normal: f32,
}

fn storage_rounding(format: wgpu::TextureFormat) -> StorageRounding {
    let float = |mantissa_bits: i32, subnormal_step: f32| StorageRounding {
        stochastic: true,
        relative: 2f32.powi(-mantissa_bits),
        absolute: subnormal_step,
        min_normal: 2f32.powi(-14),
    };
    match format {
        wgpu::TextureFormat::Rgba32Float => {
            StorageRounding { stochastic: false, relative: 0.0, absolute: 0.0, min_normal: 1.0 }
        }
        // Blue has 5 mantissa bits (red and green 6): its steps are steps of every channel.
        wgpu::TextureFormat::Rg11b10Ufloat => float(5, 2f32.powi(-19)),
        wgpu::TextureFormat::Rgb10a2Unorm => {
            StorageRounding { stochastic: false, relative: 0.0, absolute: 1.0 / 1023.0, min_normal: 1.0 }
        }
        _ => float(10, 2f32.powi(-24)),
    }
}

/// Bytes per texel of the atlas formats.
fn texel_bytes(format: wgpu::TextureFormat) -> u64 {
    u64::from(format.block_copy_size(None).unwrap_or(8))
}

/// One quantity's atlases: written this frame, read from the last (ping-pong, so any format works
/// without read-write storage), with the update pass that blends rays into them.
struct Atlas {
    layout: AtlasLayout,
    format: wgpu::TextureFormat,
    textures: [wgpu::Texture; 2],
    views: [wgpu::TextureView; 2],
    update: wgpu::ComputePipeline,
    /// `groups[w]` writes atlas `w` from atlas `1 − w`.
    groups: [wgpu::BindGroup; 2],
}

impl Atlas {
    #[allow(clippy::too_many_arguments)]
    fn new(
        ctx: &GpuContext,
        name: &str,
        layout: AtlasLayout,
        format: wgpu::TextureFormat,
        entry: &str,
        defines: &Defines,
        rays: &wgpu::Buffer,
        frame_uniform: &wgpu::Buffer,
        probe_states: &wgpu::Buffer,
    ) -> Result<Atlas, RenderError> {
        let (w, h) = layout.size();
        let make = |i: usize| {
            ctx.device.create_texture(
                &crate::gpu::TextureBuilder::d2(&format!("{name} atlas {i}"), w, h, format)
                    .storage()
                    .sampled()
                    .usage(wgpu::TextureUsages::COPY_SRC)
                    .descriptor(),
            )
        };
        let textures = [make(0), make(1)];
        let views = [0, 1].map(|i| textures[i].create_view(&Default::default()));
        let group_layout = compute::layout(
            ctx,
            name,
            &[
                storage_buffer_entry(0, true),
                texture_entry(1, wgpu::TextureSampleType::Float { filterable: false }),
                uniform_entry(2),
                storage_texture_entry(3, format, wgpu::StorageTextureAccess::WriteOnly),
                storage_buffer_entry(4, true),
            ],
        );
        let groups = [0, 1].map(|w| {
            compute::bind_group(
                ctx,
                name,
                &group_layout,
                &[
                    rays.as_entire_binding(),
                    wgpu::BindingResource::TextureView(&views[1 - w]),
                    frame_uniform.as_entire_binding(),
                    wgpu::BindingResource::TextureView(&views[w]),
                    probe_states.as_entire_binding(),
                ],
            )
        });
        let source = format!("{VOLUME_WGSL}\n{}", include_str!("update.wgsl"))
            .replace("ATLAS_FORMAT", wgsl_format_name(format));
        let rounding = storage_rounding(format);
        let defines = defines
            .clone()
            .bool("ATLAS_STOCHASTIC", rounding.stochastic)
            .f32("ATLAS_RELATIVE_STEP", rounding.relative)
            .f32("ATLAS_ABSOLUTE_STEP", rounding.absolute)
            .f32("ATLAS_MIN_NORMAL", rounding.min_normal);
        let update = compute::pipeline(ctx, name, &source, defines, entry, &[&group_layout])?;
        Ok(Atlas { layout, format, textures, views, update, groups })
    }

    fn bytes(&self) -> u64 {
        self.textures.iter().map(|t| u64::from(t.width() * t.height()) * texel_bytes(self.format)).sum()
    }

    fn record_update(&self, encoder: &mut wgpu::CommandEncoder, label: &str, written: usize) {
        let (w, h) = self.layout.size();
        compute::dispatch(
            encoder,
            label,
            &self.update,
            &[&self.groups[written]],
            [w.div_ceil(UPDATE_TILE), h.div_ceil(UPDATE_TILE), 1],
        );
    }
}

pub(crate) struct Ddgi {
    grid: ProbeGrid,
    /// Whether the volume follows the camera (scrolls) or stays over the scene.
    follows_camera: bool,
    /// First lattice cell of the volume in the last frame (None before the first).
    scroll: Option<[i32; 3]>,
    /// The scene geometry the probe states were settled for.
    geometry_version: Option<u64>,
    /// Frames the probe state pass still relocates and classifies ([`SETTLE_FRAMES`]).
    settle_frames_left: u32,
    /// Probes traced and updated per frame, and the first slot of the next frame's subset.
    update_count: u32,
    next_update_start: u32,
    rays_per_probe: u32,
    hysteresis: f32,
    seed: u32,
    probe_states: wgpu::Buffer,
    state: wgpu::ComputePipeline,
    state_group: wgpu::BindGroup,
    direct: DirectLighting,
    _direct_texture: wgpu::Texture,
    /// Mean light of the reflection rays (1×1 without them).
    reflection: wgpu::Texture,
    frame_uniform: wgpu::Buffer,
    ray_data: wgpu::Buffer,
    ray_stats: wgpu::Buffer,
    trace: wgpu::ComputePipeline,
    /// `trace_groups[w]` reads the atlases other than `w`.
    trace_groups: [wgpu::BindGroup; 2],
    irradiance: Atlas,
    distance: Atlas,
    shade: wgpu::ComputePipeline,
    /// `shade_groups[w]` reads atlases `w`.
    shade_groups: [wgpu::BindGroup; 2],
    /// The atlases the next update writes.
    written: usize,
    /// Updates since creation.
    updates: u32,
    max_workgroups: u32,
    width: u32,
    height: u32,
    warnings: Vec<String>,
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    Ok(Box::new(Ddgi::new(setup)?))
}

impl Ddgi {
    pub(crate) fn new(setup: &TechniqueSetup) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let p = setup.params;
        let mut grid = match p.grid_counts("probe_count") {
            GridCounts::AlongLongest(n) => ProbeGrid::fit(setup.gpu_scene.bounds(), n),
            GridCounts::Exact(counts) => ProbeGrid::with_counts(setup.gpu_scene.bounds(), counts),
        };
        let follows_camera = p.choice("volume") == "camera";
        let spacing = p.float("probe_spacing") as f32;
        if follows_camera && spacing > 0.0 {
            grid.spacing = Vec3::splat(spacing);
            grid.first = setup.gpu_scene.bounds().min + grid.spacing * 0.5;
        }
        let probes = grid.probes();
        let update_count = match p.int("probes_per_frame") as u32 {
            0 => probes,
            n => n.min(probes),
        };
        let rays_per_probe = p.int("rays") as u32;
        let emitters_in_probes = p.choice("emitters") == "probes";
        let mut warnings = Vec::new();

        let format = irradiance_format(p.choice("format"));
        if !has(ctx, Need::StorageTexture { format, read_write: false }) {
            return Err(RenderError::InvalidSettings(format!(
                "ddgi: format={} cannot be written by compute shaders on this adapter; use rgba16float",
                p.choice("format")
            )));
        }
        if format == wgpu::TextureFormat::Rgba32Float && !has(ctx, Need::Float32Filtering) {
            return Err(RenderError::InvalidSettings(
                "ddgi: format=rgba32float needs float32 filtering (wgpu feature FLOAT32_FILTERABLE), which this adapter lacks; use rgba16float".into(),
            ));
        }
        let distance_format = if has(
            ctx,
            Need::StorageTexture { format: wgpu::TextureFormat::Rg16Float, read_write: false },
        ) {
            wgpu::TextureFormat::Rg16Float
        } else {
            warnings.push("the adapter cannot write rg16float storage textures: the distance atlas is rgba16float (twice the memory)".into());
            wgpu::TextureFormat::Rgba16Float
        };

        let columns = (probes as f64).sqrt().ceil() as u32;
        let irradiance_layout = AtlasLayout::new(probes, p.int("irradiance_texels") as u32, columns);
        let distance_layout = AtlasLayout::new(probes, p.int("distance_texels") as u32, columns);
        let max_dim = ctx.limits().max_texture_dimension_2d;
        for (what, l) in [("irradiance", irradiance_layout), ("distance", distance_layout)] {
            let (w, h) = l.size();
            if w.max(h) > max_dim {
                return Err(RenderError::InvalidSettings(format!(
                    "ddgi: the {what} atlas of {probes} probes would be {w}x{h} texels, over the adapter's \
                     max_texture_dimension_2d ({max_dim}); lower probe_count or {what}_texels"
                )));
            }
        }
        let ray_count = u64::from(probes) * u64::from(rays_per_probe);
        ctx.check_storage_size("the probe ray buffer", ray_count * 16)?;

        let min_spacing = grid.spacing.min_element();
        let defines = flag_defines(Defines::new())
            .vec3u("PROBE_COUNTS", grid.counts)
            .vec3f("FIRST_PROBE", grid.first.to_array())
            .vec3f("PROBE_SPACING", grid.spacing.to_array())
            .u32("ATLAS_COLUMNS", columns)
            .u32("IRRADIANCE_TEXELS", irradiance_layout.interior)
            .u32("DISTANCE_TEXELS", distance_layout.interior)
            .u32("RAYS", rays_per_probe)
            .f32("MAX_DISTANCE", grid.max_distance())
            .f32("DISTANCE_EXPONENT", p.float("distance_exponent") as f32)
            .f32("NORMAL_BIAS", p.float("normal_bias") as f32 * min_spacing)
            .f32("VIEW_BIAS", p.float("view_bias") as f32 * min_spacing)
            .bool("BACKFACE_WEIGHT", p.bool("backface_weight"))
            .bool("CHEBYSHEV", p.bool("chebyshev"))
            .bool("LOW_WEIGHT_CRUSH", p.bool("low_weight_crush"))
            .bool("EMITTERS_IN_PROBES", emitters_in_probes)
            .u32("SURFEL_AREA_SAMPLES", u32::from(!emitters_in_probes))
            .u32("SURFEL_ENV_SAMPLES", u32::from(!emitters_in_probes))
            .bool("REFLECTION_RAY", p.bool("reflection_ray"))
            .f32("REFLECTION_ROUGHNESS", p.float("reflection_roughness") as f32);
        let state_defines = defines
            .clone()
            .u32("CLASSIFY_RAYS", CLASSIFY_RAYS)
            .f32("BACKFACE_THRESHOLD", BACKFACE_THRESHOLD)
            .f32("MIN_SURFACE_DISTANCE", MIN_SURFACE_DISTANCE * min_spacing)
            .f32("RELOCATION_LIMIT", p.float("relocation_limit") as f32)
            .bool("RELOCATION", p.bool("relocation"))
            .bool("CLASSIFICATION", p.bool("classification"));

        let device = &ctx.device;
        let frame_uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("probe frame"),
            contents: bytemuck::bytes_of(&ProbeFrame::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let ray_data = device.create_buffer(
            &crate::gpu::BufferBuilder::new("probe rays", ray_count * 16).storage().copy().descriptor(),
        );
        let ray_stats = compute::storage_buffer(ctx, "probe ray stats", 8);
        let fresh = ProbeState { offset: [0.0; 3], flags: PROBE_ACTIVE };
        let probe_states = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("probe states"),
            contents: bytemuck::cast_slice(&vec![fresh; probes as usize]),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
        let state_layout =
            compute::layout(ctx, "probe state", &[storage_buffer_entry(0, false), uniform_entry(1)]);
        let state_group = compute::bind_group(
            ctx,
            "probe state",
            &state_layout,
            &[probe_states.as_entire_binding(), frame_uniform.as_entire_binding()],
        );
        let state = compute::pipeline(
            ctx,
            "probe state",
            &format!("{VOLUME_WGSL}\n{}", include_str!("state.wgsl")),
            setup.gpu_scene.bvh_defines(state_defines),
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &state_layout],
        )?;
        let irradiance = Atlas::new(
            ctx,
            "probe irradiance update",
            irradiance_layout,
            format,
            "update_irradiance",
            &defines,
            &ray_data,
            &frame_uniform,
            &probe_states,
        )?;
        let distance = Atlas::new(
            ctx,
            "probe distance update",
            distance_layout,
            distance_format,
            "update_distance",
            &defines,
            &ray_data,
            &frame_uniform,
            &probe_states,
        )?;
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("probe atlases"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let filterable = wgpu::TextureSampleType::Float { filterable: true };
        let sampler_entry = wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        };

        // Probe rays: read the atlases the update does not write.
        let trace_layout = compute::layout(
            ctx,
            "probe trace",
            &[
                storage_buffer_entry(0, false),
                texture_entry(1, filterable),
                texture_entry(2, filterable),
                wgpu::BindGroupLayoutEntry { binding: 3, ..sampler_entry },
                uniform_entry(4),
                storage_buffer_entry(5, false),
                storage_buffer_entry(6, true),
            ],
        );
        let trace_groups = [0, 1].map(|w| {
            compute::bind_group(
                ctx,
                "probe trace",
                &trace_layout,
                &[
                    ray_data.as_entire_binding(),
                    wgpu::BindingResource::TextureView(&irradiance.views[1 - w]),
                    wgpu::BindingResource::TextureView(&distance.views[1 - w]),
                    wgpu::BindingResource::Sampler(&sampler),
                    frame_uniform.as_entire_binding(),
                    ray_stats.as_entire_binding(),
                    probe_states.as_entire_binding(),
                ],
            )
        });
        let trace = compute::pipeline(
            ctx,
            "probe trace",
            &format!("{VOLUME_WGSL}\n{QUERY_WGSL}\n{}", include_str!("trace.wgsl")),
            setup.gpu_scene.bvh_defines(defines.clone()),
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &trace_layout],
        )?;

        // Direct light into a texture of its own, accumulated while nothing changes.
        let (width, height) = (setup.frame.width, setup.frame.height);
        let direct_texture = compute::storage_texture(ctx, "ddgi direct", width, height, OUTPUT_FORMAT);
        let samples = if emitters_in_probes {
            LightSamples { area: 0, environment: 0 }
        } else {
            LightSamples { area: p.int("area_samples") as u32, environment: p.int("env_samples") as u32 }
        };
        let direct = DirectLighting::with_samples(setup, &direct_texture, DirectOutput::Accumulate, samples)?;

        let shade_layout = compute::layout(
            ctx,
            "probe sampling",
            &[
                storage_texture_entry(0, OUTPUT_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
                texture_entry(1, wgpu::TextureSampleType::Float { filterable: false }),
                texture_entry(2, filterable),
                texture_entry(3, filterable),
                wgpu::BindGroupLayoutEntry { binding: 4, ..sampler_entry },
                uniform_entry(5),
                storage_buffer_entry(6, true),
                storage_texture_entry(7, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
            ],
        );
        let output_view = setup.output.create_view(&Default::default());
        let (rw, rh) = if p.bool("reflection_ray") { (width, height) } else { (1, 1) };
        let reflection = compute::storage_texture(ctx, "ddgi reflection", rw, rh, OUTPUT_FORMAT);
        let reflection_view = reflection.create_view(&Default::default());
        let direct_view = direct_texture.create_view(&Default::default());
        let shade_groups = [0, 1].map(|w| {
            compute::bind_group(
                ctx,
                "probe sampling",
                &shade_layout,
                &[
                    wgpu::BindingResource::TextureView(&output_view),
                    wgpu::BindingResource::TextureView(&direct_view),
                    wgpu::BindingResource::TextureView(&irradiance.views[w]),
                    wgpu::BindingResource::TextureView(&distance.views[w]),
                    wgpu::BindingResource::Sampler(&sampler),
                    frame_uniform.as_entire_binding(),
                    probe_states.as_entire_binding(),
                    wgpu::BindingResource::TextureView(&reflection_view),
                ],
            )
        });
        let shade = compute::pipeline(
            ctx,
            "probe sampling",
            &format!("{VOLUME_WGSL}\n{QUERY_WGSL}\n{}", include_str!("shade.wgsl")),
            setup.gpu_scene.bvh_defines(defines),
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &shade_layout],
        )?;

        Ok(Ddgi {
            grid,
            follows_camera,
            scroll: None,
            geometry_version: None,
            settle_frames_left: 0,
            update_count,
            next_update_start: 0,
            probe_states,
            state,
            state_group,
            rays_per_probe,
            hysteresis: p.float("hysteresis") as f32,
            seed: p.int("seed") as u32,
            direct,
            _direct_texture: direct_texture,
            reflection,
            frame_uniform,
            ray_data,
            ray_stats,
            trace,
            trace_groups,
            irradiance,
            distance,
            shade,
            shade_groups,
            written: 0,
            updates: 0,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
            width,
            height,
            warnings,
        })
    }

    /// Writes this frame's volume position, update subset and ray rotation, and runs the probe state
    /// pass (fresh probes where the volume scrolled, relocation, classification).
    pub(crate) fn begin_frame(
        &mut self,
        fc: &FrameContext,
        profiler: &mut Profiler,
    ) -> Result<(), RenderError> {
        let scroll = if self.follows_camera { self.grid.scroll_for(fc.view.camera.position) } else { [0; 3] };
        // Relocation and classification depend on the geometry around each probe alone: they run while
        // the probes settle after creation, after the geometry moved and after the volume scrolled
        // (fresh probes entered), and are skipped once settled.
        if self.geometry_version != Some(fc.gpu_scene.geometry_version)
            || self.scroll.is_some_and(|s| s != scroll)
        {
            self.geometry_version = Some(fc.gpu_scene.geometry_version);
            self.settle_frames_left = SETTLE_FRAMES;
        }
        let classify = self.settle_frames_left > 0;
        self.settle_frames_left = self.settle_frames_left.saturating_sub(1);
        let r = ray_rotation(self.seed, fc.view.frame_counter);
        let uniform = ProbeFrame {
            rotation: [r.x_axis, r.y_axis, r.z_axis].map(|c| [c.x, c.y, c.z, 0.0]),
            scroll,
            hysteresis: self.hysteresis,
            previous_scroll: self.scroll.unwrap_or(scroll),
            update_start: self.next_update_start,
            update_count: self.update_count,
            classify: u32::from(classify),
            _pad: [0; 2],
        };
        fc.ctx.queue.write_buffer(&self.frame_uniform, 0, bytemuck::bytes_of(&uniform));
        let groups = crate::gpu::dispatch::workgroups_for(self.grid.probes(), 1, self.max_workgroups);
        profiler.pass(fc.ctx, "probe state", |encoder| {
            compute::dispatch(
                encoder,
                "probe state",
                &self.state,
                &[&fc.gpu_scene.bind_group, &fc.frame.bind_group, &self.state_group],
                groups,
            );
        })?;
        self.scroll = Some(scroll);
        self.next_update_start = (self.next_update_start + self.update_count) % self.grid.probes();
        Ok(())
    }

    /// Blends the rays in `ray_data` into the atlases (the two update passes) and flips the atlases.
    pub(crate) fn update_probes(
        &mut self,
        ctx: &GpuContext,
        profiler: &mut Profiler,
    ) -> Result<(), RenderError> {
        profiler.pass(ctx, "probe irradiance update", |encoder| {
            self.irradiance.record_update(encoder, "probe irradiance update", self.written);
        })?;
        profiler.pass(ctx, "probe distance update", |encoder| {
            self.distance.record_update(encoder, "probe distance update", self.written);
        })?;
        self.written = 1 - self.written;
        self.updates += 1;
        Ok(())
    }

    /// The atlases the last update wrote.
    pub(crate) fn current(&self) -> usize {
        1 - self.written
    }

    /// Rays traced per frame when every probe of the update subset is active.
    fn probe_rays(&self) -> u64 {
        u64::from(self.update_count) * u64::from(self.rays_per_probe)
    }

    /// (Probe rays that hit a back face, probe rays traced) since the technique was created, read back.
    pub(crate) fn ray_counts(&self, ctx: &GpuContext) -> Result<(u32, u32), RenderError> {
        let stats = readback::read_buffer(ctx, &self.ray_stats, 0, 8)?;
        let stats = bytemuck::cast_slice::<u8, u32>(&stats);
        Ok((stats[0], stats[1]))
    }

    /// Every probe's state, read back.
    pub(crate) fn read_states(&self, ctx: &GpuContext) -> Result<Vec<ProbeState>, RenderError> {
        let bytes = readback::read_buffer(ctx, &self.probe_states, 0, self.probe_states.size())?;
        Ok(bytemuck::cast_slice(&bytes).to_vec())
    }
}

impl Technique for Ddgi {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        self.begin_frame(fc, profiler)?;
        let groups = crate::gpu::dispatch::workgroups_for(
            self.probe_rays() as u32,
            TRACE_WORKGROUP,
            self.max_workgroups,
        );
        profiler.pass(fc.ctx, "probe trace", |encoder| {
            compute::dispatch(
                encoder,
                "probe trace",
                &self.trace,
                &[&fc.gpu_scene.bind_group, &fc.frame.bind_group, &self.trace_groups[self.written]],
                groups,
            );
        })?;
        self.update_probes(fc.ctx, profiler)?;
        self.direct.render(fc, profiler)?;
        compute::frame_pass(fc, profiler, "probe sampling", &self.shade, &self.shade_groups[self.current()])
    }

    fn counters(
        &mut self,
        ctx: &GpuContext,
        measured: &Measured,
    ) -> Result<BTreeMap<String, f64>, RenderError> {
        let (backface, traced) = self.ray_counts(ctx)?;
        let (backface, traced) = (f64::from(backface), f64::from(traced));
        let states = self.read_states(ctx)?;
        let with = |flag: u32| states.iter().filter(|s| s.flags & flag != 0).count() as f64;
        let spacing = self.grid.spacing;
        let offsets: Vec<f32> =
            states.iter().map(|s| (Vec3::from(s.offset) / spacing).abs().max_element()).collect();
        let relocated = offsets.iter().filter(|&&o| o > 0.0).count() as f64;
        let mean_offset = offsets.iter().sum::<f32>() / offsets.len().max(1) as f32;
        let [x, y, z] = self.grid.counts;
        let mut c = BTreeMap::from([
            ("probes".to_string(), f64::from(self.grid.probes())),
            ("probes_x".to_string(), f64::from(x)),
            ("probes_y".to_string(), f64::from(y)),
            ("probes_z".to_string(), f64::from(z)),
            ("probe_spacing_min".to_string(), f64::from(self.grid.spacing.min_element())),
            ("probes_per_frame".to_string(), f64::from(self.update_count)),
            ("probe_rays_per_frame".to_string(), self.probe_rays() as f64),
            ("probes_active".to_string(), with(PROBE_ACTIVE)),
            ("probes_inside_geometry".to_string(), with(PROBE_INSIDE)),
            ("probes_relocated".to_string(), relocated),
            ("probe_offset_mean_cells".to_string(), f64::from(mean_offset)),
            ("probe_rays_traced".to_string(), traced),
            ("probe_updates".to_string(), f64::from(self.updates)),
            ("backface_ray_fraction".to_string(), if traced > 0.0 { backface / traced } else { 0.0 }),
            ("irradiance_atlas_bytes".to_string(), self.irradiance.bytes() as f64),
            ("distance_atlas_bytes".to_string(), self.distance.bytes() as f64),
            ("probe_ray_buffer_bytes".to_string(), self.ray_data.size() as f64),
            ("probe_state_bytes".to_string(), self.probe_states.size() as f64),
            ("direct_bytes_per_pixel".to_string(), 16.0),
            ("reflection_bytes_per_pixel".to_string(), if self.reflection.width() > 1 { 16.0 } else { 0.0 }),
            ("output_bytes_per_pixel".to_string(), 16.0),
            ("pixels".to_string(), f64::from(self.width * self.height)),
        ]);
        // Per frame, from this frame's active probes and the trace pass's mean time: the timings may
        // cover fewer frames than the ray counter (a benchmark resets them after its warm-up).
        let active_rays = with(PROBE_ACTIVE) * self.probe_rays() as f64 / f64::from(self.grid.probes());
        if let Some(ms) = measured.pass_mean_ms("probe trace").filter(|&ms| ms > 0.0) {
            c.insert("probe_rays_per_second".into(), active_rays / (ms / 1e3));
        }
        Ok(c)
    }

    // Lights, the environment and geometry are read from the scene every frame; the probes follow
    // through the blend.
    fn scene_changed(
        &mut self,
        _: &GpuContext,
        _: &crate::gpu::GpuScene,
        _: SceneChange,
    ) -> Result<bool, RenderError> {
        Ok(true)
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }
}
