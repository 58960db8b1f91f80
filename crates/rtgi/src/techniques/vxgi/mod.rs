//! `vxgi`: voxel cone tracing (Crassin, Neyret, Sainz, Green & Eisemann 2011, "Interactive indirect
//! illumination using voxel cone tracing").
//!
//! The scene is voxelised into a cubic grid over its bounds (diffuse albedo, normal, occupancy), each
//! voxel takes the direct light its surfaces reflect, and the radiance (premultiplied by opacity) is
//! filtered into a mip chain: six directional volumes per level (anisotropic, the paper's choice) or
//! isotropic box-filtered mips. Camera pixels then gather diffuse light with a few wide cones over
//! their hemisphere and glossy light with one cone about the mirror direction, each marched front to
//! back through the level whose voxel matches the cone's width. A second bounce traces the diffuse
//! cones from every voxel into the first bounce's volume.
//!
//! Work is done when it is needed, not every frame: voxelisation when the geometry or the volume's
//! placement changes, injection and mips when lights or the environment change too (or every frame,
//! with `update=every-frame`, to measure what a fully dynamic scene costs). Every frame then costs the
//! direct pass and the cone tracing. Passes: "vxgi voxelization", "vxgi injection", "vxgi mips",
//! "vxgi bounce", "vxgi bounce mips", "direct lighting", "vxgi cone tracing".
//!
//! Departures from the paper, for rtgi's platform: voxelisation casts rays through the shared BVH
//! along the three axes (one per voxel column, the equivalent of the paper's dominant-axis
//! rasterisation; compute is fast and raster slow on the GPUs rtgi targets), then, for the paper's
//! conservative rasterisation (`voxelization=conservative`, the default), every triangle claims the
//! empty voxels its area overlaps by a separating-axis test in compute (conservative.wgsl), and
//! injection lights each voxel with the same direct-light routine as the camera's
//! pixels (traced shadow rays instead of a shadow map; emissive triangles and the environment
//! included) instead of splatting a light-view map.
//!
//! Clipmaps (`clipmap_levels` > 1): nested volumes of the same resolution, the coarsest over the scene,
//! each finer one half the voxel and centred on the camera, snapped to two of its voxels (its mip 1 then
//! lines up with the next level's voxels). A cone sample reads the finest level that holds it and is
//! as fine as its diameter needs. A level that moves by less than its width scrolls (`scroll`): the
//! voxels, radiance and second bounce it keeps shift with it ("vxgi scroll", through a scratch copy of
//! one level), and only the slabs it enters are voxelised, lit and bounced; its directional mips
//! are filtered again (those of levels that did not change are kept). Voxelisation and injection compute everything from a voxel's index on a lattice anchored at
//! the coarsest level's corner (never from the level's own corner), so a scrolled level holds, bit for
//! bit, the voxels and first-bounce radiance that a level voxelised and lit where it now stands would.
//! The second bounce of the voxels kept is the one gathered where the levels stood before: the same
//! scene seen through clipmap levels placed a few voxels otherwise.

#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::dispatch::workgroups_for;
use crate::gpu::{GpuContext, GpuScene, MipGenerator, Need, Profiler, TextureBuilder};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::shaders::Defines;
use crate::techniques::compute::{self, DispatchSlots};
use crate::techniques::direct::{DirectLighting, DirectOutput, with_direct_params};
use crate::techniques::{
    FrameContext, FrameNeeds, Measured, RenderError, SceneChange, Technique, TechniqueInfo, TechniqueSetup,
};

/// Cone samples start this many voxels along the axis from their origin, which itself lies a voxel
/// out along the surface's normal: the surface's own voxel must not occlude its cones.
const CONE_START: f32 = 1.0;
/// A sample's voxel is at most this fraction of its height above the plane of the surface the cone
/// leaves (the cone is narrowed there), so that filtering never reaches back into that surface: wide
/// cones otherwise occlude themselves with the coarse voxels that hold their own surface. Measured on
/// cornell-spot at 64² (5 cones, 128³): mean FLIP 0.278 without the cap, 0.230 / 0.221 / 0.226 / 0.231
/// at 0.7 / 0.5 / 0.35 / 0.25.
const FOOTPRINT_CAP: f32 = 0.5;
/// The narrowest specular cone (half-angle tangent): a mirror's cone still widens past one voxel
/// within a few voxels, so it keeps to the filtered levels rather than aliasing through level 0.
const MIN_SPECULAR_TAN: f32 = 0.02;
/// Boxes of voxels per clipmap level that a frame's volume passes work on: up to three slabs a scroll
/// enters, and the whole level.
const REGIONS: usize = 4;
/// The region of a whole level.
const WHOLE_LEVEL: usize = 3;
/// Storage format of the radiance volumes (filterable, writable as storage everywhere).
const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Voxel words (albedo + count, normal), read and written by voxelisation.
const VOXEL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
/// Most clipmap levels.
pub const MAX_CLIPMAPS: usize = 4;
/// Conservative voxelisation: triangles per workgroup of the claim pass, and the bits of a claim that
/// name its triangle (+1; the rest rank it), which bound the scene's triangles.
const CLAIM_GROUP: u32 = 64;
const CLAIM_INDEX_BITS: u32 = 24;
/// Fewest workgroups the claim pass runs: a scene of few triangles has their columns sliced over this
/// many (each slice sets the triangles up again, which costs little next to their columns).
const CLAIM_WORKGROUPS: u32 = 256;
/// Edge in voxels of the bricks whose claims the resolve pass visits.
const CLAIM_BRICK: u32 = 4;
const MAX_CLAIMING_TRIANGLES: u32 = (1 << CLAIM_INDEX_BITS) - 1;
/// A cone sample uses a finer clipmap level only this many of its voxels inside its border: filtering
/// at its mip 1 reads a voxel of 2 around the sample.
const CLIP_MARGIN: f32 = 2.0;

