//! `lpv`: light propagation volumes (Kaplanyan & Dachsbacher 2010, "Cascaded light propagation volumes
//! for real-time indirect illumination").
//!
//! Per frame: every texel of the lights' reflective shadow maps (the RSM of the `rsm` techniques) is
//! injected as a virtual point light into a grid of order-1 SH per colour channel; the surfaces the
//! RSMs and the G-buffer see are injected as blocking potentials into a geometry volume offset by half
//! a cell; the light propagates iteratively to the 6 neighbours of each cell through the faces they
//! see, attenuated by the geometry volume (optionally reflecting what it blocks by the blockers' albedo:
//! further bounces), and every step adds into the accumulated volume; camera
//! pixels read it trilinearly with their normal. Cascades: the coarsest grid covers the scene, each
//! finer one halves the cell and follows the camera, snapped to whole cells of its own so that moving
//! does not change what a cell holds (no flicker).
//!
//! Passes: "rsm" (when lights or geometry change), "direct lighting", "lpv flux scale", "lpv
//! injection", "lpv geometry injection" (G-buffer blockers), "lpv resolve", "lpv propagation" (all
//! steps), "lpv lookup". Everything is rebuilt every frame from the current scene, so the technique is
//! correct in motion and keeps no history.

#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::dispatch::workgroups_for;
use crate::gpu::{GpuContext, GpuScene, Profiler};
use crate::params::{ParamKind, ParamSpec};
use crate::shaders::Defines;
use crate::techniques::compute::{self, DispatchSlots, storage_buffer_entry, storage_texture_entry};
use crate::techniques::direct::{DirectLighting, DirectOutput, with_direct_params};
use crate::techniques::rsm::map::{self, ReflectiveShadowMap};
use crate::techniques::{
    FrameContext, FrameNeeds, Measured, RenderError, SceneChange, Technique, TechniqueInfo, TechniqueSetup,
};

/// Most cascades (the paper's figure: 3 nested grids).
pub const MAX_CASCADES: usize = 3;
/// Fixed-point scale of blocking potentials (fractions of a cell's cross-section): 2^22, so a cell's
/// sum may reach 512 cross-sections before i32 overflows, and one pixel's surfel of 1/4000 of a cell is
/// resolved to 0.1 %.
const BLOCKING_SCALE: f32 = 4_194_304.0;
/// Workgroups of the flux reduction's first dispatch (each reduces a strided share of the RSM texels;
/// at most the 256 threads of the workgroup that reduces their sums).
const FLUX_GROUPS: u32 = 256;
/// Cells over which the lookup blends a cascade into the next coarser one near its border.
const BLEND_CELLS: f32 = 2.0;

/// Per geometry-volume cell: the fixed-point sums (blocking from the RSMs (4), from the G-buffer (4),
/// and with multiple bounces the albedo sums: r, g, b and the covered fraction) and the resolved vec4f
/// slots (blocking, and with multiple bounces the albedo sums). Without multiple bounces no albedo is
/// stored.
pub fn geometry_layout(multiple_bounces: bool) -> (u64, u64) {
    if multiple_bounces { (12, 2) } else { (8, 1) }
}

const LPV_PARAMS: [ParamSpec; 14] = with_direct_params!(
    ParamSpec {
        name: "grid",
        kind: ParamKind::Int { min: 4, max: 128 },
        default: "32",
        doc: "cells along each axis of every cascade (cubic cells)",
    },
    ParamSpec {
        name: "iterations",
        kind: ParamKind::Int { min: 0, max: 256 },
        default: "8",
        doc: "propagation steps: light travels one cell per step (0 = the injected light alone)",
    },
    ParamSpec {
        name: "cascades",
        kind: ParamKind::Int { min: 1, max: MAX_CASCADES as i64 },
        default: "1",
        doc: "nested grids: the coarsest covers the scene, each finer one halves the cell and follows the \
              camera, snapped to whole cells",
    },
    ParamSpec {
        name: "geometry_volume",
        kind: ParamKind::Bool,
        default: "true",
        doc: "attenuate propagation by the blocking potential of the surfaces the RSMs and the camera see \
              (the paper's secondary occlusion; false = light passes through walls)",
    },
    ParamSpec {
        name: "multiple_bounces",
        kind: ParamKind::Bool,
        default: "false",
        doc: "reflect the light the geometry volume blocks back into the grid, scaled by the blockers' mean \
              albedo (the paper's multiple bounces: as many as fit in the iterations; needs geometry_volume)",
    },
    ParamSpec {
        name: "rsm_size",
        kind: ParamKind::Int { min: 16, max: 2048 },
        default: "256",
        doc: "injection resolution: edge of each RSM layer in texels, one virtual point light per texel",
    },
);

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "lpv",
    description: "light propagation volumes: RSM texels injected into SH grids, propagated cell to cell",
    params: &LPV_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate,
    create,
};

