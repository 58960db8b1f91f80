//! Techniques: each folder holds one technique (or family), its host code and its WGSL side by side.
//!
//! A technique declares its parameters, is created once per (scene, resolution, parameters), and per
//! frame records its passes through the [`Profiler`] (one named scope per pass), writing linear
//! radiance into the shared output texture. Adding a technique touches its own folder plus one line in
//! [`registry`].

pub mod compute;
pub mod direct;
pub mod discontinuity;
pub mod igi;
pub mod path;
pub mod rsm;

use std::collections::BTreeMap;

use crate::frame::FrameResources;
use crate::gpu::{GpuContext, GpuScene, Profiler};
use crate::params::{ParamSpec, ParamValues};
use crate::render::RenderError;
use crate::scene::Scene;

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
    pub frame_index: u32,
}

/// A real-time GI technique (or the reference path tracer).
pub trait Technique {
    /// Records and submits the frame's passes, each inside `profiler.pass(..)`.
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError>;

    /// Technique-specific figures for the stats (counts, bytes per pixel, energy lost to clamping...).
    fn counters(&mut self, ctx: &GpuContext) -> Result<BTreeMap<String, f64>, RenderError> {
        let _ = ctx;
        Ok(BTreeMap::new())
    }

    /// What the technique cannot render of this scene (e.g. light types it ignores), for the stats.
    fn warnings(&self) -> Vec<String> {
        Vec::new()
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
    pub create: fn(&TechniqueSetup) -> Result<Box<dyn Technique>, RenderError>,
}

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
    Ok((info, values))
}
