//! Imperfect shadow maps (Ritschel et al. 2008): VPL visibility from one tiny paraboloid depth map per
//! VPL, rendered from a sparse point sampling of the scene, instead of a shadow ray per receiver and
//! VPL. A sub-pass of the VPL gathers (`igi`, `igi-sh` with `visibility=ism`).
//!
//! Per frame: `ism splat` (clear the atlas, then every VPL's subset of the point pool into its map) and
//! `ism pull-push` (fill the holes); `ism points` (the pool in world space) runs once, and again after
//! meshes move. The gather reads the atlas through `lookup.wgsl`. What it loses against shadow rays for
//! the same VPLs is in docs/measurements/ism-lavapipe.md, what it buys at equal time against the path
//! tracer in docs/measurements/vpl-equal-time-lavapipe.md.

use wgpu::util::DeviceExt;

use crate::gpu::{Profiler, linear_texture};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::Scene;
use crate::sequences::radical_inverse;
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute::{self, storage_buffer_entry};
use super::light_paths::VPL_WGSL;
use super::{FrameContext, TechniqueSetup};

/// The map's hemisphere mapping and the pool subsets, shared by the splat and the lookup.
pub const PARABOLOID_WGSL: &str = include_str!("paraboloid.wgsl");
/// `vpl_visibility` for gather shaders (after [`VPL_WGSL`] and [`PARABOLOID_WGSL`]).
pub const LOOKUP_WGSL: &str = include_str!("lookup.wgsl");

/// Most points in the shared pool: VPLs take overlapping windows of it beyond this.
const MAX_POOL: u32 = 1 << 18;
/// VPL subsets the pool holds side by side before they overlap.
const POOL_SUBSETS: u32 = 16;
/// Workgroup size of the point pass.
const GROUP: u32 = 64;

/// The parameters of the VPL gathers that choose and tune the visibility test.
pub const ISM_PARAMS: [ParamSpec; 4] = [
    ParamSpec {
        name: "visibility",
        kind: ParamKind::Choice(&["rays", "ism"]),
        default: "rays",
        doc: "VPL visibility: a shadow ray per receiver and VPL (rays), or imperfect shadow maps (ism: one paraboloid depth map per surface VPL from a point sampling of the scene; lights keep their rays)",
    },
    ParamSpec {
        name: "ism_size",
        kind: ParamKind::Int { min: 16, max: 64 },
        default: "32",
        doc: "ism: texels per edge of each VPL's map (16, 32 or 64)",
    },
    ParamSpec {
        name: "ism_points",
        kind: ParamKind::Int { min: 256, max: 65536 },
        default: "8192",
        doc: "ism: points splatted into each VPL's map (a subset of a shared pool placed by area)",
    },
    ParamSpec {
        name: "ism_bias",
        kind: ParamKind::Float { min: 0.0, max: 1.0 },
        default: "0.03",
        doc: "ism: depth bias relative to the receiver's distance, on top of the slope bias of one texel (1 lets every occluder through: VPL light without visibility)",
    },
];

/// What the ISM parameters ask for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IsmSettings {
    pub size: u32,
    pub points_per_vpl: u32,
    pub bias: f32,
}

impl IsmSettings {
    /// The settings when `visibility=ism`, else `None`.
    pub fn from_params(p: &ParamValues) -> Option<Self> {
        (p.choice("visibility") == "ism").then(|| IsmSettings {
            size: p.int("ism_size") as u32,
            points_per_vpl: p.int("ism_points") as u32,
            bias: p.float("ism_bias") as f32,
        })
    }
}

/// Parameter checks before any GPU work: the map size must halve twice into whole texels.
pub fn validate(p: &ParamValues, vpls: u32) -> Result<(), String> {
    if p.choice("visibility") != "ism" {
        return Ok(());
    }
    let size = p.int("ism_size");
    if ![16, 32, 64].contains(&size) {
        return Err(format!("ism_size={size} is not one of 16, 32, 64"));
    }
    if vpls > 65535 {
        return Err(format!(
            "visibility=ism draws each VPL's map with one workgroup of a dispatch: vpls={vpls} is over 65535"
        ));
    }
    Ok(())
}

/// Defines of a gather shader that includes [`LOOKUP_WGSL`]; `None`: shadow rays only.
pub fn lookup_defines(defines: Defines, settings: Option<&IsmSettings>) -> Defines {
    let s = settings.copied().unwrap_or(IsmSettings { size: 16, points_per_vpl: 1, bias: 0.0 });
    paraboloid_defines(defines, &s)
        .bool("ISM", settings.is_some())
        .f32("ISM_BIAS", s.bias)
        .f32("ISM_MAX_SLOPE", MAX_SLOPE)
}