fn validate(p: &crate::params::ParamValues) -> Result<(), String> {
    if p.bool("multiple_bounces") && !p.bool("geometry_volume") {
        return Err("multiple_bounces reflects the light the geometry volume blocks; it needs \
                    geometry_volume=true"
            .into());
    }
    Ok(())
}

/// Mirrors `LpvParams` in volume.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct LpvParams {
    /// Per cascade: minimum corner (xyz) and cell edge (w).
    pub cascades: [[f32; 4]; MAX_CASCADES],
    pub cascade_count: u32,
    pub _pad: [u32; 3],
}

/// Mirrors `PropagationStep` in volume.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct PropagationStep {
    index: u32,
    _pad: [u32; 3],
}

/// Solid angle of an axis-aligned square of half-edge `h` centred at distance `d` on its normal:
/// 4 asin(h² / (h² + d²)).
fn square_solid_angle(h: f64, d: f64) -> f64 {
    4.0 * (h * h / (h * h + d * d)).asin()
}

/// Solid angles of a destination cell's faces seen from the source cell's centre (unit cells, centres
/// one apart): the far face (0.4006) and each side face (0.4234), as the paper tabulates. Every ray
/// from the source through the shared face (a sixth of the sphere, 2π/3) leaves the destination
/// through the far face or a side face, so the four side faces share what the far face leaves of it.
pub fn face_solid_angles() -> (f32, f32) {
    let front = square_solid_angle(0.5, 1.5);
    let near = square_solid_angle(0.5, 0.5);
    let side = (near - front) / 4.0;
    (front as f32, side as f32)
}

/// Where the cascades lie this frame (`Aabb::nested_cubes`): the coarsest covers `bounds` (cubic, a cell
/// of margin on every side); each finer one has half the cell of the next and is centred on `camera`,
/// its corner snapped to whole cells.
pub fn place_cascades(bounds: crate::scene::Aabb, camera: Vec3, grid: u32, count: usize) -> LpvParams {
    let mut p = LpvParams::zeroed();
    for (k, cube) in bounds.nested_cubes(camera, grid, count, 1).into_iter().enumerate() {
        p.cascades[k] = [cube.corner.x, cube.corner.y, cube.corner.z, cube.cell];
    }
    p.cascade_count = count as u32;
    p
}

/// The WGSL of the volumes (prepended to every LPV pass) and its defines.
const VOLUME_WGSL: &str = include_str!("volume.wgsl");

pub fn defines(grid: u32, geometry_volume: bool, multiple_bounces: bool) -> Defines {
    let (front, side) = face_solid_angles();
    Defines::new()
        .u32("GRID", grid)
        .u32("MAX_CASCADES", MAX_CASCADES as u32)
        .bool("GEOMETRY_VOLUME", geometry_volume)
        .bool("MULTIPLE_BOUNCES", multiple_bounces)
        .u32("GEOMETRY_SUMS", geometry_layout(multiple_bounces).0 as u32)
        .u32("GEOMETRY_SLOTS", geometry_layout(multiple_bounces).1 as u32)
        .f32("FRONT_SOLID_ANGLE", front)
        .f32("SIDE_SOLID_ANGLE", side)
        .f32("BLOCKING_SCALE", BLOCKING_SCALE)
        .f32("BLEND_CELLS", BLEND_CELLS)
        .u32("FLUX_GROUPS", FLUX_GROUPS)
}

pub fn inject_source() -> String {
    map::reader_source(&format!("{VOLUME_WGSL}\n{}", include_str!("inject.wgsl")))
}

pub fn resolve_source() -> String {
    format!(
        "#import common/frame.wgsl\n#import common/indirect.wgsl\n{VOLUME_WGSL}\n{}",
        include_str!("resolve.wgsl")
    )
}

pub fn propagate_source() -> String {
    format!(
        "#import common/frame.wgsl\n#import common/indirect.wgsl\n{VOLUME_WGSL}\n{}",
        include_str!("propagate.wgsl")
    )
}