const VXGI_PARAMS: [ParamSpec; 21] = with_direct_params!(
    ParamSpec {
        name: "resolution",
        kind: ParamKind::Int { min: 16, max: 512 },
        default: "128",
        doc: "voxels along each axis of the cubic volume over the scene (a power of two)",
    },
    ParamSpec {
        name: "clipmap_levels",
        kind: ParamKind::Int { min: 1, max: MAX_CLIPMAPS as i64 },
        default: "1",
        doc: "nested volumes of `resolution`³: the coarsest covers the scene, each finer one halves the voxel \
              and follows the camera (1 = one volume over the scene)",
    },
    ParamSpec {
        name: "diffuse_cones",
        kind: ParamKind::Int { min: 1, max: 16 },
        default: "5",
        doc: "cones over the hemisphere for diffuse light: one about the normal, the rest on a ring, each \
              an equal share of the cosine-weighted hemisphere",
    },
    ParamSpec {
        name: "aperture",
        kind: ParamKind::Float { min: 0.0, max: 80.0 },
        default: "0",
        doc: "half-angle of the diffuse cones in degrees; 0 = each cone's share of the hemisphere, \
              acos(1 − 1/cones), at most 60",
    },
    ParamSpec {
        name: "step",
        kind: ParamKind::Float { min: 0.1, max: 2.0 },
        default: "0.5",
        doc: "cone step as a fraction of the cone's diameter (opacity is corrected for it)",
    },
    ParamSpec {
        name: "max_distance",
        kind: ParamKind::Float { min: 0.01, max: 2.0 },
        default: "1",
        doc: "how far cones go, as a fraction of the (coarsest) volume's edge",
    },
    ParamSpec {
        name: "bounces",
        kind: ParamKind::Int { min: 1, max: 2 },
        default: "1",
        doc: "indirect bounces: 2 traces the diffuse cones from every voxel too",
    },
    ParamSpec {
        name: "specular_cone",
        kind: ParamKind::Bool,
        default: "true",
        doc: "one cone about the mirror direction for glossy surfaces, its aperture from the roughness",
    },
    ParamSpec {
        name: "anisotropic",
        kind: ParamKind::Bool,
        default: "true",
        doc: "six directional volumes per mip level (false: isotropic box-filtered mips, a sixth of the \
              memory)",
    },
    ParamSpec {
        name: "inject_samples",
        kind: ParamKind::Int { min: 0, max: 256 },
        default: "16",
        doc: "light samples per voxel for emissive triangles and for the environment (analytic lights \
              are exact)",
    },
    ParamSpec {
        name: "scroll",
        kind: ParamKind::Bool,
        default: "true",
        doc: "clipmap levels that move by less than their width keep the voxels they still hold (shifted) \
              and voxelise and light only the slabs they enter (false: a level that moves is rebuilt)",
    },
    ParamSpec {
        name: "voxelization",
        kind: ParamKind::Choice(&["conservative", "columns"]),
        default: "conservative",
        doc: "columns: one ray per voxel column along each axis, a voxel for each surface crossing a \
              column's centre (surfaces smaller than a voxel can be missed); conservative: also every \
              voxel a triangle's area overlaps (needs r32uint texture atomics)",
    },
    ParamSpec {
        name: "update",
        kind: ParamKind::Choice(&["changes", "every-frame"]),
        default: "changes",
        doc: "when to voxelise and inject: when geometry or lights change, or every frame (a dynamic \
              scene's cost)",
    },
);

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "vxgi",
    description: "voxel cone tracing: the scene voxelised, lit and filtered into mips, cones per pixel",
    params: &VXGI_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[
        super::ACCUMULATES_OUTPUT,
        Need::StorageTexture { format: VOXEL_FORMAT, read_write: true },
        Need::StorageTexture { format: RADIANCE_FORMAT, read_write: false },
    ],
    motion: super::Motion::Restarts,
    validate,
    create,
};

fn validate(p: &ParamValues) -> Result<(), String> {
    let n = p.int("resolution");
    if !(n as u64).is_power_of_two() {
        return Err(format!("resolution {n} is not a power of two (the mip chain halves it down to 1)"));
    }
    Ok(())
}

/// Mirrors `VxgiVolume` in volume.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct VxgiVolume {
    /// Per clipmap level, finest first: minimum corner (xyz) and voxel edge (w).
    pub clips: [[f32; 4]; MAX_CLIPMAPS],
    /// Per level, its minimum corner in its own voxels from `origin` (xyz): voxel c of level k is voxel
    /// corners[k] + c of a lattice that does not move with the level.
    pub corners: [[i32; 4]; MAX_CLIPMAPS],
    /// Per level, this frame's scroll in its voxels (xyz): voxel c now holds what voxel c + shift held.
    pub shifts: [[i32; 4]; MAX_CLIPMAPS],
    /// Per level, REGIONS boxes of voxels [lo, hi) (xyz of each) for this frame's volume passes:
    /// the slabs a scroll enters, then the whole level.
    pub boxes: [[[i32; 4]; 2]; REGIONS * MAX_CLIPMAPS],
    /// The lattice's origin, the coarsest level's corner (xyz).
    pub origin: [f32; 4],
}

impl VxgiVolume {
    /// Whether level `k` lies where it lies in `other`, on the same lattice.
    fn same_level(&self, other: &VxgiVolume, k: usize) -> bool {
        self.clips[k] == other.clips[k] && self.corners[k] == other.corners[k] && self.origin == other.origin
    }
}

/// Mirrors `DispatchSlot` in volume.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct DispatchSlot {
    axis: u32,
    clip: u32,
    region: u32,
    _pad: u32,
}

/// The slot of a volume pass's dispatch over `region` of level `clip` (voxelisation: along `axis`).
fn slot_index(clip: usize, region: usize, axis: usize) -> usize {
    (clip * REGIONS + region) * 3 + axis
}

/// The `clips` nested cubes of `grid`³ voxels: the coarsest centred on `bounds` with a voxel of margin on
/// every side, each finer one half the voxel, centred on `camera` and snapped to two of its voxels. Every
/// level's region WHOLE_LEVEL is the whole level; the scroll regions are empty.
pub fn place_volume(bounds: crate::scene::Aabb, camera: glam::Vec3, grid: u32, clips: usize) -> VxgiVolume {
    let mut v = VxgiVolume::zeroed();
    let cubes = bounds.nested_cubes(camera, grid, clips, 2);
    for (k, cube) in cubes.iter().enumerate() {
        v.clips[k] = [cube.corner.x, cube.corner.y, cube.corner.z, cube.cell];
        v.corners[k] = cube.offset.extend(0).to_array();
        v.boxes[k * REGIONS + WHOLE_LEVEL] = [[0; 4], [grid as i32, grid as i32, grid as i32, 0]];
    }
    let origin = cubes.last().map_or(glam::Vec3::ZERO, |c| c.corner);
    v.origin = [origin.x, origin.y, origin.z, 0.0];
    v
}

