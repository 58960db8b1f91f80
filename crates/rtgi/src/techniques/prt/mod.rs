//! `prt`: precomputed radiance transfer (Sloan, Kautz & Snyder 2002; seed 001). Once per geometry,
//! every vertex gets a transfer vector: the SH projection of its clamped cosine
//! (`transfer=unshadowed`), of its clamped cosine times its visibility of the environment
//! (`transfer=shadowed`, rays through the shared BVH), or that plus `bounces` bounces of the
//! environment's light between the surfaces (`transfer=interreflected`, RGB), order² coefficients
//! per channel (transfer.wgsl); or a glossy transfer matrix (`transfer=glossy`), the SH operator
//! that turns the environment's radiance into the vertex's self-shadowed incident radiance
//! (glossy.wgsl), with a second, RGB matrix for the light of `bounces` bounces off the other surfaces
//! (`transfer=glossy-interreflected`, which gathers interreflected transfer vectors). The environment
//! is projected into SH on the GPU and turned with it (the shared `env_projection`). Per frame, diffuse transfer gives every pixel's irradiance as the dot product
//! of its vertices' interpolated transfer with the environment's SH (shade_diffuse.wgsl); glossy
//! transfer multiplies every vertex's matrix with the environment's SH when either changes, then
//! integrates the interpolated result against the whole BRDF in the view direction through the SH
//! BRDF tables (`glossy_lobe=ggx`, shade_glossy_tables.wgsl) or reflects it with Sloan et al.'s
//! Lambert and Phong lobes (`glossy_lobe=phong`, shade_glossy_phong.wgsl). `transfer=wavelet` is all-frequency shadowed transfer in Haar
//! wavelets over a cube map of the environment (Ng, Ramamoorthi & Hanrahan 2003; [`wavelet`]).
//! Lights and emitters come from the direct pass as in `direct`.
//!
//! Per-vertex transfer is only as fine as the mesh: a wall of two triangles gets the transfer of its
//! corners, so shadows need tessellated meshes (as in the paper), or per-texel transfer
//! (`texels_per_edge`: every triangle's own patch of texels, points.wgsl). Moving meshes get self-transfer
//! (`moving_transfer=self`, every SH transfer): each rigid part's transfer of its own geometry
//! (interreflections between its own surfaces included), in its own space (parts.wgsl), lit by the
//! environment turned into that space (self_transfer.wgsl); glossy transfer's radiance stays in the
//! part's space and is shaded with the pixel's normal and view turned into it. Not built yet: a
//! UV-unwrapped lightmap atlas, light bounced off glossy surfaces' specular lobes (interreflection
//! reflects diffusely), self-transfer for wavelet transfer.

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::dispatch::workgroups_for;
use crate::gpu::scene::NO_INSTANCE;
use crate::gpu::{BufferBuilder, GpuContext, Profiler};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::shaders::Defines;

use super::brdf_tables::{BrdfTableShape, BrdfTables, LOOKUP_WGSL, SHADING_WGSL, rotation_x90_blocks};
use super::compute::{self, DispatchSlots, storage_texture_entry};
use super::direct::{DIRECT_PARAMS, DirectLighting};
use super::env_projection::{EnvironmentProjection, PROJECTION_BANDS_PARAM};
use super::{FrameContext, FrameNeeds, RenderError, Technique, TechniqueInfo, TechniqueSetup};

#[cfg(test)]
mod tests;
mod wavelet;
#[cfg(test)]
mod wavelet_tests;

use wavelet::{WaveletPasses, WaveletSettings};

/// What the transfer vectors hold.
pub const TRANSFERS: &[&str] =
    &["shadowed", "unshadowed", "interreflected", "glossy", "glossy-interreflected", "wavelet"];

/// How glossy transfer's radiance is reflected (`glossy_lobe`).
pub const GLOSSY_LOBES: &[&str] = &["ggx", "phong"];

/// The highest order of glossy transfer: a batch's harmonics (`GLOSSY_BATCH` × order² floats of
/// glossy.wgsl) must fit the 16 KiB of workgroup memory every device has, and a matrix has
/// order²(order² + 1)/2 floats per vertex (666 at order 6).
const MAX_GLOSSY_ORDER: u32 = 6;

/// The finest per-triangle texel patches (`texels_per_edge`).
const MAX_TEXELS_PER_EDGE: u32 = 32;

/// The SH orders transfer may have: the shared harmonics (common/hsh.wgsl) go to 10.
const MAX_ORDER: i64 = crate::hsh::MAX_GPU_ORDER as i64;

