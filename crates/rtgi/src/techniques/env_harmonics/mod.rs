//! `env-harmonics`: environment lighting of glossy and diffuse surfaces from harmonic coefficients,
//! the renderer of the thesis's §3.5.3 (Gautron et al. 2004): the environment projected once into SH,
//! rtgi's BRDF projected per outgoing direction into hemispherical harmonics (HSH) or, as the baseline,
//! SH; per pixel the environment's SH is turned into the normal's frame, converted to HSH by the sparse
//! matrix C, and dotted with the BRDF's coefficients. `basis=sampled` estimates the same unshadowed
//! integral by sampling the BRDF, so the bases' own error can be told apart from the missing
//! visibility, which none of the three models (the thesis neither). Lights and emitters come from
//! the direct pass as in `direct`.
//!
//! rtgi's BRDF (common/brdf.wgsl) depends on the base colour, metallic and specular factors linearly
//! once the roughness is fixed, so instead of one table per material the tables hold four scalar lobes
//! at a ladder of roughnesses (see `tables.wgsl`) and the shading pass recombines them: textured
//! materials work, and an intermediate roughness is interpolated linearly between two rungs.

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::dispatch::workgroups_for;
use crate::gpu::{BufferBuilder, GpuContext, Profiler};
use crate::hsh;
use crate::params::{ParamKind, ParamSpec};
use crate::shaders::Defines;

use super::brdf_tables::{BrdfTableShape, BrdfTables, LOOKUP_WGSL, SHADING_WGSL, rotation_x90_blocks};
use super::compute::{self, storage_texture_entry};
use super::direct::{DIRECT_PARAMS, DirectLighting};
use super::env_projection::{EnvironmentProjection, PROJECTION_BANDS_PARAM};
use super::{FrameContext, FrameNeeds, RenderError, Technique, TechniqueInfo, TechniqueSetup};

#[cfg(test)]
mod tests;

/// The harmonic bases the technique shades with, and the sampled estimate of the same integral.
pub const BASES: &[&str] = &["hsh", "sh", "sampled"];

/// The direct pass's parameters without `env_samples` (the environment is this technique's), then its
/// own.
pub const PARAMS: [ParamSpec; 15] = [
    DIRECT_PARAMS[0],
    DIRECT_PARAMS[1],
    DIRECT_PARAMS[2],
    DIRECT_PARAMS[3],
    DIRECT_PARAMS[4],
    DIRECT_PARAMS[6],
    DIRECT_PARAMS[7],
    ParamSpec {
        name: "basis",
        kind: ParamKind::Choice(BASES),
        default: "hsh",
        doc: "hsh: HSH BRDF × SH environment through C (the thesis); sh: SH BRDF × SH environment; \
              sampled: the same unshadowed integral by BRDF sampling (the bases' reference)",
    },
    ParamSpec {
        name: "order",
        kind: ParamKind::Int { min: 1, max: hsh::MAX_GPU_ORDER as i64 },
        default: "5",
        doc: "bands of the BRDF's harmonics (order² coefficients per colour and table texel) and, \
              unless environment_order says otherwise, of the environment's SH",
    },
    ParamSpec {
        name: "environment_order",
        kind: ParamKind::Int { min: 0, max: hsh::MAX_GPU_ORDER as i64 },
        default: "0",
        doc: "bands of the environment's SH for basis=hsh (0: order); above order, the HSH BRDF meets \
              more of the environment than an SH BRDF of its size can (the conversion C is \
              order² × environment_order²), and shading costs environment_order² per colour",
    },
    ParamSpec {
        name: "table_size",
        kind: ParamKind::Int { min: 2, max: 64 },
        default: "32",
        doc: "texels per side of the paraboloid map of outgoing directions of the BRDF tables (the \
              thesis: 32)",
    },
    ParamSpec {
        name: "table_samples",
        kind: ParamKind::Int { min: 16, max: 65536 },
        default: "512",
        doc: "quasi-random BRDF samples projected per table texel (once, when the technique starts)",
    },
    ParamSpec {
        name: "roughness_levels",
        kind: ParamKind::Int { min: 2, max: 65 },
        default: "9",
        doc: "roughnesses 0 … 1 the GGX tables are built at; others are interpolated linearly",
    },
    PROJECTION_BANDS_PARAM,
    ParamSpec {
        name: "reference_samples",
        kind: ParamKind::Int { min: 1, max: 4096 },
        default: "64",
        doc: "BRDF samples per pixel and frame of basis=sampled",
    },
];

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "env-harmonics",
    description: "environment lighting by an HSH (or SH) BRDF × SH environment dot product, unshadowed \
                  (Gautron et al. 2004)",
    params: &PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate,
    create,
};

fn validate(p: &crate::params::ParamValues) -> Result<(), String> {
    let environment_order = p.int("environment_order");
    if p.choice("basis") != "hsh" && environment_order != 0 && environment_order != p.int("order") {
        return Err(format!(
            "environment_order applies to basis=hsh only (an SH BRDF of order {} has nothing to meet \
             the environment's higher bands with); leave it at 0",
            p.int("order")
        ));
    }
    Ok(())
}

