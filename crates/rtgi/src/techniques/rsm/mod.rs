//! Reflective shadow maps and what is built on them (first-bounce indirect light from analytic lights,
//! without indirect visibility):
//! - `rsm`: the RSM gather of Dachsbacher & Stamminger 2005 at reduced resolution, with their
//!   geometry-aware upsampling;
//! - `rsm-interleaved`: the same gather with interleaved sampling (Hahn 2012, after Segovia et al.
//!   2006): the G-buffer split into N×M sub-buffers, each shaded with 1/(N·M) of the samples, merged
//!   back and filtered with the shared discontinuity filter over the N×M pattern;
//! - `sii`: splatting indirect illumination (Dachsbacher & Stamminger 2006): VPLs importance-sampled
//!   from the RSM by flux, each splatted over the screen region where it can contribute more than a
//!   threshold; optionally interleaved (each VPL reaches one sub-buffer), with or without the N·M
//!   rescaling the thesis omitted.
//!
//! Every pass is a profiler scope; RSM generation ("rsm") runs once, since scene and lights are static.

mod gather;
mod interleave;
pub mod map;
mod splat;
#[cfg(test)]
mod tests;

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::Profiler;
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::shaders::Defines;
use crate::techniques::RenderError;
use crate::techniques::compute::{self, storage_texture_entry};
use crate::techniques::direct::with_direct_params;
use crate::techniques::discontinuity::{self, DiscontinuityFilter, FilterSettings};
use crate::techniques::{FrameContext, FrameNeeds, TechniqueInfo, TechniqueSetup};

pub use interleave::AtlasLayout;
use interleave::Merge;
pub use map::{RsmView, reader_source};

const RSM_SIZE: ParamSpec = ParamSpec {
    name: "rsm_size",
    kind: ParamKind::Int { min: 16, max: 2048 },
    default: "256",
    doc: "edge of each RSM layer in texels (point lights use six layers)",
};
const SAMPLES: ParamSpec = ParamSpec {
    name: "samples",
    kind: ParamKind::Int { min: 1, max: 16384 },
    default: "256",
    doc: "RSM samples per pixel and light, per cube face for point lights (interleaved: split over the N·M \
          sub-buffers)",
};
const R_MAX: ParamSpec = ParamSpec {
    name: "r_max",
    kind: ParamKind::Float { min: 0.001, max: 1.5 },
    default: "1.0",
    doc: "radius of the sampling disc around the pixel's RSM position, in RSM texture space (texels farther \
          away are never gathered: below ~1 the method is biased)",
};
const WEIGHTING: ParamSpec = ParamSpec {
    name: "weighting",
    kind: ParamKind::Choice(&["xi", "xi2"]),
    default: "xi",
    doc: "sample weight: xi = ξ1, the inverse of the pattern's density (unbiased); xi2 = the paper's ξ1² (scaled \
          to be exact for uniform light, otherwise biased towards the rim: 9x the error on cornell-spot)",
};
const INTERLEAVE: ParamSpec = ParamSpec {
    name: "interleave",
    kind: ParamKind::Size2 { max: 8 },
    default: "4x4",
    doc: "interleaving pattern N×M: sub-buffers, sample subsets and the filter window",
};

const RSM_PARAMS: [ParamSpec; 14] = with_direct_params!(
    RSM_SIZE,
    SAMPLES,
    R_MAX,
    WEIGHTING,
    ParamSpec {
        name: "downsample",
        kind: ParamKind::Int { min: 1, max: 8 },
        default: "2",
        doc: "gather at 1/downsample of the resolution, then upsample geometry-aware (1 = full resolution)",
    },
    ParamSpec {
        name: "brute_force",
        kind: ParamKind::Bool,
        default: "false",
        doc: "gather every RSM texel (the method's converged value: no indirect occlusion) instead of samples",
    },
);

const RSM_INTERLEAVED_PARAMS: [ParamSpec; 13] =
    with_direct_params!(RSM_SIZE, SAMPLES, R_MAX, WEIGHTING, INTERLEAVE,);

