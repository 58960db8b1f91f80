//! `direct`: direct lighting only — the frame core's G-buffer and shadow maps, the shared BRDF, and
//! ray-traced sampling of emissive triangles and the environment. It is the baseline every GI technique
//! adds indirect light to, and the analytic tests check it against closed forms.

use crate::frame::{OUTPUT_FORMAT, PRIMARY_PARAM, SHADOW_PARAMS};
use crate::gpu::Profiler;
use crate::params::{ParamKind, ParamSpec};
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute::{self, storage_texture_entry};
use super::{FrameContext, FrameNeeds, Technique, TechniqueInfo, TechniqueSetup};

/// The parameters of direct lighting, which every technique that adds indirect light to it also takes.
pub const DIRECT_PARAMS: [ParamSpec; 8] = [
    SHADOW_PARAMS[0],
    SHADOW_PARAMS[1],
    SHADOW_PARAMS[2],
    SHADOW_PARAMS[3],
    ParamSpec {
        name: "area_samples",
        kind: ParamKind::Int { min: 0, max: 256 },
        default: "4",
        doc: "ray-traced light samples of emissive triangles per pixel and frame",
    },
    ParamSpec {
        name: "env_samples",
        kind: ParamKind::Int { min: 0, max: 256 },
        default: "4",
        doc: "ray-traced environment samples per pixel and frame (maps and sky importance-sampled)",
    },
    ParamSpec {
        name: "seed",
        kind: ParamKind::Int { min: 0, max: 4294967295 },
        default: "0",
        doc: "random seed",
    },
    PRIMARY_PARAM,
];

/// A technique's parameter array: [`DIRECT_PARAMS`] followed by the technique's own, for techniques that
/// add indirect light to the direct-lighting pass.
macro_rules! with_direct_params {
    ($($extra:expr),* $(,)?) => {
        [
            $crate::techniques::direct::DIRECT_PARAMS[0],
            $crate::techniques::direct::DIRECT_PARAMS[1],
            $crate::techniques::direct::DIRECT_PARAMS[2],
            $crate::techniques::direct::DIRECT_PARAMS[3],
            $crate::techniques::direct::DIRECT_PARAMS[4],
            $crate::techniques::direct::DIRECT_PARAMS[5],
            $crate::techniques::direct::DIRECT_PARAMS[6],
            $crate::techniques::direct::DIRECT_PARAMS[7],
            $($extra,)*
        ]
    };
}
pub(crate) use with_direct_params;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "direct",
    description: "direct light only: shadow-mapped analytic lights, ray-traced area lights and environment",
    params: &DIRECT_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate: super::independent_params,
    create,
};

/// The direct-lighting pass, reusable by techniques that add indirect light: it writes this frame's
/// estimate into a target texture, either averaged progressively over frames (`Accumulate`) or
/// replacing it (`Replace`, for a technique that combines it with its own terms).
pub struct DirectLighting {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
}

/// Ray-traced light samples per pixel and frame of the direct pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightSamples {
    /// Of emissive triangles.
    pub area: u32,
    pub environment: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirectOutput {
    Accumulate,
    Replace,
}

impl DirectLighting {
    /// `target` must have the `OUTPUT_FORMAT` and storage usage; `setup.params` must hold [`DIRECT_PARAMS`].
    pub fn new(
        setup: &TechniqueSetup,
        target: &wgpu::Texture,
        mode: DirectOutput,
    ) -> Result<Self, RenderError> {
        let samples = LightSamples {
            area: setup.params.int("area_samples") as u32,
            environment: setup.params.int("env_samples") as u32,
        };
        Self::with_samples(setup, target, mode, samples)
    }

    /// As [`DirectLighting::new`] with the numbers of light samples given rather than taken from the
    /// parameters: a technique whose own passes carry the light of emitters or the environment sets
    /// them to zero.
    /// The pass for a technique that lights with the environment itself: analytic lights and
    /// emissive triangles (`setup.params`' `area_samples`), no environment samples, written into a
    /// target of its own (`"LABEL direct"`), which is returned with it for the technique to read.
    pub fn without_environment(
        setup: &TechniqueSetup,
        label: &str,
    ) -> Result<(Self, wgpu::Texture), RenderError> {
        let (w, h) = (setup.frame.width, setup.frame.height);
        let target = compute::storage_texture(setup.ctx, &format!("{label} direct"), w, h, OUTPUT_FORMAT);
        let samples = LightSamples { area: setup.params.int("area_samples") as u32, environment: 0 };
        let direct = Self::with_samples(setup, &target, DirectOutput::Replace, samples)?;
        Ok((direct, target))
    }

    pub fn with_samples(
        setup: &TechniqueSetup,
        target: &wgpu::Texture,
        mode: DirectOutput,
        samples: LightSamples,
    ) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let layout = compute::layout(
            ctx,
            "direct",
            &[storage_texture_entry(0, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite)],
        );
        let view = target.create_view(&Default::default());
        let bind_group =
            compute::bind_group(ctx, "direct", &layout, &[wgpu::BindingResource::TextureView(&view)]);
        let defines = Defines::new()
            .u32("AREA_SAMPLES", samples.area)
            .u32("ENV_SAMPLES", samples.environment)
            .bool("ACCUMULATE", mode == DirectOutput::Accumulate);
        let pipeline = compute::pipeline(
            ctx,
            "direct",
            include_str!("direct.wgsl"),
            setup.gpu_scene.bvh_defines(defines),
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout],
        )?;
        Ok(DirectLighting { pipeline, bind_group })
    }

    /// Records the pass as "direct lighting".
    pub fn render(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        compute::frame_pass(fc, profiler, "direct lighting", &self.pipeline, &self.bind_group)
    }
}

struct Direct(DirectLighting);

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    Ok(Box::new(Direct(DirectLighting::new(setup, setup.output, DirectOutput::Accumulate)?)))
}

impl Technique for Direct {
    fn counters(
        &mut self,
        _ctx: &crate::gpu::GpuContext,
        _: &super::Measured,
    ) -> Result<std::collections::BTreeMap<String, f64>, RenderError> {
        // Per-pixel memory beside the shared G-buffer (which the renderer reports): the f32 output.
        Ok(std::collections::BTreeMap::from([("output_bytes_per_pixel".to_string(), 16.0)]))
    }

    // Lights, shadow maps and the environment are read from the scene every frame.
    fn scene_changed(
        &mut self,
        _: &crate::gpu::GpuContext,
        _: &crate::gpu::GpuScene,
        _: super::SceneChange,
    ) -> Result<bool, RenderError> {
        Ok(true)
    }

    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        self.0.render(fc, profiler)
    }
}

#[cfg(test)]
mod tests {
    use crate::shaders::{Defines, validate};

    #[test]
    fn shader_validates() {
        validate(
            "direct",
            include_str!("direct.wgsl"),
            &Defines::new()
                .u32("TILE", 8)
                .u32("AREA_SAMPLES", 4)
                .u32("ENV_SAMPLES", 4)
                .bool("ACCUMULATE", true),
        );
    }
}
