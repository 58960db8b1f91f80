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
//! rasterisation without the conservative mode; compute is fast and raster slow on the GPUs rtgi
//! targets), and injection lights each voxel with the same direct-light routine as the camera's
//! pixels (traced shadow rays instead of a shadow map; emissive triangles and the environment
//! included) instead of splatting a light-view map.
//!
//! Clipmaps (`clipmap_levels` > 1): nested volumes of the same resolution, the coarsest over the scene,
//! each finer one half the voxel and centred on the camera, snapped to two of its voxels (its mip 1 then
//! lines up with the next level's voxels). A cone sample reads the finest level that holds it and is
//! as fine as its diameter needs. A level is voxelised and lit again when it moves; a production
//! engine would scroll it (toroidal addressing) and update only the new slabs.

#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};

use crate::frame::OUTPUT_FORMAT;
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
/// Storage format of the radiance volumes (filterable, writable as storage everywhere).
const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Voxel words (albedo + count, normal), read and written by voxelisation.
const VOXEL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
/// Most clipmap levels.
pub const MAX_CLIPMAPS: usize = 4;
/// A cone sample uses a finer clipmap level only this many of its voxels inside its border: filtering
/// at its mip 1 reads a voxel of 2 around the sample.
const CLIP_MARGIN: f32 = 2.0;

const VXGI_PARAMS: [ParamSpec; 19] = with_direct_params!(
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
}

/// Mirrors `DispatchSlot` in volume.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct DispatchSlot {
    axis: u32,
    clip: u32,
    _pad: [u32; 2],
}

/// The `clips` nested cubes of `grid`³ voxels: the coarsest centred on `bounds` with a voxel of margin on
/// every side, each finer one half the voxel, centred on `camera` and snapped to two of its voxels.
pub fn place_volume(bounds: crate::scene::Aabb, camera: glam::Vec3, grid: u32, clips: usize) -> VxgiVolume {
    let mut v = VxgiVolume::zeroed();
    for (k, (corner, voxel)) in bounds.nested_cubes(camera, grid, clips, 2).into_iter().enumerate() {
        v.clips[k] = [corner.x, corner.y, corner.z, voxel];
    }
    v
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
    }
}

const VOLUME_WGSL: &str = include_str!("volume.wgsl");
const CONE_WGSL: &str = include_str!("cone.wgsl");

pub fn voxelize_source() -> String {
    format!("#import common/frame.wgsl\n{VOLUME_WGSL}\n{}", include_str!("voxelize.wgsl"))
}

