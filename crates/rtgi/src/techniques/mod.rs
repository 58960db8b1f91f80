//! Techniques: each folder holds one technique (or family), its host code and its WGSL side by side.
//!
//! A technique declares its parameters, is created once per (scene, resolution, parameters), and per
//! frame records its passes through the [`Profiler`] (one named scope per pass), writing linear
//! radiance into the shared output texture. Adding a technique touches its own folder plus one line in
//! [`registry`].

pub mod brdf_tables;
pub mod compute;
pub mod ddgi;
pub mod direct;
pub mod discontinuity;
pub mod env_harmonics;
pub mod env_projection;
#[cfg(test)]
pub(crate) mod fixture;
pub mod glints;
pub mod igi;
pub mod ism;
pub mod light_paths;
pub mod lpv;
pub mod path;
pub mod photon_map;
pub mod prt;
pub mod radiance_cache;
pub mod rsm;
pub mod subsurface;
pub mod vxgi;

use std::collections::BTreeMap;

use crate::frame::{FrameResources, FrameView};
use crate::gpu::{GpuContext, GpuError, GpuScene, PassTiming, Profiler};
use crate::params::{ParamSpec, ParamValues};
use crate::scene::Scene;

/// Errors of a render. Defined with the techniques (the lowest layer that raises all of them) so that
/// the renderer above imports it and nothing here imports the renderer.
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

/// What a technique gets when it is created.
pub struct TechniqueSetup<'a> {
    pub ctx: &'a GpuContext,
    pub scene: &'a Scene,
    pub gpu_scene: &'a GpuScene,
    pub frame: &'a FrameResources,
    pub params: &'a ParamValues,
    /// The `OUTPUT_FORMAT` storage texture the technique writes radiance into.
    pub output: &'a wgpu::Texture,
}

/// What a technique gets every frame.
pub struct FrameContext<'a> {
    pub ctx: &'a GpuContext,
    pub gpu_scene: &'a GpuScene,
    pub frame: &'a FrameResources,
    /// Camera, previous camera, counters, time and whether history is valid (also in the frame
    /// uniforms for shaders).
    pub view: FrameView,
    /// The scene one time step ahead, for techniques that predict the next frame
    /// ([`Technique::predicts_next_frame`]); `None` when nothing is animated or the step is unknown.
    pub next: Option<&'a NextPose>,
    /// Whether this frame shows the pose the last frame's `next` predicted (true when nothing was
    /// predicted to change and nothing moved). A technique whose history was interpolated towards its
    /// prediction must not carry it over when this is false: the time jumped or stalled, or something
    /// moved that nobody predicted.
    pub prediction_held: bool,
}

/// The animated scene one time step after the frame being rendered: what a technique that predicts
/// change (`radiance-cache-temporal`, as Gautron et al.'s predefined animations) needs of it.
#[derive(Clone, Debug, PartialEq)]
pub struct NextPose {
    /// Scene seconds from this frame to the next.
    pub time_step: f32,
    /// Per mesh, the matrix from its world position in this frame to the next frame's (IDENTITY for
    /// meshes that do not move).
    pub mesh_motion: Vec<glam::Mat4>,
    /// The analytic lights at the next frame (same count and kinds as the scene's).
    pub lights: Vec<crate::scene::Light>,
}

impl<'a> FrameContext<'a> {
    /// The first frame of a still image, with the camera the frame resources were created with.
    pub fn still(ctx: &'a GpuContext, gpu_scene: &'a GpuScene, frame: &'a FrameResources) -> Self {
        FrameContext { ctx, gpu_scene, frame, view: frame.view, next: None, prediction_held: true }
    }

    /// Accumulated samples before this frame: 0 on the first frame after any change.
    pub fn sample_index(&self) -> u32 {
        self.view.sample_index
    }
}

/// Times the renderer measured, for counters that are rates (e.g. samples per second).
pub struct Measured<'a> {
    pub passes: &'a [PassTiming],
    /// Wall time of all frames, submission to completion.
    pub frames_wall_ms: f64,
}

impl Measured<'_> {
    /// Total time of pass `name`: GPU timestamps when reliable, else serialised wall time; `None` when
    /// neither was measured (frame timing without reliable timestamps).
    pub fn pass_ms(&self, name: &str) -> Option<f64> {
        let p = self.passes.iter().find(|p| p.name == name)?;
        p.gpu_ms.or(p.wall_ms)
    }

    /// Mean time of one call of pass `name` ([`Self::pass_ms`] over its calls).
    pub fn pass_mean_ms(&self, name: &str) -> Option<f64> {
        let calls = self.passes.iter().find(|p| p.name == name)?.calls;
        self.pass_ms(name).filter(|_| calls > 0).map(|ms| ms / f64::from(calls))
    }

    /// Mean time of a steady call of pass `name` (every call after the first, whose time includes
    /// lazy pipeline compilation on some drivers): GPU timestamps, else serialised wall time; `None`
    /// after a single call or when neither was measured.
    pub fn pass_steady_ms(&self, name: &str) -> Option<f64> {
        let p = self.passes.iter().find(|p| p.name == name)?;
        p.gpu.as_ref().map(|g| g.mean_ms).or(p.steady_wall_ms)
    }
}

