//! `rsm` and `rsm-interleaved`: the RSM gather, at reduced resolution with geometry-aware upsampling, or
//! interleaved over N×M sub-buffers with a geometry-aware blur over the pattern.

use std::collections::BTreeMap;

use super::interleave::{self, AtlasLayout, SplitGBuffer};
use super::map::{self, ReflectiveShadowMap};
use super::{Resolve, Sampling, gather_samples};
use crate::frame::OUTPUT_FORMAT;
use crate::gpu::{GpuContext, Profiler, readback};
use crate::shaders::Defines;
use crate::techniques::RenderError;
use crate::techniques::compute::{self, DispatchSlots, storage_texture_entry};
use crate::techniques::direct::{DirectLighting, DirectOutput};
use crate::techniques::{FrameContext, Measured, Technique, TechniqueSetup};

/// Samples (of one subset) per dispatch: lavapipe loses work in much longer loops.
const SAMPLES_PER_DISPATCH: u32 = 256;
/// RSM texels per dispatch of the brute-force gather.
const TEXELS_PER_DISPATCH: u32 = 4096;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Chunk {
    first: u32,
    count: u32,
    accumulate: u32,
    _pad: u32,
}

/// One gather pipeline over one atlas, one dispatch per chunk of samples.
struct GatherPass {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    chunks: DispatchSlots,
    size: (u32, u32),
}

impl GatherPass {
    fn record(&self, encoder: &mut wgpu::CommandEncoder, fc: &FrameContext, rsm: &ReflectiveShadowMap) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("rsm gather"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &fc.gpu_scene.bind_group, &[]);
        pass.set_bind_group(1, &fc.frame.bind_group, &[]);
        pass.set_bind_group(3, &rsm.bind_group, &[]);
        for offset in self.chunks.offsets() {
            pass.set_bind_group(2, &self.group, &[offset]);
            pass.dispatch_workgroups(
                self.size.0.div_ceil(compute::TILE),
                self.size.1.div_ceil(compute::TILE),
                1,
            );
        }
    }
}

pub struct Gather {
    direct: DirectLighting,
    rsm: ReflectiveShadowMap,
    layout: AtlasLayout,
    sampling: Sampling,
    samples_buffer: wgpu::Buffer,
    split: SplitGBuffer,
    gather: GatherPass,
    /// Reduced resolution: upsampling and the full-resolution gather of the pixels it cannot interpolate.
    upsample: Option<(wgpu::ComputePipeline, wgpu::BindGroup, GatherPass, wgpu::Texture)>,
    resolve: Resolve,
    samples_per_pixel: u32,
    brute_force: bool,
}

#[allow(clippy::too_many_arguments)]
fn gather_pass(
    setup: &TechniqueSetup,
    rsm: &ReflectiveShadowMap,
    layout: AtlasLayout,
    surfaces: &SplitGBuffer,
    target: &wgpu::Texture,
    samples: &wgpu::Buffer,
    per_subset: u32,
    brute_force: bool,
    fixup: bool,
) -> Result<GatherPass, RenderError> {
    let ctx = setup.ctx;
    let (total, step) =
        if brute_force { (rsm.texels(), TEXELS_PER_DISPATCH) } else { (per_subset, SAMPLES_PER_DISPATCH) };
    let chunk_list: Vec<Chunk> = (0..total.max(1))
        .step_by(step as usize)
        .map(|first| Chunk {
            first,
            count: step.min(total - first),
            accumulate: u32::from(first > 0),
            _pad: 0,
        })
        .collect();
    let chunks = DispatchSlots::new(ctx, "rsm gather chunks", &chunk_list);
    let mut entries = vec![
        storage_texture_entry(0, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
        compute::storage_buffer_entry(1, true),
        chunks.entry(2),
    ];
    entries.extend(interleave::surface_entries(wgpu::ShaderStages::COMPUTE));
    let bgl = compute::layout(ctx, "rsm gather", &entries);
    let defines = layout
        .defines(Defines::new())
        .u32("SAMPLES_PER_SUBSET", per_subset)
        .bool("BRUTE_FORCE", brute_force)
        .bool("FIXUP", fixup)
        .bool("SPLIT_GBUFFER", layout.is_interleaved());
    let source = map::reader_source(&format!(
        "{}\n{}\n{}",
        interleave::ATLAS_WGSL,
        interleave::SURFACES_WGSL,
        include_str!("gather.wgsl")
    ));
    let pipeline = compute::pipeline(
        ctx,
        "rsm gather",
        &source,
        defines,
        "main",
        &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &bgl, &rsm.layout],
    )?;
    let target_view = target.create_view(&Default::default());
    let group = surfaces.bind_group(
        ctx,
        "rsm gather",
        &bgl,
        &[wgpu::BindingResource::TextureView(&target_view), samples.as_entire_binding(), chunks.resource()],
    );
    Ok(GatherPass { pipeline, group, chunks, size: layout.size() })
}

