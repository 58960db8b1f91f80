//! `igi` and `igi-sh`: instant global illumination (Wald et al. 2002) — VPLs from quasi-random light
//! paths (instant radiosity), interleaved sampling and the discontinuity filter — and its extension that
//! filters incident radiance projected on order-2 spherical harmonics instead of irradiance, so the
//! filter may cross normal changes (normal maps) and glossy BRDFs can be shaded (the method of
//! `research/seeds/000`).
//!
//! Per frame: `vpl generation` (light paths → VPL sets), `visibility + accumulation` (per pixel, the
//! VPLs of its set through shadow rays: demodulated radiance, or SH coefficients), `discontinuity
//! filter`, `shading` (recombine with the BRDF; plus the `direct` pass when `direct=raster`).

use std::collections::BTreeMap;

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::{GpuContext, Profiler, linear_texture, readback};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute::{self, DispatchSlots, storage_buffer_entry, storage_texture_entry, texture_entry};
use super::direct::{DirectLighting, DirectOutput, with_direct_params};
use super::discontinuity::{DiscontinuityFilter, FilterSettings, packed_buffer_bytes};
use super::ism::{self, ImperfectShadowMaps, IsmSettings};
use super::light_paths::{GpuVpl, LightPaths, MAX_DEPTH, VPL_WGSL, mean_albedo, set_layout};
use super::{FrameContext, FrameNeeds, Measured, Technique, TechniqueInfo, TechniqueSetup};

/// VPLs per set and dispatch of the gather pass.
const CHUNK: u32 = 256;

macro_rules! igi_params {
    ($($extra:expr),* $(,)?) => {
        with_direct_params![
            ParamSpec {
                name: "vpls",
                kind: ParamKind::Int { min: 1, max: 1 << 20 },
                default: "1024",
                doc: "total VPLs per frame over all interleaving sets (each set gets vpls / (n·m) slots)",
            },
            ParamSpec {
                name: "depth",
                kind: ParamKind::Int { min: 0, max: MAX_DEPTH as i64 },
                default: "8",
                doc: "light-path depth: VPLs are stored at up to this many reflections (0 = on the lights only)",
            },
            ParamSpec {
                name: "interleave",
                kind: ParamKind::Size2 { max: 16 },
                default: "4x4",
                doc: "n×m uncorrelated VPL sets; pixel (x, y) uses set (x mod n) + n·(y mod m)",
            },
            ParamSpec {
                name: "direct",
                kind: ParamKind::Choice(&["vpl", "raster"]),
                default: "raster",
                doc: "direct light from the `direct` technique with VPLs for indirect light only (raster, the default: at every VPL count of the quick bench, docs/measurements/bench-quick, it had the lower FLIP on all three scenes — few VPLs on a light are a noisy estimate of its direct light, and order-2 SH band-limit them), or from the VPLs on the light sources too (vpl: all light from VPLs, as in the papers)",
            },
            ParamSpec {
                name: "g_max",
                kind: ParamKind::Float { min: 0.0, max: 1e9 },
                default: "0",
                doc: "bound on the VPL's part cos θ_vpl/d² of the geometry term (1/m²), VPLs on surfaces only; 0 = unbounded",
            },
            ParamSpec {
                name: "bias_compensation",
                kind: ParamKind::Bool,
                default: "false",
                doc: "add back the light removed by g_max with one hemisphere ray per pixel (Kollig & Keller 2004)",
            },
            super::ism::ISM_PARAMS[0],
            super::ism::ISM_PARAMS[1],
            super::ism::ISM_PARAMS[2],
            super::ism::ISM_PARAMS[3],
            ParamSpec {
                name: "filter",
                kind: ParamKind::Bool,
                default: "true",
                doc: "apply the discontinuity filter (one interleaving cell wide)",
            },
            ParamSpec {
                name: "depth_threshold",
                kind: ParamKind::Float { min: 0.0, max: 10.0 },
                default: "0.02",
                doc: "filter: largest distance of a neighbour from the pixel's tangent plane, relative to its camera distance",
            },
            $($extra,)*
        ]
    };
}