/// The voxels a level of `grid`³ enters when it scrolls by `shift` (new voxel c is old voxel c + shift;
/// every component below `grid` in size): up to three disjoint slabs [lo, hi), across x, then y within
/// the x it kept, then z within the x and y it kept.
pub fn entered_slabs(grid: u32, shift: [i32; 3]) -> Vec<[[i32; 3]; 2]> {
    let n = grid as i32;
    let mut kept = [[0, n]; 3];
    let mut slabs = Vec::new();
    for axis in 0..3 {
        let d = shift[axis];
        if d == 0 {
            continue;
        }
        // New voxels c with c + d outside [0, n).
        let (entered, rest) = if d > 0 { ([n - d, n], [0, n - d]) } else { ([0, -d], [-d, n]) };
        let mut lo = [kept[0][0], kept[1][0], kept[2][0]];
        let mut hi = [kept[0][1], kept[1][1], kept[2][1]];
        lo[axis] = entered[0];
        hi[axis] = entered[1];
        slabs.push([lo, hi]);
        kept[axis] = rest;
    }
    slabs
}

/// The clipmap levels of (level, region) pairs, each once, in order.
fn levels_of(regions: &[(usize, usize)]) -> Vec<usize> {
    let mut levels: Vec<usize> = regions.iter().map(|&(k, _)| k).collect();
    levels.dedup();
    levels
}

/// What a frame does to one clipmap level's voxels.
#[derive(Clone, Copy, Debug, PartialEq)]
enum LevelWork {
    Keep,
    /// Voxelised and lit anew, all of it.
    Rebuild,
    /// Scrolled (by `volume.shifts`); the slabs it enters are its `volume.boxes` of regions 0..slabs.
    Scroll {
        slabs: usize,
    },
}

/// Half-angle of the diffuse cones in radians: `aperture_deg`, or (0) each cone's equal share of the
/// hemisphere's solid angle, 2π(1 − cos θ) = 2π / cones, at most 60°.
pub fn diffuse_half_angle(cones: u32, aperture_deg: f64) -> f64 {
    if aperture_deg > 0.0 {
        aperture_deg.to_radians()
    } else {
        (1.0 - 1.0 / f64::from(cones)).acos().min(60f64.to_radians())
    }
}

/// The settings every VXGI shader is specialised with.
#[derive(Clone, Copy, Debug)]
pub struct ShaderSettings {
    pub grid: u32,
    pub clips: u32,
    pub diffuse_cones: u32,
    pub diffuse_tan: f32,
    pub step: f32,
    /// In voxels of the coarsest level.
    pub max_distance: f32,
    pub specular_cone: bool,
    pub anisotropic: bool,
    pub inject_samples: u32,
    pub conservative: bool,
}

impl ShaderSettings {
    fn from_params(p: &ParamValues) -> Self {
        let grid = p.int("resolution") as u32;
        let diffuse_cones = p.int("diffuse_cones") as u32;
        ShaderSettings {
            grid,
            clips: p.int("clipmap_levels") as u32,
            diffuse_cones,
            diffuse_tan: diffuse_half_angle(diffuse_cones, p.float("aperture")).tan() as f32,
            step: p.float("step") as f32,
            max_distance: p.float("max_distance") as f32 * grid as f32,
            specular_cone: p.bool("specular_cone"),
            anisotropic: p.bool("anisotropic"),
            inject_samples: p.int("inject_samples") as u32,
            conservative: p.choice("voxelization") == "conservative",
        }
    }

    /// Mip levels of each clipmap level's radiance: the voxels, then each halving down to one voxel.
    pub fn levels(&self) -> u32 {
        self.grid.ilog2() + 1
    }

    pub fn defines(&self) -> Defines {
        // The narrowest cone advances STEP voxels a step; none needs more steps than its distance, in
        // each clipmap level it crosses.
        let per_level = (self.max_distance.min(3f32.sqrt() * self.grid as f32) / self.step).ceil() as u32;
        let max_steps = per_level * self.clips + 1;
        Defines::new()
            .u32("GRID", self.grid)
            .u32("CLIPS", self.clips)
            .u32("MAX_CLIPMAPS", MAX_CLIPMAPS as u32)
            .u32("REGIONS", REGIONS as u32)
            .f32("CLIP_MARGIN", CLIP_MARGIN)
            .u32("LEVELS", self.levels())
            .u32("DIFFUSE_CONES", self.diffuse_cones)
            .f32("DIFFUSE_TAN", self.diffuse_tan)
            .f32("STEP", self.step)
            .f32("MAX_DISTANCE", self.max_distance)
            .u32("MAX_CONE_STEPS", max_steps)
            .f32("CONE_START", CONE_START)
            .f32("FOOTPRINT_CAP", FOOTPRINT_CAP)
            .f32("MIN_SPECULAR_TAN", MIN_SPECULAR_TAN)
            .bool("SPECULAR_CONE", self.specular_cone)
            .bool("ANISOTROPIC", self.anisotropic)
            .u32("INJECT_SAMPLES", self.inject_samples)
            .bool("CONSERVATIVE", self.conservative)
            .u32("CLAIM_GROUP", CLAIM_GROUP)
            .u32("CLAIM_INDEX_BITS", CLAIM_INDEX_BITS)
            .u32("CLAIM_BRICK", CLAIM_BRICK)
    }
}

const VOLUME_WGSL: &str = include_str!("volume.wgsl");
const CONE_WGSL: &str = include_str!("cone.wgsl");

pub fn voxelize_source() -> String {
    format!("#import common/frame.wgsl\n{VOLUME_WGSL}\n{}", include_str!("voxelize.wgsl"))
}

pub fn conservative_source() -> String {
    format!("{}\n{}", voxelize_source(), include_str!("conservative.wgsl"))
}

pub fn inject_source() -> String {
    format!("#import common/frame.wgsl\n{VOLUME_WGSL}\n{CONE_WGSL}\n{}", include_str!("inject.wgsl"))
}

pub fn scroll_source() -> String {
    format!("{VOLUME_WGSL}\n{}", include_str!("scroll.wgsl"))
}

pub fn mips_source() -> String {
    include_str!("mips.wgsl").to_string()
}

