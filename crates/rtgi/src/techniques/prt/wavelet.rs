//! All-frequency wavelet transfer (Ng, Ramamoorthi & Hanrahan 2003), `prt transfer=wavelet`: every
//! vertex's shadowed transfer over a cube-map parameterisation of the environment (cube.wgsl), one
//! ray per texel through the shared BVH, in the orthonormal non-standard Haar basis (haar.wgsl),
//! keeping its `wavelet_transfer_terms` largest coefficients (select.wgsl; wavelet_transfer.wgsl).
//! Whenever the environment turns or changes, it is resampled onto the cube, transformed, and its
//! `wavelet_terms` largest coefficients kept (the paper's per-frame non-linear approximation); every
//! vertex's irradiance is the sparse dot product of the two (wavelet_lighting.wgsl), interpolated per
//! pixel (shade_wavelet.wgsl). The basis is orthonormal, so keeping every term gives exactly the
//! pixel-basis sum Σ_t T_t L_t.

use crate::gpu::dispatch::{compute_pass, workgroups_for};
use crate::gpu::{BufferBuilder, Profiler};
use crate::shaders::Defines;

use super::compute::{self, DispatchSlots};
use super::{FrameContext, RenderError, TechniqueSetup};

/// The largest cube resolution: a coefficient's index is kept in 16 bits (6 · 64² = 24576).
pub const MAX_RESOLUTION: u32 = 64;
/// Each scratch buffer of the precomputation holds at most this many bytes (vertices go in chunks).
const SCRATCH_BYTES: u64 = 32 << 20;
const WORKGROUP: u32 = 64;

/// Mirrors `HaarStep` of haar.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct HaarStep {
    first_row: u32,
    rows: u32,
    size: u32,
    kept: u32,
}

/// Texels (and coefficients) of a cube of `resolution`² texels per face.
pub fn cube_texels(resolution: u32) -> u32 {
    6 * resolution * resolution
}

/// The defines both wavelet shaders are compiled with (the transfer's cache key hashes the transfer
/// shader composed with them).
pub fn wavelet_defines(setup: &TechniqueSetup, resolution: u32, vertices: u32) -> Defines {
    setup.gpu_scene.bvh_defines(Defines::new()).u32("VERTEX_COUNT", vertices).u32("CUBE_SIZE", resolution)
}

/// The composed source of the transfer passes (`f32` coefficients) or the lighting passes (`vec4f`).
pub fn wavelet_wgsl(lighting: bool) -> String {
    let (alias, passes) = if lighting {
        ("vec4f", include_str!("wavelet_lighting.wgsl"))
    } else {
        ("f32", include_str!("wavelet_transfer.wgsl"))
    };
    format!(
        "alias Coefficient = {alias};\n{}\n{}\n{}\n{passes}",
        include_str!("cube.wgsl"),
        include_str!("haar.wgsl"),
        include_str!("select.wgsl")
    )
}

/// The Haar levels' sizes, finest first: CUBE_SIZE, CUBE_SIZE / 2, ..., 2.
fn level_sizes(resolution: u32) -> impl Iterator<Item = u32> {
    std::iter::successors(Some(resolution), |s| Some(s / 2)).take_while(|s| *s >= 2)
}

/// Level `j` reads the scaling buffer that level `j − 1` wrote: ping-pong between two bind groups
/// (0: A → B, 1: B → A). The texels are written into A, which level 0 reads.
const TEXELS_GROUP: usize = 1;

/// A ping-pong pair of bind groups over the Haar scratch buffers A and B (and the output C).
struct HaarScratch {
    groups: [wgpu::BindGroup; 2],
}