const IGI_PARAMS: [ParamSpec; 22] = igi_params!(
    ParamSpec {
        name: "filter_normals",
        kind: ParamKind::Bool,
        default: "true",
        doc: "filter: stop at normal changes (false = filter irradiance across normals)",
    },
    ParamSpec {
        name: "normal_threshold",
        kind: ParamKind::Float { min: -1.0, max: 1.0 },
        default: "0.9",
        doc: "filter: smallest cosine between shading normals that counts as the same surface",
    },
);

const IGI_SH_PARAMS: [ParamSpec; 20] = igi_params!();

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "igi",
    description: "instant global illumination: VPLs, interleaved sampling, discontinuity filter of irradiance",
    params: &IGI_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate,
    create: create_classic,
};

pub const SH_INFO: TechniqueInfo = TechniqueInfo {
    name: "igi-sh",
    description: "IGI filtering incident radiance as order-2 SH: keeps normal-map detail, shades glossy BRDFs",
    params: &IGI_SH_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate,
    create: create_sh,
};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Variant {
    Classic,
    Sh,
}

impl Variant {
    /// Packed half-float vec4s per pixel: demodulated RGB radiance, or 9 RGB SH coefficients.
    fn vec4s(self) -> u32 {
        match self {
            Variant::Classic => 1,
            Variant::Sh => 7,
        }
    }
}

struct Igi {
    variant: Variant,
    direct: Option<DirectLighting>,
    light_paths: LightPaths,
    gather: wgpu::ComputePipeline,
    gather_group: wgpu::BindGroup,
    vpl_buffer: wgpu::Buffer,
    /// This frame's VPLs copied into a linear texture for the gather's loop (`table_vpl` in gather.wgsl).
    vpl_table: wgpu::Texture,
    chunks: DispatchSlots,
    ism: Option<ImperfectShadowMaps>,
    filter: Option<DiscontinuityFilter>,
    shade: wgpu::ComputePipeline,
    shade_group: wgpu::BindGroup,
    clamp_stats: wgpu::Buffer,
    counters: BTreeMap<String, f64>,
    width: u32,
    height: u32,
}

fn create_classic(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    create(setup, Variant::Classic)
}

fn create_sh(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    create(setup, Variant::Sh)
}

/// The parameter combinations that leave a set without VPLs, checked before any GPU work. (That every
/// set holds one VPL per analytic light with `direct=vpl` depends on the scene: `create` checks it.)
fn validate(p: &ParamValues) -> Result<(), String> {
    let (ix, iy) = p.size2("interleave");
    let sets = ix * iy;
    let vpls = p.int("vpls") as u32;
    if vpls < sets {
        return Err(format!(
            "vpls={vpls} gives no VPL to each of the {sets} interleaving sets ({ix}x{iy}); \
             use vpls >= {sets} or a smaller interleave"
        ));
    }
    if p.choice("direct") == "raster" && p.int("depth") == 0 {
        return Err(
            "depth=0 with direct=raster leaves no VPLs (depth 0 stores VPLs on the lights only)".into()
        );
    }
    super::ism::validate(p, vpls)
}