/// The direct pass's parameters without `env_samples` (the environment is this technique's), then its
/// own.
pub const PARAMS: [ParamSpec; 19] = [
    DIRECT_PARAMS[0],
    DIRECT_PARAMS[1],
    DIRECT_PARAMS[2],
    DIRECT_PARAMS[3],
    DIRECT_PARAMS[4],
    DIRECT_PARAMS[6],
    DIRECT_PARAMS[7],
    ParamSpec {
        name: "transfer",
        kind: ParamKind::Choice(TRANSFERS),
        default: "shadowed",
        doc: "shadowed: clamped cosine × the vertex's visibility of the environment (rays through the \
              BVH); unshadowed: the clamped cosine alone; interreflected: shadowed plus `bounces` \
              bounces of the environment's light between the surfaces (RGB: 3 × order² per vertex); \
              glossy: a matrix per vertex from the environment's SH to the vertex's shadowed incident \
              radiance, shaded with the whole BRDF (diffuse and specular lobes; order ≤ 6, \
              order²(order² + 1)/2 floats per vertex); glossy-interreflected: glossy plus the light of \
              `bounces` bounces between the surfaces, which reflect it diffusely (a second, RGB matrix: \
              3 order⁴ more floats per vertex); wavelet: shadowed transfer in Haar wavelets over \
              a cube map of the environment (all-frequency shadows; `wavelet_*`, not `order`)",
    },
    ParamSpec {
        name: "glossy_lobe",
        kind: ParamKind::Choice(GLOSSY_LOBES),
        default: "ggx",
        doc: "transfer=glossy: how the transferred radiance is reflected. ggx: integrated against the whole \
              BRDF (Lambert and GGX) in the view direction through SH BRDF tables (built once, per \
              roughness level); phong: Sloan et al.'s radially symmetric lobes, Lambert about the normal \
              plus a normalised Phong lobe about the mirror direction with the exponent equivalent to the \
              roughness (2/α² − 2), zonal harmonics turned to their axes: no tables, an approximation of \
              GGX",
    },
    ParamSpec {
        name: "bounces",
        kind: ParamKind::Int { min: 1, max: 16 },
        default: "2",
        doc: "bounces of the environment's light between the surfaces (transfer=interreflected and \
              glossy-interreflected)",
    },
    ParamSpec {
        name: "order",
        kind: ParamKind::Int { min: 1, max: MAX_ORDER },
        default: "4",
        doc: "SH bands of transfer and environment (order² coefficients per vertex; Sloan et al.: 4-5)",
    },
    ParamSpec {
        name: "transfer_samples",
        kind: ParamKind::Int { min: 1, max: 65536 },
        default: "256",
        doc: "directions per vertex of the precomputation (cosine-distributed; uniform for glossy)",
    },
    PROJECTION_BANDS_PARAM,
    ParamSpec {
        name: "wavelet_resolution",
        kind: ParamKind::Int { min: 4, max: wavelet::MAX_RESOLUTION as i64 },
        default: "32",
        doc: "transfer=wavelet: texels per cube face side (a power of two; 6 × resolution² coefficients, \
              one visibility ray per texel and vertex)",
    },
    ParamSpec {
        name: "wavelet_terms",
        kind: ParamKind::Int { min: 1, max: 6 * (wavelet::MAX_RESOLUTION * wavelet::MAX_RESOLUTION) as i64 },
        default: "61",
        doc: "transfer=wavelet: the environment's largest Haar coefficients kept each time it changes or \
              turns (at resolution 32, 6 = 0.1 %, 18 = 0.3 %, 61 = 1 % of the 6144; at most all of them)",
    },
    ParamSpec {
        name: "wavelet_transfer_terms",
        kind: ParamKind::Int { min: 1, max: 6 * (wavelet::MAX_RESOLUTION * wavelet::MAX_RESOLUTION) as i64 },
        default: "512",
        doc: "transfer=wavelet: each vertex's largest Haar coefficients of transfer kept, weighted by their \
              support's area (4 bytes each: a 16-bit index and an f16 value; at most all 6 × resolution²)",
    },
    ParamSpec {
        name: "texels_per_edge",
        kind: ParamKind::Int { min: 0, max: MAX_TEXELS_PER_EDGE as i64 },
        default: "0",
        doc: "0: transfer per vertex; R > 0: per texel of every triangle's own patch, at the (R + 1)(R + 2)/2 \
              points of its barycentric lattice, interpolated per pixel within the lattice's cells \
              (transfer R times finer than the mesh without a UV unwrap; that many more points to \
              precompute and keep; not with transfer=wavelet)",
    },
    ParamSpec {
        name: "moving_transfer",
        kind: ParamKind::Choice(&["self", "recompute"]),
        default: "self",
        doc: "scenes with moving meshes, SH transfer (not wavelet). self: each rigid part's transfer of its \
              own geometry alone, in its own space, precomputed once: a moving mesh shadows only itself \
              (and interreflected transfer bounces light between its own surfaces only) and turns its \
              transfer with it (the environment's SH is turned into its space when it or the environment \
              moves), the static meshes shadow (and light) only each other; recompute: every vertex's \
              transfer from the whole scene as posed, again in every frame in which a mesh moved \
              (wavelet transfer always recomputes)",
    },
    ParamSpec {
        name: "transfer_cache",
        kind: ParamKind::Choice(&["on", "off"]),
        default: "on",
        doc: "on: keep the first geometry's transfer on disk (RTGI_CACHE_DIR/precomputed, keyed by the \
              geometry, materials, settings and code) and load it instead of precomputing again",
    },
];

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "prt",
    description: "precomputed radiance transfer: per-vertex SH transfer vectors (unshadowed, shadowed, \
                  interreflected) or glossy transfer matrices applied to the environment's SH (Sloan, \
                  Kautz & Snyder 2002), or shadowed transfer in Haar wavelets over a cube map (Ng, \
                  Ramamoorthi & Hanrahan 2003)",
    params: &PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate,
    create,
};

fn validate(p: &ParamValues) -> Result<(), String> {
    if is_glossy(p.choice("transfer")) && p.int("order") > i64::from(MAX_GLOSSY_ORDER) {
        return Err(format!(
            "transfer={} takes order ≤ {MAX_GLOSSY_ORDER} (order {} asked): a vertex's matrix has \
             order²(order² + 1)/2 floats and the precomputation keeps 64 directions' order² harmonics in \
             workgroup memory",
            p.choice("transfer"),
            p.int("order")
        ));
    }
    if p.choice("transfer") == "wavelet" && p.int("texels_per_edge") > 0 {
        return Err("texels_per_edge is for SH transfer: wavelet transfer is per vertex".into());
    }
    let resolution = p.int("wavelet_resolution");
    if p.choice("transfer") == "wavelet" && !(resolution as u32).is_power_of_two() {
        return Err(format!("wavelet_resolution must be a power of two (got {resolution})"));
    }
    Ok(())
}

/// Whether `transfer` is one of the glossy transfer matrices (glossy.wgsl).
fn is_glossy(transfer: &str) -> bool {
    matches!(transfer, "glossy" | "glossy-interreflected")
}

/// Directions of a glossy batch whose gathered bounce light (3 × order² floats each, glossy.wgsl's
/// `gathered`) fits 16 KiB of workgroup memory beside the batch's harmonics (64 × order² floats): a
/// power of two, so that rounds of it make up the batch.
fn bounce_round(coefficients: u32) -> u32 {
    let free = 16384 / 4 - GLOSSY_BATCH * coefficients;
    let round = (free / (3 * coefficients)).min(GLOSSY_BATCH);
    1 << round.ilog2()
}

/// The BRDF tables glossy transfer shades with: env-harmonics' defaults (the thesis's 32² paraboloid
/// map; 9 roughnesses, interpolated linearly between; 512 samples per texel).
fn glossy_table_shape(order: u32) -> BrdfTableShape {
    BrdfTableShape { hsh: false, order, size: 32, roughness_levels: 9, samples: 512 }
}

/// Invocations per workgroup of the transfer pass.
const WORKGROUP: u32 = 64;
/// Directions one transfer dispatch adds per vertex (`BATCH` of transfer.wgsl).
const BATCH: u32 = 32;
/// Directions one glossy transfer dispatch adds per vertex (`GLOSSY_BATCH` of glossy.wgsl: one per
/// invocation of a workgroup).
const GLOSSY_BATCH: u32 = 64;