impl HaarScratch {
    /// `bytes` per scratch buffer; `extra` resources at bindings 4.. (the same in both groups).
    fn new(
        setup: &TechniqueSetup,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        steps: &DispatchSlots,
        bytes: u64,
        extra: &[wgpu::BindingResource],
    ) -> Result<(HaarScratch, wgpu::Buffer), RenderError> {
        let ctx = setup.ctx;
        let buffer = |name: &str| {
            BufferBuilder::new(&format!("{label} {name}"), bytes)
                .storage()
                .copy()
                .build(ctx)
                .map_err(|e| RenderError::InvalidSettings(format!("prt: {e}; lower wavelet_resolution")))
        };
        let (a, b, out) = (buffer("scaling a")?, buffer("scaling b")?, buffer("coefficients")?);
        let group = |input: &wgpu::Buffer, scaling: &wgpu::Buffer| {
            let mut resources = vec![
                steps.resource(),
                input.as_entire_binding(),
                scaling.as_entire_binding(),
                out.as_entire_binding(),
            ];
            resources.extend(extra.iter().cloned());
            compute::bind_group(ctx, label, layout, &resources)
        };
        Ok((HaarScratch { groups: [group(&a, &b), group(&b, &a)] }, out))
    }
}

/// The layout of the Haar passes' group: the step, the two scaling buffers, the output, then
/// `extra` storage buffers (read-only or not) at bindings 4...
fn haar_layout(
    setup: &TechniqueSetup,
    label: &str,
    steps: &DispatchSlots,
    extra: &[bool],
) -> wgpu::BindGroupLayout {
    let mut entries = vec![
        steps.entry(0),
        compute::storage_buffer_entry(1, true),
        compute::storage_buffer_entry(2, false),
        compute::storage_buffer_entry(3, false),
    ];
    entries.extend(extra.iter().enumerate().map(|(i, r)| compute::storage_buffer_entry(4 + i as u32, *r)));
    compute::layout(setup.ctx, label, &entries)
}

/// The slots of one row set's passes: the texels, every Haar level, then the selection.
fn row_steps(first_row: u32, rows: u32, resolution: u32, kept: u32) -> Vec<HaarStep> {
    let mut steps = vec![HaarStep { first_row, rows, size: resolution, kept }];
    steps.extend(level_sizes(resolution).map(|size| HaarStep { first_row, rows, size, kept }));
    steps.push(HaarStep { first_row, rows, size: resolution, kept });
    steps
}

/// Encodes one row set's passes from the slots at `offsets` (as laid out by [`row_steps`]): `texels`
/// (`[x, y]` workgroups), the Haar levels, then `select` with a workgroup per row.
#[allow(clippy::too_many_arguments)]
fn encode_rows(
    pass: &mut wgpu::ComputePass,
    scratch: &HaarScratch,
    offsets: &[u32],
    texels: (&wgpu::ComputePipeline, [u32; 2]),
    haar: &wgpu::ComputePipeline,
    select: &wgpu::ComputePipeline,
    rows: u32,
    resolution: u32,
    max: u32,
) {
    pass.set_pipeline(texels.0);
    pass.set_bind_group(2, &scratch.groups[TEXELS_GROUP], &[offsets[0]]);
    pass.dispatch_workgroups(texels.1[0], texels.1[1], 1);
    pass.set_pipeline(haar);
    for (j, size) in level_sizes(resolution).enumerate() {
        let [x, y, _] = workgroups_for(rows * 6 * (size / 2) * (size / 2), WORKGROUP, max);
        pass.set_bind_group(2, &scratch.groups[j % 2], &[offsets[1 + j]]);
        pass.dispatch_workgroups(x, y, 1);
    }
    pass.set_pipeline(select);
    pass.set_bind_group(2, &scratch.groups[0], &[offsets[offsets.len() - 1]]);
    pass.dispatch_workgroups(rows, 1, 1);
}