impl Gather {
    /// `interleave` = (N, M); (1, 1) with `downsample` ≥ 1 is the plain gather.
    pub fn new(setup: &TechniqueSetup, interleave: (u32, u32), downsample: u32) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let p = setup.params;
        let (w, h) = (setup.frame.width, setup.frame.height);
        let direct_target = compute::storage_texture(ctx, "direct", w, h, OUTPUT_FORMAT);
        let direct = DirectLighting::new(setup, &direct_target, DirectOutput::Replace)?;
        let rsm = ReflectiveShadowMap::new(ctx, setup.scene, setup.gpu_scene, p.int("rsm_size") as u32)?;
        let layout = if interleave == (1, 1) {
            AtlasLayout::reduced(w, h, downsample)
        } else {
            AtlasLayout::interleaved(w, h, interleave.0, interleave.1)
        };
        let brute_force = p.get("brute_force").is_some_and(|_| p.bool("brute_force"));
        let subsets = layout.subsets();
        let requested = p.int("samples") as u32;
        if requested < subsets {
            return Err(RenderError::InvalidSettings(format!(
                "samples={requested} is fewer than the {subsets} sub-buffers of the {}x{} pattern",
                interleave.0, interleave.1
            )));
        }
        let per_subset = requested / subsets;
        let sampling = Sampling::from_params(p, per_subset * subsets, per_subset, rsm.size);
        let samples_buffer =
            compute::storage_buffer(ctx, "rsm samples", u64::from(per_subset * subsets) * 16);
        let split = SplitGBuffer::new(ctx, setup.frame, layout, &setup.gpu_scene.bind_group_layout)?;
        let (aw, ah) = layout.size();
        let atlas = compute::storage_texture(ctx, "rsm indirect atlas", aw, ah, OUTPUT_FORMAT);
        let gather = gather_pass(
            setup,
            &rsm,
            layout,
            &split,
            &atlas,
            &samples_buffer,
            per_subset,
            brute_force,
            false,
        )?;
        let mut indirect = atlas;
        let mut upsample = None;
        if downsample > 1 {
            let full = compute::storage_texture(ctx, "rsm indirect", w, h, OUTPUT_FORMAT);
            let bgl = compute::layout(
                ctx,
                "rsm upsample",
                &[
                    compute::texture_entry(0, wgpu::TextureSampleType::Float { filterable: false }),
                    storage_texture_entry(1, OUTPUT_FORMAT, wgpu::StorageTextureAccess::WriteOnly),
                ],
            );
            let (lv, fv) = (indirect.create_view(&Default::default()), full.create_view(&Default::default()));
            let group = compute::bind_group(
                ctx,
                "rsm upsample",
                &bgl,
                &[wgpu::BindingResource::TextureView(&lv), wgpu::BindingResource::TextureView(&fv)],
            );
            let pipeline = compute::pipeline(
                ctx,
                "rsm upsample",
                include_str!("upsample.wgsl"),
                Defines::new()
                    .u32("DOWNSAMPLE", downsample)
                    .f32("DEPTH_THRESHOLD", super::DEPTH_THRESHOLD)
                    .f32("NORMAL_COS", super::NORMAL_COS),
                "main",
                &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &bgl],
            )?;
            let full_layout = AtlasLayout::reduced(w, h, 1);
            let full_surfaces =
                SplitGBuffer::new(ctx, setup.frame, full_layout, &setup.gpu_scene.bind_group_layout)?;
            let fixup = gather_pass(
                setup,
                &rsm,
                full_layout,
                &full_surfaces,
                &full,
                &samples_buffer,
                per_subset,
                brute_force,
                true,
            )?;
            upsample = Some((pipeline, group, fixup, full.clone()));
            indirect = full;
        }
        let resolve = Resolve::new(setup, layout, &indirect, &direct_target)?;
        Ok(Gather {
            direct,
            rsm,
            layout,
            sampling,
            samples_buffer,
            split,
            gather,
            upsample,
            resolve,
            samples_per_pixel: per_subset,
            brute_force,
        })
    }
}