/// Steepest receiver slope (tan θ) the lookup's depth bias follows. Measured on two-rooms (1024 VPLs,
/// 256², the dark room's floor against shadow rays with the same VPLs): 4 let the floor see VPLs
/// through the wall (24 % too bright), 1 shadowed the floor itself (28 % too dark), 2 gives +0.8 %.
const MAX_SLOPE: f32 = 2.0;

fn paraboloid_defines(defines: Defines, s: &IsmSettings) -> Defines {
    defines.u32("ISM_SIZE", s.size).u32("ISM_POINTS_PER_VPL", s.points_per_vpl).u32("ISM_POOL", pool_size(s))
}

fn map_defines(defines: Defines, s: &IsmSettings, scene: &Scene, total_area: f64) -> Defines {
    paraboloid_defines(defines, s)
        .f32("ISM_POINT_RADIUS", point_radius(total_area, s.points_per_vpl))
        // Ritschel et al.: thresholds of about 5 % of the scene's extent.
        .f32("ISM_PULL_THRESHOLD", 0.05 * scene.bounds().extent().max_element())
}

fn pool_size(s: &IsmSettings) -> u32 {
    (s.points_per_vpl * POOL_SUBSETS).min(MAX_POOL).max(s.points_per_vpl)
}

/// Radius of the disc one point of a VPL's subset stands for: the scene's area shared among the subset.
fn point_radius(total_area: f64, points_per_vpl: u32) -> f32 {
    (total_area / (std::f64::consts::PI * f64::from(points_per_vpl))).sqrt() as f32
}

fn triangle_areas(scene: &Scene) -> Vec<f64> {
    let mut areas = Vec::with_capacity(scene.triangle_count());
    for mesh in &scene.meshes {
        for t in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|i| mesh.positions[t[i] as usize].as_dvec3());
            areas.push(0.5 * (b - a).cross(c - a).length());
        }
    }
    areas
}

/// The point pool: `count` points placed by area over triangles of `areas` ([`triangle_areas`], the GPU scene's
/// triangle order), each as (triangle bits, u, v, 0). Triangles are picked by inverting the area CDF at
/// the base-2 radical inverse and the point inside by the base-3 and base-5 ones, so every window of
/// consecutive points (a VPL's subset) is stratified over the area.
pub fn point_pool(areas: &[f64], count: u32) -> Vec<[f32; 4]> {
    let mut cdf = Vec::with_capacity(areas.len());
    let mut sum = 0.0;
    for a in areas {
        sum += a;
        cdf.push(sum);
    }
    (0..count)
        .map(|i| {
            let target = radical_inverse(2, i) * sum;
            let triangle = cdf.partition_point(|&c| c <= target).min(areas.len().saturating_sub(1));
            // Uniform in the triangle (the square-root mapping of sample_triangle in sampling.wgsl).
            let (u1, u2) = (radical_inverse(3, i), radical_inverse(5, i));
            let r = u1.sqrt();
            let (u, v) = (r * (1.0 - u2), r * u2);
            [f32::from_bits(triangle as u32), u as f32, v as f32, 0.0]
        })
        .collect()
}

pub struct ImperfectShadowMaps {
    points: wgpu::ComputePipeline,
    points_group: wgpu::BindGroup,
    splat: wgpu::ComputePipeline,
    splat_group: wgpu::BindGroup,
    pull_push: wgpu::ComputePipeline,
    pull_push_group: wgpu::BindGroup,
    atlas: wgpu::Buffer,
    /// The filled atlas copied into a linear texture, which the gathers read.
    maps: wgpu::Texture,
    maps_view: wgpu::TextureView,
    settings: IsmSettings,
    pool: u32,
    vpl_count: u32,
    points_current: bool,
    bytes: u64,
}

impl ImperfectShadowMaps {
    /// Maps for the `vpl_count` VPLs of `vpls` (the layout of `GpuVpl`).
    pub fn new(
        setup: &TechniqueSetup,
        vpls: &wgpu::Buffer,
        vpl_count: u32,
        settings: IsmSettings,
    ) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let pool = pool_size(&settings);
        let atlas_bytes = u64::from(vpl_count) * u64::from(settings.size * settings.size) * 4;
        ctx.check_storage_size("the imperfect shadow map atlas", atlas_bytes)?;
        let atlas = compute::storage_buffer(ctx, "ism atlas", atlas_bytes);
        let maps = linear_texture::create(ctx, "ism maps", wgpu::TextureFormat::R32Float, atlas_bytes / 4)?;
        let maps_view = maps.create_view(&Default::default());
        let areas = triangle_areas(setup.scene);
        let pool_data = point_pool(&areas, pool);
        let pool_buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ism point pool"),
            contents: bytemuck::cast_slice(&pool_data),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let positions = compute::storage_buffer(ctx, "ism point positions", u64::from(pool) * 16);
        let total_area: f64 = areas.iter().sum();
        let defines = || map_defines(Defines::new(), &settings, setup.scene, total_area);
        let layouts = |layout| [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, layout];