pub fn shade_source() -> String {
    format!("#import common/frame.wgsl\n{VOLUME_WGSL}\n{CONE_WGSL}\n{}", include_str!("shade.wgsl"))
}

/// Bytes of a texture's mip chain.
fn texture_bytes(texture: &wgpu::Texture) -> u64 {
    let texel = texture.format().block_copy_size(None).unwrap_or(0) as u64;
    (0..texture.mip_level_count())
        .map(|level| {
            let s = texture.size().mip_level_size(level, texture.dimension());
            u64::from(s.width) * u64::from(s.height) * u64::from(s.depth_or_array_layers) * texel
        })
        .sum()
}

fn view_level(texture: &wgpu::Texture, level: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("vxgi level"),
        base_mip_level: level,
        mip_level_count: Some(1),
        ..Default::default()
    })
}

/// The voxels and radiance volumes on the GPU, and the pipelines over them.
pub struct Vxgi {
    settings: ShaderSettings,
    bounces: u32,
    every_frame: bool,
    direct: DirectLighting,
    _direct_texture: wgpu::Texture,
    volume_buffer: wgpu::Buffer,
    volume: VxgiVolume,
    voxel_albedo: wgpu::Texture,
    voxel_normal: wgpu::Texture,
    /// Level 0 of the first bounce, of the second (bounces = 2), and the directional levels
    /// (anisotropic). The isotropic mips live in the level-0 textures' own chains.
    lit: [wgpu::Texture; 2],
    directional: Option<wgpu::Texture>,
    /// Per dispatch of the volume passes: (clip level, region, axis), at slot_index.
    slots: DispatchSlots,
    scroll: Option<Scroller>,
    /// The layout of bind group 2, for passes outside the technique (the tests' cone probes).
    #[cfg_attr(not(test), allow(dead_code))]
    layout: wgpu::BindGroupLayout,
    /// Bind group 2 for: voxelisation and injection (writing lit[0]), the bounce (reading lit[0],
    /// writing lit[1]), and the camera's cones (reading the last bounce).
    inject_group: wgpu::BindGroup,
    bounce_group: wgpu::BindGroup,
    shade_group: wgpu::BindGroup,
    /// Per bounce, the bind groups of the directional levels 1.. (each from the level above).
    mip_groups: [Vec<wgpu::BindGroup>; 2],
    /// Per clipmap level, the slot of its directional mips' dispatches.
    mip_slots: DispatchSlots,
    mip_generator: MipGenerator,
    clear: wgpu::ComputePipeline,
    voxelize: wgpu::ComputePipeline,
    conservative: Option<Conservative>,
    inject: wgpu::ComputePipeline,
    bounce: wgpu::ComputePipeline,
    mip_from_base: wgpu::ComputePipeline,
    mip_from_directional: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    /// Per clipmap level: its voxels must be rebuilt (geometry changed).
    voxels_dirty: [bool; MAX_CLIPMAPS],
    light_dirty: bool,
    /// Levels scrolled and levels rebuilt, since creation.
    scrolls: u64,
    rebuilds: u64,
}

/// Conservative voxelisation's passes: claims, the resolve dispatch's arguments, the resolve; the buffer
/// of those arguments and its bind group (group 3 of the arguments pass). The claimed bricks' bits and
/// list are bound in group 2 of every pass (stand-ins of 16 bytes without conservative voxelisation).
struct Conservative {
    claim: wgpu::ComputePipeline,
    arguments: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    resolve_args: wgpu::Buffer,
    args_group: wgpu::BindGroup,
    brick_bits: wgpu::Buffer,
    claimed_bricks: wgpu::Buffer,
}

/// What scrolling a clipmap level needs: a scratch copy of one level's voxel words and radiance, and the
/// pass that shifts them back into the level.
struct Scroller {
    albedo: wgpu::Texture,
    normal: wgpu::Texture,
    radiance: wgpu::Texture,
    group: wgpu::BindGroup,
    voxels: wgpu::ComputePipeline,
    radiance_only: wgpu::ComputePipeline,
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    Ok(Box::new(Vxgi::new(setup)?))
}

impl Vxgi {
    pub fn new(setup: &TechniqueSetup) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let p = setup.params;
        let settings = ShaderSettings::from_params(p);
        let bounces = p.int("bounces") as u32;
        let n = settings.grid;
        if settings.conservative {
            crate::gpu::require(ctx, &[Need::TextureAtomics], "vxgi voxelization=conservative")?;
            let triangles = setup.gpu_scene.info.triangle_count;
            if triangles > MAX_CLAIMING_TRIANGLES {
                return Err(RenderError::InvalidSettings(format!(
                    "vxgi voxelization=conservative handles at most {MAX_CLAIMING_TRIANGLES} triangles and \
                     the scene has {triangles}; use voxelization=columns"
                )));
            }
        }
        let (width, height) = (setup.frame.width, setup.frame.height);
        let direct_texture = compute::storage_texture(ctx, "vxgi direct", width, height, OUTPUT_FORMAT);
        let direct = DirectLighting::new(setup, &direct_texture, DirectOutput::Accumulate)?;