pub fn shade_source() -> String {
    format!(
        "#import common/frame.wgsl\n#import common/brdf.wgsl\n{VOLUME_WGSL}\n{}",
        include_str!("shade.wgsl")
    )
}

/// The volumes on the GPU and the pipelines over them.
pub struct Lpv {
    grid: u32,
    cascades: usize,
    iterations: u32,
    geometry_volume: bool,
    rsm: ReflectiveShadowMap,
    direct: DirectLighting,
    _direct_texture: wgpu::Texture,
    params_buffer: wgpu::Buffer,
    params: LpvParams,
    /// Light after injection / between steps (ping, pong) and the sum over steps.
    volumes: [wgpu::Buffer; 3],
    /// Per geometry cell: blocking potential and mean albedo (two vec4f).
    geometry: wgpu::Buffer,
    /// Injection's fixed-point sums: light, and blocking (two sources per geometry cell) with albedo.
    light_fixed: wgpu::Buffer,
    blocking_fixed: wgpu::Buffer,
    /// Bind group 2, with ping and pong swapped in the second.
    groups: [wgpu::BindGroup; 2],
    steps: DispatchSlots,
    flux: [wgpu::ComputePipeline; 2],
    inject: wgpu::ComputePipeline,
    inject_gbuffer: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    propagate: wgpu::ComputePipeline,
    shade: wgpu::ComputePipeline,
    max_workgroups: u32,
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    Ok(Box::new(Lpv::new(setup)?))
}

impl Lpv {
    pub fn new(setup: &TechniqueSetup) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let p = setup.params;
        let grid = p.int("grid") as u32;
        let cascades = p.int("cascades") as usize;
        let iterations = p.int("iterations") as u32;
        let geometry_volume = p.bool("geometry_volume");
        let multiple_bounces = p.bool("multiple_bounces");
        let cells = u64::from(grid).pow(3) * cascades as u64;
        let geometry_cells = u64::from(grid + 1).pow(3) * cascades as u64;
        let limit = ctx.limits().max_storage_buffer_binding_size;
        let largest = cells * 48;
        let (sums, slots) = geometry_layout(multiple_bounces);
        let geometry_bytes = geometry_cells * sums * 4;
        if largest > limit || geometry_bytes > limit {
            return Err(RenderError::InvalidSettings(format!(
                "lpv: {cascades} cascade(s) of {grid}³ cells need storage buffers of {} MiB, over the device's \
                 max_storage_buffer_binding_size of {} MiB; lower grid or cascades",
                largest.max(geometry_bytes) >> 20,
                limit >> 20
            )));
        }
        let rsm = ReflectiveShadowMap::new(ctx, setup.scene, setup.gpu_scene, p.int("rsm_size") as u32)?;
        let (width, height) = (setup.frame.width, setup.frame.height);
        let direct_texture = compute::storage_texture(ctx, "lpv direct", width, height, OUTPUT_FORMAT);
        let direct = DirectLighting::new(setup, &direct_texture, DirectOutput::Accumulate)?;

