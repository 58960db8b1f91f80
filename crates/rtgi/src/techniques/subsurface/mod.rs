//! `subsurface`: multiple scattering in translucent materials by the dipole diffusion approximation
//! (Jensen et al. 2001), integrated hierarchically over irradiance samples as Jensen & Buhler 2002 do,
//! with the dual hierarchy and frequency analysis of Belcour, Dumont-Bècle, Holzschuch et al.
//! (Graphics Interface 2019; seed 003, article 3) that also clusters pixels.
//!
//! Per frame, on the GPU:
//! 1. **irradiance**: every illumination sample (placed once on the translucent meshes, see
//!    [`samples`], and moved with them) gets its irradiance from every light, shadows traced through
//!    the BVH;
//! 2. **tree**: each mesh's kd-tree aggregates Σ E·A and the irradiance-weighted position bottom-up,
//!    one dispatch per level;
//! 3. **clusters**: each pixel's outgoing-radiance sampling rate s_p from the frequency analysis
//!    ([`bandwidth`]); squares of one 8×8 tile's quadtree that show one translucent mesh and are at most
//!    P = ρ / max s_p pixels across become one job (ρ = 0: every pixel alone, the single-tree method);
//! 4. **traversal**: one tree traversal per job, a node used whole when its solid angle A/d² seen from
//!    the cluster is below ε and its bounds do not meet the cluster's (ε = 0: every sample, the
//!    brute-force reference of the same model);
//! 5. **single scattering** (`single_scattering` > 0): Jensen et al. 2001's single-scattering term
//!    per translucent pixel, by Monte Carlo along the refracted view ray with every light traced
//!    through the medium;
//! 6. **shade**: direct light, with a translucent material's Lambertian part replaced by
//!    F_t(η, θ_o)/π · Σ R_d E A, plus the single-scattered light.
//!
//! What is and is not modelled: the multiple-scattering term of the BSSRDF (as the paper), and its
//! single-scattering term only with `single_scattering` (isotropic, with the reduced coefficients as
//! the path tracer's walk; it pairs with the better dipole, whose α'² weighting leaves it room); three
//! profiles, the three the paper demonstrates: Jensen et al.'s standard dipole, d'Eon's better dipole
//! and Frisvad et al.'s directional dipole (which takes each node's luminance-weighted mean refracted
//! light direction and normal, exact for one light and one sample, an approximation where several
//! lights or a coarse node mix directions); the entry Fresnel transmittance on the radial dipoles'
//! irradiance only with `entry_fresnel` (Jensen & Buhler use plain irradiance), always on the
//! directional one, whose definition includes it; direct light on the samples unless
//! `indirect_samples` adds one bounce of indirect light; blue-noise samples by Yuksel's weighted
//! sample elimination of four times as many area-sampled candidates rather than Bowers et al.'s
//! parallel Poisson disks; the thesis's pixel kd-tree replaced by each tile's quadtree, which the GPU
//! walks without a build; curvature from G-buffer neighbours rather than Kalogerakis et al.'s estimator.
//! The path tracer and every other technique see a translucent material as the Lambertian of its total
//! diffuse reflectance.

pub mod bandwidth;
pub mod samples;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::dispatch::workgroups_for;
use crate::gpu::{BufferBuilder, GpuContext, GpuScene, Profiler, readback};
use crate::params::{ParamKind, ParamSpec};
use crate::scene::Scene;
use crate::scene::subsurface::DipoleModel;
use crate::shaders::Defines;

use super::compute::{self, DispatchSlots, storage_buffer_entry, storage_texture_entry};
use super::direct::with_direct_params;
use super::{
    FrameContext, FrameNeeds, Measured, RenderError, SceneChange, Technique, TechniqueInfo, TechniqueSetup,
};
use bandwidth::ANGULAR_BINS;
use samples::{IlluminationTrees, MAX_DEPTH};