        let clips = settings.clips;
        let volume =
            place_volume(setup.gpu_scene.bounds(), setup.frame.view.camera.position, n, clips as usize);
        let volume_buffer = {
            use wgpu::util::DeviceExt;
            ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("vxgi volume"),
                contents: bytemuck::bytes_of(&volume),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
        };
        let voxels = |label, usage| {
            TextureBuilder::d3(label, n, n, clips * n, VOXEL_FORMAT).storage().copy().usage(usage).build(ctx)
        };
        let voxel_albedo = voxels("vxgi voxel albedo", wgpu::TextureUsages::empty())?;
        // Conservative voxelisation claims voxels by atomic maxima into their normal words.
        let (normal_usage, normal_access) = if settings.conservative {
            (wgpu::TextureUsages::STORAGE_ATOMIC, wgpu::StorageTextureAccess::Atomic)
        } else {
            (wgpu::TextureUsages::empty(), wgpu::StorageTextureAccess::ReadWrite)
        };
        let voxel_normal = voxels("vxgi voxel normal", normal_usage)?;
        let radiance_mips = if settings.anisotropic { 1 } else { settings.levels() };
        // `size`³ per clipmap level, the levels stacked along z (stand-ins: one texel).
        let radiance = |label, size: u32| {
            let depth = if size == 1 { 1 } else { clips * size };
            TextureBuilder::d3(label, size, size, depth, RADIANCE_FORMAT)
                .mips(if size == 1 { 1 } else { radiance_mips })
                .storage()
                .sampled()
                .copy()
                .build(ctx)
        };
        // Stand-ins for the bindings a pass does not use: one written, one read (never the same texture
        // in both roles within a pass).
        let unused_target = radiance("vxgi unused target", 1)?;
        let unused_source = radiance("vxgi unused source", 1)?;
        let second =
            if bounces > 1 { radiance("vxgi radiance bounce 2", n)? } else { radiance("vxgi unused", 1)? };
        let lit = [radiance("vxgi radiance", n)?, second];
        let directional = if settings.anisotropic {
            Some(
                TextureBuilder::d3("vxgi directional radiance", 3 * n, n / 2, clips * n / 2, RADIANCE_FORMAT)
                    .mips(n.ilog2())
                    .storage()
                    .sampled()
                    .copy()
                    .build(ctx)?,
            )
        } else {
            None
        };
        // Claimed bricks: a bit each and a list (a count, then up to one entry each).
        let bricks = if settings.conservative { u64::from(n / CLAIM_BRICK).pow(3) } else { 0 };
        let brick_bits =
            compute::storage_buffer(ctx, "vxgi claimed brick bits", (bricks.div_ceil(32) * 4).max(16));
        let claimed_bricks = compute::storage_buffer(ctx, "vxgi claimed bricks", (4 + bricks * 4).max(16));
        let slot_values: Vec<DispatchSlot> = (0..clips)
            .flat_map(|clip| (0..REGIONS as u32).map(move |region| (clip, region)))
            .flat_map(|(clip, region)| (0..3).map(move |axis| DispatchSlot { axis, clip, region, _pad: 0 }))
            .collect();
        let slots = DispatchSlots::new(ctx, "vxgi dispatch slots", &slot_values);