/// What changed in place in the GPU scene (see [`Technique::scene_changed`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneChange {
    /// Analytic lights moved (same count and kinds).
    Lights,
    /// The environment changed (e.g. a sky whose sun moved).
    Environment,
    /// The environment turned ([`crate::scene::Scene::environment_rotation`]): what it holds and its
    /// sampling table are unchanged, [`GpuScene::world_from_environment`] is new. SH projections
    /// rotate instead of projecting again.
    EnvironmentRotation,
    /// Moving meshes moved ([`GpuScene::move_meshes`]): vertices, BVH top level, bounds and, when an
    /// emitter moved, the emitter table are updated; [`GpuScene::geometry_version`] is new.
    Geometry,
}

/// How a technique behaves when the camera, lights or objects move.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Motion {
    /// Every frame is computed from the current scene alone; accumulation over frames restarts on any
    /// change, so the image is correct in motion but as noisy as one frame.
    Restarts,
    /// Keeps history across frames and updates or reprojects it as things move.
    Temporal,
}

impl Motion {
    pub fn describe(self) -> &'static str {
        match self {
            Motion::Restarts => "correct in motion; accumulation restarts on every change",
            Motion::Temporal => "temporal: keeps and updates history as things move",
        }
    }
}

/// A real-time GI technique (or the reference path tracer).
pub trait Technique: Send {
    /// Records and submits the frame's passes, each inside `profiler.pass(..)`.
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError>;

    /// Technique-specific figures for the stats (counts, bytes per pixel, energy lost to clamping...).
    fn counters(
        &mut self,
        ctx: &GpuContext,
        measured: &Measured,
    ) -> Result<BTreeMap<String, f64>, RenderError> {
        let _ = (ctx, measured);
        Ok(BTreeMap::new())
    }

    /// Something the technique may have derived state from changed in place: the GPU scene's light
    /// buffer and [`GpuScene::lights_version`], its environment (scene info, baked sky, sampling
    /// table), or its geometry ([`SceneChange::Geometry`]) are already updated. Returns whether the
    /// technique brought itself up to date; `false` makes the renderer create it anew, which is always
    /// correct but recompiles its pipelines.
    fn scene_changed(
        &mut self,
        ctx: &GpuContext,
        gpu_scene: &GpuScene,
        change: SceneChange,
    ) -> Result<bool, RenderError> {
        let _ = (ctx, gpu_scene, change);
        Ok(false)
    }

    /// What the technique cannot render of this scene (e.g. light types it ignores), for the stats.
    fn warnings(&self) -> Vec<String> {
        Vec::new()
    }

    /// Whether the technique reads [`FrameContext::next`] (the renderer poses the scene a step ahead
    /// only for those that do).
    fn predicts_next_frame(&self) -> bool {
        false
    }
}

/// The frame inputs a technique reads; the frame core skips what nobody needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameNeeds {
    pub gbuffer: bool,
}

/// A registered technique: what `rtgi list` prints and how to instantiate it.
pub struct TechniqueInfo {
    pub name: &'static str,
    pub description: &'static str,
    pub params: &'static [ParamSpec],
    pub needs: FrameNeeds,
    /// Optional device capabilities the technique cannot run without; the renderer checks them before
    /// creating it, so a missing one is an error naming it.
    pub features: &'static [crate::gpu::Need],
    pub motion: Motion,
    /// Checks of parameter combinations that need neither scene nor device (each value alone is
    /// already checked against its [`ParamSpec`]); [`resolve`] runs it, so a bad combination is an
    /// error before any GPU work.
    pub validate: fn(&ParamValues) -> Result<(), String>,
    pub create: fn(&TechniqueSetup) -> Result<Box<dyn Technique>, RenderError>,
}

/// [`TechniqueInfo::validate`] of techniques whose parameters are independent of each other.
pub fn independent_params(_: &ParamValues) -> Result<(), String> {
    Ok(())
}

/// Read-write access to the `OUTPUT_FORMAT` radiance texture: every technique accumulates into it in
/// place.
pub const ACCUMULATES_OUTPUT: crate::gpu::Need =
    crate::gpu::Need::StorageTexture { format: crate::frame::OUTPUT_FORMAT, read_write: true };

/// Every technique, in the order `rtgi list` prints them.
pub fn registry() -> &'static [TechniqueInfo] {
    &[
        direct::INFO,
        path::INFO,
        igi::INFO,
        igi::SH_INFO,
        rsm::RSM_INFO,
        rsm::RSM_INTERLEAVED_INFO,
        rsm::SII_INFO,
        ddgi::INFO,
        lpv::INFO,
        vxgi::INFO,
        radiance_cache::INFO,
        radiance_cache::TEMPORAL_INFO,
        radiance_cache::PHOTON_INFO,
        env_harmonics::INFO,
        prt::INFO,
        subsurface::INFO,
        glints::INFO,
    ]
}

/// Finds a technique and validates `settings` against its parameters.
pub fn resolve(
    name: &str,
    settings: &[(String, String)],
) -> Result<(&'static TechniqueInfo, ParamValues), String> {
    let info = registry().iter().find(|t| t.name == name).ok_or_else(|| {
        format!(
            "unknown technique '{name}'; techniques: {}",
            registry().iter().map(|t| t.name).collect::<Vec<_>>().join(", ")
        )
    })?;
    let values = ParamValues::from_settings(name, info.params, settings)?;
    (info.validate)(&values).map_err(|e| format!("{name}: {e}"))?;
    Ok((info, values))
}
