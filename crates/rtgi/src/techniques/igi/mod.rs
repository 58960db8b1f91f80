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

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use wgpu::util::DeviceExt;

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::scene::{LIGHT_DIRECTIONAL, LIGHT_SPOT, luminance, mean_srgb_luminance};
use crate::gpu::{GpuContext, Profiler, readback};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::Scene;
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute::{
    self, DispatchSlots, storage_buffer_entry, storage_texture_entry, texture_entry, uniform_entry,
};
use super::direct::{DirectLighting, DirectOutput, with_direct_params};
use super::discontinuity::{DiscontinuityFilter, FilterSettings, packed_buffer_bytes};
use super::{FrameContext, FrameNeeds, Measured, Technique, TechniqueInfo, TechniqueSetup};

const VPL_WGSL: &str = include_str!("vpl.wgsl");

/// Light-path vertices beyond this are not stored (the Halton dimensions run out at 32).
pub const MAX_DEPTH: u32 = 8;
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

const IGI_PARAMS: [ParamSpec; 18] = igi_params!(
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

const IGI_SH_PARAMS: [ParamSpec; 16] = igi_params!();

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

/// Mirrors `Vpl` in vpl.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuVpl {
    pub position: [f32; 3],
    pub kind: u32,
    pub normal: [f32; 3],
    pub light: u32,
    pub flux: [f32; 3],
    pub roughness: f32,
    pub incoming: [f32; 3],
    pub metallic: f32,
    pub base_color: [f32; 3],
    pub specular: f32,
}

/// Mirrors `LightEntry` in generate.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct LightEntry {
    pub cdf: f32,
    pub probability: f32,
    pub kind: u32,
    pub index: u32,
}

const ENTRY_LIGHT: u32 = 0;
const ENTRY_EMISSIVE: u32 = 1;
const ENTRY_ENVIRONMENT: u32 = 2;

/// Mirrors `VplGeneration` in generate.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct VplGeneration {
    pub sets: u32,
    pub paths: u32,
    pub slots_per_set: u32,
    pub max_depth: u32,
    pub entry_count: u32,
    pub fixed_lights: u32,
    pub _pad: [u32; 2],
    pub sphere: [f32; 4],
}

/// How one set's VPL slots are spent: first `fixed` slots, one per analytic light, then `paths` light
/// paths, `alive[j]` of them reaching vertex j (round(paths · ρ̄^j), instant radiosity's quasi-random
/// roulette), vertex j's slots at `offset[j]` (`None` where vertex j is not stored: on the lights when
/// direct light comes from rasterisation).
///
/// Analytic (point, spot, directional) lights get a slot of their own in every set when VPLs carry the
/// direct light: every VPL instant radiosity would place on a point light is the light itself, so one
/// exact VPL replaces them all and removes their sampling noise; paths still start from every light in
/// proportion to power, and only their vertex 0 on emissive triangles and the environment is stored.
#[derive(Clone, Debug, PartialEq)]
pub struct SetLayout {
    pub fixed: u32,
    pub paths: u32,
    pub alive: Vec<u32>,
    pub offset: Vec<Option<u32>>,
    /// Slots used (≤ the slots per set; the rest stay empty).
    pub used: u32,
}

/// The set layout with the most paths whose stored vertices fit in `slots` after `fixed` light slots
/// (vertex 0 stored only when `store_vertex0`), or `None` when neither a light nor a path fits.
pub fn set_layout(
    slots: u32,
    survival: f32,
    depth: u32,
    fixed: u32,
    store_vertex0: bool,
) -> Option<SetLayout> {
    if fixed > slots {
        return None;
    }
    let build = |paths: u32| {
        let alive: Vec<u32> = (0..=depth)
            .map(|j| (f64::from(paths) * f64::from(survival).powi(j as i32)).round() as u32)
            .map(|n| n.min(paths))
            .collect();
        let mut offset = Vec::with_capacity(alive.len());
        let mut used = fixed;
        for (j, &n) in alive.iter().enumerate() {
            if j == 0 && !store_vertex0 {
                offset.push(None);
            } else {
                offset.push(Some(used));
                used += n;
            }
        }
        SetLayout { fixed, paths, alive, offset, used }
    };
    // `used` grows with `paths`, so search for the largest that fits.
    let (mut lo, mut hi) = (0u32, slots.max(1));
    while lo < hi {
        let mid = lo + (hi - lo).div_ceil(2);
        if build(mid).used <= slots { lo = mid } else { hi = mid - 1 }
    }
    let layout = build(lo);
    (layout.used > 0 && (lo > 0 || fixed > 0)).then_some(layout)
}