/// Mirrors `Batch` of transfer.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Batch {
    first_sample: u32,
    order: u32,
}

/// Dispatches `pipeline` once per batch of directions (`batches`' slots) over `[x, y]` workgroups.
fn encode_batches(
    encoder: &mut wgpu::CommandEncoder,
    scene_groups: &[&wgpu::BindGroup; 2],
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
    batches: &DispatchSlots,
    [x, y]: [u32; 2],
) {
    let mut pass =
        crate::gpu::dispatch::compute_pass(encoder, "transfer precomputation", pipeline, scene_groups);
    for offset in batches.offsets() {
        pass.set_bind_group(2, group, &[offset]);
        pass.dispatch_workgroups(x, y, 1);
    }
}

/// The passes of transfer vectors (transfer.wgsl) into one buffer: shadowed or unshadowed transfer,
/// then `bounces` bounces of interreflection.
struct VectorPasses {
    accumulate: wgpu::ComputePipeline,
    interreflect: wgpu::ComputePipeline,
    add_bounce: wgpu::ComputePipeline,
    /// The passes' resources with bounce buffer 0 as the previous bounce and 1 as this one, and the
    /// other way round.
    groups: [wgpu::BindGroup; 2],
    /// Interreflection's bounce increments (4 bytes each without interreflection).
    bounce_buffers: [wgpu::Buffer; 2],
    batches: DispatchSlots,
    bounces: u32,
    /// Floats per point (order² × channels).
    floats: u32,
}

impl VectorPasses {
    /// The vectors into `target` (the groups' binding 0), cleared first.
    fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_groups: &[&wgpu::BindGroup; 2],
        target: &wgpu::Buffer,
        points: u32,
        max_workgroups: u32,
    ) {
        let [x, y, _] = workgroups_for(points, WORKGROUP, max_workgroups);
        let [fx, fy, _] = workgroups_for(points * self.floats, WORKGROUP, max_workgroups);
        encoder.clear_buffer(target, 0, None);
        encode_batches(encoder, scene_groups, &self.accumulate, &self.groups[0], &self.batches, [x, y]);
        if self.bounces > 0 {
            // Bounce 0 (shadowed transfer, the same in every channel) is the first bounce's source.
            encoder.copy_buffer_to_buffer(target, 0, &self.bounce_buffers[0], 0, target.size());
        }
        for b in 0..self.bounces as usize {
            // Bounce b + 1 reads bounce buffer b % 2 and writes the other, then joins the sum.
            encoder.clear_buffer(&self.bounce_buffers[(b + 1) % 2], 0, None);
            let group = &self.groups[b % 2];
            encode_batches(encoder, scene_groups, &self.interreflect, group, &self.batches, [x, y]);
            let mut pass = crate::gpu::dispatch::compute_pass(
                encoder,
                "transfer precomputation",
                &self.add_bounce,
                scene_groups,
            );
            pass.set_bind_group(2, group, &[0]);
            pass.dispatch_workgroups(fx, fy, 1);
        }
    }

    fn scratch_bytes(&self) -> u64 {
        self.bounce_buffers.iter().map(wgpu::Buffer::size).sum()
    }
}

/// transfer=glossy-interreflected: what the glossy matrices' bounce part gathers (glossy.wgsl's
/// GLOSSY_BOUNCE): every point's interreflected diffuse transfer of `bounces` − 1 bounces.
struct GlossyBounce {
    vectors: VectorPasses,
    /// The vectors (RGB, order² × 3 floats per point).
    reflected: wgpu::Buffer,
    gather: wgpu::ComputePipeline,
}

/// The passes that compute a geometry's transfer.
enum TransferPasses {
    /// Transfer vectors (transfer.wgsl).
    Vectors(VectorPasses),
    /// Glossy transfer matrices (glossy.wgsl) and the transferred radiance they make of the
    /// environment's SH.
    Matrices {
        accumulate: wgpu::ComputePipeline,
        lighting: wgpu::ComputePipeline,
        group: wgpu::BindGroup,
        batches: DispatchSlots,
        /// Order² vec4f per vertex.
        transferred: wgpu::Buffer,
        /// transfer=glossy-interreflected.
        bounce: Option<Box<GlossyBounce>>,
    },
    /// Wavelet transfer terms and the per-frame wavelet lighting.
    Wavelets(Box<WaveletPasses>),
}

/// A geometry's transfer and the passes that compute it.
struct Transfer {
    buffer: wgpu::Buffer,
    passes: TransferPasses,
    vertices: u32,
    /// The points transfer is kept at (points.wgsl): `vertices`, or the triangles' texels.
    points: u32,
    /// Floats per vertex: order² coefficients × colour channels, a matrix's upper triangle, or the kept
    /// wavelet terms (a packed u32 each).
    floats_per_vertex: u32,
    /// Coefficients per colour channel of the environment's SH.
    coefficients: u32,
    /// Rays per point and transfer sample of the precomputation.
    rays_per_sample: u32,
    /// The geometry the vectors were computed for; `None` before the first frame.
    computed_for: Option<u64>,
    /// Precomputations run (not loaded from the cache).
    precomputations: u32,
    cache: Option<TransferCache>,
}

/// The on-disk copy of the transfer of the geometry the technique was created for.
struct TransferCache {
    disk: crate::cache::DiskCache,
    /// Hashes everything the vectors depend on (see [`transfer_key`]).
    key: u64,
    /// The GPU scene's geometry version at creation: later geometry (moved meshes) is not cached.
    geometry: u64,
    /// The vectors were computed in a frame not yet read back and written to disk.
    store_pending: bool,
    loads: u32,
    stores: u32,
    /// Why the last write failed, for the warnings.
    error: Option<String>,
}

/// The cache key of the transfer: the crate version, this file (how the passes are dispatched), the
/// transfer shader as composed with its defines and imports, the settings, and every vertex, index,
/// material and texture of the scene the GPU scene was uploaded from (interreflection reads albedos).
fn transfer_key(scene: &crate::scene::Scene, composed_shader: &str, settings: &[u32]) -> u64 {
    let mut h = crate::cache::StableHasher::default();
    h.str(env!("CARGO_PKG_VERSION")).str(include_str!("mod.rs")).str(include_str!("wavelet.rs"));
    h.str(composed_shader);
    for v in settings {
        h.u32(*v);
    }
    for m in &scene.meshes {
        h.u32(m.material).u32(m.positions.len() as u32).u32(m.indices.len() as u32);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            h.f32s(&p.to_array()).f32s(&n.to_array());
        }
        for uv in &m.uvs {
            h.f32s(&uv.to_array());
        }
        for i in &m.indices {
            h.u32(*i);
        }
    }
    for m in &scene.materials {
        h.f32s(&m.base_color.to_array()).f32s(&[m.metallic, m.roughness, m.specular]);
        h.u32(u32::from(m.double_sided));
        for t in [m.base_color_texture, m.metallic_roughness_texture] {
            h.u32(t.map_or(u32::MAX, |t| t.texture));
        }
    }
    for t in &scene.textures {
        h.u32(t.width).u32(t.height).u32(u32::from(t.srgb)).bytes(&t.rgba8);
    }
    h.finish()
}

