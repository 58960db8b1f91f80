//! BRDF tables over outgoing directions (the thesis's §3.5.2, after Kautz et al. 2002), a sub-pass
//! shared by `env-harmonics` and `radiance-cache`: for every outgoing direction at a texel centre of a
//! paraboloid map, the harmonic coefficients (HSH, or SH) over incoming directions of the four
//! cosine-weighted scalar lobes rtgi's BRDF is a linear combination of, at a ladder of roughnesses
//! (build.wgsl). Built once on the GPU; `lookup.wgsl` reads them (bilinear in the outgoing direction,
//! linear in roughness) and recombines the lobes with a material as `brdf_terms` does.

use crate::gpu::dispatch::workgroups_for;
use crate::gpu::{BufferBuilder, Profiler};
use crate::shaders::Defines;

use super::compute::{self, DispatchSlots};
use super::{FrameContext, RenderError, TechniqueSetup};

/// The table lookup and lobe recombination. A shader composed with it declares
/// `brdf_tables: array<f32>` (read-only storage) and gets the defines of [`BrdfTableShape::defines`].
pub const LOOKUP_WGSL: &str = include_str!("lookup.wgsl");

/// Shading from SH coefficients of incident radiance through the tables, composed after
/// [`LOOKUP_WGSL`]. The composing shader declares `rotation_x90` (the buffer of
/// [`rotation_x90_blocks`]) and defines `incident_sh(k)`.
pub const SHADING_WGSL: &str = include_str!("shading.wgsl");

/// Invocations per workgroup of the build pass.
const WORKGROUP: u32 = 64;
/// Samples per table element in one dispatch (long loops in one invocation are unsafe on lavapipe).
const SAMPLES_PER_DISPATCH: u32 = 64;

/// What a set of tables holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BrdfTableShape {
    /// HSH (true) or SH coefficients.
    pub hsh: bool,
    /// Bands: order² coefficients per lobe and texel.
    pub order: u32,
    /// Texels per side of the paraboloid map of outgoing directions.
    pub size: u32,
    /// Roughnesses 0 … 1 of the GGX lobes.
    pub roughness_levels: u32,
    /// Quasi-random BRDF samples projected per texel.
    pub samples: u32,
}

impl BrdfTableShape {
    /// Lambert, its Fresnel loss, then D·V and S·D·V per roughness.
    pub fn tables(&self) -> u32 {
        2 + 2 * self.roughness_levels
    }

    pub fn coefficients(&self) -> u32 {
        self.order * self.order
    }

    /// Table entries: tables × texels × coefficients.
    pub fn elements(&self) -> u32 {
        self.tables() * self.size * self.size * self.coefficients()
    }

    pub fn bytes(&self) -> u64 {
        4 * u64::from(self.elements())
    }

    /// The defines `lookup.wgsl` and `build.wgsl` read.
    pub fn defines(&self, defines: Defines) -> Defines {
        defines
            .u32("TABLE_SIZE", self.size)
            .u32("ROUGHNESS_LEVELS", self.roughness_levels)
            .bool("HSH_BASIS", self.hsh)
    }
}

/// The tables and the pass that builds them.
pub struct BrdfTables {
    pub shape: BrdfTableShape,
    /// [table][texel][coefficient], f32.
    pub buffer: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    slots: DispatchSlots,
    built: bool,
    max_workgroups: u32,
}

