//! `glints`: direct light on high-frequency normal-mapped surfaces with the reflectance filtered over
//! each pixel's footprint, from a cumulative histogram of the normal map's micronormals: part (a) of
//! "Scalable Appearance Filtering for Complex Lighting Effects" (Gamboa, Guertin & Nowrouzezahrai,
//! SIGGRAPH Asia 2018; seed 003, article 2).
//!
//! Once per scene, on the CPU: for every normal-mapped material, the histogram SAT of its map
//! ([`histogram`]). Per frame, one GPU pass: a pixel on such a material re-casts its primary ray, bounds
//! the ray differentials' footprint by a box in texel space (the axis-aligned box with the footprint's
//! second moments), reads the box's normal histogram in 4–16 lookups per bin, and reflects light with
//! Σ_b w_b f(n_b; v, l) (n_b·l)⁺, the shared BRDF with each non-empty bin's normal as shading normal and
//! the bin's share of the footprint as weight ("G × D" with the thesis's histogram). One evaluation per
//! light gives the converged glint pattern of a point, spot or directional light: no sub-pixel sampling,
//! no noise, no temporal aliasing.
//!
//! Emissive triangles and the environment are lit by light samples weighted by the filtered
//! reflectance: unbiased, but noisy per frame like `direct`, converging over frames. With `env_order`
//! above 0 the environment's specular light is instead part (b) of the paper, basis-space
//! integration ([`environment`]): the footprint's normal distribution as SH over the half vector (each
//! bin's GGX lobe, a zonal harmonic turned to the bin's normal, weighted by the bin's F·G at its
//! mirror direction) dotted with the view's half-vector-space lighting, converged in one frame but
//! for the lighting's SH truncation; shadows by the ratio estimator of Heitz et al. 2018 over the same
//! environment samples, accumulated over frames. The footprint is an axis-aligned box (as the
//! thesis's, though moment-matched rather than bounding), so the shape of sheared or rotated
//! anisotropic footprints is lost; a microfacet's own roughness is the material's.

pub mod environment;
pub mod histogram;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::{BufferBuilder, GpuContext, GpuScene, Profiler, readback};
use crate::params::{ParamKind, ParamSpec};
use crate::scene::Scene;
use crate::shaders::Defines;

use super::compute::{self, storage_buffer_entry, storage_texture_entry};
use super::direct::with_direct_params;
use super::{
    FrameContext, FrameNeeds, Measured, RenderError, SceneChange, Technique, TechniqueInfo, TechniqueSetup,
};
use histogram::NormalHistogram;

pub const PARAMS: [ParamSpec; 11] = with_direct_params![
    ParamSpec {
        name: "bins",
        kind: ParamKind::Int { min: 3, max: 33 },
        default: "17",
        doc: "histogram bins along each axis of the projected disc of normals (odd keeps a bin centred on the macro normal); memory is (bins² + bins) × 4 bytes per texel",
    },
    ParamSpec {
        name: "env_order",
        kind: ParamKind::Int { min: 0, max: 24 },
        default: "0",
        doc: "0: the environment through light samples; N: its specular light by basis-space integration with SH of N bands (order N, N² coefficients) over the half vector, shadows by the ratio estimator",
    },
    ParamSpec {
        name: "env_views",
        kind: ParamKind::Int { min: 4, max: 128 },
        default: "24",
        doc: "with env_order > 0: view directions of the half-vector lighting table, (env_views + 1) latitudes × 2 env_views longitudes, each env_order² rgb coefficients",
    },
];

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "glints",
    description: "glints: direct light on normal-mapped surfaces filtered over each pixel's footprint by a histogram SAT of micronormals",
    params: &PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate: super::independent_params,
    create,
};

/// Per material: where its histogram is (WGSL `GlintMaterial`); `size` 0 for materials without a
/// normal map.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuGlintMaterial {
    pub offset: u32,
    pub size: u32,
    pub bins: u32,
    pub weight_per_texel: u32,
    pub normal_offset: u32,
    pub _pad: [u32; 3],
}