pub const PARAMS: [ParamSpec; 15] = with_direct_params![
    ParamSpec {
        name: "samples",
        kind: ParamKind::Int { min: 16, max: 1 << 20 },
        default: "16384",
        doc: "illumination samples over all translucent meshes (by area; spacing should stay below the mean free path)",
    },
    ParamSpec {
        name: "epsilon",
        kind: ParamKind::Float { min: 0.0, max: 4.0 },
        default: "0.1",
        doc: "ε: a tree node lights a cluster whole when its solid angle A/d² is below this (0: every sample, the reference)",
    },
    ParamSpec {
        name: "dipole",
        kind: ParamKind::Choice(&["classical", "better", "directional"]),
        default: "classical",
        doc: "diffusion profile: Jensen et al. 2001's dipole, d'Eon 2012's better dipole (fluence term, corrected diffusion coefficient) or Frisvad et al. 2014's directional dipole (a ray source along the refracted light, with the entry Fresnel term)",
    },
    ParamSpec {
        name: "entry_fresnel",
        kind: ParamKind::Bool,
        default: "false",
        doc: "weight the radial dipoles' irradiance by the entry Fresnel transmittance T12, as Jensen et al. 2001's BSSRDF (false: plain irradiance, as Jensen & Buhler 2002; the directional dipole always includes it)",
    },
    ParamSpec {
        name: "indirect_samples",
        kind: ParamKind::Int { min: 0, max: 64 },
        default: "0",
        doc: "rays per illumination sample and frame that add one bounce of indirect light to the samples (0: direct light only, as Jensen & Buhler); the frames' average converges",
    },
    ParamSpec {
        name: "single_scattering",
        kind: ParamKind::Int { min: 0, max: 64 },
        default: "0",
        doc: "points per translucent pixel and frame along the refracted view ray that add Jensen et al. 2001's single-scattering term (each lit by every light through the medium; 0: the multiple-scattering dipole alone, as Jensen & Buhler); the frames' average converges",
    },
    ParamSpec {
        name: "rho",
        kind: ParamKind::Float { min: 0.0, max: 16.0 },
        default: "0.75",
        doc: "ρ: pixel clusters up to ρ / max s_p pixels across share one traversal (0: every pixel alone, single tree)",
    },
];

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "subsurface",
    description: "subsurface scattering: dipole BSSRDF over hierarchical irradiance samples, pixels clustered by frequency analysis",
    params: &PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate: super::independent_params,
    create,
};

/// The diffusion profile the technique integrates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Profile {
    /// A profile of distance alone, R_d(r).
    Radial(DipoleModel),
    /// Frisvad et al.'s directional dipole.
    Directional,
}

impl Profile {
    fn from_choice(choice: &str) -> Self {
        match choice {
            "better" => Profile::Radial(DipoleModel::Better),
            "directional" => Profile::Directional,
            _ => Profile::Radial(DipoleModel::Classical),
        }
    }
}

/// Per material: its profile (WGSL `Medium`), zero for opaque materials.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMedium {
    pub transport: [f32; 3],
    pub exit_scale: f32,
    pub z_r: [f32; 3],
    pub spatial_bandwidth: f32,
    pub z_v: [f32; 3],
    pub c_phi: f32,
    /// The radial profile's weights of its flux and fluence terms (`scene::subsurface::Dipole`).
    pub k_e: [f32; 3],
    pub c_e: f32,
    pub k_phi: [f32; 3],
    pub _pad0: f32,
    /// The directional dipole's (`scene::subsurface::DirectionalDipole`).
    pub diffusion: [f32; 3],
    pub _pad1: f32,
    pub extrapolation: [f32; 3],
    pub _pad2: f32,
    pub backlit_depth2: [f32; 3],
    pub _pad3: f32,
    pub virtual_offset: [f32; 3],
    pub _pad4: f32,
}

/// WGSL `ClusterJob`.
pub const CLUSTER_JOB_BYTES: u64 = 48;
/// WGSL `NodeLight`.
pub const NODE_LIGHT_BYTES: u64 = 64;
/// WGSL `SampleLight`.
pub const SAMPLE_LIGHT_BYTES: u64 = 32;
/// The counters' slots (COUNTER_* in bindings.wgsl).
pub const COUNTERS: [&str; 5] = [
    "subsurface_clusters",
    "subsurface_evaluations",
    "subsurface_node_visits",
    "subsurface_pixels",
    // Walks the driver cut short (llvmpipe ends a loop after 65535 iterations): nonzero means the
    // image lacks light, e.g. ε = 0 over more than 32768 samples on lavapipe.
    "subsurface_truncated_walks",
];

const BINDINGS: &str = include_str!("bindings.wgsl");
const WORKGROUP: u32 = 64;