        let params =
            place_cascades(setup.gpu_scene.bounds(), setup.frame.view.camera.position, grid, cascades);
        let params_buffer = {
            use wgpu::util::DeviceExt;
            ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("lpv params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            })
        };
        let buffer = |label: &str, size: u64| compute::storage_buffer(ctx, label, size.max(16));
        let light_fixed = buffer("lpv injected light (fixed point)", cells * 48);
        let blocking_fixed = buffer("lpv blocking (fixed point)", geometry_bytes);
        let volumes = [
            buffer("lpv light ping", cells * 48),
            buffer("lpv light pong", cells * 48),
            buffer("lpv accumulated light", cells * 48),
        ];
        let geometry = buffer("lpv geometry volume", geometry_cells * slots * 16);
        // The scale and the partial sums of the FLUX_GROUPS workgroups.
        let flux_scale = buffer("lpv flux scale", 4 * (1 + u64::from(FLUX_GROUPS)));
        let step_values: Vec<PropagationStep> =
            (0..iterations.max(1)).map(|index| PropagationStep { index, _pad: [0; 3] }).collect();
        let steps = DispatchSlots::new(ctx, "lpv propagation steps", &step_values);

        let layout = compute::layout(
            ctx,
            "lpv",
            &[
                compute::uniform_entry(0),
                storage_buffer_entry(1, false),
                storage_buffer_entry(2, false),
                storage_buffer_entry(3, false),
                storage_buffer_entry(4, false),
                storage_buffer_entry(5, false),
                storage_buffer_entry(6, false),
                storage_buffer_entry(7, false),
                steps.entry(8),
                compute::texture_entry(9, wgpu::TextureSampleType::Float { filterable: false }),
                storage_texture_entry(10, OUTPUT_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
            ],
        );
        let direct_view = direct_texture.create_view(&Default::default());
        let output_view = setup.output.create_view(&Default::default());
        let groups = [0, 1].map(|swap| {
            let (a, b) = if swap == 0 { (&volumes[0], &volumes[1]) } else { (&volumes[1], &volumes[0]) };
            compute::bind_group(
                ctx,
                "lpv",
                &layout,
                &[
                    params_buffer.as_entire_binding(),
                    light_fixed.as_entire_binding(),
                    blocking_fixed.as_entire_binding(),
                    a.as_entire_binding(),
                    b.as_entire_binding(),
                    volumes[2].as_entire_binding(),
                    geometry.as_entire_binding(),
                    flux_scale.as_entire_binding(),
                    steps.resource(),
                    wgpu::BindingResource::TextureView(&direct_view),
                    wgpu::BindingResource::TextureView(&output_view),
                ],
            )
        });
        let defines = defines(grid, geometry_volume, multiple_bounces);
        let layouts =
            [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout, &rsm.layout];
        let pipeline = |name: &str, source: &str, entry: &str, layouts: &[&wgpu::BindGroupLayout]| {
            compute::pipeline(ctx, name, source, defines.clone(), entry, layouts)
        };
        let inject_wgsl = inject_source();
        Ok(Lpv {
            grid,
            cascades,
            iterations,
            geometry_volume,
            direct,
            _direct_texture: direct_texture,
            params_buffer,
            params,
            steps,
            flux: [
                pipeline("lpv flux scale", &inject_wgsl, "measure_flux", &layouts)?,
                pipeline("lpv flux scale total", &inject_wgsl, "flux_scale_from_partials", &layouts)?,
            ],
            inject: pipeline("lpv injection", &inject_wgsl, "inject_rsm", &layouts)?,
            inject_gbuffer: pipeline("lpv geometry injection", &inject_wgsl, "inject_gbuffer", &layouts)?,
            resolve: pipeline("lpv resolve", &resolve_source(), "main", &layouts)?,
            propagate: pipeline("lpv propagation", &propagate_source(), "main", &layouts)?,
            shade: pipeline("lpv lookup", &shade_source(), "main", &layouts)?,
            rsm,
            volumes,
            geometry,
            light_fixed,
            blocking_fixed,
            groups,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
        })
    }

    fn cells(&self) -> u32 {
        self.grid.pow(3) * self.cascades as u32
    }

    fn geometry_cells(&self) -> u32 {
        (self.grid + 1).pow(3) * self.cascades as u32
    }

    /// Records `pipeline` over the scene, the frame, the volumes (ping and pong as of propagation step
    /// `step`, with its slot) and the RSM: every LPV pipeline has the same four groups.
    fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        fc: &FrameContext,
        (name, pipeline): (&str, &wgpu::ComputePipeline),
        step: usize,
        workgroups: [u32; 3],
    ) {
        let (scene, frame) = (&fc.gpu_scene.bind_group, &fc.frame.bind_group);
        let mut pass = crate::gpu::dispatch::compute_pass(encoder, name, pipeline, &[scene, frame]);
        let offset = self.steps.offsets().nth(step).unwrap_or(0);
        pass.set_bind_group(2, &self.groups[step % 2], &[offset]);
        pass.set_bind_group(3, &self.rsm.bind_group, &[]);
        pass.dispatch_workgroups(workgroups[0], workgroups[1], workgroups[2]);
    }

    fn pixel_workgroups(fc: &FrameContext) -> [u32; 3] {
        [fc.frame.width.div_ceil(compute::TILE), fc.frame.height.div_ceil(compute::TILE), 1]
    }