/// The counters' slots (COUNTER_* in glints.wgsl).
pub const COUNTERS: [&str; 4] =
    ["glints_pixels", "glints_active_bins", "glints_slot_groups", "glints_clamped_footprints"];

/// The histograms of a scene's normal-mapped materials, one per distinct (map, normal scale).
pub struct SceneHistograms {
    pub materials: Vec<GpuGlintMaterial>,
    pub histograms: Vec<NormalHistogram>,
}

/// Bytes of `maps` histograms of `size`² texels with `bins`² bins.
pub fn histogram_bytes(bins: u32, maps: u64, size: u32) -> u64 {
    maps * u64::from(size) * u64::from(size) * u64::from(histogram::stored_bins(bins)) * 4
}

/// The largest odd number of bins, at most `requested` (at most one below it when it is even), whose
/// histograms fit in one binding of `limit` bytes; `None` when not even 3 do.
pub fn fitting_bins(requested: u32, maps: u64, size: u32, limit: u64) -> Option<u32> {
    if histogram_bytes(requested, maps, size) <= limit {
        return Some(requested);
    }
    let mut bins = if requested.is_multiple_of(2) { requested - 1 } else { requested - 2 };
    while bins >= 3 {
        if histogram_bytes(bins, maps, size) <= limit {
            return Some(bins);
        }
        bins -= 2;
    }
    None
}

impl SceneHistograms {
    /// How many histograms [`SceneHistograms::build`] makes: the distinct (normal map, normal scale)
    /// pairs of the scene's materials.
    pub fn distinct_maps(scene: &Scene) -> u64 {
        let mut keys: Vec<(u32, u32)> = scene
            .materials
            .iter()
            .filter_map(|m| m.normal_texture.map(|t| (t.texture, m.normal_scale.to_bits())))
            .collect();
        keys.sort_unstable();
        keys.dedup();
        keys.len() as u64
    }

    /// `texture_size`: the side of the linear texture array's layers, which the GPU samples.
    pub fn build(scene: &Scene, texture_size: u32, bins: u32) -> Self {
        let mut keys: Vec<(u32, u32)> = Vec::new();
        let mut histograms: Vec<NormalHistogram> = Vec::new();
        let mut materials = Vec::with_capacity(scene.materials.len());
        let mut offset = 0u32;
        let mut normal_offset = 0u32;
        let mut placed: Vec<(u32, u32)> = Vec::new();
        for m in &scene.materials {
            let Some(t) = m.normal_texture else {
                materials.push(GpuGlintMaterial::default());
                continue;
            };
            let key = (t.texture, m.normal_scale.to_bits());
            let index = match keys.iter().position(|k| *k == key) {
                Some(i) => i,
                None => {
                    let image = crate::gpu::scene::texture_layer_image(scene, t.texture, texture_size);
                    let h = NormalHistogram::build(image.as_raw(), texture_size, m.normal_scale, bins);
                    keys.push(key);
                    placed.push((offset, normal_offset));
                    offset += h.sat.len() as u32;
                    normal_offset += h.bin_count();
                    histograms.push(h);
                    keys.len() - 1
                }
            };
            let h = &histograms[index];
            materials.push(GpuGlintMaterial {
                offset: placed[index].0,
                size: h.width,
                bins: h.bins,
                weight_per_texel: h.weight_per_texel(),
                normal_offset: placed[index].1,
                _pad: [0; 3],
            });
        }
        SceneHistograms { materials, histograms }
    }

    pub fn bytes(&self) -> u64 {
        self.histograms.iter().map(NormalHistogram::bytes).sum()
    }
}

pub struct Glints {
    pipeline: wgpu::ComputePipeline,
    environment: Option<environment::EnvironmentTables>,
    history_bytes: u64,
    group: wgpu::BindGroup,
    counters: wgpu::Buffer,
    histogram_bytes: u64,
    width: u32,
    height: u32,
    histogram_count: usize,
    build_ms: f64,
    warnings: Vec<String>,
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    Ok(Box::new(Glints::new(setup)?))
}