/// The wavelet passes of `prt`: the precomputation (vertices in chunks) and the per-frame lighting.
pub struct WaveletPasses {
    resolution: u32,
    vertices: u32,
    /// Terms kept per vertex (transfer) and of the lighting.
    pub transfer_terms: u32,
    pub lighting_terms: u32,
    chunk: u32,
    pub visibility: wgpu::ComputePipeline,
    transfer_haar: wgpu::ComputePipeline,
    select_transfer: wgpu::ComputePipeline,
    transfer_scratch: HaarScratch,
    transfer_steps: DispatchSlots,
    light_cube: wgpu::ComputePipeline,
    lighting_haar: wgpu::ComputePipeline,
    select_lighting: wgpu::ComputePipeline,
    light_vertices: wgpu::ComputePipeline,
    lighting_scratch: HaarScratch,
    lighting_steps: DispatchSlots,
    /// The frame's kept lighting coefficients, zero elsewhere (vec4f per coefficient).
    pub kept_lighting: wgpu::Buffer,
    /// The lighting's whole transform (vec4f per coefficient), which the tests check.
    #[cfg_attr(not(test), allow(dead_code))]
    pub lighting_coefficients: wgpu::Buffer,
    /// Every vertex's irradiance (vec4f, rgb).
    pub irradiance: wgpu::Buffer,
    /// The environment's turn the irradiance is of, if it is current.
    lit_for: Option<glam::Mat3>,
    pub lightings: u64,
    max_workgroups: u32,
}

/// The settings of wavelet transfer.
pub struct WaveletSettings {
    pub resolution: u32,
    pub transfer_terms: u32,
    pub lighting_terms: u32,
}

impl WaveletPasses {
    /// The passes for `vertices` vertices whose transfer terms go to `transfer` (u32 per term).
    pub fn new(
        setup: &TechniqueSetup,
        s: &WaveletSettings,
        vertices: u32,
        transfer: &wgpu::Buffer,
    ) -> Result<WaveletPasses, RenderError> {
        let ctx = setup.ctx;
        let texels = cube_texels(s.resolution);
        let max_workgroups = ctx.limits().max_compute_workgroups_per_dimension;
        let chunk = (SCRATCH_BYTES / (4 * u64::from(texels))).clamp(1, u64::from(vertices.max(1))) as u32;
        let defines = wavelet_defines(setup, s.resolution, vertices);
        let pipeline = |label: &str, source: &str, layout: &wgpu::BindGroupLayout, entry: &str| {
            let layouts = [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, layout];
            compute::pipeline(ctx, label, source, defines.clone(), entry, &layouts)
        };

        let transfer_values: Vec<HaarStep> = (0..vertices.div_ceil(chunk))
            .flat_map(|c| {
                let first = c * chunk;
                row_steps(first, chunk.min(vertices - first), s.resolution, s.transfer_terms)
            })
            .collect();
        let transfer_steps = DispatchSlots::new(ctx, "prt wavelet transfer steps", &transfer_values);
        let transfer_layout = haar_layout(setup, "prt wavelet transfer", &transfer_steps, &[false]);
        let (transfer_scratch, _) = HaarScratch::new(
            setup,
            "prt wavelet transfer",
            &transfer_layout,
            &transfer_steps,
            4 * u64::from(chunk) * u64::from(texels),
            &[transfer.as_entire_binding()],
        )?;
        let transfer_source = wavelet_wgsl(false);
        let transfer_pipeline =
            |entry: &str| pipeline("prt wavelet transfer", &transfer_source, &transfer_layout, entry);

        let mut lighting_values = row_steps(0, 1, s.resolution, s.lighting_terms);
        lighting_values.push(HaarStep { first_row: 0, rows: 1, size: s.resolution, kept: s.transfer_terms });
        let lighting_steps = DispatchSlots::new(ctx, "prt wavelet lighting steps", &lighting_values);
        let lighting_layout =
            haar_layout(setup, "prt wavelet lighting", &lighting_steps, &[false, true, false]);
        let coefficient_bytes = 16 * u64::from(texels);
        let kept_lighting = compute::storage_buffer(ctx, "prt wavelet kept lighting", coefficient_bytes);
        let irradiance = BufferBuilder::new("prt vertex irradiance", 16 * u64::from(vertices.max(1)))
            .storage()
            .copy()
            .build(ctx)?;
        let (lighting_scratch, lighting_coefficients) = HaarScratch::new(
            setup,
            "prt wavelet lighting",
            &lighting_layout,
            &lighting_steps,
            coefficient_bytes,
            &[
                kept_lighting.as_entire_binding(),
                transfer.as_entire_binding(),
                irradiance.as_entire_binding(),
            ],
        )?;
        let lighting_source = wavelet_wgsl(true);
        let lighting_pipeline =
            |entry: &str| pipeline("prt wavelet lighting", &lighting_source, &lighting_layout, entry);
        Ok(WaveletPasses {
            resolution: s.resolution,
            vertices,
            transfer_terms: s.transfer_terms,
            lighting_terms: s.lighting_terms,
            chunk,
            visibility: transfer_pipeline("visibility_cube")?,
            transfer_haar: transfer_pipeline("haar_level")?,
            select_transfer: transfer_pipeline("select_transfer")?,
            transfer_scratch,
            transfer_steps,
            light_cube: lighting_pipeline("light_cube")?,
            lighting_haar: lighting_pipeline("haar_level")?,
            select_lighting: lighting_pipeline("select_lighting")?,
            light_vertices: lighting_pipeline("light_vertices")?,
            lighting_scratch,
            lighting_steps,
            kept_lighting,
            lighting_coefficients,
            irradiance,
            lit_for: None,
            lightings: 0,
            max_workgroups,
        })
    }