    /// Builds the volumes of this frame (injection, resolve and propagation), without shading.
    fn build_volumes(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let ctx = fc.ctx;
        let params = place_cascades(fc.gpu_scene.bounds(), fc.view.camera.position, self.grid, self.cascades);
        // Fixed cascades (all but the camera-centred ones) never move: write only what changed.
        if bytemuck::bytes_of(&params) != bytemuck::bytes_of(&self.params) {
            self.params = params;
            ctx.queue.write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
        }
        self.rsm.render(ctx, fc.gpu_scene, profiler)?;
        let linear = |invocations: u32| workgroups_for(invocations, 64, self.max_workgroups);
        profiler.pass(ctx, "lpv flux scale", |e| {
            self.record(e, fc, ("lpv flux scale", &self.flux[0]), 0, [FLUX_GROUPS, 1, 1]);
            self.record(e, fc, ("lpv flux scale", &self.flux[1]), 0, [1, 1, 1]);
        })?;
        profiler.pass(ctx, "lpv injection", |e| {
            self.record(e, fc, ("lpv injection", &self.inject), 0, linear(self.rsm.texels()));
        })?;
        if self.geometry_volume {
            profiler.pass(ctx, "lpv geometry injection", |e| {
                let pass = ("lpv geometry injection", &self.inject_gbuffer);
                self.record(e, fc, pass, 0, Self::pixel_workgroups(fc));
            })?;
        }
        profiler.pass(ctx, "lpv resolve", |e| {
            let cells = self.geometry_cells().max(self.cells());
            self.record(e, fc, ("lpv resolve", &self.resolve), 0, linear(cells));
        })?;
        self.propagate(fc, profiler)
    }

    /// The propagation steps (pass "lpv propagation") from the light in the ping volume.
    fn propagate(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        if self.iterations == 0 {
            return Ok(());
        }
        let workgroups = workgroups_for(self.cells(), 64, self.max_workgroups);
        profiler.pass(fc.ctx, "lpv propagation", |e| {
            for step in 0..self.iterations as usize {
                self.record(e, fc, ("lpv propagation", &self.propagate), step, workgroups);
            }
        })?;
        Ok(())
    }
}

/// The CPU twin of one propagation step (propagate.wgsl), for tests: `light[cell][channel]` order-1
/// SH of one cascade of `grid`³ cells, `geometry` its (grid+1)³ cells of blocking potential and albedo
/// sums (rgb: albedo × covered fraction, w: covered fraction; None: no occlusion), `bounces` the MULTIPLE_BOUNCES reflection of blocked light. Returns the light
/// gathered by each cell.
pub fn propagate_step_cpu(
    grid: usize,
    light: &[[[f32; 4]; 3]],
    geometry: Option<&[[[f32; 4]; 2]]>,
    bounces: bool,
) -> Vec<[[f32; 4]; 3]> {
    use crate::sh::{cosine_lobe4, eval4};
    const AXES: [[i32; 3]; 6] = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];
    let (front, side) = face_solid_angles();
    let n = grid as i32;
    let index = |c: [i32; 3]| ((c[2] * n + c[1]) * n + c[0]) as usize;
    let vec = |c: [i32; 3]| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
    let outside = |c: [i32; 3]| c.iter().any(|&c| c < 0 || c >= n);
    // Trilinear in the geometry volume (cells on whole grid positions); slot 0 blocking, 1 albedo.
    let geometry_at = |g: Vec3, slot: usize| -> [f32; 4] {
        let geometry = geometry.unwrap_or(&[]);
        let base = g.floor().clamp(Vec3::ZERO, Vec3::splat((grid - 1) as f32));
        let f = (g - base).clamp(Vec3::ZERO, Vec3::ONE);
        let mut sum = [0.0f32; 4];
        for k in 0..8 {
            let corner = [k & 1, (k >> 1) & 1, k >> 2];
            let w: f32 = (0..3).map(|a| if corner[a] == 1 { f[a] } else { 1.0 - f[a] }).product();
            let c: [usize; 3] = std::array::from_fn(|a| base[a] as usize + corner[a]);
            let b = geometry[(c[2] * (grid + 1) + c[1]) * (grid + 1) + c[0]][slot];
            for (s, v) in sum.iter_mut().zip(b) {
                *s += v * w;
            }
        }
        sum
    };
    // The flux per channel that `source` sends through each face of the cell beyond its face towards
    // `dir` (scaled by `weight(towards)`), each with that face's outward normal.
    let through_faces = |source: &[[f32; 4]; 3], dir: [i32; 3], weight: &dyn Fn(Vec3) -> f32| {
        let faces = AXES.iter().filter(|&&face| face != dir.map(|c| -c));
        faces
            .map(|&face| {
                let towards = (vec(dir) + 0.5 * vec(face)).normalize();
                let solid_angle = if face == dir { front } else { side };
                let w = weight(towards);
                let flux: [f32; 3] =
                    std::array::from_fn(|ch| eval4(&source[ch], towards).max(0.0) * solid_angle * w);
                (vec(face), flux)
            })
            .collect::<Vec<_>>()
    };
    let add_lobe = |sum: &mut [[f32; 4]; 3], normal: Vec3, flux: [f32; 3]| {
        let lobe = cosine_lobe4(normal);
        for (channel, s) in sum.iter_mut().enumerate() {
            for k in 0..4 {
                s[k] += lobe[k] * std::f32::consts::FRAC_1_PI * flux[channel];
            }
        }
    };
    let mut out = vec![[[0.0f32; 4]; 3]; grid * grid * grid];
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let cell = [x, y, z];
                let mut gathered = [[0.0f32; 4]; 3];
                for dir in AXES {
                    let from = [x - dir[0], y - dir[1], z - dir[2]];
                    if outside(from) {
                        continue;
                    }
                    let blocking =
                        geometry.map(|_| geometry_at(vec(cell) + Vec3::splat(0.5) - 0.5 * vec(dir), 0));
                    let transmit =
                        |towards: Vec3| blocking.map_or(1.0, |b| 1.0 - eval4(&b, towards).clamp(0.0, 1.0));
                    for (face, flux) in through_faces(&light[index(from)], dir, &transmit) {
                        add_lobe(&mut gathered, face, flux);
                    }
                }
                if bounces && geometry.is_some() {
                    for dir in AXES {
                        if outside([x + dir[0], y + dir[1], z + dir[2]]) {
                            continue;
                        }
                        let face_centre = vec(cell) + Vec3::splat(0.5) + 0.5 * vec(dir);
                        let b = geometry_at(face_centre, 0);
                        let a = geometry_at(face_centre, 1);
                        let albedo: [f32; 3] =
                            std::array::from_fn(|ch| if a[3] > 0.0 { a[ch] / a[3] } else { 0.0 });
                        let block = |towards: Vec3| eval4(&b, towards).clamp(0.0, 1.0);
                        let mut blocked = [0.0f32; 3];
                        for (_, flux) in through_faces(&light[index(cell)], dir, &block) {
                            for ch in 0..3 {
                                blocked[ch] += flux[ch];
                            }
                        }
                        add_lobe(
                            &mut gathered,
                            -vec(dir),
                            std::array::from_fn(|ch| albedo[ch] * blocked[ch]),
                        );
                    }
                }
                out[index(cell)] = gathered;
            }
        }
    }
    out
}