struct Prt {
    direct: DirectLighting,
    /// The environment's SH (`None` for wavelet transfer, which resamples it onto a cube instead).
    projection: Option<EnvironmentProjection>,
    transfer: Transfer,
    /// Glossy transfer's BRDF tables (built on the first frame).
    tables: Option<BrdfTables>,
    /// The transferred radiance is that of the current matrices and environment (glossy transfer).
    lit: bool,
    shade: wgpu::ComputePipeline,
    shade_group: wgpu::BindGroup,
    samples: u32,
    max_workgroups: u32,
    /// Whether some meshes may move (the GPU scene has instances): without self-transfer each move
    /// recomputes every vertex's transfer, which the user is warned of.
    moving_meshes: bool,
    /// Transfer per rigid part (`moving_transfer=self`), lit by the environment turned into each part.
    self_transfer: Option<SelfTransfer>,
}

/// What lights self-transfer (transfer.wgsl's SELF_TRANSFER): the environment's SH turned into every
/// BVH instance's space (self_transfer.wgsl) whenever the environment or the instances' placement
/// changes.
struct SelfTransfer {
    turn: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    /// Per instance, the band matrices of its turn (`hsh::sh_rotation`).
    rotations: wgpu::Buffer,
    instances: u32,
    order: u32,
    /// The geometry whose placement `instance_sh` was turned for.
    turned_for: Option<u64>,
    turns: u64,
}

impl SelfTransfer {
    fn new(
        setup: &TechniqueSetup,
        projection: &EnvironmentProjection,
        instance_sh: &wgpu::Buffer,
        instances: u32,
        order: u32,
    ) -> Result<SelfTransfer, RenderError> {
        let ctx = setup.ctx;
        let floats = u64::from(super::env_projection::rotation_floats(order));
        let rotations = BufferBuilder::new("prt instance turns", 4 * floats * u64::from(instances.max(1)))
            .storage()
            .copy()
            .build(ctx)?;
        let uniform =
            BufferBuilder::with_contents("prt parts", bytemuck::cast_slice(&[order, instances, 0, 0]))
                .usage(wgpu::BufferUsages::UNIFORM)
                .build(ctx)?;
        let layout = compute::layout(
            ctx,
            "prt self-transfer",
            &[
                compute::storage_buffer_entry(0, true),
                compute::storage_buffer_entry(1, true),
                compute::storage_buffer_entry(2, false),
                compute::uniform_entry(3),
            ],
        );
        let group = compute::bind_group(
            ctx,
            "prt self-transfer",
            &layout,
            &[
                projection.coefficients.as_entire_binding(),
                rotations.as_entire_binding(),
                instance_sh.as_entire_binding(),
                uniform.as_entire_binding(),
            ],
        );
        let turn = compute::pipeline(
            ctx,
            "prt self-transfer",
            include_str!("self_transfer.wgsl"),
            Defines::new(),
            "turn_into_instances",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout],
        )?;
        Ok(SelfTransfer { turn, group, rotations, instances, order, turned_for: None, turns: 0 })
    }

    /// Turns the environment's SH into every instance's space unless current; true when it did.
    fn turn(
        &mut self,
        fc: &FrameContext,
        profiler: &mut Profiler,
        new_environment: bool,
        max_workgroups: u32,
    ) -> Result<bool, RenderError> {
        let geometry = fc.gpu_scene.geometry_version;
        if !new_environment && self.turned_for == Some(geometry) {
            return Ok(false);
        }
        let mut floats = Vec::new();
        for m in fc.gpu_scene.instance_world_to_object() {
            // Rigid motion with uniform scale: the world-to-object map over its scale is a rotation
            // (a reflection too, for a mirrored mesh, which sh_rotation takes as well).
            let scale = m.determinant().abs().cbrt();
            let r = if scale > 0.0 && scale.is_finite() { m / scale } else { glam::Mat3::IDENTITY };
            floats.extend(crate::hsh::sh_rotation(self.order as usize, r.as_dmat3()).bands_f32());
        }
        fc.ctx.queue.write_buffer(&self.rotations, 0, bytemuck::cast_slice(&floats));
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group];
        let [x, y, _] = workgroups_for(self.instances * self.order * self.order, WORKGROUP, max_workgroups);
        profiler.pass(fc.ctx, "environment into moving meshes", |encoder| {
            let mut pass = crate::gpu::dispatch::compute_pass(
                encoder,
                "environment into moving meshes",
                &self.turn,
                &groups,
            );
            pass.set_bind_group(2, &self.group, &[]);
            pass.dispatch_workgroups(x, y, 1);
        })?;
        self.turned_for = Some(geometry);
        self.turns += 1;
        Ok(true)
    }
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    Ok(Box::new(Prt::new(setup)?))
}

