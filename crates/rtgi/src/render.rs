//! The headless rendering API: scene in, HDR radiance image and statistics out.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::gpu::{AdapterSummary, GpuContext, GpuError};
use crate::image::HdrImage;
use crate::scene::Scene;

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
}

/// A finished render.
pub struct RenderOutput {
    pub image: HdrImage,
    pub stats: RenderStats,
}

/// Progress of a render: `done` of `total` frames.
pub type ProgressFn<'a> = dyn FnMut(u32, u32) + 'a;

/// Renders `scene` as `settings` say.
pub fn render(
    ctx: &GpuContext,
    scene: &Scene,
    settings: &RenderSettings,
    progress: &mut ProgressFn<'_>,
) -> Result<RenderOutput, RenderError> {
    let _ = (ctx, scene, settings, progress);
    Err(RenderError::InvalidSettings("the frame core is being wired up".into()))
}