const SII_PARAMS: [ParamSpec; 14] = with_direct_params!(
    RSM_SIZE,
    ParamSpec {
        name: "vpls",
        kind: ParamKind::Int { min: 1, max: 65536 },
        default: "256",
        doc: "VPLs taken from the RSM, importance-sampled by reflected flux",
    },
    ParamSpec {
        name: "splat_threshold",
        kind: ParamKind::Float { min: 0.001, max: 100.0 },
        default: "0.25",
        doc: "a VPL's splat ends where its bound I/(π d²) drops below this × (mean VPL intensity)/(π R²), R = \
              scene radius: an average VPL reaches R/sqrt(threshold)",
    },
    ParamSpec {
        name: "interleave",
        kind: ParamKind::Size2 { max: 8 },
        default: "1x1",
        doc: "interleaving pattern N×M (1x1: none): VPL k reaches sub-buffer k mod N·M only",
    },
    ParamSpec {
        name: "rescale",
        kind: ParamKind::Bool,
        default: "true",
        doc: "interleaved: scale each VPL by N·M (the thesis did not, so its images lose (N·M−1)/(N·M) of the light)",
    },
    ParamSpec {
        name: "splat",
        kind: ParamKind::Choice(&["tiles", "tiles-shared", "tiles-texel", "raster"]),
        default: "tiles",
        doc: "tiles: per-tile VPL sets and a per-texel loop in compute (no blending), each tile's VPLs read \
              once into workgroup memory on GPUs (tiles-shared) and per texel from the VPL table on CPU \
              adapters (tiles-texel), the faster there; raster: one additively blended quad per VPL (the \
              paper's way); same texels, values and order",
    },
);

pub const RSM_INFO: TechniqueInfo = TechniqueInfo {
    name: "rsm",
    description: "reflective shadow maps: per-pixel gather of RSM pixel lights (no indirect occlusion), \
                  reduced resolution + geometry-aware upsampling",
    params: &RSM_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate: super::independent_params,
    create: |setup| Ok(Box::new(gather::Gather::new(setup, (1, 1), setup.params.int("downsample") as u32)?)),
};

pub const RSM_INTERLEAVED_INFO: TechniqueInfo = TechniqueInfo {
    name: "rsm-interleaved",
    description: "RSM gather with interleaved sampling: N×M sub-buffers, 1/(N·M) of the samples each, merge \
                  and discontinuity filter",
    params: &RSM_INTERLEAVED_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate: super::independent_params,
    create: |setup| Ok(Box::new(gather::Gather::new(setup, interleave_param(setup.params)?, 1)?)),
};

pub const SII_INFO: TechniqueInfo = TechniqueInfo {
    name: "sii",
    description: "splatting indirect illumination: flux-importance-sampled RSM VPLs splatted over bounded \
                  screen regions, optionally interleaved",
    params: &SII_PARAMS,
    needs: FrameNeeds { gbuffer: true },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate: super::independent_params,
    create: |setup| Ok(Box::new(splat::Splat::new(setup, interleave_param(setup.params)?)?)),
};

fn interleave_param(params: &ParamValues) -> Result<(u32, u32), RenderError> {
    let (n, m) = params.size2("interleave");
    if n > 8 || m > 8 {
        return Err(RenderError::InvalidSettings(format!("interleave {n}x{m}: at most 8x8")));
    }
    Ok((n, m))
}

/// The gather's sample pattern.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    pub count: u32,
    /// Consecutive blocks of this many samples form the subsets of interleaved sampling.
    pub per_subset: u32,
    pub r_max: f32,
    /// Weight ξ1² (the paper) instead of ξ1.
    pub xi2: bool,
    pub rsm_size: u32,
}

impl Sampling {
    pub fn from_params(p: &ParamValues, count: u32, per_subset: u32, rsm_size: u32) -> Self {
        Sampling {
            count,
            per_subset,
            r_max: p.float("r_max") as f32,
            xi2: p.choice("weighting") == "xi2",
            rsm_size,
        }
    }
}

