//! The headless rendering API: scene in, HDR radiance image and statistics out.

use std::collections::BTreeMap;

use serde::Serialize;

use std::time::Instant;

use crate::frame::{FrameResources, OUTPUT_FORMAT, ShadowSettings};
use crate::gpu::{AdapterSummary, GpuContext, GpuError, GpuScene, Profiler, readback};
use crate::image::HdrImage;
use crate::scene::Scene;
use crate::techniques::{self, FrameContext, TechniqueSetup};

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// A technique name from [`crate::techniques::registry`].
    pub technique: String,
    /// `key=value` technique parameters, validated against the technique's specs.
    pub technique_settings: Vec<(String, String)>,
    pub width: u32,
    pub height: u32,
    /// Frames to run; progressive techniques accumulate over them, temporal ones update history.
    pub frames: u32,
}

/// Errors of a render.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("unknown technique '{name}'; techniques: {available}")]
    UnknownTechnique { name: String, available: String },
    #[error("{0}")]
    InvalidSettings(String),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Shader(#[from] crate::shaders::ShaderError),
}

/// Time spent in one named pass, summed over all frames.
#[derive(Clone, Debug, Serialize)]
pub struct PassTiming {
    pub name: String,
    /// From GPU timestamp queries; `None` when they are unavailable or unreliable.
    pub gpu_ms: Option<f64>,
    /// Wall time from submission to completion with passes serialised (exact on CPU drivers, an upper
    /// bound on GPUs).
    pub wall_ms: f64,
    /// How often the pass ran (e.g. once per frame).
    pub calls: u32,
    /// Mean wall time of the calls after the first (whose time includes lazy pipeline compilation on some
    /// drivers); `None` after a single call.
    pub steady_wall_ms: Option<f64>,
}

/// Statistics of a render, written by `rtgi render --stats`.
#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    pub scene: String,
    pub technique: String,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub adapter: AdapterSummary,
    /// Wall time of the frames (excluding scene upload and pipeline creation).
    pub wall_ms: f64,
    /// Wall time of scene upload, BVH build and pipeline creation.
    pub setup_ms: f64,
    /// `reliable`, or why per-pass GPU times are absent.
    pub timestamps: String,
    pub passes: Vec<PassTiming>,
    pub parameters: BTreeMap<String, String>,
    pub triangles: usize,
    pub bvh_build_ms: f64,
    pub gpu_scene_bytes: u64,
    /// Technique-specific counters (e.g. VPL counts, bytes per pixel).
    pub counters: BTreeMap<String, f64>,
    /// What the GPU upload had to change (e.g. textures downsampled to the array size).
    pub warnings: Vec<String>,
}

/// A finished render.
pub struct RenderOutput {
    pub image: HdrImage,
    pub stats: RenderStats,
}

/// Progress of a render: `done` of `total` frames.
pub type ProgressFn<'a> = dyn FnMut(u32, u32) + 'a;

/// Renders `scene` as `settings` say: uploads the scene, builds the frame inputs and the technique, runs
/// `settings.frames` frames and reads the radiance back.
pub fn render(
    ctx: &GpuContext,
    scene: &Scene,
    settings: &RenderSettings,
    progress: &mut ProgressFn<'_>,
) -> Result<RenderOutput, RenderError> {
    let (info, params) =
        techniques::resolve(&settings.technique, &settings.technique_settings).map_err(|e| {
            if techniques::registry().iter().any(|t| t.name == settings.technique) {
                RenderError::InvalidSettings(e)
            } else {
                RenderError::UnknownTechnique {
                    name: settings.technique.clone(),
                    available: techniques::registry().iter().map(|t| t.name).collect::<Vec<_>>().join(", "),
                }
            }
        })?;
    if settings.width == 0 || settings.height == 0 {
        return Err(RenderError::InvalidSettings(format!(
            "image size {}x{} is empty; width and height must be at least 1",
            settings.width, settings.height
        )));
    }
    if settings.frames == 0 {
        return Err(RenderError::InvalidSettings("frames must be at least 1".into()));
    }
    let setup_start = Instant::now();
    let (gpu_scene, mut frame, output, mut technique) =
        ctx.checked("setting up the render", || setup(ctx, scene, settings, info, &params))??;
    ctx.wait_idle()?;
    let setup_ms = setup_start.elapsed().as_secs_f64() * 1e3;

    let seed = params.get("seed").map_or(0, |_| params.int("seed") as u32);
    let mut profiler = Profiler::new(ctx);
    let start = Instant::now();
    ctx.checked("rendering", || -> Result<(), RenderError> {
        for frame_index in 0..settings.frames {
            frame.begin_frame(ctx, frame_index, seed);
            if info.needs.gbuffer {
                frame.render_inputs(ctx, &gpu_scene, &mut profiler)?;
            }
            technique.render_frame(
                &FrameContext { ctx, gpu_scene: &gpu_scene, frame: &frame, frame_index },
                &mut profiler,
            )?;
            progress(frame_index + 1, settings.frames);
        }
        Ok(())
    })??;
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let texels = readback::read_texture(ctx, &output, 16)?;
    let rgba: &[f32] = bytemuck::cast_slice(&texels);
    let image = HdrImage {
        width: settings.width,
        height: settings.height,
        rgb: rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect(),
    };
    let counters = technique.counters(ctx)?;
    let timestamps = match profiler.timestamp_status() {
        Ok(()) => "reliable".to_string(),
        Err(why) => why,
    };
    let stats = RenderStats {
        scene: scene.name.clone(),
        technique: info.name.to_string(),
        width: settings.width,
        height: settings.height,
        frames: settings.frames,
        adapter: ctx.summary.clone(),
        wall_ms,
        setup_ms,
        timestamps,
        passes: profiler.timings(),
        parameters: params.to_map(),
        triangles: scene.triangle_count(),
        bvh_build_ms: gpu_scene.bvh_build_ms,
        gpu_scene_bytes: gpu_scene.memory_bytes,
        counters,
        warnings: gpu_scene.warnings.iter().cloned().chain(technique.warnings()).collect(),
    };
    Ok(RenderOutput { image, stats })
}

type Setup = (GpuScene, FrameResources, wgpu::Texture, Box<dyn techniques::Technique>);

fn setup(
    ctx: &GpuContext,
    scene: &Scene,
    settings: &RenderSettings,
    info: &techniques::TechniqueInfo,
    params: &crate::params::ParamValues,
) -> Result<Setup, RenderError> {
    let gpu_scene = GpuScene::new(ctx, scene)?;
    let frame = FrameResources::new(
        ctx,
        &gpu_scene,
        scene,
        settings.width,
        settings.height,
        ShadowSettings::from_params(params),
    )?;
    let output = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("radiance"),
        size: wgpu::Extent3d { width: settings.width, height: settings.height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: OUTPUT_FORMAT,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let technique = (info.create)(&TechniqueSetup {
        ctx,
        scene,
        gpu_scene: &gpu_scene,
        frame: &frame,
        params,
        output: &output,
    })?;
    Ok((gpu_scene, frame, output, technique))
}