impl Glints {
    pub fn new(setup: &TechniqueSetup) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let requested = setup.params.int("bins") as u32;
        let size = setup.gpu_scene.linear_texture_size;
        let maps = SceneHistograms::distinct_maps(setup.scene);
        let limit = ctx.limits().max_storage_buffer_binding_size;
        let mut warnings = Vec::new();
        let bins = fitting_bins(requested, maps, size, limit).ok_or_else(|| {
            RenderError::InvalidSettings(format!(
                "glints: the normal histograms of {maps} map(s) at {size}² texels do not fit the device's \
                 max_storage_buffer_binding_size of {} MiB even with 3 × 3 bins",
                limit >> 20
            ))
        })?;
        if bins < requested {
            warnings.push(format!(
                "glints: bins={requested} would take {} MiB for {maps} map(s) at {size}² texels, over the device's \
                 max_storage_buffer_binding_size of {} MiB: using bins={bins}",
                histogram_bytes(requested, maps, size) >> 20,
                limit >> 20
            ));
        }
        let t0 = std::time::Instant::now();
        let scene_histograms = SceneHistograms::build(setup.scene, size, bins);
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        if scene_histograms.histograms.is_empty() {
            warnings.push("glints: the scene has no normal-mapped material; direct light only".to_string());
        }
        let histogram_bytes = scene_histograms.bytes();
        let sat: Vec<u32> = if scene_histograms.histograms.is_empty() {
            vec![0]
        } else {
            scene_histograms.histograms.iter().flat_map(|h| h.sat.iter().copied()).collect()
        };
        let mut normals: Vec<[f32; 4]> = scene_histograms
            .histograms
            .iter()
            .flat_map(|h| h.bin_normals.iter().map(|n| n.extend(0.0).to_array()))
            .collect();
        if normals.is_empty() {
            normals.push([0.0, 0.0, 1.0, 0.0]);
        }
        let mut materials = scene_histograms.materials;
        if materials.is_empty() {
            materials.push(GpuGlintMaterial::default());
        }
        let buffers = [
            BufferBuilder::with_contents("glints materials", bytemuck::cast_slice(&materials))
                .storage()
                .build(ctx)?,
            BufferBuilder::with_contents("glints histograms", bytemuck::cast_slice(&sat))
                .storage()
                .build(ctx)?,
            BufferBuilder::with_contents("glints bin normals", bytemuck::cast_slice(&normals))
                .storage()
                .build(ctx)?,
            BufferBuilder::new("glints counters", 4 * COUNTERS.len() as u64).storage().copy().build(ctx)?,
        ];
        let mut order = setup.params.int("env_order") as u32;
        let env_samples = setup.params.int("env_samples") as u32;
        if order > 0 && setup.scene.environment == crate::scene::Environment::None {
            warnings.push("glints: env_order has no effect: the scene has no environment".to_string());
            order = 0;
        }
        if order > 0 && env_samples == 0 {
            warnings.push(
                "glints: env_samples=0 leaves the ratio estimator no samples: the environment's specular light is unshadowed"
                    .to_string(),
            );
        }
        let environment = if order > 0 {
            let shape = environment::TableShape::new(order, setup.params.int("env_views") as u32);
            Some(environment::EnvironmentTables::new(setup, shape)?)
        } else {
            None
        };
        let (width, height) = (setup.output.width(), setup.output.height());
        let history_bytes = if environment.is_some() { 64 * u64::from(width) * u64::from(height) } else { 0 };
        let history = environment
            .as_ref()
            .map(|_| BufferBuilder::new("glints environment history", history_bytes).storage().build(ctx))
            .transpose()?;
        let mut entries: Vec<wgpu::BindGroupLayoutEntry> =
            (0..3).map(|b| storage_buffer_entry(b, true)).collect();
        entries.push(storage_buffer_entry(3, false));
        entries.push(storage_texture_entry(4, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite));
        if environment.is_some() {
            entries.extend([
                storage_buffer_entry(5, true),
                storage_buffer_entry(6, true),
                storage_buffer_entry(7, false),
            ]);
        }
        let layout = compute::layout(ctx, "glints", &entries);
        let output = setup.output.create_view(&Default::default());
        let mut resources: Vec<wgpu::BindingResource> =
            buffers.iter().map(|b| b.as_entire_binding()).collect();
        resources.push(wgpu::BindingResource::TextureView(&output));
        if let (Some(tables), Some(history)) = (&environment, &history) {
            resources.extend([
                tables.table.as_entire_binding(),
                tables.lobe_zh.as_entire_binding(),
                history.as_entire_binding(),
            ]);
        }
        let group = compute::bind_group(ctx, "glints", &layout, &resources);
        let mut defines = setup
            .gpu_scene
            .bvh_defines(Defines::new())
            .u32("AREA_SAMPLES", setup.params.int("area_samples") as u32)
            .u32("ENV_SAMPLES", env_samples)
            .bool("GLINT_ENV_SH", environment.is_some());
        if let Some(tables) = &environment {
            defines = tables.shape.defines(defines);
        }
        let pipeline = compute::pipeline(
            ctx,
            "glints",
            include_str!("glints.wgsl"),
            defines,
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout],
        )?;
        Ok(Glints {
            pipeline,
            environment,
            history_bytes,
            group,
            counters: buffers[3].clone(),
            histogram_bytes,
            width,
            height,
            histogram_count: scene_histograms.histograms.len(),
            build_ms,
            warnings,
        })
    }

    /// The counters of the last frame (see [`COUNTERS`]).
    pub fn read_counters(&self, ctx: &GpuContext) -> Result<[u32; 4], RenderError> {
        let bytes = readback::read_buffer(ctx, &self.counters, 0, 4 * COUNTERS.len() as u64)?;
        Ok(bytemuck::pod_read_unaligned(&bytes))
    }
}