impl Technique for Lpv {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        self.build_volumes(fc, profiler)?;
        self.direct.render(fc, profiler)?;
        profiler.pass(fc.ctx, "lpv lookup", |e| {
            self.record(e, fc, ("lpv lookup", &self.shade), 0, Self::pixel_workgroups(fc));
        })?;
        Ok(())
    }

    // The direct term reads the scene every frame; the RSMs re-aim and render again when lights or
    // geometry move, and the volumes are rebuilt every frame anyway.
    fn scene_changed(
        &mut self,
        ctx: &GpuContext,
        gpu_scene: &GpuScene,
        change: SceneChange,
    ) -> Result<bool, RenderError> {
        self.rsm.scene_changed(ctx, gpu_scene, change);
        Ok(true)
    }

    fn counters(&mut self, _: &GpuContext, _: &Measured) -> Result<BTreeMap<String, f64>, RenderError> {
        let mut c = BTreeMap::new();
        let light: u64 = self.volumes.iter().map(wgpu::Buffer::size).sum();
        c.insert("lpv_light_bytes".into(), light as f64);
        c.insert("lpv_injection_bytes".into(), self.light_fixed.size() as f64);
        c.insert("lpv_geometry_bytes".into(), (self.geometry.size() + self.blocking_fixed.size()) as f64);
        c.insert("lpv_cells".into(), f64::from(self.cells()));
        c.insert("lpv_iterations".into(), f64::from(self.iterations));
        for k in 0..self.cascades {
            c.insert(format!("lpv_cascade{k}_cell"), f64::from(self.params.cascades[k][3]));
        }
        c.insert("rsm_texels".into(), f64::from(self.rsm.texels()));
        c.insert("rsm_bytes".into(), f64::from(self.rsm.texels() * map::BYTES_PER_TEXEL));
        Ok(c)
    }

    fn warnings(&self) -> Vec<String> {
        self.rsm.warnings.clone()
    }
}