/// Area-weighted mean albedo (luminance of the BRDF's directional albedo at normal incidence) of the
/// scene's surfaces: the survival rate of light paths, clamped to [0.05, 0.95].
pub fn mean_albedo(scene: &Scene) -> f32 {
    let mut weighted = 0.0f64;
    let mut area = 0.0f64;
    for mesh in &scene.meshes {
        let Some(m) = scene.materials.get(mesh.material as usize) else { continue };
        let tex = m
            .base_color_texture
            .map_or(1.0, |t| scene.textures.get(t.texture as usize).map_or(1.0, mean_srgb_luminance));
        let base = luminance(m.base_color.truncate()) * tex;
        let dielectric = base * (1.0 - m.specular * 0.04) + m.specular * 0.04;
        let albedo = dielectric + (base - dielectric) * m.metallic;
        let mesh_area: f64 = mesh
            .indices
            .chunks_exact(3)
            .map(|t| {
                let p = |i: u32| mesh.positions[i as usize];
                f64::from((p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).length() * 0.5)
            })
            .sum();
        weighted += f64::from(albedo) * mesh_area;
        area += mesh_area;
    }
    if area <= 0.0 {
        return 0.5;
    }
    ((weighted / area) as f32).clamp(0.05, 0.95)
}

/// The light sources paths start from, with probabilities proportional to their (luminance) power.
pub fn light_entries(
    lights: &[crate::gpu::scene::GpuLight],
    emissive_power: f32,
    environment_power: f32,
    scene_radius: f32,
) -> Vec<LightEntry> {
    let disc = std::f32::consts::PI * scene_radius * scene_radius;
    let mut entries: Vec<(u32, u32, f32)> = lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let lum = luminance(Vec3::from(l.intensity));
            let power = match l.kind {
                LIGHT_DIRECTIONAL => lum * disc,
                LIGHT_SPOT => lum * 2.0 * std::f32::consts::PI * (1.0 - l.cos_outer),
                _ => lum * 4.0 * std::f32::consts::PI,
            };
            (ENTRY_LIGHT, i as u32, power)
        })
        .collect();
    // Emitters are two-sided: twice the one-sided power π·A·L.
    entries.push((ENTRY_EMISSIVE, 0, 2.0 * emissive_power));
    entries.push((ENTRY_ENVIRONMENT, 0, environment_power * disc));
    entries.retain(|e| e.2 > 0.0 && e.2.is_finite());
    let total: f32 = entries.iter().map(|e| e.2).sum();
    let mut running = 0.0;
    let mut out: Vec<LightEntry> = entries
        .iter()
        .map(|&(kind, index, power)| {
            running += power;
            LightEntry { cdf: running / total, probability: power / total, kind, index }
        })
        .collect();
    if let Some(last) = out.last_mut() {
        last.cdf = 1.0;
    }
    out
}

struct Igi {
    variant: Variant,
    direct: Option<DirectLighting>,
    generate: Option<(wgpu::ComputePipeline, wgpu::BindGroup, u32)>,
    gather: wgpu::ComputePipeline,
    gather_group: wgpu::BindGroup,
    chunks: DispatchSlots,
    filter: Option<DiscontinuityFilter>,
    shade: wgpu::ComputePipeline,
    shade_group: wgpu::BindGroup,
    clamp_stats: wgpu::Buffer,
    counters: BTreeMap<String, f64>,
    width: u32,
    height: u32,
    /// The light entries VPL paths start from, and the scene radius they were computed with: they hold
    /// light indices and powers, not positions, so moved lights keep them valid.
    entries: Vec<LightEntry>,
    radius: f32,
    /// The entries on the GPU (`None` when no VPL is generated).
    entry_buffer: Option<wgpu::Buffer>,
}

impl Igi {
    /// Rewrites the light entries for `gpu_scene`'s sources as they are now; `false` when their number
    /// changed (a source's power reached or left zero), which needs a new technique.
    fn update_entries(&mut self, ctx: &GpuContext, gpu_scene: &crate::gpu::GpuScene) -> bool {
        let entries = light_entries(
            &gpu_scene.lights,
            gpu_scene.info.emissive_power,
            gpu_scene.environment_power,
            self.radius,
        );
        if entries == self.entries {
            return true;
        }
        match &self.entry_buffer {
            Some(buffer) if entries.len() == self.entries.len() => {
                ctx.queue.write_buffer(buffer, 0, bytemuck::cast_slice(&entries));
                self.entries = entries;
                true
            }
            _ => false,
        }
    }
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
    Ok(())
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

    let device = &ctx.device;
    let vpl_count = u64::from(slots_per_set * sets);
    ctx.check_storage_size("the VPL buffer", vpl_count * size_of::<GpuVpl>() as u64)?;
    let vpl_buffer = compute::storage_buffer(ctx, "vpls", vpl_count * size_of::<GpuVpl>() as u64);