    /// Encodes the whole precomputation, chunk by chunk, into `pass` (the transfer buffer is cleared
    /// before: unused slots stay 0).
    pub fn encode_precompute(&self, pass: &mut wgpu::ComputePass) {
        let offsets: Vec<u32> = self.transfer_steps.offsets().collect();
        let per_chunk = offsets.len() / self.vertices.div_ceil(self.chunk).max(1) as usize;
        for (c, offsets) in offsets.chunks(per_chunk.max(1)).enumerate() {
            let rows = self.chunk.min(self.vertices - c as u32 * self.chunk);
            let [x, y, _] =
                workgroups_for(rows * cube_texels(self.resolution), WORKGROUP, self.max_workgroups);
            encode_rows(
                pass,
                &self.transfer_scratch,
                offsets,
                (&self.visibility, [x, y]),
                &self.transfer_haar,
                &self.select_transfer,
                rows,
                self.resolution,
                self.max_workgroups,
            );
        }
    }

    /// The environment or the transfer changed (not only turned): light the vertices again before
    /// the next frame.
    pub fn invalidate(&mut self) {
        self.lit_for = None;
    }

    /// Resamples, transforms and approximates the environment and lights every vertex, unless the
    /// irradiance is that of the current environment and turn.
    pub fn light(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let turn = fc.gpu_scene.world_from_environment();
        if self.lit_for == Some(turn) {
            return Ok(());
        }
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group];
        let offsets: Vec<u32> = self.lighting_steps.offsets().collect();
        let (rows, vertex_slot) = offsets.split_at(offsets.len() - 1);
        let max = self.max_workgroups;
        profiler.pass(fc.ctx, "wavelet lighting", |encoder| {
            encoder.clear_buffer(&self.kept_lighting, 0, None);
            let mut pass = compute_pass(encoder, "wavelet lighting", &self.light_cube, &groups);
            let [x, y, _] = workgroups_for(cube_texels(self.resolution), WORKGROUP, max);
            encode_rows(
                &mut pass,
                &self.lighting_scratch,
                rows,
                (&self.light_cube, [x, y]),
                &self.lighting_haar,
                &self.select_lighting,
                1,
                self.resolution,
                max,
            );
        })?;
        profiler.pass(fc.ctx, "wavelet vertex irradiance", |encoder| {
            let mut pass = compute_pass(encoder, "wavelet vertex irradiance", &self.light_vertices, &groups);
            pass.set_bind_group(2, &self.lighting_scratch.groups[0], &[vertex_slot[0]]);
            let [x, y, _] = workgroups_for(self.vertices, WORKGROUP, max);
            pass.dispatch_workgroups(x, y, 1);
        })?;
        self.lit_for = Some(turn);
        self.lightings += 1;
        Ok(())
    }

    /// The stats' figures: terms kept, the lighting's recomputations and the wavelet buffers' bytes.
    pub fn counters(&self) -> [(String, f64); 4] {
        [
            ("wavelet_terms".to_string(), f64::from(self.lighting_terms)),
            ("wavelet_transfer_terms".to_string(), f64::from(self.transfer_terms)),
            ("wavelet_lightings".to_string(), self.lightings as f64),
            ("wavelet_cube_texels".to_string(), f64::from(cube_texels(self.resolution))),
        ]
    }

    /// Rays the precomputation traces: exactly half the texel centres face a vertex's hemisphere (the
    /// centres are symmetric under negation).
    pub fn rays(&self) -> f64 {
        f64::from(self.vertices) * f64::from(cube_texels(self.resolution)) / 2.0
    }
}