impl Technique for Glints {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        if let Some(tables) = &mut self.environment {
            tables.update(fc, profiler)?;
        }
        profiler.pass(fc.ctx, "glints", |encoder| {
            encoder.clear_buffer(&self.counters, 0, None);
            compute::dispatch_pixels(
                encoder,
                "glints",
                &self.pipeline,
                &[&fc.gpu_scene.bind_group, &fc.frame.bind_group, &self.group],
                fc.frame.width,
                fc.frame.height,
            );
        })?;
        Ok(())
    }

    fn counters(&mut self, ctx: &GpuContext, _: &Measured) -> Result<BTreeMap<String, f64>, RenderError> {
        let values = self.read_counters(ctx)?;
        let mut out: BTreeMap<String, f64> =
            COUNTERS.iter().zip(values).map(|(name, v)| (name.to_string(), f64::from(v))).collect();
        out.insert("glints_histograms".into(), self.histogram_count as f64);
        out.insert("glints_histogram_bytes".into(), self.histogram_bytes as f64);
        out.insert("glints_histogram_build_ms".into(), self.build_ms);
        let pixels = f64::from(self.width) * f64::from(self.height);
        out.insert("output_bytes_per_pixel".into(), 16.0 + self.history_bytes as f64 / pixels);
        if let Some(tables) = &self.environment {
            out.insert("glints_env_table_bytes".into(), tables.shape.table_bytes() as f64);
            out.insert("glints_env_basis_bytes".into(), tables.shape.basis_bytes() as f64);
            out.insert("glints_env_table_projections".into(), tables.projections as f64);
        }
        Ok(out)
    }

    // Lights and the environment are read every frame and the footprint is found by a ray through the
    // current geometry; the histograms depend on the materials only, the environment's tables on what
    // it holds (not on its turn: they are in its own frame).
    fn scene_changed(
        &mut self,
        _: &GpuContext,
        _: &GpuScene,
        change: SceneChange,
    ) -> Result<bool, RenderError> {
        if change == SceneChange::Environment
            && let Some(tables) = &mut self.environment
        {
            tables.invalidate();
        }
        Ok(true)
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }
}
