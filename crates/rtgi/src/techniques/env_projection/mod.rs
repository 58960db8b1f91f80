//! The SH projection of the scene's environment on the GPU, a sub-pass shared by the techniques that
//! light with environment harmonics (`env-harmonics`, `prt`): radiance read through
//! common/environment.wgsl (what the path tracer sees) on a grid of equal-area bands in z × as many
//! uniform steps in φ (project.wgsl), run once and again whenever the environment changes.

use crate::gpu::Profiler;
use crate::gpu::dispatch::workgroups_for;
use crate::params::{ParamKind, ParamSpec};
use crate::shaders::Defines;

use super::compute::{self, DispatchSlots};
use super::{FrameContext, RenderError, TechniqueSetup};

/// The projection grid's parameter, shared by the techniques that project.
pub const PROJECTION_BANDS_PARAM: ParamSpec = ParamSpec {
    name: "projection_bands",
    kind: ParamKind::Int { min: 16, max: 2048 },
    default: "512",
    doc: "the environment's projection grid: equal-area bands in z × as many steps in φ",
};

/// The projection passes' source.
pub const PROJECT_WGSL: &str = include_str!("project.wgsl");

/// Invocations per workgroup.
const WORKGROUP: u32 = 64;
/// φ steps per projection band in one dispatch (long loops in one invocation are unsafe on lavapipe).
const PHI_PER_DISPATCH: u32 = 64;

pub struct EnvironmentProjection {
    partial: wgpu::ComputePipeline,
    reduce: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    slots: DispatchSlots,
    partials: wgpu::Buffer,
    /// The environment's SH coefficients (order² of them), one `vec4f` each: radiance in rgb.
    pub coefficients: wgpu::Buffer,
    order: u32,
    bands: u32,
    projected: bool,
    max_workgroups: u32,
}

impl EnvironmentProjection {
    /// A projection onto the SH of `order` bands over a grid of `bands` × `bands` directions.
    pub fn new(setup: &TechniqueSetup, label: &str, order: u32, bands: u32) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let count = order * order;
        let coefficients =
            compute::storage_buffer(ctx, &format!("{label} environment sh"), 16 * u64::from(count));
        let partials = compute::storage_buffer(
            ctx,
            &format!("{label} environment partial sums"),
            16 * u64::from(bands * count),
        );
        let first_phis: Vec<[u32; 4]> =
            (0..bands.div_ceil(PHI_PER_DISPATCH)).map(|i| [i * PHI_PER_DISPATCH, order, 0, 0]).collect();
        let slots = DispatchSlots::new(ctx, &format!("{label} projection steps"), &first_phis);
        let layout = compute::layout(
            ctx,
            "environment projection",
            &[
                compute::storage_buffer_entry(0, false),
                compute::storage_buffer_entry(1, false),
                slots.entry(2),
            ],
        );
        let group = compute::bind_group(
            ctx,
            "environment projection",
            &layout,
            &[partials.as_entire_binding(), coefficients.as_entire_binding(), slots.resource()],
        );
        let defines = setup
            .gpu_scene
            .bvh_defines(Defines::new())
            .u32("PROJECTION_BANDS", bands)
            .u32("PHI_PER_DISPATCH", PHI_PER_DISPATCH);
        let layouts = [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout];
        let pipeline = |entry: &str| {
            compute::pipeline(ctx, "environment projection", PROJECT_WGSL, defines.clone(), entry, &layouts)
        };
        Ok(EnvironmentProjection {
            partial: pipeline("partial")?,
            reduce: pipeline("reduce")?,
            group,
            slots,
            partials,
            coefficients,
            order,
            bands,
            projected: false,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
        })
    }

    /// Projects the environment unless the last projection is still current.
    pub fn project(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        if self.projected {
            return Ok(());
        }
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group];
        let count = self.order * self.order;
        profiler.pass(fc.ctx, "environment projection", |encoder| {
            encoder.clear_buffer(&self.partials, 0, None);
            let mut pass =
                crate::gpu::dispatch::compute_pass(encoder, "environment projection", &self.partial, &groups);
            let [x, y, _] = workgroups_for(self.bands * count, WORKGROUP, self.max_workgroups);
            for offset in self.slots.offsets() {
                pass.set_bind_group(2, &self.group, &[offset]);
                pass.dispatch_workgroups(x, y, 1);
            }
            pass.set_pipeline(&self.reduce);
            pass.set_bind_group(2, &self.group, &[0]);
            pass.dispatch_workgroups(count.div_ceil(WORKGROUP), 1, 1);
        })?;
        self.projected = true;
        Ok(())
    }

    /// The environment changed: project it again before the next frame.
    pub fn invalidate(&mut self) {
        self.projected = false;
    }

    /// SH coefficients per colour channel.
    pub fn coefficient_count(&self) -> u32 {
        self.order * self.order
    }
}