/// The profile and bandwidths of every material (opaque ones zero).
pub fn media(scene: &Scene, profile: Profile) -> (Vec<GpuMedium>, Vec<f32>) {
    let mut media = Vec::new();
    let mut angular = Vec::new();
    for material in &scene.materials {
        match material.subsurface {
            Some(m) => {
                media.push(match profile {
                    Profile::Radial(model) => {
                        let dipole = m.dipole(model);
                        GpuMedium {
                            transport: dipole.transport.to_array(),
                            exit_scale: std::f32::consts::FRAC_1_PI,
                            z_r: dipole.z_r.to_array(),
                            spatial_bandwidth: bandwidth::spatial_bandwidth(&dipole) as f32,
                            z_v: dipole.z_v.to_array(),
                            k_e: dipole.k_e.to_array(),
                            k_phi: dipole.k_phi.to_array(),
                            ..Default::default()
                        }
                    }
                    Profile::Directional => {
                        let dipole = m.directional_dipole();
                        GpuMedium {
                            transport: dipole.transport.to_array(),
                            exit_scale: dipole.exit_scale,
                            spatial_bandwidth: bandwidth::directional_spatial_bandwidth(&dipole, m.eta)
                                as f32,
                            c_phi: dipole.c_phi,
                            c_e: dipole.c_e,
                            diffusion: dipole.diffusion.to_array(),
                            extrapolation: dipole.extrapolation.to_array(),
                            backlit_depth2: dipole.backlit_depth2.to_array(),
                            virtual_offset: dipole.virtual_offset.to_array(),
                            ..Default::default()
                        }
                    }
                });
                angular.extend(bandwidth::angular_bandwidths(m.eta));
            }
            None => {
                media.push(GpuMedium::default());
                angular.extend([0.0; ANGULAR_BINS]);
            }
        }
    }
    (media, angular)
}

pub struct Subsurface {
    place: wgpu::ComputePipeline,
    /// Whether the samples sit where their meshes are now (false at first and after meshes moved).
    placed: bool,
    irradiance: wgpu::ComputePipeline,
    tree: wgpu::ComputePipeline,
    clusters: wgpu::ComputePipeline,
    traverse: wgpu::ComputePipeline,
    /// Jensen et al.'s single-scattering term (`single_scattering` > 0), before shading.
    single: Option<wgpu::ComputePipeline>,
    shade: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    levels: DispatchSlots,
    level_group: wgpu::BindGroup,
    level_counts: Vec<u32>,
    counters: wgpu::Buffer,
    sample_count: u32,
    node_count: u32,
    depth: u32,
    pixels: u32,
    bytes: u64,
    max_workgroups: u32,
    warnings: Vec<String>,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Level {
    offset: u32,
    count: u32,
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    Ok(Box::new(Subsurface::new(setup)?))
}

impl Subsurface {
    pub fn new(setup: &TechniqueSetup) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let params = setup.params;
        let trees = IlluminationTrees::build(setup.scene, params.int("samples") as u32);
        if trees.depth() > MAX_DEPTH {
            return Err(RenderError::InvalidSettings(format!(
                "subsurface: an illumination tree is {} levels deep, the traversal handles {MAX_DEPTH}",
                trees.depth()
            )));
        }
        let mut warnings = Vec::new();
        if trees.roots.iter().all(|&r| r == samples::NO_NODE) {
            warnings.push("subsurface: the scene has no translucent material; direct light only".to_string());
        }
        for (mesh, spacing, free_path) in &trees.spacing {
            if spacing > free_path {
                warnings.push(format!(
                    "subsurface: samples on '{mesh}' are {:.1} mm apart, more than the medium's mean free path \
                     ({:.1} mm): raise `samples`",
                    spacing * 1000.0,
                    free_path * 1000.0
                ));
            }
        }
        let profile = Profile::from_choice(setup.params.choice("dipole"));
        let (media, angular) = media(setup.scene, profile);
        // Triangles within each mesh become triangles of the GPU scene.
        let samples: Vec<samples::IlluminationSample> = trees
            .samples
            .iter()
            .map(|s| samples::IlluminationSample {
                triangle: setup.gpu_scene.mesh_ranges[s.mesh as usize].start / 3 + s.triangle,
                ..*s
            })
            .collect();
        let (w, h) = (setup.frame.width, setup.frame.height);
        let pixels = w * h;
        let sample_count = trees.samples.len() as u32;
        let node_count = trees.nodes.len() as u32;