        let filterable = wgpu::TextureSampleType::Float { filterable: true };
        let layout = compute::layout(
            ctx,
            "vxgi",
            &[
                compute::uniform_entry(0),
                compute::storage_texture_3d_entry(1, VOXEL_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
                compute::storage_texture_3d_entry(2, VOXEL_FORMAT, normal_access),
                compute::storage_texture_3d_entry(3, RADIANCE_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
                compute::texture_3d_entry(4, filterable),
                compute::texture_3d_entry(5, filterable),
                compute::filtering_sampler_entry(6),
                compute::texture_entry(7, wgpu::TextureSampleType::Float { filterable: false }),
                compute::storage_texture_entry(8, OUTPUT_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
                slots.entry(9),
                compute::storage_buffer_entry(10, false),
                compute::storage_buffer_entry(11, false),
            ],
        );
        let sampler = ctx.device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("vxgi radiance"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let full = |t: &wgpu::Texture| t.create_view(&Default::default());
        let directional_view = full(directional.as_ref().unwrap_or(&unused_source));
        let direct_view = full(&direct_texture);
        let output_view = full(setup.output);
        let (albedo_view, normal_view) = (full(&voxel_albedo), full(&voxel_normal));
        let group = |label: &str, out: &wgpu::TextureView, base: &wgpu::TextureView| {
            compute::bind_group(
                ctx,
                label,
                &layout,
                &[
                    volume_buffer.as_entire_binding(),
                    wgpu::BindingResource::TextureView(&albedo_view),
                    wgpu::BindingResource::TextureView(&normal_view),
                    wgpu::BindingResource::TextureView(out),
                    wgpu::BindingResource::TextureView(base),
                    wgpu::BindingResource::TextureView(&directional_view),
                    wgpu::BindingResource::Sampler(&sampler),
                    wgpu::BindingResource::TextureView(&direct_view),
                    wgpu::BindingResource::TextureView(&output_view),
                    slots.resource(),
                    brick_bits.as_entire_binding(),
                    claimed_bricks.as_entire_binding(),
                ],
            )
        };
        let last = &lit[(bounces - 1) as usize];
        let inject_group = group("vxgi injection", &view_level(&lit[0], 0), &full(&unused_source));
        let bounce_group = group("vxgi bounce", &view_level(&lit[1], 0), &full(&lit[0]));
        let shade_group = group("vxgi cone tracing", &view_level(&unused_target, 0), &full(last));

        // One dispatch slot per clipmap level: the directional mips are filtered level by level, for
        // the levels whose voxels changed.
        let mip_slots =
            DispatchSlots::new(ctx, "vxgi mip slots", &(0..clips).map(|k| [k, 0, 0, 0]).collect::<Vec<_>>());
        let mip_layout = compute::layout(
            ctx,
            "vxgi mips",
            &[
                compute::texture_3d_entry(0, wgpu::TextureSampleType::Float { filterable: false }),
                compute::storage_texture_3d_entry(1, RADIANCE_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
                mip_slots.entry(2),
            ],
        );
        let mip_groups = [0, 1].map(|b| match &directional {
            Some(d) if b < bounces as usize => (1..settings.levels())
                .map(|m| {
                    let source = if m == 1 { view_level(&lit[b], 0) } else { view_level(d, m - 2) };
                    let target = view_level(d, m - 1);
                    compute::bind_group(
                        ctx,
                        "vxgi mip level",
                        &mip_layout,
                        &[
                            wgpu::BindingResource::TextureView(&source),
                            wgpu::BindingResource::TextureView(&target),
                            mip_slots.resource(),
                        ],
                    )
                })
                .collect(),
            _ => Vec::new(),
        });

        // Voxelisation traces (its conservative coverage test): the scene's traversal variant.
        let defines = setup.gpu_scene.bvh_defines(settings.defines());
        let layouts = [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout];
        let pipeline = |name: &str, source: &str, entry: &str| {
            compute::pipeline(ctx, name, source, defines.clone(), entry, &layouts)
        };
        let mip_pipeline = |entry: &str| {
            compute::pipeline(ctx, "vxgi mips", &mips_source(), defines.clone(), entry, &[&mip_layout])
        };
        let (voxelize_wgsl, inject_wgsl) = (voxelize_source(), inject_source());
        let scroll = if clips > 1 && p.bool("scroll") {
            let scratch =
                |label, format| TextureBuilder::d3(label, n, n, n, format).sampled().copy().build(ctx);
            let (albedo, normal) =
                (scratch("vxgi scroll albedo", VOXEL_FORMAT)?, scratch("vxgi scroll normal", VOXEL_FORMAT)?);
            let radiance = scratch("vxgi scroll radiance", RADIANCE_FORMAT)?;
            let uint = wgpu::TextureSampleType::Uint;
            let scratch_layout = compute::layout(
                ctx,
                "vxgi scroll",
                &[
                    compute::texture_3d_entry(0, uint),
                    compute::texture_3d_entry(1, uint),
                    compute::texture_3d_entry(2, wgpu::TextureSampleType::Float { filterable: false }),
                ],
            );
            let group = compute::bind_group(
                ctx,
                "vxgi scroll",
                &scratch_layout,
                &[
                    wgpu::BindingResource::TextureView(&full(&albedo)),
                    wgpu::BindingResource::TextureView(&full(&normal)),
                    wgpu::BindingResource::TextureView(&full(&radiance)),
                ],
            );
            let layouts = [layouts[0], layouts[1], layouts[2], &scratch_layout];
            let pipeline = |entry: &str| {
                compute::pipeline(ctx, "vxgi scroll", &scroll_source(), defines.clone(), entry, &layouts)
            };
            Some(Scroller {
                voxels: pipeline("scroll_voxels")?,
                radiance_only: pipeline("scroll_radiance")?,
                albedo,
                normal,
                radiance,
                group,
            })
        } else {
            None
        };
        Ok(Vxgi {
            bounces,
            every_frame: p.choice("update") == "every-frame",
            direct,
            _direct_texture: direct_texture,
            volume_buffer,
            volume,
            clear: pipeline("vxgi clear", &voxelize_wgsl, "clear_voxels")?,
            voxelize: pipeline("vxgi voxelization", &voxelize_wgsl, "voxelize")?,
            conservative: if settings.conservative {
                let wgsl = conservative_source();
                let defines =
                    defines.clone().u32("MAX_WORKGROUPS", ctx.limits().max_compute_workgroups_per_dimension);
                let args_layout = compute::layout(
                    ctx,
                    "vxgi resolve arguments",
                    &[compute::storage_buffer_entry(0, false)],
                );
                let resolve_args = ctx.device.create_buffer(
                    &crate::gpu::BufferBuilder::new("vxgi resolve arguments", 16)
                        .storage()
                        .usage(wgpu::BufferUsages::INDIRECT)
                        .descriptor(),
                );
                let args_group = compute::bind_group(
                    ctx,
                    "vxgi resolve arguments",
                    &args_layout,
                    &[resolve_args.as_entire_binding()],
                );
                let pipeline = |entry: &str, layouts: &[&wgpu::BindGroupLayout]| {
                    compute::pipeline(ctx, "vxgi voxelization", &wgsl, defines.clone(), entry, layouts)
                };
                let with_args = [layouts[0], layouts[1], layouts[2], &args_layout];
                Some(Conservative {
                    claim: pipeline("claim_voxels", &layouts)?,
                    arguments: pipeline("resolve_arguments", &with_args)?,
                    resolve: pipeline("resolve_claims", &layouts)?,
                    resolve_args,
                    args_group,
                    brick_bits,
                    claimed_bricks,
                })
            } else {
                None
            },
            inject: pipeline("vxgi injection", &inject_wgsl, "inject")?,
            bounce: pipeline("vxgi bounce", &inject_wgsl, "bounce")?,
            mip_from_base: mip_pipeline("from_base")?,
            mip_from_directional: mip_pipeline("from_directional")?,
            shade: pipeline("vxgi cone tracing", &shade_source(), "main")?,
            settings,
            voxel_albedo,
            voxel_normal,
            lit,
            directional,
            slots,
            scroll,
            layout,
            inject_group,
            bounce_group,
            shade_group,
            mip_groups,
            mip_slots,
            mip_generator: MipGenerator::new(),
            voxels_dirty: [true; MAX_CLIPMAPS],
            light_dirty: true,
            scrolls: 0,
            rebuilds: 0,
        })
    }

    /// Workgroups (4³ voxels each) over a region's box.
    fn box_workgroups(&self, clip: usize, region: usize) -> [u32; 3] {
        let [lo, hi] = self.volume.boxes[clip * REGIONS + region];
        std::array::from_fn(|a| ((hi[a] - lo[a]).max(0) as u32).div_ceil(4))
    }

    /// Records `pipeline` over the scene, the frame, `group` and (the scroll's scratch) `extra`
    /// (dispatch slot `slot`).
    fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        fc: &FrameContext,
        (name, pipeline): (&str, &wgpu::ComputePipeline),
        (group, extra): (&wgpu::BindGroup, Option<&wgpu::BindGroup>),
        slot: usize,
        workgroups: [u32; 3],
    ) {
        let (scene, frame) = (&fc.gpu_scene.bind_group, &fc.frame.bind_group);
        let mut pass = crate::gpu::dispatch::compute_pass(encoder, name, pipeline, &[scene, frame]);
        pass.set_bind_group(2, group, &[self.slots.offsets().nth(slot).unwrap_or(0)]);
        if let Some(extra) = extra {
            pass.set_bind_group(3, extra, &[]);
        }
        pass.dispatch_workgroups(workgroups[0], workgroups[1], workgroups[2]);
    }

    /// Shifts the voxels and radiance of each scrolled level in `levels` by its `volume.shifts`, clearing
    /// what it enters (pass "vxgi scroll").
    fn scroll(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        levels: &[usize],
    ) -> Result<(), RenderError> {
        let Some(scroll) = &self.scroll else { return Ok(()) };
        let n = self.settings.grid;
        let copy = |e: &mut wgpu::CommandEncoder, from: &wgpu::Texture, to: &wgpu::Texture, k: usize| {
            e.copy_texture_to_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: from,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: 0, y: 0, z: k as u32 * n },
                    aspect: wgpu::TextureAspect::All,
                },
                to.as_image_copy(),
                wgpu::Extent3d { width: n, height: n, depth_or_array_layers: n },
            );
        };
        let workgroups = [n.div_ceil(4); 3];
        profiler.pass(fc.ctx, "vxgi scroll", |e| {
            for &k in levels {
                copy(e, &self.voxel_albedo, &scroll.albedo, k);
                copy(e, &self.voxel_normal, &scroll.normal, k);
                copy(e, &self.lit[0], &scroll.radiance, k);
                let slot = slot_index(k, WHOLE_LEVEL, 0);
                let pass = ("vxgi scroll", &scroll.voxels);
                self.record(e, fc, pass, (&self.inject_group, Some(&scroll.group)), slot, workgroups);
                if self.bounces > 1 {
                    copy(e, &self.lit[1], &scroll.radiance, k);
                    let pass = ("vxgi scroll", &scroll.radiance_only);
                    self.record(e, fc, pass, (&self.bounce_group, Some(&scroll.group)), slot, workgroups);
                }
            }
        })?;
        Ok(())
    }