impl Prt {
    fn new(setup: &TechniqueSetup) -> Result<Prt, RenderError> {
        let ctx = setup.ctx;
        let p: &ParamValues = setup.params;
        let order = p.int("order") as u32;
        let samples = p.int("transfer_samples") as u32;
        let count = order * order;
        let kind = p.choice("transfer");
        let glossy = is_glossy(kind);
        // Glossy transfer reflected through the BRDF tables (not Phong lobes).
        let tabled = glossy && p.choice("glossy_lobe") == "ggx";
        let wavelets = kind == "wavelet";
        let interreflected = kind == "interreflected";
        // Glossy matrices with a bounce part (glossy.wgsl's GLOSSY_BOUNCE), which gathers
        // interreflected transfer vectors.
        let glossy_bounce = kind == "glossy-interreflected";
        let channels: u32 = if interreflected || glossy_bounce { 3 } else { 1 };
        let bounces = if interreflected || glossy_bounce { p.int("bounces") as u32 } else { 0 };
        let resolution = p.int("wavelet_resolution") as u32;
        // More terms than the cube has coefficients is all of them.
        let terms = |name| (p.int(name) as u32).min(wavelet::cube_texels(resolution));
        let wavelet_settings = WaveletSettings {
            resolution,
            transfer_terms: terms("wavelet_transfer_terms"),
            lighting_terms: terms("wavelet_terms"),
        };
        let floats_per_vertex = if glossy {
            count * (count + 1) / 2 + if glossy_bounce { 3 * count * count } else { 0 }
        } else if wavelets {
            wavelet_settings.transfer_terms
        } else {
            count * channels
        };
        let vertices = u32::try_from(setup.scene.vertex_count())
            .map_err(|_| RenderError::InvalidSettings("prt: the scene has more than 2³² vertices".into()))?;
        // The points transfer is kept at (points.wgsl): the vertices, or every triangle's texel patch.
        let texels = p.int("texels_per_edge") as u32;
        let points = if texels == 0 {
            vertices
        } else {
            let patch = u64::from((texels + 1) * (texels + 2) / 2);
            u32::try_from(setup.scene.triangle_count() as u64 * patch).map_err(|_| {
                RenderError::InvalidSettings(format!(
                    "prt: {} triangles × {patch} texels per patch is more than 2³² points; lower texels_per_edge",
                    setup.scene.triangle_count()
                ))
            })?
        };

        // Transfer per rigid part (transfer.wgsl's SELF_TRANSFER) when meshes may move.
        let parts = (!wavelets && p.choice("moving_transfer") == "self")
            .then(|| setup.gpu_scene.bvh_parts(vertices as usize))
            .flatten();
        let instances =
            if parts.is_some() { setup.gpu_scene.instance_world_to_object().len() as u32 } else { 0 };

        // The environment is this technique's: the direct pass adds lights and emitters only.
        let (direct, direct_target) = DirectLighting::without_environment(setup, "prt")?;
        let projection = (!wavelets)
            .then(|| EnvironmentProjection::new(setup, "prt", order, p.int("projection_bands") as u32))
            .transpose()?;

        let lower = if wavelets { "wavelet_transfer_terms" } else { "order" };
        let too_large = |e| {
            RenderError::InvalidSettings(format!(
                "prt: {e}; lower {lower} ({floats_per_vertex} words of transfer per point)"
            ))
        };
        let storage =
            |label, bytes| BufferBuilder::new(label, bytes).storage().copy().build(ctx).map_err(too_large);
        // Bytes of `floats` f32 per point.
        let per_point = |floats: u32| u64::from(points.max(1)) * u64::from(floats) * 4;
        let buffer = storage("prt transfer", per_point(floats_per_vertex))?;
        let defines = setup
            .gpu_scene
            .bvh_defines(Defines::new())
            .u32("POINT_COUNT", points)
            .u32("TEXELS_PER_EDGE", texels)
            .u32("TRANSFER_SAMPLES", samples)
            .u32("CHANNELS", channels)
            .u32("COEFFICIENTS", count)
            .u32("FLOATS_PER_POINT", floats_per_vertex)
            .bool("GLOSSY_BOUNCE", glossy_bounce)
            .u32("BOUNCE_ROUND", if glossy_bounce { bounce_round(count) } else { 1 })
            .bool("SHADOWED", kind != "unshadowed")
            .bool("SELF_TRANSFER", parts.is_some())
            .u32("NO_INSTANCE", NO_INSTANCE)
            .u32("STATIC_ROOT", parts.as_ref().and_then(|p| p.static_root).unwrap_or(0));
        let read_only_words = |label, words: &[u32]| {
            BufferBuilder::with_contents(label, bytemuck::cast_slice(words))
                .usage(wgpu::BufferUsages::STORAGE)
                .build(ctx)
                .map_err(too_large)
        };
        let vertex_instances = match &parts {
            Some(parts) => read_only_words("prt vertex instances", &parts.vertex_instances)?,
            None => read_only_words("prt vertex instances", &[NO_INSTANCE])?,
        };
        let layouts = |own| [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, own];
        // Self-transfer's environment, turned into each instance's space (self_transfer.wgsl).
        let instance_sh = storage("prt instance sh", u64::from(instances.max(1)) * u64::from(count) * 16)?;

        // Glossy matrices add 64 directions per dispatch, transfer vectors 32.
        let slots = |batch: u32| {
            let values: Vec<Batch> =
                (0..samples.div_ceil(batch)).map(|i| Batch { first_sample: i * batch, order }).collect();
            DispatchSlots::new(ctx, "prt transfer batches", &values)
        };
        let batches = slots(if glossy { GLOSSY_BATCH } else { BATCH });
        let transfer_layout = compute::layout(
            ctx,
            "prt transfer",
            &[
                compute::storage_buffer_entry(0, false),
                batches.entry(1),
                compute::storage_buffer_entry(2, true),
                compute::storage_buffer_entry(3, false),
                compute::storage_buffer_entry(4, true),
                compute::storage_buffer_entry(5, true),
                compute::storage_buffer_entry(6, true),
            ],
        );
        let transfer_group =
            |target: &wgpu::Buffer, batches: &DispatchSlots, [a, b, reflected]: [&wgpu::Buffer; 3]| {
                compute::bind_group(
                    ctx,
                    "prt transfer",
                    &transfer_layout,
                    &[
                        target.as_entire_binding(),
                        batches.resource(),
                        a.as_entire_binding(),
                        b.as_entire_binding(),
                        vertex_instances.as_entire_binding(),
                        instance_sh.as_entire_binding(),
                        reflected.as_entire_binding(),
                    ],
                )
            };
        // Bindings a pass set does not read.
        let unused = storage("prt unused", 4)?;
        let transfer_pipeline = |source: &str, entry: &str| {
            compute::pipeline(ctx, "prt transfer", source, defines.clone(), entry, &layouts(&transfer_layout))
        };
        let vector_source = transfer_wgsl(false);
        // Transfer vectors into `target` with `bounces` bounces of interreflection, dispatched by
        // `batches` (slots of BATCH directions).
        let vector_passes = |target: &wgpu::Buffer,
                             bounces: u32,
                             batches: DispatchSlots|
         -> Result<VectorPasses, RenderError> {
            let bounce_bytes = if bounces > 0 { per_point(count * channels) } else { 4 };
            let bounce_buffers =
                [storage("prt bounce a", bounce_bytes)?, storage("prt bounce b", bounce_bytes)?];
            let [a, b] = &bounce_buffers;
            let groups = [
                transfer_group(target, &batches, [a, b, &unused]),
                transfer_group(target, &batches, [b, a, &unused]),
            ];
            Ok(VectorPasses {
                accumulate: transfer_pipeline(&vector_source, "accumulate")?,
                interreflect: transfer_pipeline(&vector_source, "interreflect")?,
                add_bounce: transfer_pipeline(&vector_source, "add_bounce")?,
                groups,
                bounce_buffers,
                batches,
                bounces,
                floats: count * channels,
            })
        };
        let matrix_source = transfer_wgsl(true);
        let passes = if let Some(projection) = projection.as_ref().filter(|_| glossy) {
            let transferred = storage("prt transferred radiance", per_point(count * 4))?;
            let bounce = glossy_bounce
                .then(|| -> Result<Box<GlossyBounce>, RenderError> {
                    let reflected = storage("prt reflected transfer", per_point(count * 3))?;
                    Ok(Box::new(GlossyBounce {
                        vectors: vector_passes(&reflected, bounces - 1, slots(BATCH))?,
                        gather: transfer_pipeline(&matrix_source, "accumulate_bounce")?,
                        reflected,
                    }))
                })
                .transpose()?;
            let reflected = bounce.as_ref().map_or(&unused, |b| &b.reflected);
            let group =
                transfer_group(&buffer, &batches, [&projection.coefficients, &transferred, reflected]);
            TransferPasses::Matrices {
                accumulate: transfer_pipeline(&matrix_source, "accumulate_matrix")?,
                lighting: transfer_pipeline(&matrix_source, "transfer_lighting")?,
                group,
                batches,
                transferred,
                bounce,
            }
        } else if wavelets {
            TransferPasses::Wavelets(Box::new(WaveletPasses::new(
                setup,
                &wavelet_settings,
                vertices,
                &buffer,
            )?))
        } else {
            TransferPasses::Vectors(vector_passes(&buffer, bounces, batches)?)
        };
        let cache = (p.choice("transfer_cache") == "on").then(|| -> Result<TransferCache, RenderError> {
            let composed = if wavelets {
                let defines = wavelet::wavelet_defines(setup, wavelet_settings.resolution, vertices);
                crate::shaders::compose("prt wavelet transfer", &wavelet::wavelet_wgsl(false), &defines)?
            } else if glossy_bounce {
                // The bounce part gathers the vectors' passes' result.
                let matrices = crate::shaders::compose("prt transfer", &matrix_source, &defines)?;
                matrices + &crate::shaders::compose("prt transfer", &vector_source, &defines)?
            } else {
                let source = if glossy { &matrix_source } else { &vector_source };
                crate::shaders::compose("prt transfer", source, &defines)?
            };
            let mut settings = vec![
                order,
                samples,
                channels,
                bounces,
                wavelet_settings.resolution,
                wavelet_settings.transfer_terms,
                texels,
            ];
            if let Some(parts) = &parts {
                // Which vertices are in which part, and the space each instance's transfer is in (the
                // one its geometry was uploaded in, which the setup's placement maps to).
                settings.extend(&parts.vertex_instances);
                for m in setup.gpu_scene.instance_world_to_object() {
                    settings.extend(m.to_cols_array().map(f32::to_bits));
                }
            }
            Ok(TransferCache {
                disk: crate::cache::DiskCache::new(crate::cache::precomputed_dir(), "prt-transfer"),
                key: transfer_key(setup.scene, &composed, &settings),
                geometry: setup.gpu_scene.geometry_version,
                store_pending: false,
                loads: 0,
                stores: 0,
                error: None,
            })
        });
        let cache = cache.transpose()?;

        let shape = BufferBuilder::with_contents("prt shape", bytemuck::cast_slice(&[order, 0, 0, 0]))
            .usage(wgpu::BufferUsages::UNIFORM)
            .build(ctx)?;
        let tables = tabled.then(|| BrdfTables::new(setup, glossy_table_shape(order), "prt")).transpose()?;
        let rotation = tabled
            .then(|| {
                BufferBuilder::with_contents(
                    "prt rotation x90",
                    bytemuck::cast_slice(&rotation_x90_blocks(order as usize)),
                )
                .usage(wgpu::BufferUsages::STORAGE)
                .build(ctx)
            })
            .transpose()?;
        let self_transfer = match (&parts, &projection) {
            (Some(_), Some(projection)) => {
                Some(SelfTransfer::new(setup, projection, &instance_sh, instances, order)?)
            }
            _ => None,
        };
        let (direct_view, output_view) =
            (direct_target.create_view(&Default::default()), setup.output.create_view(&Default::default()));
        let mut shade_resources = vec![
            wgpu::BindingResource::TextureView(&direct_view),
            wgpu::BindingResource::TextureView(&output_view),
            shape.as_entire_binding(),
            match &passes {
                TransferPasses::Matrices { transferred, .. } => transferred.as_entire_binding(),
                TransferPasses::Wavelets(w) => w.irradiance.as_entire_binding(),
                TransferPasses::Vectors(_) => buffer.as_entire_binding(),
            },
        ];
        // Bindings 4 on, read-only storage, in binding order: diffuse transfer's environment SH,
        // self-transfer's vertex instances and the environment turned into each instance; glossy
        // transfer's Rx(90°) blocks and BRDF tables (through the tables), then its vertex instances.
        match (&passes, &projection) {
            (TransferPasses::Vectors(_), Some(projection)) => shade_resources.extend([
                projection.coefficients.as_entire_binding(),
                vertex_instances.as_entire_binding(),
                instance_sh.as_entire_binding(),
            ]),
            (TransferPasses::Matrices { .. }, _) => {
                if let (Some(rotation), Some(tables)) = (&rotation, &tables) {
                    shade_resources.extend([rotation.as_entire_binding(), tables.buffer.as_entire_binding()]);
                }
                shade_resources.push(vertex_instances.as_entire_binding());
            }
            _ => {}
        }
        let mut shade_entries = vec![
            compute::texture_entry(0, wgpu::TextureSampleType::Float { filterable: false }),
            storage_texture_entry(1, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
            compute::uniform_entry(2),
        ];
        shade_entries
            .extend((3..shade_resources.len() as u32).map(|b| compute::storage_buffer_entry(b, true)));
        let shade_layout = compute::layout(ctx, "prt shade", &shade_entries);
        let shade_group = compute::bind_group(ctx, "prt shade", &shade_layout, &shade_resources);
        let shade_defines = match &tables {
            Some(t) => t.shape.defines(defines),
            None => defines,
        };
        let shade = compute::pipeline(
            ctx,
            "prt shade",
            &shade_wgsl(kind, p.choice("glossy_lobe")),
            shade_defines,
            "main",
            &layouts(&shade_layout),
        )?;

        Ok(Prt {
            direct,
            projection,
            transfer: Transfer {
                buffer,
                passes,
                vertices,
                points,
                floats_per_vertex,
                coefficients: count,
                // Vectors: one ray per bounce and the shadowed start; matrices: one, and the bounce
                // part's vectors (bounces − 1 bounces and their start) and gathering.
                rays_per_sample: if glossy {
                    1 + if glossy_bounce { bounces + 1 } else { 0 }
                } else {
                    1 + bounces
                },
                computed_for: None,
                precomputations: 0,
                cache,
            },
            tables,
            lit: false,
            shade,
            shade_group,
            samples,
            max_workgroups: ctx.limits().max_compute_workgroups_per_dimension,
            moving_meshes: setup.gpu_scene.has_instances(),
            self_transfer,
        })
    }

    /// Writes vectors computed in an earlier (now submitted) frame to the disk cache. A failed write
    /// is a warning, not an error: the technique renders the same without the cache.
    fn store_transfer(&mut self, ctx: &GpuContext) -> Result<(), RenderError> {
        let t = &mut self.transfer;
        let Some(cache) = t.cache.as_mut().filter(|c| c.store_pending) else { return Ok(()) };
        cache.store_pending = false;
        let bytes = crate::gpu::readback::read_buffer(ctx, &t.buffer, 0, t.buffer.size())?;
        match cache.disk.store(cache.key, &bytes) {
            Ok(_) => cache.stores += 1,
            Err(e) => cache.error = Some(e),
        }
        Ok(())
    }

    /// Computes the transfer unless it belongs to the current geometry, or loads it from the disk
    /// cache for the geometry the technique was created for; true when the transfer is new.
    fn precompute(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<bool, RenderError> {
        let geometry = fc.gpu_scene.geometry_version;
        // Self-transfer is of each part in its own space: true however the parts are placed.
        let per_part = self.self_transfer.is_some();
        let t = &mut self.transfer;
        if t.computed_for == Some(geometry) || (per_part && t.computed_for.is_some()) {
            return Ok(false);
        }
        t.computed_for = Some(geometry);
        if let Some(cache) = t.cache.as_mut().filter(|c| per_part || c.geometry == geometry) {
            if let Some(bytes) = cache.disk.load(cache.key, t.buffer.size() as usize) {
                fc.ctx.queue.write_buffer(&t.buffer, 0, &bytes);
                cache.loads += 1;
                return Ok(true);
            }
            cache.store_pending = true;
        }
        t.precomputations += 1;
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group];
        let max = self.max_workgroups;
        profiler.pass(fc.ctx, "transfer precomputation", |encoder| match &t.passes {
            TransferPasses::Wavelets(w) => {
                encoder.clear_buffer(&t.buffer, 0, None);
                let mut pass = crate::gpu::dispatch::compute_pass(
                    encoder,
                    "transfer precomputation",
                    &w.visibility,
                    &groups,
                );
                w.encode_precompute(&mut pass);
            }
            TransferPasses::Matrices { accumulate, group, batches, bounce, .. } => {
                if let Some(b) = bounce {
                    b.vectors.encode(encoder, &groups, &b.reflected, t.points, max);
                }
                encoder.clear_buffer(&t.buffer, 0, None);
                // A workgroup per vertex.
                let [x, y, _] = workgroups_for(t.points * GLOSSY_BATCH, GLOSSY_BATCH, max);
                encode_batches(encoder, &groups, accumulate, group, batches, [x, y]);
                if let Some(b) = bounce {
                    encode_batches(encoder, &groups, &b.gather, group, batches, [x, y]);
                }
            }
            TransferPasses::Vectors(v) => v.encode(encoder, &groups, &t.buffer, t.points, max),
        })?;
        Ok(true)
    }

    /// Glossy transfer: every vertex's transferred radiance, its matrix times the environment's SH,
    /// unless it is current.
    fn light_vertices(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let t = &self.transfer;
        let TransferPasses::Matrices { lighting, group, .. } = &t.passes else { return Ok(()) };
        if self.lit {
            return Ok(());
        }
        let [x, y, _] = workgroups_for(t.points * t.coefficients, WORKGROUP, self.max_workgroups);
        let groups = [&fc.gpu_scene.bind_group, &fc.frame.bind_group];
        profiler.pass(fc.ctx, "transferred radiance", |encoder| {
            let mut pass =
                crate::gpu::dispatch::compute_pass(encoder, "transferred radiance", lighting, &groups);
            // The first batch's slot: the pass reads only its order.
            pass.set_bind_group(2, group, &[0]);
            pass.dispatch_workgroups(x, y, 1);
        })?;
        self.lit = true;
        Ok(())
    }
}

/// The transfer passes' shader: the direction lattice, then the vectors' or the matrices' passes.
fn transfer_wgsl(glossy: bool) -> String {
    let passes = if glossy { include_str!("glossy.wgsl") } else { include_str!("transfer.wgsl") };
    format!(
        "{}\n{}\n{}\n{passes}",
        include_str!("lattice.wgsl"),
        include_str!("points.wgsl"),
        include_str!("parts.wgsl")
    )
}

/// The shading pass's shader for `transfer` (and `glossy_lobe`): the pixel's triangle and point, then
/// diffuse, glossy or wavelet environment light.
fn shade_wgsl(transfer: &str, glossy_lobe: &str) -> String {
    let shade = format!("{}\n{}", include_str!("points.wgsl"), include_str!("shade.wgsl"));
    let transfer = if is_glossy(transfer) { "glossy" } else { transfer };
    match (transfer, glossy_lobe) {
        ("glossy", "phong") => {
            let (glossy, phong) =
                (include_str!("shade_glossy.wgsl"), include_str!("shade_glossy_phong.wgsl"));
            format!("{shade}\n{glossy}\n{phong}")
        }
        ("glossy", _) => {
            let (glossy, tables) =
                (include_str!("shade_glossy.wgsl"), include_str!("shade_glossy_tables.wgsl"));
            format!("{shade}\n{LOOKUP_WGSL}\n{SHADING_WGSL}\n{glossy}\n{tables}")
        }
        ("wavelet", _) => format!("{shade}\n{}", include_str!("shade_wavelet.wgsl")),
        _ => format!("{shade}\n{}", include_str!("shade_diffuse.wgsl")),
    }
}

impl Technique for Prt {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        self.store_transfer(fc.ctx)?;
        let new_transfer = self.precompute(fc, profiler)?;
        let new_environment = match self.projection.as_mut() {
            Some(projection) => projection.project(fc, profiler)?,
            None => false,
        };
        self.lit &= !new_transfer && !new_environment;
        if let Some(parts) = self.self_transfer.as_mut() {
            // Glossy transfer's radiance is of the turned environment: light the vertices again.
            self.lit &= !parts.turn(fc, profiler, new_environment, self.max_workgroups)?;
        }
        if let TransferPasses::Wavelets(w) = &mut self.transfer.passes {
            if new_transfer {
                w.invalidate();
            }
            w.light(fc, profiler)?;
        }
        if let Some(tables) = self.tables.as_mut() {
            tables.build_once(fc, profiler)?;
        }
        self.light_vertices(fc, profiler)?;
        self.direct.render(fc, profiler)?;
        compute::frame_pass(fc, profiler, "prt shading", &self.shade, &self.shade_group)
    }