        let storage = |label: &str, contents: &[u8]| {
            BufferBuilder::with_contents(label, contents).storage().copy().build(ctx)
        };
        let zeroed = |label: &str, size: u64| BufferBuilder::new(label, size).storage().copy().build(ctx);
        let buffers = [
            storage("subsurface samples", bytemuck::cast_slice(&samples))?,
            zeroed("subsurface sample light", u64::from(sample_count) * SAMPLE_LIGHT_BYTES)?,
            storage("subsurface nodes", bytemuck::cast_slice(&trees.nodes))?,
            zeroed("subsurface node light", u64::from(node_count) * NODE_LIGHT_BYTES)?,
            storage("subsurface mesh roots", bytemuck::cast_slice(&trees.roots))?,
            storage("subsurface media", bytemuck::cast_slice(&media))?,
            storage("subsurface angular bandwidth", bytemuck::cast_slice(&angular))?,
            zeroed("subsurface jobs", u64::from(pixels) * CLUSTER_JOB_BYTES)?,
            zeroed("subsurface job light", u64::from(pixels) * 16)?,
            zeroed("subsurface pixel jobs", u64::from(pixels) * 4)?,
            zeroed("subsurface counters", 4 * COUNTERS.len() as u64)?,
            storage("subsurface node order", bytemuck::cast_slice(&trees.order))?,
        ];
        let single_points = params.int("single_scattering") as u32;
        let single_light = zeroed(
            "subsurface single scattering",
            if single_points > 0 { u64::from(pixels) * 16 } else { 16 },
        )?;
        let bytes = buffers.iter().chain([&single_light]).map(wgpu::Buffer::size).sum();
        // The buffers in order, then the output, then the single-scattered light.
        let mut entries: Vec<wgpu::BindGroupLayoutEntry> =
            (0..buffers.len() as u32).map(|b| storage_buffer_entry(b, false)).collect();
        entries.push(storage_texture_entry(
            buffers.len() as u32,
            OUTPUT_FORMAT,
            wgpu::StorageTextureAccess::ReadWrite,
        ));
        entries.push(storage_buffer_entry(buffers.len() as u32 + 1, false));
        let layout = compute::layout(ctx, "subsurface", &entries);
        let output = setup.output.create_view(&Default::default());
        let mut resources: Vec<wgpu::BindingResource> =
            buffers.iter().map(|b| b.as_entire_binding()).collect();
        resources.push(wgpu::BindingResource::TextureView(&output));
        resources.push(single_light.as_entire_binding());
        let group = compute::bind_group(ctx, "subsurface", &layout, &resources);

        let levels: Vec<Level> =
            trees.levels.iter().map(|&(offset, count)| Level { offset, count }).collect();
        let level_counts = levels.iter().map(|l| l.count).collect();
        let slots = DispatchSlots::new(ctx, "subsurface tree levels", &levels);
        let level_layout = compute::layout(ctx, "subsurface tree level", &[slots.entry(0)]);
        let level_group =
            compute::bind_group(ctx, "subsurface tree level", &level_layout, &[slots.resource()]);

        let defines = setup
            .gpu_scene
            .bvh_defines(Defines::new())
            .u32("AREA_SAMPLES", params.int("area_samples") as u32)
            .u32("ENV_SAMPLES", params.int("env_samples") as u32)
            .u32("INDIRECT_SAMPLES", params.int("indirect_samples") as u32)
            .u32("SINGLE_SCATTERING", single_points)
            .f32("EPSILON", params.float("epsilon") as f32)
            .f32("RHO", params.float("rho") as f32)
            .bool("DIRECTIONAL", profile == Profile::Directional)
            .bool("ENTRY_FRESNEL", profile == Profile::Directional || params.bool("entry_fresnel"));
        let groups = [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout];
        let pipeline = |name: &str, source: &str, groups: &[&wgpu::BindGroupLayout]| {
            compute::pipeline(ctx, name, &format!("{BINDINGS}\n{source}"), defines.clone(), "main", groups)
        };
        let tree_groups = [groups[0], groups[1], groups[2], &level_layout];
        Ok(Subsurface {
            place: pipeline("subsurface placement", include_str!("place.wgsl"), &groups)?,
            placed: false,
            irradiance: pipeline("subsurface irradiance", include_str!("irradiance.wgsl"), &groups)?,
            tree: pipeline("subsurface tree", include_str!("tree.wgsl"), &tree_groups)?,
            clusters: pipeline("subsurface clusters", include_str!("clusters.wgsl"), &groups)?,
            traverse: pipeline("subsurface traversal", include_str!("traverse.wgsl"), &groups)?,
            single: if single_points > 0 {
                Some(pipeline("subsurface single scattering", include_str!("single.wgsl"), &groups)?)
            } else {
                None
            },
            shade: pipeline("subsurface shade", include_str!("shade.wgsl"), &groups)?,
            group,
            levels: slots,
            level_group,
            level_counts,
            counters: buffers[10].clone(),
            sample_count,
            node_count,
            depth: trees.depth(),
            pixels,
            bytes,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
            warnings,
        })
    }