/// The environment's SH order: `environment_order`, or `order` when that is 0.
fn environment_order(p: &crate::params::ParamValues) -> u32 {
    match p.int("environment_order") {
        0 => p.int("order") as u32,
        n => n as u32,
    }
}

/// Invocations per workgroup of the fold pass.
const WORKGROUP: u32 = 64;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Basis {
    Hsh,
    Sh,
    Sampled,
}

/// The fold of HSH tables with C (fold.wgsl).
struct Fold {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    /// The folded tables: the BRDF tables' shape at the environment's order.
    shape: BrdfTableShape,
}

/// The setup passes of the harmonic bases: BRDF tables and their fold (once) and the environment's
/// projection (again whenever the environment changes).
struct Harmonics {
    tables: BrdfTables,
    fold: Option<Fold>,
    projection: EnvironmentProjection,
    max_workgroups: u32,
}

struct EnvHarmonics {
    direct: DirectLighting,
    shade: wgpu::ComputePipeline,
    shade_group: wgpu::BindGroup,
    harmonics: Option<Harmonics>,
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    let ctx = setup.ctx;
    let p = setup.params;
    let basis = match p.choice("basis") {
        "sh" => Basis::Sh,
        "sampled" => Basis::Sampled,
        _ => Basis::Hsh,
    };
    let order = p.int("order") as u32;
    let env_order = environment_order(p);
    let table_size = p.int("table_size") as u32;
    let levels = p.int("roughness_levels") as u32;
    let table_samples = p.int("table_samples") as u32;
    let bands = p.int("projection_bands") as u32;

    // The environment is this technique's: the direct pass adds lights and emitters only.
    let (direct, direct_target) = DirectLighting::without_environment(setup, "env-harmonics")?;

    let harmonic = basis != Basis::Sampled;
    let shape = BrdfTableShape {
        hsh: basis == Basis::Hsh,
        order,
        size: table_size,
        roughness_levels: levels,
        samples: table_samples,
    };
    let defines = shape
        .defines(Defines::new())
        .u32("REFERENCE_SAMPLES", p.int("reference_samples") as u32)
        .bool("BASIS_SAMPLED", basis == Basis::Sampled);
    let defines = setup.gpu_scene.bvh_defines(defines);
    // Constant inputs, checked against the device's limits like every buffer (BufferBuilder).
    let constant = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
        BufferBuilder::with_contents(label, bytes).usage(usage).build(ctx)
    };
    let tables = harmonic.then(|| BrdfTables::new(setup, shape, "env-harmonics")).transpose()?;
    // The HSH tables folded with C (what shading reads); the SH tables are read as they are.
    let folded_shape = BrdfTableShape { order: env_order, ..shape };
    let folded_bytes = if basis == Basis::Hsh { folded_shape.bytes() } else { 4 };
    let folded = BufferBuilder::new("env-harmonics folded brdf tables", folded_bytes)
        .storage()
        .build(ctx)
        .map_err(|e| {
            RenderError::InvalidSettings(format!(
                "env-harmonics: {e}; lower table_size, roughness_levels or environment_order"
            ))
        })?;
    let projection =
        harmonic.then(|| EnvironmentProjection::new(setup, "env-harmonics", env_order, bands)).transpose()?;
    // basis=sampled projects nothing: 16 bytes stand in for the coefficients.
    let no_projection = compute::storage_buffer(ctx, "env-harmonics no environment sh", 16);
    let rotation = constant(
        "env-harmonics rotation x90",
        bytemuck::cast_slice(&if harmonic { rotation_x90_blocks(env_order as usize) } else { Vec::new() }),
        wgpu::BufferUsages::STORAGE,
    )?;
    let shading_shape =
        constant("env-harmonics shape", bytemuck::bytes_of(&env_order), wgpu::BufferUsages::UNIFORM)?;

    fn layouts<'a>(
        setup: &'a TechniqueSetup,
        own: &'a wgpu::BindGroupLayout,
    ) -> [&'a wgpu::BindGroupLayout; 3] {
        [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, own]
    }
    let read_only = |b: u32| compute::storage_buffer_entry(b, true);
    let shade_layout = compute::layout(
        ctx,
        "env-harmonics shade",
        &[
            compute::texture_entry(0, wgpu::TextureSampleType::Float { filterable: false }),
            storage_texture_entry(1, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
            read_only(2),
            read_only(3),
            read_only(4),
            compute::uniform_entry(5),
        ],
    );
    let (direct_view, output_view) =
        (direct_target.create_view(&Default::default()), setup.output.create_view(&Default::default()));
    let shade_group = compute::bind_group(
        ctx,
        "env-harmonics shade",
        &shade_layout,
        &[
            wgpu::BindingResource::TextureView(&direct_view),
            wgpu::BindingResource::TextureView(&output_view),
            projection.as_ref().map_or(&no_projection, |p| &p.coefficients).as_entire_binding(),
            rotation.as_entire_binding(),
            // basis=sampled reads no table: the 4 bytes of `folded` stand in.
            match &tables {
                Some(t) if basis == Basis::Sh => t.buffer.as_entire_binding(),
                _ => folded.as_entire_binding(),
            },
            shading_shape.as_entire_binding(),
        ],
    );
    let shade = compute::pipeline(
        ctx,
        "env-harmonics shade",
        &format!("{LOOKUP_WGSL}\n{SHADING_WGSL}\n{}", include_str!("shade.wgsl")),
        defines.clone(),
        "main",
        &layouts(setup, &shade_layout),
    )?;

    let harmonics = if let (Some(tables), Some(projection)) = (tables, projection) {
        let fold = if basis == Basis::Hsh {
            let conversion = constant(
                "env-harmonics conversion",
                bytemuck::cast_slice::<f32, u8>(
                    &hsh::conversion(order as usize, env_order as usize)
                        .iter()
                        .flatten()
                        .map(|&x| x as f32)
                        .collect::<Vec<_>>(),
                ),
                wgpu::BufferUsages::STORAGE,
            )?;
            let fold_shape = constant(
                "env-harmonics fold shape",
                bytemuck::cast_slice(&[order, env_order, 0, 0]),
                wgpu::BufferUsages::UNIFORM,
            )?;
            let layout = compute::layout(
                ctx,
                "env-harmonics fold",
                &[
                    read_only(0),
                    read_only(1),
                    compute::storage_buffer_entry(2, false),
                    compute::uniform_entry(3),
                ],
            );
            let group = compute::bind_group(
                ctx,
                "env-harmonics fold",
                &layout,
                &[
                    tables.buffer.as_entire_binding(),
                    conversion.as_entire_binding(),
                    folded.as_entire_binding(),
                    fold_shape.as_entire_binding(),
                ],
            );
            let pipeline = compute::pipeline(
                ctx,
                "env-harmonics fold",
                include_str!("fold.wgsl"),
                defines.clone(),
                "fold",
                &layouts(setup, &layout),
            )?;
            Some(Fold { pipeline, group, shape: folded_shape })
        } else {
            None
        };
        Some(Harmonics {
            tables,
            fold,
            projection,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
        })
    } else {
        None
    };
    Ok(Box::new(EnvHarmonics { direct, shade, shade_group, harmonics }))
}

