//! The SH projection of the scene's environment on the GPU, a sub-pass shared by the techniques that
//! light with environment harmonics (`env-harmonics`, `prt`): radiance read through
//! common/environment.wgsl (what the path tracer sees) on a grid of equal-area bands in z × as many
//! uniform steps in φ (project.wgsl), run once and again whenever the environment changes.
//!
//! The projection is of the environment in its own frame; the world's coefficients are its SH rotation
//! by the scene's environment turn ([`crate::scene::Scene::environment_rotation`]). A turning
//! environment therefore costs one small matrix product per frame (band l's (2l+1)² matrix, built on
//! the CPU by [`crate::hsh::sh_rotation`], applied on the GPU), not a projection.

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
    rotate: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    slots: DispatchSlots,
    partials: wgpu::Buffer,
    /// The SH rotation's band matrices, row-major, band after band.
    rotation_matrices: wgpu::Buffer,
    /// The world's SH coefficients of the environment (order² of them), one `vec4f` each: radiance in
    /// rgb.
    pub coefficients: wgpu::Buffer,
    order: u32,
    bands: u32,
    projected: bool,
    /// The turn `coefficients` were rotated by, if they are current.
    rotated_by: Option<glam::Mat3>,
    /// Projections and rotations run so far (a turning environment must not project again).
    pub projections: u64,
    pub rotations: u64,
    /// CPU milliseconds spent building band matrices (once per new turn), in all.
    pub rotation_matrix_ms: f64,
    max_workgroups: u32,
}

/// Floats in the band matrices of an order-`order` SH rotation: Σ_{l<order} (2l+1)².
pub(crate) fn rotation_floats(order: u32) -> u32 {
    (0..order).map(|l| (2 * l + 1) * (2 * l + 1)).sum()
}

impl EnvironmentProjection {
    /// A projection onto the SH of `order` bands over a grid of `bands` × `bands` directions.
    pub fn new(setup: &TechniqueSetup, label: &str, order: u32, bands: u32) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let count = order * order;
        let coefficients =
            compute::storage_buffer(ctx, &format!("{label} environment sh"), 16 * u64::from(count));
        let unrotated = compute::storage_buffer(
            ctx,
            &format!("{label} environment sh, unrotated"),
            16 * u64::from(count),
        );
        let rotation_matrices = compute::storage_buffer(
            ctx,
            &format!("{label} environment sh rotation"),
            4 * u64::from(rotation_floats(order)),
        );
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
                compute::storage_buffer_entry(3, false),
                compute::storage_buffer_entry(4, true),
            ],
        );
        let group = compute::bind_group(
            ctx,
            "environment projection",
            &layout,
            &[
                partials.as_entire_binding(),
                unrotated.as_entire_binding(),
                slots.resource(),
                coefficients.as_entire_binding(),
                rotation_matrices.as_entire_binding(),
            ],
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
            rotate: pipeline("rotate")?,
            group,
            slots,
            partials,
            rotation_matrices,
            coefficients,
            order,
            bands,
            projected: false,
            rotated_by: None,
            projections: 0,
            rotations: 0,
            rotation_matrix_ms: 0.0,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
        })
    }

    /// Projects the environment unless the last projection is still current, and rotates the projection
    /// into the world unless the environment's turn is the one last applied; true when the
    /// coefficients changed.
    pub fn project(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<bool, RenderError> {
        let turn = fc.gpu_scene.world_from_environment();
        if self.projected && self.rotated_by == Some(turn) {
            return Ok(false);
        }
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group];
        let count = self.order * self.order;
        if !self.projected {
            profiler.pass(fc.ctx, "environment projection", |encoder| {
                encoder.clear_buffer(&self.partials, 0, None);
                let mut pass = crate::gpu::dispatch::compute_pass(
                    encoder,
                    "environment projection",
                    &self.partial,
                    &groups,
                );
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
            self.projections += 1;
        }
        if self.rotated_by != Some(turn) {
            let start = std::time::Instant::now();
            let floats = crate::hsh::sh_rotation(self.order as usize, turn.as_dmat3()).bands_f32();
            self.rotation_matrix_ms += start.elapsed().as_secs_f64() * 1e3;
            fc.ctx.queue.write_buffer(&self.rotation_matrices, 0, bytemuck::cast_slice(&floats));
        }
        profiler.pass(fc.ctx, "environment rotation", |encoder| {
            let mut pass =
                crate::gpu::dispatch::compute_pass(encoder, "environment rotation", &self.rotate, &groups);
            pass.set_bind_group(2, &self.group, &[0]);
            pass.dispatch_workgroups(count.div_ceil(WORKGROUP), 1, 1);
        })?;
        self.rotated_by = Some(turn);
        self.rotations += 1;
        Ok(true)
    }

    /// The environment changed: project it again before the next frame.
    pub fn invalidate(&mut self) {
        self.projected = false;
    }

    /// The stats' figures of the projection: projections, rotations and the mean CPU time of building
    /// a turn's band matrices (not in the GPU times).
    pub fn counters(&self) -> [(String, f64); 3] {
        let mean = if self.rotations > 0 { self.rotation_matrix_ms / self.rotations as f64 } else { 0.0 };
        [
            ("environment_projections".to_string(), self.projections as f64),
            ("environment_rotations".to_string(), self.rotations as f64),
            ("environment_rotation_matrix_cpu_ms".to_string(), mean),
        ]
    }

    /// SH coefficients per colour channel.
    pub fn coefficient_count(&self) -> u32 {
        self.order * self.order
    }
}