/// The CPU twin of cube.wgsl's `cube_point`: the unnormalised direction through (a, b) of `face`.
#[cfg(test)]
pub fn cube_point(face: u32, a: f32, b: f32) -> glam::Vec3 {
    let axis = (face / 2) as usize;
    let mut p = [0.0f32; 3];
    p[axis] = if face.is_multiple_of(2) { 1.0 } else { -1.0 };
    p[(axis + 1) % 3] = a;
    p[(axis + 2) % 3] = b;
    glam::Vec3::from_array(p)
}

/// The CPU twin of cube.wgsl: texel `texel`'s centre direction and exact solid angle.
#[cfg(test)]
pub fn cube_texel(resolution: u32, texel: u32) -> (glam::Vec3, f32) {
    let area = resolution * resolution;
    let (face, i) = (texel / area, texel % area);
    let coordinate = |t: u32, offset: f32| (t as f32 + offset) * 2.0 / resolution as f32 - 1.0;
    let (x, y) = (i % resolution, i / resolution);
    let corner = |a: f32, b: f32| (a * b).atan2((a * a + b * b + 1.0).sqrt());
    let (lo, hi) = ((coordinate(x, 0.0), coordinate(y, 0.0)), (coordinate(x, 1.0), coordinate(y, 1.0)));
    let solid_angle = corner(hi.0, hi.1) - corner(lo.0, hi.1) - corner(hi.0, lo.1) + corner(lo.0, lo.1);
    (cube_point(face, coordinate(x, 0.5), coordinate(y, 0.5)).normalize(), solid_angle)
}

/// The CPU twin of haar.wgsl's `haar_support_area`: coefficient `index`'s support's area over its
/// face's.
#[cfg(test)]
pub fn haar_support_area(resolution: u32, index: u32) -> f64 {
    let i = index % (resolution * resolution);
    let m = (i % resolution).max(i / resolution).max(1);
    let level = f64::from(1u32 << m.ilog2());
    1.0 / (level * level)
}

/// The CPU twin of haar.wgsl: the non-standard orthonormal Haar transform of one `resolution`²
/// face, in place, in the Mallat layout.
#[cfg(test)]
pub fn haar_face(face: &mut [f64], resolution: usize) {
    let mut scaling = face.to_vec();
    let mut size = resolution;
    while size >= 2 {
        let half = size / 2;
        let mut next = vec![0.0; resolution * resolution];
        for y in 0..half {
            for x in 0..half {
                let at = |dx: usize, dy: usize| scaling[(2 * y + dy) * resolution + 2 * x + dx];
                let (p00, p10, p01, p11) = (at(0, 0), at(1, 0), at(0, 1), at(1, 1));
                face[y * resolution + x + half] = 0.5 * (p00 - p10 + p01 - p11);
                face[(y + half) * resolution + x] = 0.5 * (p00 + p10 - p01 - p11);
                face[(y + half) * resolution + x + half] = 0.5 * (p00 - p10 - p01 + p11);
                next[y * resolution + x] = 0.5 * (p00 + p10 + p01 + p11);
            }
        }
        if half == 1 {
            face[0] = next[0];
        }
        scaling = next;
        size = half;
    }
}