/// Second dimension of the Sobol sequence (polynomial x + 1).
fn sobol2(mut i: u32) -> u32 {
    let (mut v, mut r) = (1u32 << 31, 0u32);
    while i != 0 {
        if i & 1 != 0 {
            r ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    r
}

fn hash(mut x: u32) -> u32 {
    x = x.wrapping_mul(747796405).wrapping_add(2891336453);
    let w = ((x >> ((x >> 28) + 4)) ^ x).wrapping_mul(277803737);
    (w >> 22) ^ w
}

/// The sample offsets of the gather: `(du, dv, weight, ξ1)` per sample.
///
/// ξ = the 2D Sobol points (XOR-scrambled per seed and frame), so each block of `per_subset` (a power of
/// two) consecutive samples is a stratified (0,m,2)-net on its own and the blocks together are one.
/// Offset (r_max·ξ1·sin 2πξ2, r_max·ξ1·cos 2πξ2); the weight turns a sample into an estimate of the sum
/// over the disc's π·r_max²·size² texels, divided by the samples a pixel takes: its density is
/// 1/(2π·r·r_max) per unit area, so the unbiased weight is 2π·r_max²·size²·ξ1 / n; the paper's ξ1² is
/// scaled by 3 (E\[ξ1²\] = 1/3) instead, which is exact when the texels are all alike.
pub fn gather_samples(s: &Sampling, seed: u32, frame: u32) -> Vec<[f32; 4]> {
    let scramble =
        (hash(seed ^ 0x9e37_79b9), hash(hash(seed).wrapping_add(frame).wrapping_mul(0x85eb_ca6b) ^ 7));
    let (sx, sy) = if frame == 0 && seed == 0 { (0, 0) } else { scramble };
    let texels = std::f32::consts::PI * s.r_max * s.r_max * (s.rsm_size as f32).powi(2);
    (0..s.count)
        .map(|k| {
            let x1 = (k.reverse_bits() ^ sx) as f32 * (1.0 / 4294967296.0);
            let x2 = (sobol2(k) ^ sy) as f32 * (1.0 / 4294967296.0);
            let r = s.r_max * x1;
            let (sin, cos) = (2.0 * std::f32::consts::PI * x2).sin_cos();
            let weight = if s.xi2 { 3.0 * x1 * x1 } else { 2.0 * x1 } * texels / s.per_subset as f32;
            [r * sin, r * cos, weight, x1]
        })
        .collect()
}

/// Where the composite reads the indirect light from.
enum Indirect<'a> {
    Texture(&'a wgpu::Texture),
    Packed(&'a wgpu::Buffer),
}

/// Direct + indirect into the output, accumulated over frames (pass "composite").
struct Composite {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
}

impl Composite {
    pub fn new(
        setup: &TechniqueSetup,
        direct: &wgpu::Texture,
        indirect: Indirect,
    ) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let float = wgpu::TextureSampleType::Float { filterable: false };
        let mut entries = vec![
            compute::texture_entry(0, float),
            storage_texture_entry(1, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
        ];
        entries.push(match indirect {
            Indirect::Texture(_) => compute::texture_entry(2, float),
            Indirect::Packed(_) => compute::storage_buffer_entry(3, true),
        });
        let bgl = compute::layout(ctx, "composite", &entries);
        let (dv, ov) =
            (direct.create_view(&Default::default()), setup.output.create_view(&Default::default()));
        let iv = match indirect {
            Indirect::Texture(t) => Some(t.create_view(&Default::default())),
            Indirect::Packed(_) => None,
        };
        let third = match (&indirect, &iv) {
            (Indirect::Packed(b), _) => wgpu::BindGroupEntry { binding: 3, resource: b.as_entire_binding() },
            (_, Some(v)) => {
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(v) }
            }
            _ => unreachable!("a texture source has a view"),
        };
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("composite"),
            layout: &bgl,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&dv) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&ov) },
                third,
            ],
        });
        let entry = match indirect {
            Indirect::Texture(_) => "main",
            Indirect::Packed(_) => "main_packed",
        };
        let pipeline = compute::pipeline(
            ctx,
            "composite",
            include_str!("composite.wgsl"),
            Defines::new(),
            entry,
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &bgl],
        )?;
        Ok(Composite { pipeline, bind_group })
    }

    pub fn render(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        compute::frame_pass(fc, profiler, "composite", &self.pipeline, &self.bind_group)
    }
}