    /// The counters of the last frame: clusters (jobs), BSSRDF evaluations, node visits, translucent
    /// pixels, truncated walks.
    pub fn read_counters(&self, ctx: &GpuContext) -> Result<[u32; 5], RenderError> {
        let bytes = readback::read_buffer(ctx, &self.counters, 0, 4 * COUNTERS.len() as u64)?;
        Ok(bytemuck::pod_read_unaligned(&bytes))
    }
}

impl Technique for Subsurface {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group, &self.group];
        if self.sample_count > 0 {
            let [x, y, _] = workgroups_for(self.sample_count, WORKGROUP, self.max_workgroups);
            if !self.placed {
                profiler.pass(fc.ctx, "subsurface placement", |encoder| {
                    compute::dispatch(encoder, "subsurface placement", &self.place, &groups, [x, y, 1]);
                })?;
                self.placed = true;
            }
            profiler.pass(fc.ctx, "subsurface irradiance", |encoder| {
                compute::dispatch(encoder, "subsurface irradiance", &self.irradiance, &groups, [x, y, 1]);
            })?;
            profiler.pass(fc.ctx, "subsurface tree", |encoder| {
                let mut pass =
                    crate::gpu::dispatch::compute_pass(encoder, "subsurface tree", &self.tree, &groups);
                for (offset, count) in self.levels.offsets().zip(&self.level_counts) {
                    pass.set_bind_group(3, &self.level_group, &[offset]);
                    pass.dispatch_workgroups(count.div_ceil(WORKGROUP), 1, 1);
                }
            })?;
        }
        profiler.pass(fc.ctx, "subsurface clusters", |encoder| {
            encoder.clear_buffer(&self.counters, 0, None);
            compute::dispatch_pixels(
                encoder,
                "subsurface clusters",
                &self.clusters,
                &groups,
                fc.frame.width,
                fc.frame.height,
            );
        })?;
        if self.sample_count > 0 {
            // Sized for one job per pixel: clusters only ever merge pixels.
            let [x, y, _] = workgroups_for(self.pixels, WORKGROUP, self.max_workgroups);
            profiler.pass(fc.ctx, "subsurface traversal", |encoder| {
                compute::dispatch(encoder, "subsurface traversal", &self.traverse, &groups, [x, y, 1]);
            })?;
        }
        if let Some(single) = &self.single {
            compute::frame_pass(fc, profiler, "subsurface single scattering", single, &self.group)?;
        }
        compute::frame_pass(fc, profiler, "subsurface shade", &self.shade, &self.group)
    }

    fn counters(&mut self, ctx: &GpuContext, _: &Measured) -> Result<BTreeMap<String, f64>, RenderError> {
        let values = self.read_counters(ctx)?;
        let mut out: BTreeMap<String, f64> =
            COUNTERS.iter().zip(values).map(|(name, v)| (name.to_string(), f64::from(v))).collect();
        out.insert("subsurface_samples".into(), f64::from(self.sample_count));
        out.insert("subsurface_tree_nodes".into(), f64::from(self.node_count));
        out.insert("subsurface_tree_depth".into(), f64::from(self.depth));
        out.insert("subsurface_bytes".into(), self.bytes as f64);
        out.insert("output_bytes_per_pixel".into(), 16.0);
        Ok(out)
    }

    // The samples' irradiance is recomputed every frame, so moving lights need nothing; moved meshes
    // carry their samples (placed again from their triangles, the trees' bounds refitted). The trees'
    // topology and the samples' areas stay: right for rigid motion, approximate for a mesh that scales.
    fn scene_changed(
        &mut self,
        _: &GpuContext,
        _: &GpuScene,
        change: SceneChange,
    ) -> Result<bool, RenderError> {
        if change == SceneChange::Geometry {
            self.placed = false;
        }
        Ok(true)
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }
}