        let points_layout = compute::layout(
            ctx,
            "ism points",
            &[storage_buffer_entry(0, true), storage_buffer_entry(1, false)],
        );
        let points_group = compute::bind_group(
            ctx,
            "ism points",
            &points_layout,
            &[pool_buffer.as_entire_binding(), positions.as_entire_binding()],
        );
        let points = compute::pipeline(
            ctx,
            "ism points",
            include_str!("points.wgsl"),
            setup.gpu_scene.bvh_defines(defines()),
            "main",
            &layouts(&points_layout),
        )?;

        let splat_layout = compute::layout(
            ctx,
            "ism splat",
            &[storage_buffer_entry(0, true), storage_buffer_entry(1, true), storage_buffer_entry(2, false)],
        );
        let splat_group = compute::bind_group(
            ctx,
            "ism splat",
            &splat_layout,
            &[vpls.as_entire_binding(), positions.as_entire_binding(), atlas.as_entire_binding()],
        );
        let splat = compute::pipeline(
            ctx,
            "ism splat",
            &format!("{VPL_WGSL}\n{PARABOLOID_WGSL}\n{}", include_str!("splat.wgsl")),
            setup.gpu_scene.bvh_defines(defines()),
            "main",
            &layouts(&splat_layout),
        )?;

        let pull_push_layout = compute::layout(ctx, "ism pull-push", &[storage_buffer_entry(0, false)]);
        let pull_push_group =
            compute::bind_group(ctx, "ism pull-push", &pull_push_layout, &[atlas.as_entire_binding()]);
        let pull_push = compute::pipeline(
            ctx,
            "ism pull-push",
            include_str!("pull_push.wgsl"),
            defines(),
            "main",
            &layouts(&pull_push_layout),
        )?;
        let bytes = atlas_bytes + linear_texture::bytes(&maps) + u64::from(pool) * 32;
        Ok(ImperfectShadowMaps {
            points,
            points_group,
            splat,
            splat_group,
            pull_push,
            pull_push_group,
            atlas,
            maps,
            maps_view,
            settings,
            pool,
            vpl_count,
            points_current: false,
            bytes,
        })
    }

    /// The filled maps, `ISM_SIZE²` distances per VPL (FLT_MAX where nothing was seen), as the linear
    /// texture `ism_maps` of `lookup.wgsl`.
    pub fn maps(&self) -> &wgpu::TextureView {
        &self.maps_view
    }

    /// Meshes moved: the pool is placed again before the next splat.
    pub fn geometry_moved(&mut self) {
        self.points_current = false;
    }

    /// Records the passes; the VPLs must be this frame's.
    pub fn render(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        fn groups<'a>(fc: &'a FrameContext, g: &'a wgpu::BindGroup) -> [&'a wgpu::BindGroup; 3] {
            [&fc.gpu_scene.bind_group, &fc.frame.bind_group, g]
        }
        if !self.points_current {
            profiler.pass(fc.ctx, "ism points", |encoder| {
                compute::dispatch(
                    encoder,
                    "ism points",
                    &self.points,
                    &groups(fc, &self.points_group),
                    [self.pool.div_ceil(GROUP), 1, 1],
                );
            })?;
            self.points_current = true;
        }
        profiler.pass(fc.ctx, "ism splat", |encoder| {
            encoder.clear_buffer(&self.atlas, 0, None);
            compute::dispatch(
                encoder,
                "ism splat",
                &self.splat,
                &groups(fc, &self.splat_group),
                [self.vpl_count, 1, 1],
            );
        })?;
        profiler.pass(fc.ctx, "ism pull-push", |encoder| {
            compute::dispatch(
                encoder,
                "ism pull-push",
                &self.pull_push,
                &groups(fc, &self.pull_push_group),
                [self.vpl_count, 1, 1],
            );
            linear_texture::copy_from_buffer(encoder, &self.atlas, &self.maps, self.atlas.size());
        })?;
        Ok(())
    }

    /// Counters for the stats.
    pub fn counters(&self) -> [(&'static str, f64); 4] {
        [
            ("ism_bytes", self.bytes as f64),
            ("ism_points_per_vpl", f64::from(self.settings.points_per_vpl)),
            ("ism_pool_points", f64::from(self.pool)),
            ("ism_size", f64::from(self.settings.size)),
        ]
    }
}

#[cfg(test)]
mod tests;