fn create(setup: &TechniqueSetup, variant: Variant) -> Result<Box<dyn Technique>, RenderError> {
    let ctx = setup.ctx;
    let p = setup.params;
    let name = if variant == Variant::Sh { "igi-sh" } else { "igi" };
    let (ix, iy) = p.size2("interleave");
    let sets = ix * iy;
    let vpls = p.int("vpls") as u32;
    let depth = p.int("depth") as u32;
    let direct_raster = p.choice("direct") == "raster";
    let slots_per_set = vpls / sets;
    let survival = mean_albedo(setup.scene);
    let analytic_lights = setup.gpu_scene.lights.len() as u32;
    // Vertex 0 is stored for emissive triangles and the environment only (analytic lights have their
    // fixed slots), and only when VPLs carry the direct light.
    let sampled_sources = setup.gpu_scene.info.emissive_count > 0 || setup.gpu_scene.environment_power > 0.0;
    let fixed = if direct_raster { 0 } else { analytic_lights };
    let layout = set_layout(slots_per_set, survival, depth, fixed, !direct_raster && sampled_sources);
    let (width, height) = (setup.frame.width, setup.frame.height);

    let mut counters = BTreeMap::from([
        ("vpl_slots".to_string(), f64::from(slots_per_set * sets)),
        ("sets".to_string(), f64::from(sets)),
        ("survival".to_string(), f64::from(survival)),
    ]);
    // `resolve` ran this already; again here so that no caller gets a technique with empty VPL sets.
    validate(p).map_err(|e| RenderError::InvalidSettings(format!("{name}: {e}")))?;
    if !direct_raster && analytic_lights > slots_per_set {
        return Err(RenderError::InvalidSettings(format!(
            "{name}: with direct=vpl every interleaving set holds one VPL per analytic light ({analytic_lights}), \
             but vpls={vpls} gives {slots_per_set} per set ({ix}x{iy}); raise vpls or use direct=raster"
        )));
    }

    let vpl_count = u64::from(slots_per_set * sets);
    ctx.check_storage_size("the VPL buffer", vpl_count * size_of::<GpuVpl>() as u64)?;
    let vpl_buffer = compute::storage_buffer(ctx, "vpls", vpl_count * size_of::<GpuVpl>() as u64);
    let vpl_table = linear_texture::create(
        ctx,
        "igi vpl table",
        wgpu::TextureFormat::Rgba32Uint,
        vpl_count * VPL_TABLE_TEXELS,
    )?;
    let vpl_table_view = vpl_table.create_view(&Default::default());

    // VPL generation.
    let light_paths = LightPaths::new(setup, &vpl_buffer, sets, slots_per_set, depth, layout.as_ref())?;
    let (paths, stored) = match (&layout, light_paths.traces()) {
        (Some(layout), true) => (layout.paths, layout.used * sets),
        // No light, or too few slots for one path: every VPL stays empty (a black indirect term).
        _ => (0, 0),
    };
    counters.insert("paths_per_set".into(), f64::from(paths));
    counters.insert("vpls_stored".into(), f64::from(stored));

    // Visibility + accumulation.
    let vec4s = variant.vec4s();
    let packed = packed_buffer_bytes(width, height, vec4s);
    ctx.check_storage_size("the per-pixel VPL accumulation buffer", packed)?;
    let accum = compute::storage_buffer(ctx, "igi accumulation", packed);
    let filtered = compute::storage_buffer(ctx, "igi filtered", packed);
    let clamp_stats = compute::storage_buffer(ctx, "igi clamp stats", u64::from(width * height) * 16);
    // Chunk.begin of each dispatch (see gather.wgsl).
    let chunk_begins: Vec<[u32; 4]> =
        (0..slots_per_set.div_ceil(CHUNK)).map(|c| [c * CHUNK, 0, 0, 0]).collect();
    let chunks = DispatchSlots::new(ctx, "igi chunks", &chunk_begins);
    let ism_settings = IsmSettings::from_params(p);
    let ism = match &ism_settings {
        Some(s) => Some(ImperfectShadowMaps::new(setup, &vpl_buffer, slots_per_set * sets, *s)?),
        None => None,
    };
    // With shadow rays only, the lookup's binding gets a placeholder.
    let no_ism = match &ism {
        Some(_) => None,
        None => Some(
            linear_texture::create(ctx, "igi no ism", wgpu::TextureFormat::R32Float, 1)?
                .create_view(&Default::default()),
        ),
    };
    let ism_maps = ism.as_ref().map(|m| m.maps()).or(no_ism.as_ref()).expect("one of the two");
    let gather_layout = compute::layout(
        ctx,
        "igi gather",
        &[
            compute::texture_entry(0, wgpu::TextureSampleType::Uint),
            storage_buffer_entry(1, false),
            storage_buffer_entry(2, false),
            chunks.entry(3),
            compute::texture_entry(4, wgpu::TextureSampleType::Float { filterable: false }),
        ],
    );
    let gather_group = compute::bind_group(
        ctx,
        "igi gather",
        &gather_layout,
        &[
            wgpu::BindingResource::TextureView(&vpl_table_view),
            accum.as_entire_binding(),
            clamp_stats.as_entire_binding(),
            chunks.resource(),
            wgpu::BindingResource::TextureView(ism_maps),
        ],
    );
    let gather = compute::pipeline(
        ctx,
        "igi gather",
        &gather_source(),
        setup.gpu_scene.bvh_defines(ism::lookup_defines(
            gather_defines(variant, ix, iy, slots_per_set, p.float("g_max") as f32)
                .bool("COMPENSATE", p.bool("bias_compensation"))
                .bool("DIRECT_RASTER", direct_raster),
            ism_settings.as_ref(),
        )),
        "main",
        &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &gather_layout],
    )?;

    // Discontinuity filter.
    let filter = if p.bool("filter") && sets > 1 {
        let normal_cos = match variant {
            Variant::Classic if p.bool("filter_normals") => Some(p.float("normal_threshold") as f32),
            _ => None,
        };
        let settings = FilterSettings {
            window: [ix, iy],
            depth_threshold: p.float("depth_threshold") as f32,
            normal_cos,
            material_test: true,
        };
        Some(DiscontinuityFilter::new(setup, &accum, &filtered, vec4s, &settings)?)
    } else {
        None
    };

    // Direct light and shading.
    let direct_texture = compute::storage_texture(
        ctx,
        "igi direct",
        if direct_raster { width } else { 1 },
        if direct_raster { height } else { 1 },
        OUTPUT_FORMAT,
    );
    let direct = if direct_raster {
        Some(DirectLighting::new(setup, &direct_texture, DirectOutput::Replace)?)
    } else {
        None
    };
    let shade_layout = compute::layout(
        ctx,
        "igi shade",
        &[
            storage_buffer_entry(0, true),
            texture_entry(1, wgpu::TextureSampleType::Float { filterable: false }),
            storage_texture_entry(2, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
        ],
    );
    let direct_view = direct_texture.create_view(&Default::default());
    let output_view = setup.output.create_view(&Default::default());
    let shade_group = compute::bind_group(
        ctx,
        "igi shade",
        &shade_layout,
        &[
            if filter.is_some() { filtered.as_entire_binding() } else { accum.as_entire_binding() },
            wgpu::BindingResource::TextureView(&direct_view),
            wgpu::BindingResource::TextureView(&output_view),
        ],
    );
    let shade = compute::pipeline(
        ctx,
        "igi shade",
        include_str!("shade.wgsl"),
        shade_defines(variant, direct_raster),
        "main",
        &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &shade_layout],
    )?;

    let data_bytes = f64::from(vec4s * 8);
    counters.insert("accumulation_bytes_per_pixel".into(), data_bytes);
    counters.insert("filtered_bytes_per_pixel".into(), if filter.is_some() { data_bytes } else { 0.0 });
    counters.insert("clamp_stats_bytes_per_pixel".into(), 16.0);
    counters.insert("direct_bytes_per_pixel".into(), if direct_raster { 16.0 } else { 0.0 });
    counters.insert("output_bytes_per_pixel".into(), 16.0);
    counters.insert("vpl_bytes".into(), (vpl_count * size_of::<GpuVpl>() as u64) as f64);
    if let Some(ism) = &ism {
        counters.extend(ism.counters().map(|(k, v)| (k.to_string(), v)));
    }
    Ok(Box::new(Igi {
        variant,
        direct,
        light_paths,
        gather,
        gather_group,
        vpl_buffer,
        vpl_table,
        chunks,
        ism,
        filter,
        shade,
        shade_group,
        clamp_stats,
        counters,
        width,
        height,
    }))
}