/// The geometry-aware blur of interleaved sampling: the shared discontinuity filter over exactly the
/// N×M pattern (pass "discontinuity filter").
struct Filter {
    filter: DiscontinuityFilter,
    output: wgpu::Buffer,
}

/// Plane-distance tolerance of the interleaved blur and of the upsampling's similarity test, relative to
/// the camera distance.
pub const DEPTH_THRESHOLD: f32 = 0.02;
/// Smallest cosine between shading normals the blur averages over.
pub const NORMAL_COS: f32 = 0.9;

impl Filter {
    pub fn new(
        setup: &TechniqueSetup,
        pattern: (u32, u32),
        input: &wgpu::Buffer,
    ) -> Result<Self, RenderError> {
        let bytes = discontinuity::packed_buffer_bytes(setup.frame.width, setup.frame.height, 1);
        let output = compute::storage_buffer(setup.ctx, "filtered indirect", bytes);
        let settings = FilterSettings {
            window: [pattern.0, pattern.1],
            depth_threshold: DEPTH_THRESHOLD,
            normal_cos: Some(NORMAL_COS),
            material_test: true,
        };
        let filter = DiscontinuityFilter::new(setup, input, &output, 1, &settings)?;
        Ok(Filter { filter, output })
    }

    pub fn output(&self) -> &wgpu::Buffer {
        &self.output
    }

    pub fn render(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        self.filter.render(fc, profiler, "discontinuity filter")
    }
}

/// How every RSM technique ends a frame: when interleaved, merge the sub-buffers back into the image
/// layout and blur them over the pattern with the discontinuity filter; then direct + indirect into the
/// output.
pub struct Resolve {
    merge: Option<(Merge, Filter)>,
    composite: Composite,
}

impl Resolve {
    /// `indirect` is in `layout` (the atlas when interleaved, the image otherwise).
    pub fn new(
        setup: &TechniqueSetup,
        layout: AtlasLayout,
        indirect: &wgpu::Texture,
        direct: &wgpu::Texture,
    ) -> Result<Self, RenderError> {
        if !layout.is_interleaved() {
            return Ok(Resolve {
                merge: None,
                composite: Composite::new(setup, direct, Indirect::Texture(indirect))?,
            });
        }
        let merged = packed_buffer(setup, "indirect merged");
        let merge = Merge::new(
            setup.ctx,
            setup.frame,
            &setup.gpu_scene.bind_group_layout,
            layout,
            indirect,
            &merged,
        )?;
        let filter = Filter::new(setup, (layout.n, layout.m), &merged)?;
        let composite = Composite::new(setup, direct, Indirect::Packed(filter.output()))?;
        Ok(Resolve { merge: Some((merge, filter)), composite })
    }

    pub fn render(&self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        if let Some((merge, filter)) = &self.merge {
            profiler.pass(fc.ctx, "merge", |e| merge.record(e, &fc.gpu_scene.bind_group, fc.frame))?;
            filter.render(fc, profiler)?;
        }
        self.composite.render(fc, profiler)
    }
}

/// A packed half-float buffer of one vec4 per pixel.
fn packed_buffer(setup: &TechniqueSetup, label: &str) -> wgpu::Buffer {
    compute::storage_buffer(
        setup.ctx,
        label,
        discontinuity::packed_buffer_bytes(setup.frame.width, setup.frame.height, 1),
    )
}