    /// Voxelises the scene into the voxel words of each (level, region) in `regions`; a whole level is
    /// cleared first (pass "vxgi voxelization").
    fn voxelize(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        regions: &[(usize, usize)],
    ) -> Result<(), RenderError> {
        profiler.pass(fc.ctx, "vxgi voxelization", |e| {
            for &(k, r) in regions {
                if r == WHOLE_LEVEL {
                    let clear = ("vxgi clear", &self.clear);
                    let workgroups = self.box_workgroups(k, r);
                    self.record(e, fc, clear, (&self.inject_group, None), slot_index(k, r, 0), workgroups);
                }
                let [lo, hi] = self.volume.boxes[k * REGIONS + r];
                for axis in 0..3 {
                    // One thread per column along the axis, over the box's other two axes.
                    let across = |a: usize| ((hi[a] - lo[a]).max(0) as u32).div_ceil(8);
                    let columns = [across((axis + 1) % 3), across((axis + 2) % 3), 1];
                    let pass = ("vxgi voxelization", &self.voxelize);
                    self.record(e, fc, pass, (&self.inject_group, None), slot_index(k, r, axis), columns);
                }
                if let Some(c) = &self.conservative {
                    self.record_conservative(e, fc, c, slot_index(k, r, 0));
                }
            }
        })?;
        Ok(())
    }

    /// Records conservative voxelisation's passes over the box of dispatch slot `slot`, after its column
    /// rays: every triangle's claims, then the resolve of the claimed bricks.
    fn record_conservative(
        &self,
        e: &mut wgpu::CommandEncoder,
        fc: &FrameContext,
        c: &Conservative,
        slot: usize,
    ) {
        let name = "vxgi voxelization";
        e.clear_buffer(&c.brick_bits, 0, None);
        e.clear_buffer(&c.claimed_bricks, 0, Some(4));
        let most = fc.ctx.limits().max_compute_workgroups_per_dimension;
        let [x, y, _] = workgroups_for(fc.gpu_scene.info.triangle_count, CLAIM_GROUP, most);
        // Slices of each workgroup's columns, so that at least CLAIM_WORKGROUPS workgroups share them.
        let slices = CLAIM_WORKGROUPS.div_ceil((x * y).max(1)).clamp(1, most);
        self.record(e, fc, (name, &c.claim), (&self.inject_group, None), slot, [x, y, slices]);
        self.record(e, fc, (name, &c.arguments), (&self.inject_group, Some(&c.args_group)), slot, [1, 1, 1]);
        let (scene, frame) = (&fc.gpu_scene.bind_group, &fc.frame.bind_group);
        let mut pass = crate::gpu::dispatch::compute_pass(e, name, &c.resolve, &[scene, frame]);
        pass.set_bind_group(2, &self.inject_group, &[self.slots.offsets().nth(slot).unwrap_or(0)]);
        pass.dispatch_workgroups_indirect(&c.resolve_args, 0);
    }

    /// Records `pipeline` over the voxels of each (level, region) in `regions` (pass `name`).
    fn over_regions(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        (name, pipeline): (&str, &wgpu::ComputePipeline),
        group: &wgpu::BindGroup,
        regions: &[(usize, usize)],
    ) -> Result<(), RenderError> {
        profiler.pass(fc.ctx, name, |e| {
            for &(k, r) in regions {
                let workgroups = self.box_workgroups(k, r);
                self.record(e, fc, (name, pipeline), (group, None), slot_index(k, r, 0), workgroups);
            }
        })?;
        Ok(())
    }

    /// The mips of bounce `b`'s radiance in the clipmap levels `levels` (directional mips; isotropic
    /// mips are filtered over the whole texture), pass `name`.
    fn build_mips(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        (b, name): (usize, &str),
        levels: &[usize],
    ) -> Result<(), RenderError> {
        let ctx = fc.ctx;
        let mut failure = None;
        profiler.pass(ctx, name, |e| {
            if self.directional.is_none() {
                failure = self.mip_generator.record(ctx, e, &self.lit[b]).err();
                return;
            }
            for (m, group) in self.mip_groups[b].iter().enumerate() {
                let pipeline = if m == 0 { &self.mip_from_base } else { &self.mip_from_directional };
                let size = (self.settings.grid >> (m + 1)).max(1);
                for &k in levels {
                    let mut pass = crate::gpu::dispatch::compute_pass(e, name, pipeline, &[]);
                    pass.set_bind_group(0, group, &[self.mip_slots.offsets().nth(k).unwrap_or(0)]);
                    pass.dispatch_workgroups(size.div_ceil(4), size.div_ceil(4), size.div_ceil(4));
                }
            }
        })?;
        failure.map_or(Ok(()), |e| Err(e.into()))
    }

    /// What this frame does to each level, with `volume` (where the levels now lie) given the scroll
    /// boxes and shifts of the levels that scroll.
    fn plan(&self, volume: &mut VxgiVolume) -> [LevelWork; MAX_CLIPMAPS] {
        let n = self.settings.grid as i32;
        let mut work = [LevelWork::Keep; MAX_CLIPMAPS];
        for (k, work) in work.iter_mut().enumerate().take(self.settings.clips as usize) {
            if self.every_frame || self.voxels_dirty[k] {
                *work = LevelWork::Rebuild;
                continue;
            }
            if volume.same_level(&self.volume, k) {
                continue;
            }
            let shift: [i32; 3] = std::array::from_fn(|a| volume.corners[k][a] - self.volume.corners[k][a]);
            let lattice_kept =
                volume.origin == self.volume.origin && volume.clips[k][3] == self.volume.clips[k][3];
            if self.scroll.is_none() || !lattice_kept || shift.iter().any(|d| d.abs() >= n) {
                *work = LevelWork::Rebuild;
                continue;
            }
            let slabs = entered_slabs(self.settings.grid, shift);
            for (r, [lo, hi]) in slabs.iter().enumerate() {
                volume.boxes[k * REGIONS + r] = [[lo[0], lo[1], lo[2], 0], [hi[0], hi[1], hi[2], 0]];
            }
            volume.shifts[k] = [shift[0], shift[1], shift[2], 0];
            *work = LevelWork::Scroll { slabs: slabs.len() };
        }
        work
    }