/// Texels per VPL of the gather's VPL table (`VPL_TABLE_TEXELS` in gather.wgsl): a [`GpuVpl`]'s bytes.
const VPL_TABLE_TEXELS: u64 = (size_of::<GpuVpl>() / 16) as u64;
const _: () = assert!(size_of::<GpuVpl>().is_multiple_of(16));

fn gather_source() -> String {
    format!("{VPL_WGSL}\n{}\n{}\n{}", ism::PARABOLOID_WGSL, ism::LOOKUP_WGSL, include_str!("gather.wgsl"))
}

fn gather_defines(variant: Variant, ix: u32, iy: u32, slots_per_set: u32, g_max: f32) -> Defines {
    Defines::new()
        .bool("SH", variant == Variant::Sh)
        .u32("VEC4S", variant.vec4s())
        .u32("INTERLEAVE_X", ix)
        .u32("INTERLEAVE_Y", iy)
        .u32("SLOTS_PER_SET", slots_per_set)
        .u32("CHUNK", CHUNK)
        .f32("G_MAX", g_max)
}

fn shade_defines(variant: Variant, direct_raster: bool) -> Defines {
    Defines::new()
        .bool("SH", variant == Variant::Sh)
        .u32("VEC4S", variant.vec4s())
        .bool("DIRECT_RASTER", direct_raster)
}