    // VPL generation.
    let bounds = setup.scene.bounds();
    let centre = (bounds.min + bounds.max) * 0.5;
    let radius = ((bounds.max - bounds.min).length() * 0.5).max(1e-3);
    let entries = light_entries(
        &setup.gpu_scene.lights,
        setup.gpu_scene.info.emissive_power,
        setup.gpu_scene.environment_power,
        radius,
    );
    let mut entry_buffer_kept = None;
    let generate = match (&layout, entries.is_empty() && analytic_lights == 0) {
        (Some(layout), false) => {
            counters.insert("paths_per_set".into(), f64::from(layout.paths));
            counters.insert("vpls_stored".into(), f64::from(layout.used * sets));
            let mut table: Vec<u32> = layout.alive.clone();
            table.extend(layout.offset.iter().map(|o| o.unwrap_or(u32::MAX)));
            let table_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("vpl layout"),
                contents: bytemuck::cast_slice(&table),
                usage: wgpu::BufferUsages::STORAGE,
            });
            let entry_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("light entries"),
                contents: bytemuck::cast_slice(&entries),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            });
            let params = VplGeneration {
                sets,
                paths: layout.paths,
                slots_per_set,
                max_depth: depth,
                entry_count: entries.len() as u32,
                fixed_lights: layout.fixed,
                _pad: [0; 2],
                sphere: [centre.x, centre.y, centre.z, radius],
            };
            let params_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("vpl generation"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let group_layout = compute::layout(
                ctx,
                "vpl generation",
                &[
                    storage_buffer_entry(0, false),
                    storage_buffer_entry(1, true),
                    storage_buffer_entry(2, true),
                    uniform_entry(3),
                ],
            );
            let group = compute::bind_group(
                ctx,
                "vpl generation",
                &group_layout,
                &[
                    vpl_buffer.as_entire_binding(),
                    table_buffer.as_entire_binding(),
                    entry_buffer.as_entire_binding(),
                    params_buffer.as_entire_binding(),
                ],
            );
            let pipeline = compute::pipeline(
                ctx,
                "vpl generation",
                &format!("{VPL_WGSL}\n{}", include_str!("generate.wgsl")),
                setup.gpu_scene.bvh_defines(Defines::new()),
                "main",
                &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &group_layout],
            )?;
            entry_buffer_kept = Some(entry_buffer);
            Some((pipeline, group, (sets * layout.paths.max(layout.fixed)).div_ceil(64)))
        }
        _ => {
            // No light, or too few slots for one path: every VPL stays empty (a black indirect term).
            counters.insert("paths_per_set".into(), 0.0);
            counters.insert("vpls_stored".into(), 0.0);
            None
        }
    };

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
    let gather_layout = compute::layout(
        ctx,
        "igi gather",
        &[
            storage_buffer_entry(0, true),
            storage_buffer_entry(1, false),
            storage_buffer_entry(2, false),
            chunks.entry(3),
        ],
    );
    let gather_group = compute::bind_group(
        ctx,
        "igi gather",
        &gather_layout,
        &[
            vpl_buffer.as_entire_binding(),
            accum.as_entire_binding(),
            clamp_stats.as_entire_binding(),
            chunks.resource(),
        ],
    );
    let gather = compute::pipeline(
        ctx,
        "igi gather",
        &format!("{VPL_WGSL}\n{}", include_str!("gather.wgsl")),
        setup.gpu_scene.bvh_defines(
            gather_defines(variant, ix, iy, slots_per_set, p.float("g_max") as f32)
                .bool("COMPENSATE", p.bool("bias_compensation"))
                .bool("DIRECT_RASTER", direct_raster),
        ),
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
    Ok(Box::new(Igi {
        entries,
        radius,
        entry_buffer: entry_buffer_kept,
        variant,
        direct,
        generate,
        gather,
        gather_group,
        chunks,
        filter,
        shade,
        shade_group,
        clamp_stats,
        counters,
        width,
        height,
    }))
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
        _: super::SceneChange,
    ) -> Result<bool, RenderError> {
        Ok(self.update_entries(ctx, gpu_scene))
    }

    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let groups = |g| [&fc.gpu_scene.bind_group, &fc.frame.bind_group, g];
        if let Some(direct) = &self.direct {
            direct.render(fc, profiler)?;
        }
        if let Some((pipeline, group, workgroups)) = &self.generate {
            profiler.pass(fc.ctx, "vpl generation", |encoder| {
                compute::dispatch(encoder, "vpl generation", pipeline, &groups(group), [*workgroups, 1, 1]);
            })?;
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