    /// Brings the voxels and the radiance volumes up to date with the scene and the camera (clipmap
    /// levels that moved).
    fn update(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let clips = self.settings.clips as usize;
        let mut volume =
            place_volume(fc.gpu_scene.bounds(), fc.view.camera.position, self.settings.grid, clips);
        let work = self.plan(&mut volume);
        if volume != self.volume {
            self.volume = volume;
            fc.ctx.queue.write_buffer(&self.volume_buffer, 0, bytemuck::bytes_of(&volume));
        }
        let levels = 0..clips;
        let scrolled: Vec<usize> =
            levels.clone().filter(|&k| matches!(work[k], LevelWork::Scroll { .. })).collect();
        let rebuilt = levels.clone().filter(|&k| work[k] == LevelWork::Rebuild);
        // The regions whose voxels are new this frame: whole levels rebuilt, slabs scrolled into.
        let fresh: Vec<(usize, usize)> = levels
            .clone()
            .flat_map(|k| {
                match work[k] {
                    LevelWork::Keep => 0..0,
                    LevelWork::Rebuild => WHOLE_LEVEL..WHOLE_LEVEL + 1,
                    LevelWork::Scroll { slabs } => 0..slabs,
                }
                .map(move |r| (k, r))
            })
            .collect();
        self.scrolls += scrolled.len() as u64;
        self.rebuilds += rebuilt.clone().count() as u64;
        if !scrolled.is_empty() {
            self.scroll(fc, profiler, &scrolled)?;
        }
        if !fresh.is_empty() {
            self.voxelize(fc, profiler, &fresh)?;
        }
        // New light everywhere when lights change, else in the voxels that are new; the second bounce
        // reads every level, so it follows any rebuild or light change, but a scroll only brings the
        // slabs it enters.
        let all: Vec<(usize, usize)> = levels.map(|k| (k, WHOLE_LEVEL)).collect();
        // Both bounces filter into the one directional texture, which holds the second bounce's mips
        // between frames: with two, every level's mips are filtered again for each (the bounce pass
        // reads the first bounce's everywhere); with one, those of the levels that changed.
        let mip_levels =
            |regions: &[(usize, usize)]| levels_of(if self.bounces > 1 { &all } else { regions });
        let lit = if self.light_dirty { &all } else { &fresh };
        if !lit.is_empty() {
            let inject = ("vxgi injection", &self.inject);
            self.over_regions(fc, profiler, inject, &self.inject_group, lit)?;
            self.build_mips(fc, profiler, (0, "vxgi mips"), &mip_levels(lit))?;
        }
        let bounced = if self.light_dirty || rebuilt.count() > 0 { &all } else { &fresh };
        if self.bounces > 1 && !bounced.is_empty() {
            let pass = ("vxgi bounce", &self.bounce);
            self.over_regions(fc, profiler, pass, &self.bounce_group, bounced)?;
            self.build_mips(fc, profiler, (1, "vxgi bounce mips"), &mip_levels(bounced))?;
        }
        self.voxels_dirty = [false; MAX_CLIPMAPS];
        self.light_dirty = false;
        Ok(())
    }
}

impl Technique for Vxgi {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        self.update(fc, profiler)?;
        self.direct.render(fc, profiler)?;
        let workgroups = [fc.frame.width.div_ceil(compute::TILE), fc.frame.height.div_ceil(compute::TILE), 1];
        profiler.pass(fc.ctx, "vxgi cone tracing", |e| {
            self.record(e, fc, ("vxgi cone tracing", &self.shade), (&self.shade_group, None), 0, workgroups);
        })?;
        Ok(())
    }

    fn scene_changed(
        &mut self,
        _: &GpuContext,
        _: &GpuScene,
        change: SceneChange,
    ) -> Result<bool, RenderError> {
        match change {
            SceneChange::Lights | SceneChange::Environment | SceneChange::EnvironmentRotation => {
                self.light_dirty = true
            }
            SceneChange::Geometry => self.voxels_dirty = [true; MAX_CLIPMAPS],
        }
        Ok(true)
    }

    fn counters(&mut self, _: &GpuContext, _: &Measured) -> Result<BTreeMap<String, f64>, RenderError> {
        let mut c = BTreeMap::new();
        let voxels = texture_bytes(&self.voxel_albedo) + texture_bytes(&self.voxel_normal);
        let radiance: u64 = self.lit.iter().map(texture_bytes).sum();
        c.insert("vxgi_voxel_bytes".into(), voxels as f64);
        c.insert("vxgi_radiance_bytes".into(), radiance as f64);
        c.insert("vxgi_directional_bytes".into(), self.directional.as_ref().map_or(0, texture_bytes) as f64);
        // The finest level's voxel; with clipmaps, each level's too.
        c.insert("vxgi_voxel_size".into(), f64::from(self.volume.clips[0][3]));
        c.insert("vxgi_levels".into(), f64::from(self.settings.levels()));
        c.insert("vxgi_clipmap_levels".into(), f64::from(self.settings.clips));
        c.insert("vxgi_level_scrolls".into(), self.scrolls as f64);
        c.insert("vxgi_level_rebuilds".into(), self.rebuilds as f64);
        let scratch = self
            .scroll
            .as_ref()
            .map_or(0, |s| [&s.albedo, &s.normal, &s.radiance].map(texture_bytes).iter().sum());
        c.insert("vxgi_scroll_scratch_bytes".into(), scratch as f64);
        // Conservative voxelisation's claimed-brick bits and list.
        let claims = self.conservative.as_ref().map_or(0, |c| c.brick_bits.size() + c.claimed_bricks.size());
        c.insert("vxgi_claim_bytes".into(), claims as f64);
        for k in 1..self.settings.clips as usize {
            c.insert(format!("vxgi_clip{k}_voxel_size"), f64::from(self.volume.clips[k][3]));
        }
        Ok(c)
    }
}