    // Lights and emitters are the direct pass's, read every frame; a new environment is projected
    // again (a turned one only rotated, by the projection itself) and new geometry gets new transfer
    // before the next frame; glossy transfer lights its vertices again after either.
    fn scene_changed(
        &mut self,
        _: &GpuContext,
        _: &crate::gpu::GpuScene,
        change: super::SceneChange,
    ) -> Result<bool, RenderError> {
        if change == super::SceneChange::Environment {
            if let Some(projection) = self.projection.as_mut() {
                projection.invalidate();
            }
            if let TransferPasses::Wavelets(w) = &mut self.transfer.passes {
                w.invalidate();
            }
        }
        Ok(true)
    }

    fn counters(
        &mut self,
        ctx: &GpuContext,
        _: &super::Measured,
    ) -> Result<std::collections::BTreeMap<String, f64>, RenderError> {
        // The stats come after the last frame: a run of one frame still leaves its transfer on disk.
        self.store_transfer(ctx)?;
        let cache = self.transfer.cache.as_ref();
        let cache_count = |f: fn(&TransferCache) -> u32| f64::from(cache.map_or(0, f));
        let mut counters = std::collections::BTreeMap::from([
            ("transfer_cache_loads".to_string(), cache_count(|c| c.loads)),
            ("transfer_cache_stores".to_string(), cache_count(|c| c.stores)),
            ("transfer_vertices".to_string(), f64::from(self.transfer.vertices)),
            ("transfer_points".to_string(), f64::from(self.transfer.points)),
            ("transfer_precomputations".to_string(), f64::from(self.transfer.precomputations)),
            ("transfer_floats_per_vertex".to_string(), f64::from(self.transfer.floats_per_vertex)),
            ("transfer_bytes".to_string(), self.transfer.buffer.size() as f64),
            (
                "transfer_rays".to_string(),
                match &self.transfer.passes {
                    TransferPasses::Wavelets(w) => w.rays(),
                    _ => {
                        f64::from(self.transfer.points)
                            * f64::from(self.samples)
                            * f64::from(self.transfer.rays_per_sample)
                    }
                },
            ),
            // The direct pass's target and the output, both f32 RGBA.
            ("output_bytes_per_pixel".to_string(), 32.0),
        ]);
        // Buffers the precomputation alone uses (interreflection's bounces, the vectors glossy bounces
        // gather).
        let mut scratch = 0;
        match &self.transfer.passes {
            TransferPasses::Matrices { transferred, bounce, .. } => {
                counters.insert("transferred_radiance_bytes".to_string(), transferred.size() as f64);
                if let Some(b) = bounce {
                    scratch = b.reflected.size() + b.vectors.scratch_bytes();
                }
            }
            TransferPasses::Wavelets(w) => counters.extend(w.counters()),
            TransferPasses::Vectors(v) => scratch = v.scratch_bytes(),
        }
        counters.insert("transfer_scratch_bytes".to_string(), scratch as f64);
        if let Some(tables) = &self.tables {
            counters.insert("brdf_table_bytes".to_string(), tables.shape.bytes() as f64);
        }
        if let Some(parts) = &self.self_transfer {
            counters.insert("self_transfer_instances".to_string(), f64::from(parts.instances));
            counters.insert("self_transfer_turns".to_string(), parts.turns as f64);
        }
        if let Some(projection) = &self.projection {
            counters.extend(projection.counters());
        }
        Ok(counters)
    }

