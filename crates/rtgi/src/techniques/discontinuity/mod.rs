//! The discontinuity filter of interleaved sampling, shared by every technique that interleaves
//! (`igi`, `igi-sh`, `rsm-interleaved`): see `filter.wgsl` for what it averages and where it stops.

use crate::gpu::Profiler;
use crate::render::RenderError;
use crate::shaders::Defines;

use super::compute;
use super::{FrameContext, TechniqueSetup};

/// Where the filter stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterSettings {
    /// Window in pixels; for interleaved sampling, the interleaving pattern n × m.
    pub window: [u32; 2],
    /// Largest distance of a neighbour from the centre's tangent plane, relative to the camera distance.
    pub depth_threshold: f32,
    /// Smallest cosine between shading normals; `None` lets the filter cross normal changes.
    pub normal_cos: Option<f32>,
    /// Stop at material (object) boundaries.
    pub material_test: bool,
}

/// Bytes of a buffer holding `vec4s` packed half-float vec4s per pixel.
pub fn packed_buffer_bytes(width: u32, height: u32, vec4s: u32) -> u64 {
    u64::from(width) * u64::from(height) * u64::from(vec4s) * 8
}

pub struct DiscontinuityFilter {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
}

impl DiscontinuityFilter {
    /// Filters `input` into `output`, both of [`packed_buffer_bytes`] for the frame size.
    pub fn new(
        setup: &TechniqueSetup,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        vec4s_per_pixel: u32,
        settings: &FilterSettings,
    ) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let layout = compute::layout(
            ctx,
            "discontinuity filter",
            &[compute::storage_buffer_entry(0, true), compute::storage_buffer_entry(1, false)],
        );
        let bind_group = compute::bind_group(
            ctx,
            "discontinuity filter",
            &layout,
            &[input.as_entire_binding(), output.as_entire_binding()],
        );
        let pipeline = compute::pipeline(
            ctx,
            "discontinuity filter",
            include_str!("filter.wgsl"),
            defines(vec4s_per_pixel, settings),
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout],
        )?;
        Ok(DiscontinuityFilter { pipeline, bind_group })
    }

    /// Records the filter as the pass `name`.
    pub fn render(&self, fc: &FrameContext, profiler: &mut Profiler, name: &str) -> Result<(), RenderError> {
        profiler.pass(fc.ctx, name, |encoder| {
            compute::dispatch_pixels(
                encoder,
                name,
                &self.pipeline,
                &[&fc.gpu_scene.bind_group, &fc.frame.bind_group, &self.bind_group],
                fc.frame.width,
                fc.frame.height,
            );
        })?;
        Ok(())
    }
}

fn defines(vec4s: u32, s: &FilterSettings) -> Defines {
    Defines::new()
        .u32("VEC4S", vec4s)
        .u32("WINDOW_X", s.window[0].max(1))
        .u32("WINDOW_Y", s.window[1].max(1))
        .f32("DEPTH_THRESHOLD", s.depth_threshold)
        .f32("NORMAL_COS", s.normal_cos.unwrap_or(-2.0))
        .bool("MATERIAL_TEST", s.material_test)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shaders::validate;

    #[test]
    fn shader_validates() {
        let s = FilterSettings {
            window: [4, 4],
            depth_threshold: 0.02,
            normal_cos: Some(0.9),
            material_test: true,
        };
        validate("discontinuity filter", include_str!("filter.wgsl"), &defines(7, &s).u32("TILE", 8));
    }
}
