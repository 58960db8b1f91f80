//! The tables of the basis-space environment integration (`env_order` > 0; environment.wgsl says
//! what each holds), computed on the GPU when the technique is created and again when the environment
//! changes. They are in the environment's own frame, so a turning environment costs nothing here.

use crate::gpu::{BufferBuilder, Profiler};
use crate::shaders::Defines;

use super::super::compute::{self, storage_buffer_entry};
use super::super::{FrameContext, RenderError, TechniqueSetup};

/// Roughness steps of the lobe table (linear in roughness between them).
pub const ROUGHNESS_STEPS: u32 = 33;

/// The shape of the tables for an SH order and a view grid of `views` rows below the pole.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TableShape {
    pub order: u32,
    /// Latitude rows, both poles included.
    pub view_rows: u32,
    pub view_columns: u32,
    /// Bands of equal area in z of the half-vector quadrature (2 × bands² directions).
    pub h_bands: u32,
}

impl TableShape {
    pub fn new(order: u32, views: u32) -> Self {
        // Enough quadrature directions for the basis of `order` bands (3 per band in z and 6 in φ)
        // plus a margin for the lighting's own detail.
        TableShape { order, view_rows: views + 1, view_columns: 2 * views, h_bands: 3 * order + 8 }
    }

    pub fn coefficients(&self) -> u32 {
        self.order * self.order
    }

    pub fn views(&self) -> u32 {
        self.view_rows * self.view_columns
    }

    pub fn h_directions(&self) -> u32 {
        2 * self.h_bands * self.h_bands
    }

    /// Bytes of the lighting table (rgb + padding per coefficient per view).
    pub fn table_bytes(&self) -> u64 {
        16 * u64::from(self.views()) * u64::from(self.coefficients())
    }

    /// Bytes of the basis values at the half-vector quadrature's directions (kept to compute the
    /// lighting table again when the environment changes).
    pub fn basis_bytes(&self) -> u64 {
        4 * u64::from(self.h_directions()) * u64::from(self.coefficients())
    }

    /// The defines both the tables' passes and the shading pass read.
    pub fn defines(&self, defines: Defines) -> Defines {
        defines
            .u32("ENV_ORDER", self.order)
            .u32("ENV_VIEW_ROWS", self.view_rows)
            .u32("ENV_VIEW_COLUMNS", self.view_columns)
            .u32("ENV_H_BANDS", self.h_bands)
            .u32("ENV_ROUGHNESS_STEPS", ROUGHNESS_STEPS)
    }
}

pub struct EnvironmentTables {
    pub shape: TableShape,
    lobe: wgpu::ComputePipeline,
    basis: wgpu::ComputePipeline,
    project: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    /// Per roughness step, the GGX lobe's `order` zonal coefficients k_l.
    pub lobe_zh: wgpu::Buffer,
    /// Per view, the SH coefficients of its half-vector-space lighting.
    pub table: wgpu::Buffer,
    basis_ready: bool,
    current: bool,
    /// Times the lighting table was computed.
    pub projections: u64,
    max_workgroups: u32,
}

impl EnvironmentTables {
    pub fn new(setup: &TechniqueSetup, shape: TableShape) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let lobe_zh = BufferBuilder::new("glints lobe zh", 4 * u64::from(ROUGHNESS_STEPS * shape.order))
            .storage()
            .copy()
            .build(ctx)?;
        let basis =
            BufferBuilder::new("glints half-vector basis", shape.basis_bytes()).storage().build(ctx)?;
        let table = BufferBuilder::new("glints environment table", shape.table_bytes())
            .storage()
            .copy()
            .build(ctx)?;
        let entries: Vec<wgpu::BindGroupLayoutEntry> =
            (0..3).map(|b| storage_buffer_entry(b, false)).collect();
        let layout = compute::layout(ctx, "glints environment tables", &entries);
        let group = compute::bind_group(
            ctx,
            "glints environment tables",
            &layout,
            &[lobe_zh.as_entire_binding(), basis.as_entire_binding(), table.as_entire_binding()],
        );
        let layouts = [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout];
        let pipeline = |entry: &str| {
            compute::pipeline(
                ctx,
                &format!("glints environment {entry}"),
                include_str!("environment.wgsl"),
                shape.defines(Defines::new()),
                entry,
                &layouts,
            )
        };
        Ok(EnvironmentTables {
            shape,
            lobe: pipeline("lobe")?,
            basis: pipeline("basis_values")?,
            project: pipeline("project")?,
            group,
            lobe_zh,
            table,
            basis_ready: false,
            current: false,
            projections: 0,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
        })
    }

    /// The environment changed: compute the lighting table again before the next frame.
    pub fn invalidate(&mut self) {
        self.current = false;
    }

    /// Computes the tables unless they are current.
    pub fn update(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        if self.current {
            return Ok(());
        }
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group, &self.group];
        let shape = self.shape;
        if !self.basis_ready {
            let max = self.max_workgroups;
            profiler.pass(fc.ctx, "glints lobe and basis tables", |encoder| {
                let lobes = ROUGHNESS_STEPS * shape.order;
                compute::dispatch(encoder, "glints lobe zh", &self.lobe, &groups, [lobes.div_ceil(64), 1, 1]);
                let values = shape.h_directions() * shape.coefficients();
                let workgroups = crate::gpu::dispatch::workgroups_for(values, 64, max);
                compute::dispatch(encoder, "glints half-vector basis", &self.basis, &groups, workgroups);
            })?;
            self.basis_ready = true;
        }
        profiler.pass(fc.ctx, "glints environment table", |encoder| {
            let blocks = shape.coefficients().div_ceil(64);
            compute::dispatch(
                encoder,
                "glints environment table",
                &self.project,
                &groups,
                [blocks, shape.views(), 1],
            );
        })?;
        self.current = true;
        self.projections += 1;
        Ok(())
    }
}