impl Harmonics {
    /// Builds (and folds) the BRDF tables on the first frame and projects the environment when it is
    /// new.
    fn prepare(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group];
        // The fold reads the tables: once, right after they are built.
        let built = self.tables.build_once(fc, profiler)?;
        if let Some(fold) = self.fold.as_ref().filter(|_| built) {
            profiler.pass(fc.ctx, "brdf table fold", |encoder| {
                let [x, y, _] = workgroups_for(fold.shape.elements(), WORKGROUP, self.max_workgroups);
                compute::dispatch(
                    encoder,
                    "brdf table fold",
                    &fold.pipeline,
                    &[groups[0], groups[1], &fold.group],
                    [x, y, 1],
                );
            })?;
        }
        self.projection.project(fc, profiler)?;
        Ok(())
    }
}

impl Technique for EnvHarmonics {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        if let Some(h) = self.harmonics.as_mut() {
            h.prepare(fc, profiler)?;
        }
        self.direct.render(fc, profiler)?;
        compute::frame_pass(fc, profiler, "environment shading", &self.shade, &self.shade_group)
    }

    // Lights and emitters are the direct pass's, read every frame; a new environment is projected
    // again before the next frame; the BRDF tables depend on nothing in the scene.
    fn scene_changed(
        &mut self,
        _: &GpuContext,
        _: &crate::gpu::GpuScene,
        change: super::SceneChange,
    ) -> Result<bool, RenderError> {
        if let (super::SceneChange::Environment, Some(h)) = (change, self.harmonics.as_mut()) {
            h.projection.invalidate();
        }
        Ok(true)
    }

    fn counters(
        &mut self,
        _: &GpuContext,
        _: &super::Measured,
    ) -> Result<std::collections::BTreeMap<String, f64>, RenderError> {
        let mut c = std::collections::BTreeMap::from([
            // The direct pass's target and the output, both f32 RGBA.
            ("output_bytes_per_pixel".to_string(), 32.0),
        ]);
        if let Some(h) = &self.harmonics {
            c.insert("brdf_table_bytes".to_string(), h.tables.shape.bytes() as f64);
            c.insert("folded_table_bytes".to_string(), h.fold.as_ref().map_or(0, |f| f.shape.bytes()) as f64);
            c.insert(
                "environment_coefficients_per_colour".to_string(),
                f64::from(h.projection.coefficient_count()),
            );
            c.extend(h.projection.counters());
        }
        Ok(c)
    }

    fn warnings(&self) -> Vec<String> {
        vec![
            "env-harmonics: environment light is unshadowed (no visibility), as in the thesis's renderer"
                .into(),
        ]
    }
}