    fn warnings(&self) -> Vec<String> {
        let wavelets = matches!(self.transfer.passes, TransferPasses::Wavelets(_));
        let mut warnings = vec![if wavelets {
            "prt: wavelet transfer is diffuse and shadowed (specular lobes get no environment light, \
             there are no interreflections); back faces get no environment light"
                .into()
        } else if let TransferPasses::Matrices { bounce, .. } = &self.transfer.passes {
            format!(
                "prt: glossy transfer carries the environment's light in {} SH bands, too few for sharp \
                 reflections (low roughness is blurred){}{}; back faces get no environment light",
                self.projection.as_ref().map_or(0, |p| p.coefficient_count().isqrt()),
                if self.tables.is_some() {
                    ""
                } else {
                    "; Phong lobes about the mirror direction stand in for GGX (no off-specular peak, \
                     Fresnel taken at the view angle)"
                },
                if bounce.is_some() {
                    "; the surfaces light bounces off reflect it diffusely (their specular lobes pass no \
                     light on)"
                } else {
                    ""
                }
            )
        } else {
            "prt: diffuse transfer (specular lobes get no environment light; transfer=glossy gives them \
             some); back faces get no environment light"
                .into()
        }];
        if let Some(e) = self.transfer.cache.as_ref().and_then(|c| c.error.as_ref()) {
            warnings.push(format!("prt: the transfer was not cached ({e})"));
        }
        if self.self_transfer.is_some() {
            warnings.push(
                "prt: the scene has moving meshes; their transfer is self-transfer (moving_transfer=self): \
                 each moving mesh shadows (and interreflects light onto) only itself, the static meshes only \
                 each other, and no shadow or bounced light passes between a moving mesh and the rest"
                    .into(),
            );
        } else if self.moving_meshes {
            warnings.push(
                "prt: the scene has moving meshes; every frame in which one moves recomputes the transfer of \
                 every vertex (precomputed transfer assumes still geometry)"
                    .into(),
            );
        }
        warnings
    }
}