impl Technique for Gather {
    // The direct term reads the scene's lights, shadow maps and environment every frame; the RSMs
    // re-aim and render again when lights move (the environment does not bounce in RSM techniques).
    fn scene_changed(
        &mut self,
        ctx: &GpuContext,
        gpu_scene: &crate::gpu::GpuScene,
        change: crate::techniques::SceneChange,
    ) -> Result<bool, RenderError> {
        self.rsm.scene_changed(ctx, gpu_scene, change);
        Ok(true)
    }

    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let ctx = fc.ctx;
        let samples = gather_samples(&self.sampling, fc.frame.uniforms.seed, fc.view.frame_counter);
        ctx.queue.write_buffer(&self.samples_buffer, 0, bytemuck::cast_slice(&samples));
        self.rsm.render(ctx, fc.gpu_scene, profiler)?;
        self.direct.render(fc, profiler)?;
        let (scene, frame) = (&fc.gpu_scene.bind_group, &fc.frame.bind_group);
        if self.layout.is_interleaved() {
            profiler.pass(ctx, "split", |e| self.split.record(e, scene, frame))?;
        }
        profiler.pass(ctx, "rsm gather", |e| self.gather.record(e, fc, &self.rsm))?;
        if let Some((pipeline, group, fixup, _)) = &self.upsample {
            compute::frame_pass(fc, profiler, "upsample", pipeline, group)?;
            profiler.pass(ctx, "full-resolution fixup", |e| fixup.record(e, fc, &self.rsm))?;
        }
        self.resolve.render(fc, profiler)
    }

    fn counters(&mut self, ctx: &GpuContext, _: &Measured) -> Result<BTreeMap<String, f64>, RenderError> {
        let mut c = BTreeMap::new();
        c.insert("rsm_texels".into(), f64::from(self.rsm.texels()));
        c.insert("rsm_layers".into(), self.rsm.views.len() as f64);
        c.insert("rsm_bytes".into(), f64::from(self.rsm.texels() * map::BYTES_PER_TEXEL));
        // One sampling disc per light, six for a point light's cube faces.
        let discs = self.rsm.light_discs;
        let per_pixel = if self.brute_force { self.rsm.texels() } else { self.samples_per_pixel * discs };
        c.insert("samples_per_pixel".into(), f64::from(per_pixel));
        c.insert("sample_subsets".into(), f64::from(self.layout.subsets()));
        let (aw, ah) = self.layout.size();
        c.insert("gathered_texels".into(), f64::from(aw * ah));
        if let Some((_, _, _, full)) = &self.upsample {
            let texels = readback::read_texture(ctx, full, 16)?;
            let px: &[f32] = bytemuck::cast_slice(&texels);
            let fixed = px.chunks_exact(4).filter(|p| p[3] < 0.5).count();
            c.insert("fixup_pixels".into(), fixed as f64);
            c.insert("fixup_fraction".into(), fixed as f64 / (px.len() / 4) as f64);
        }
        Ok(c)
    }

    fn warnings(&self) -> Vec<String> {
        self.rsm.warnings.clone()
    }
}