impl BrdfTables {
    /// The tables of `shape`; `what` names the technique in errors ("lower … or …").
    pub fn new(setup: &TechniqueSetup, shape: BrdfTableShape, what: &str) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let buffer = BufferBuilder::new("brdf tables", shape.bytes()).storage().build(ctx).map_err(|e| {
            RenderError::InvalidSettings(format!(
                "{what}: {e}; lower the BRDF tables' size, order or roughnesses"
            ))
        })?;
        let first_samples: Vec<[u32; 4]> = (0..shape.samples.div_ceil(SAMPLES_PER_DISPATCH))
            .map(|i| [i * SAMPLES_PER_DISPATCH, shape.order, 0, 0])
            .collect();
        let slots = DispatchSlots::new(ctx, "brdf table samples", &first_samples);
        let layout =
            compute::layout(ctx, "brdf tables", &[compute::storage_buffer_entry(0, false), slots.entry(1)]);
        let group =
            compute::bind_group(ctx, "brdf tables", &layout, &[buffer.as_entire_binding(), slots.resource()]);
        let defines = shape
            .defines(Defines::new())
            .u32("TABLE_SAMPLES", shape.samples)
            .u32("SAMPLES_PER_DISPATCH", SAMPLES_PER_DISPATCH);
        let pipeline = compute::pipeline(
            ctx,
            "brdf tables",
            include_str!("build.wgsl"),
            setup.gpu_scene.bvh_defines(defines),
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout],
        )?;
        Ok(BrdfTables {
            shape,
            buffer,
            pipeline,
            group,
            slots,
            built: false,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
        })
    }

    /// Builds the tables in a pass of their own ("brdf tables") unless they are built; true when it
    /// did (the tables depend on nothing in the scene, so once is enough).
    pub fn build_once(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<bool, RenderError> {
        if self.built {
            return Ok(false);
        }
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group];
        profiler.pass(fc.ctx, "brdf tables", |encoder| {
            let [x, y, _] = workgroups_for(self.shape.elements(), WORKGROUP, self.max_workgroups);
            let mut pass =
                crate::gpu::dispatch::compute_pass(encoder, "brdf tables", &self.pipeline, &groups);
            for offset in self.slots.offsets() {
                pass.set_bind_group(2, &self.group, &[offset]);
                pass.dispatch_workgroups(x, y, 1);
            }
        })?;
        self.built = true;
        Ok(true)
    }
}

/// The order-`order` SH matrices of Rx(90°), band by band (block l at l(4l² − 1)/3), as shade.wgsl
/// reads them.
pub fn rotation_x90_blocks(order: usize) -> Vec<f32> {
    crate::hsh::sh_rotation(order, glam::DMat3::from_rotation_x(std::f64::consts::FRAC_PI_2)).bands_f32()
}

/// The SH coefficients of f seen from the frame of the unit normal `n`: g(d) = f(R d) with
/// R = Rz(φ) Ry(θ) taking +z to `n`, by the decomposition shade.wgsl uses (Z turns and the one X
/// matrix), and the direction `d` in that frame. The CPU twin of `harmonic_environment`'s turn.
pub fn to_normal_frame(c: &[f64], order: usize, n: glam::DVec3, d: glam::DVec3) -> (Vec<f64>, glam::DVec3) {
    let theta = n.z.clamp(-1.0, 1.0).acos();
    let phi = if n.x.abs() + n.y.abs() > 0.0 { n.y.atan2(n.x) } else { 0.0 };
    let x90 = crate::hsh::sh_rotation(order, glam::DMat3::from_rotation_x(std::f64::consts::FRAC_PI_2));
    let x90_inverse =
        crate::hsh::sh_rotation(order, glam::DMat3::from_rotation_x(-std::f64::consts::FRAC_PI_2));
    let g = crate::hsh::rotate_z(c, order, -phi);
    let g = x90.apply(&g);
    let g = crate::hsh::rotate_z(&g, order, -theta);
    let g = x90_inverse.apply(&g);
    let local = glam::DMat3::from_rotation_y(-theta) * glam::DMat3::from_rotation_z(-phi) * d;
    (g, local)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shaders::validate;

    #[test]
    fn shaders_validate() {
        for hsh in [true, false] {
            let shape = BrdfTableShape { hsh, order: 3, size: 8, roughness_levels: 3, samples: 128 };
            let d = shape
                .defines(Defines::new())
                .u32("TABLE_SAMPLES", 128)
                .u32("SAMPLES_PER_DISPATCH", SAMPLES_PER_DISPATCH)
                .bool("BVH_INSTANCES", false);
            validate("brdf tables", include_str!("build.wgsl"), &d);
            let lookup =
                format!("@group(2) @binding(0) var<storage, read> brdf_tables: array<f32>;\n{LOOKUP_WGSL}");
            validate("brdf table lookup", &lookup, &d);
        }
    }
}