pub fn inject_source() -> String {
    format!("#import common/frame.wgsl\n{VOLUME_WGSL}\n{CONE_WGSL}\n{}", include_str!("inject.wgsl"))
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
    /// Per dispatch of the volume passes: (clip level, axis), slot 3 × clip + axis.
    slots: DispatchSlots,
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
    mip_generator: MipGenerator,
    clear: wgpu::ComputePipeline,
    voxelize: wgpu::ComputePipeline,
    inject: wgpu::ComputePipeline,
    bounce: wgpu::ComputePipeline,
    mip_from_base: wgpu::ComputePipeline,
    mip_from_directional: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    /// Per clipmap level: its voxels must be rebuilt (it moved, geometry changed).
    voxels_dirty: [bool; MAX_CLIPMAPS],
    light_dirty: bool,
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
        let voxels =
            |label| TextureBuilder::d3(label, n, n, clips * n, VOXEL_FORMAT).storage().copy().build(ctx);
        let voxel_albedo = voxels("vxgi voxel albedo")?;
        let voxel_normal = voxels("vxgi voxel normal")?;
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
        let slot_values: Vec<DispatchSlot> = (0..clips)
            .flat_map(|clip| (0..3).map(move |axis| DispatchSlot { axis, clip, _pad: [0; 2] }))
            .collect();
        let slots = DispatchSlots::new(ctx, "vxgi dispatch slots", &slot_values);

        let filterable = wgpu::TextureSampleType::Float { filterable: true };
        let layout = compute::layout(
            ctx,
            "vxgi",
            &[
                compute::uniform_entry(0),
                compute::storage_texture_3d_entry(1, VOXEL_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
                compute::storage_texture_3d_entry(2, VOXEL_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
                compute::storage_texture_3d_entry(3, RADIANCE_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
                compute::texture_3d_entry(4, filterable),
                compute::texture_3d_entry(5, filterable),
                compute::filtering_sampler_entry(6),
                compute::texture_entry(7, wgpu::TextureSampleType::Float { filterable: false }),
                compute::storage_texture_entry(8, OUTPUT_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
                slots.entry(9),
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
                ],
            )
        };
        let last = &lit[(bounces - 1) as usize];
        let inject_group = group("vxgi injection", &view_level(&lit[0], 0), &full(&unused_source));
        let bounce_group = group("vxgi bounce", &view_level(&lit[1], 0), &full(&lit[0]));
        let shade_group = group("vxgi cone tracing", &view_level(&unused_target, 0), &full(last));

        let mip_layout = compute::layout(
            ctx,
            "vxgi mips",
            &[
                compute::texture_3d_entry(0, wgpu::TextureSampleType::Float { filterable: false }),
                compute::storage_texture_3d_entry(1, RADIANCE_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
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
        Ok(Vxgi {
            bounces,
            every_frame: p.choice("update") == "every-frame",
            direct,
            _direct_texture: direct_texture,
            volume_buffer,
            volume,
            clear: pipeline("vxgi clear", &voxelize_wgsl, "clear_voxels")?,
            voxelize: pipeline("vxgi voxelization", &voxelize_wgsl, "voxelize")?,
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
            layout,
            inject_group,
            bounce_group,
            shade_group,
            mip_groups,
            mip_generator: MipGenerator::new(),
            voxels_dirty: [true; MAX_CLIPMAPS],
            light_dirty: true,
        })
    }

    fn volume_workgroups(&self) -> [u32; 3] {
        [self.settings.grid.div_ceil(4); 3]
    }

    /// Records `pipeline` over the scene, the frame and `group` (dispatch slot `slot`: 3 × clip + axis).
    fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        fc: &FrameContext,
        (name, pipeline): (&str, &wgpu::ComputePipeline),
        group: &wgpu::BindGroup,
        slot: usize,
        workgroups: [u32; 3],
    ) {
        let (scene, frame) = (&fc.gpu_scene.bind_group, &fc.frame.bind_group);
        let mut pass = crate::gpu::dispatch::compute_pass(encoder, name, pipeline, &[scene, frame]);
        pass.set_bind_group(2, group, &[self.slots.offsets().nth(slot).unwrap_or(0)]);
        pass.dispatch_workgroups(workgroups[0], workgroups[1], workgroups[2]);
    }

    /// Voxelises the scene into the voxel words of the clipmap levels in `levels` (pass "vxgi
    /// voxelization").
    fn voxelize(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        levels: &[usize],
    ) -> Result<(), RenderError> {
        let n = self.settings.grid;
        profiler.pass(fc.ctx, "vxgi voxelization", |e| {
            for &k in levels {
                let clear = ("vxgi clear", &self.clear);
                self.record(e, fc, clear, &self.inject_group, 3 * k, self.volume_workgroups());
                for axis in 0..3 {
                    let columns = [n.div_ceil(8), n.div_ceil(8), 1];
                    let pass = ("vxgi voxelization", &self.voxelize);
                    self.record(e, fc, pass, &self.inject_group, 3 * k + axis, columns);
                }
            }
        })?;
        Ok(())
    }

    /// Records `pipeline` over every voxel of the clipmap levels in `levels` (pass `name`).
    fn over_levels(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        (name, pipeline): (&str, &wgpu::ComputePipeline),
        group: &wgpu::BindGroup,
        levels: &[usize],
    ) -> Result<(), RenderError> {
        profiler.pass(fc.ctx, name, |e| {
            for &k in levels {
                self.record(e, fc, (name, pipeline), group, 3 * k, self.volume_workgroups());
            }
        })?;
        Ok(())
    }

    /// The mips of bounce `b`'s radiance (pass `name`).
    fn build_mips(
        &self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        b: usize,
        name: &str,
    ) -> Result<(), RenderError> {
        let ctx = fc.ctx;
        let mut failure = None;
        profiler.pass(ctx, name, |e| {
            if self.directional.is_none() {
                failure = self.mip_generator.record(ctx, e, &self.lit[b]).err();
                return;
            }
            for (k, group) in self.mip_groups[b].iter().enumerate() {
                let pipeline = if k == 0 { &self.mip_from_base } else { &self.mip_from_directional };
                let size = (self.settings.grid >> (k + 1)).max(1);
                let depth = size * self.settings.clips;
                compute::dispatch(
                    e,
                    name,
                    pipeline,
                    &[group],
                    [size.div_ceil(4), size.div_ceil(4), depth.div_ceil(4)],
                );
            }
        })?;
        failure.map_or(Ok(()), |e| Err(e.into()))
    }

    /// Brings the voxels and the radiance volumes up to date with the scene and the camera (clipmap
    /// levels that moved).
    fn update(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let clips = self.settings.clips as usize;
        let volume = place_volume(fc.gpu_scene.bounds(), fc.view.camera.position, self.settings.grid, clips);
        if volume != self.volume {
            for k in 0..clips {
                self.voxels_dirty[k] |= volume.clips[k] != self.volume.clips[k];
            }
            self.volume = volume;
            fc.ctx.queue.write_buffer(&self.volume_buffer, 0, bytemuck::bytes_of(&volume));
        }
        if self.every_frame {
            self.voxels_dirty = [true; MAX_CLIPMAPS];
        }
        let dirty: Vec<usize> = (0..clips).filter(|&k| self.voxels_dirty[k]).collect();
        if !dirty.is_empty() {
            self.voxelize(fc, profiler, &dirty)?;
        }
        // New light everywhere when lights change, else in the levels voxelised again; the second
        // bounce reads every level, so it follows any change.
        let all: Vec<usize> = (0..clips).collect();
        let lit = if self.light_dirty { &all } else { &dirty };
        if !lit.is_empty() {
            self.over_levels(fc, profiler, ("vxgi injection", &self.inject), &self.inject_group, lit)?;
            self.build_mips(fc, profiler, 0, "vxgi mips")?;
            if self.bounces > 1 {
                let pass = ("vxgi bounce", &self.bounce);
                self.over_levels(fc, profiler, pass, &self.bounce_group, &all)?;
                self.build_mips(fc, profiler, 1, "vxgi bounce mips")?;
            }
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
            self.record(e, fc, ("vxgi cone tracing", &self.shade), &self.shade_group, 0, workgroups);
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
        for k in 1..self.settings.clips as usize {
            c.insert(format!("vxgi_clip{k}_voxel_size"), f64::from(self.volume.clips[k][3]));
        }
        Ok(c)
    }
}
