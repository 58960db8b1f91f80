//! Techniques: each folder holds one technique (or family), its host code and its WGSL side by side.
//!
//! A technique declares its parameters, is created once per (scene, resolution, parameters), and per
//! frame records its passes through the [`Profiler`] (one named scope per pass), writing linear
//! radiance into the shared output texture. Adding a technique touches its own folder plus one line in
//! [`registry`].

pub mod direct;
pub mod path;

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
    &[direct::INFO, path::INFO]
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

/// Helpers for the common shape of a technique pass: a compute pipeline over bind groups 0 (scene),
/// 1 (frame) and 2 (the technique's own resources).
pub mod compute {
    use crate::gpu::GpuContext;
    use crate::shaders::{self, Defines, ShaderError};

    /// Workgroup edge of screen-space compute passes (passed to WGSL as `TILE`).
    pub const TILE: u32 = 8;

    pub fn pipeline(
        ctx: &GpuContext,
        name: &str,
        source: &str,
        defines: Defines,
        entry: &str,
        layouts: &[&wgpu::BindGroupLayout],
    ) -> Result<wgpu::ComputePipeline, ShaderError> {
        let module = shaders::create_module(&ctx.device, name, source, &defines.u32("TILE", TILE))?;
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|l| Some(*l)).collect();
        let layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(name),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        });
        Ok(ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: Some(&layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        }))
    }

    /// A bind-group layout entry for a storage texture visible to compute shaders.
    pub fn storage_texture_entry(
        binding: u32,
        format: wgpu::TextureFormat,
        access: wgpu::StorageTextureAccess,
    ) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::StorageTexture {
                access,
                format,
                view_dimension: wgpu::TextureViewDimension::D2,
            },
            count: None,
        }
    }

    /// Dispatches one thread per pixel in TILE×TILE workgroups.
    pub fn dispatch_pixels(
        encoder: &mut wgpu::CommandEncoder,
        label: &str,
        pipeline: &wgpu::ComputePipeline,
        bind_groups: &[&wgpu::BindGroup],
        width: u32,
        height: u32,
    ) {
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
        pass.set_pipeline(pipeline);
        for (i, g) in bind_groups.iter().enumerate() {
            pass.set_bind_group(i as u32, *g, &[]);
        }
        pass.dispatch_workgroups(width.div_ceil(TILE), height.div_ceil(TILE), 1);
    }
}