impl Technique for Igi {
    // VPLs are generated from the scene's lights and environment every frame; the light entries (which
    // source a path starts from, by power) are rewritten in place.
    fn scene_changed(
        &mut self,
        ctx: &GpuContext,
        gpu_scene: &crate::gpu::GpuScene,
        change: super::SceneChange,
    ) -> Result<bool, RenderError> {
        if change == super::SceneChange::Geometry
            && let Some(ism) = &mut self.ism
        {
            ism.geometry_moved();
        }
        Ok(self.light_paths.update_entries(ctx, gpu_scene))
    }

    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        if let Some(direct) = &self.direct {
            direct.render(fc, profiler)?;
        }
        self.light_paths.dispatch(fc, profiler, "vpl generation")?;
        profiler.pass(fc.ctx, "vpl table", |encoder| {
            linear_texture::copy_from_buffer(
                encoder,
                &self.vpl_buffer,
                &self.vpl_table,
                self.vpl_buffer.size(),
            )
        })?;
        if let Some(ism) = &mut self.ism {
            ism.render(fc, profiler)?;
        }
        profiler.pass(fc.ctx, "visibility + accumulation", |encoder| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("visibility + accumulation"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.gather);
            pass.set_bind_group(0, &fc.gpu_scene.bind_group, &[]);
            pass.set_bind_group(1, &fc.frame.bind_group, &[]);
            for offset in self.chunks.offsets() {
                pass.set_bind_group(2, &self.gather_group, &[offset]);
                pass.dispatch_workgroups(
                    self.width.div_ceil(compute::TILE),
                    self.height.div_ceil(compute::TILE),
                    1,
                );
            }
        })?;
        if let Some(filter) = &self.filter {
            filter.render(fc, profiler, "discontinuity filter")?;
        }
        compute::frame_pass(fc, profiler, "shading", &self.shade, &self.shade_group)
    }

    fn counters(&mut self, ctx: &GpuContext, _: &Measured) -> Result<BTreeMap<String, f64>, RenderError> {
        let bytes =
            readback::read_buffer(ctx, &self.clamp_stats, 0, u64::from(self.width * self.height) * 16)?;
        let stats: &[f32] = bytemuck::cast_slice(&bytes);
        let mut sums = [0.0f64; 4];
        for s in stats.chunks_exact(4) {
            for (sum, v) in sums.iter_mut().zip(s) {
                *sum += f64::from(*v);
            }
        }
        let [kept, lost, compensated, overflowed] = sums;
        let fraction = |x: f64| if kept + lost > 0.0 { x / (kept + lost) } else { 0.0 };
        let mut c = self.counters.clone();
        // Of the last frame's incident light (luminance, all pixels): the share the bound removed, and
        // the share bias compensation added back.
        c.insert("clamped_energy_fraction".into(), fraction(lost));
        c.insert("compensated_energy_fraction".into(), fraction(compensated));
        // Pixels whose stored light exceeded the half-float range and was scaled down into it.
        c.insert("half_overflow_pixels".into(), overflowed);
        c.insert("sh".into(), if self.variant == Variant::Sh { 1.0 } else { 0.0 });
        Ok(c)
    }
}

#[cfg(test)]
mod tests;
