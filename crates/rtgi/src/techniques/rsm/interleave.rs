//! Interleaved sampling's buffer layout (Segovia et al. 2006, as used by the thesis): the G-buffer
//! split into N×M sub-buffers, each a decimated copy of the image shaded with its own subset of the
//! samples or VPLs, and the result merged back. `atlas.wgsl` is the GPU side of [`AtlasLayout`].

use crate::frame::{self, FrameResources};
use crate::gpu::GpuContext;
use crate::shaders::Defines;
use crate::techniques::RenderError;
use crate::techniques::compute;

/// Where each texel of a technique's indirect buffer comes from (see `atlas.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AtlasLayout {
    pub n: u32,
    pub m: u32,
    pub sub_w: u32,
    pub sub_h: u32,
    pub downsample: u32,
}

impl AtlasLayout {
    /// N×M sub-buffers of a `width`×`height` image.
    pub fn interleaved(width: u32, height: u32, n: u32, m: u32) -> Self {
        AtlasLayout { n, m, sub_w: width.div_ceil(n), sub_h: height.div_ceil(m), downsample: 1 }
    }

    /// One buffer at 1/`f` of the resolution.
    pub fn reduced(width: u32, height: u32, f: u32) -> Self {
        AtlasLayout { n: 1, m: 1, sub_w: width.div_ceil(f), sub_h: height.div_ceil(f), downsample: f }
    }

    pub fn size(&self) -> (u32, u32) {
        (self.sub_w * self.n, self.sub_h * self.m)
    }

    pub fn subsets(&self) -> u32 {
        self.n * self.m
    }

    pub fn is_interleaved(&self) -> bool {
        self.subsets() > 1
    }

    pub fn defines(&self, defines: Defines) -> Defines {
        defines
            .u32("INTERLEAVE_N", self.n)
            .u32("INTERLEAVE_M", self.m)
            .u32("SUB_W", self.sub_w)
            .u32("SUB_H", self.sub_h)
            .u32("DOWNSAMPLE", self.downsample)
    }

    /// The sample subset of atlas texel `a` (CPU twin of `atlas_subset`, for tests).
    pub fn subset(&self, a: (u32, u32)) -> u32 {
        a.0 / self.sub_w + self.n * (a.1 / self.sub_h)
    }

    /// The pixel of atlas texel `a` before clamping, for `downsample == 1` (CPU twin of
    /// `atlas_source`); `None` for padding texels.
    pub fn source(&self, a: (u32, u32), width: u32, height: u32) -> Option<(u32, u32)> {
        let (i, j) = (a.0 / self.sub_w, a.1 / self.sub_h);
        let p = ((a.0 % self.sub_w) * self.n + i, (a.1 % self.sub_h) * self.m + j);
        (p.0 < width && p.1 < height).then_some(p)
    }

    /// The atlas texel of pixel `p` (CPU twin of `atlas_of_pixel`).
    pub fn of_pixel(&self, p: (u32, u32)) -> (u32, u32) {
        ((p.0 % self.n) * self.sub_w + p.0 / self.n, (p.1 % self.m) * self.sub_h + p.1 / self.m)
    }
}

/// WGSL of the atlas layout.
pub const ATLAS_WGSL: &str = include_str!("atlas.wgsl");
/// WGSL of the surface bindings (2:8–11) in the atlas layout.
pub const SURFACES_WGSL: &str = include_str!("surfaces.wgsl");

/// The first binding of `surfaces.wgsl` in bind group 2 (its four textures take 8–11); a pass's own
/// resources come before it.
const SURFACE_BINDING: u32 = 8;

/// Layout entries 8–11 of `surfaces.wgsl`, visible to `stages`.
pub fn surface_entries(stages: wgpu::ShaderStages) -> Vec<wgpu::BindGroupLayoutEntry> {
    let float = wgpu::TextureSampleType::Float { filterable: false };
    [float, float, wgpu::TextureSampleType::Uint, float]
        .into_iter()
        .zip(SURFACE_BINDING..)
        .map(|(sample_type, binding)| wgpu::BindGroupLayoutEntry {
            visibility: stages,
            ..compute::texture_entry(binding, sample_type)
        })
        .collect()
}

/// The G-buffer copied into the atlas layout (or, without interleaving, the frame's own G-buffer).
pub struct SplitGBuffer {
    pub albedo: wgpu::TextureView,
    pub normal: wgpu::TextureView,
    pub material: wgpu::TextureView,
    pub distance: wgpu::TextureView,
    split: Option<(wgpu::ComputePipeline, wgpu::BindGroup)>,
    layout: AtlasLayout,
}

impl SplitGBuffer {
    pub fn new(
        ctx: &GpuContext,
        frame: &FrameResources,
        layout: AtlasLayout,
        gpu_scene_layout: &wgpu::BindGroupLayout,
    ) -> Result<Self, RenderError> {
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        if !layout.is_interleaved() {
            let g = &frame.gbuffer;
            return Ok(SplitGBuffer {
                albedo: view(&g.albedo),
                normal: view(&g.normal),
                material: view(&g.material),
                distance: view(&g.distance),
                split: None,
                layout,
            });
        }
        let (w, h) = layout.size();
        let formats =
            [frame::ALBEDO_FORMAT, frame::NORMAL_FORMAT, frame::MATERIAL_FORMAT, frame::DISTANCE_FORMAT];
        let textures: Vec<wgpu::Texture> =
            formats.iter().map(|f| compute::storage_texture(ctx, "split gbuffer", w, h, *f)).collect();
        let entries: Vec<wgpu::BindGroupLayoutEntry> = formats
            .iter()
            .enumerate()
            .map(|(i, f)| compute::storage_texture_entry(i as u32, *f, wgpu::StorageTextureAccess::WriteOnly))
            .collect();
        let bgl = compute::layout(ctx, "split gbuffer", &entries);
        let views: Vec<wgpu::TextureView> = textures.iter().map(view).collect();
        let resources: Vec<wgpu::BindingResource> =
            views.iter().map(wgpu::BindingResource::TextureView).collect();
        let bind_group = compute::bind_group(ctx, "split gbuffer", &bgl, &resources);
        let source = format!("{ATLAS_WGSL}\n{}", include_str!("split.wgsl"));
        let pipeline = compute::pipeline(
            ctx,
            "split gbuffer",
            &source,
            layout.defines(Defines::new()),
            "split_gbuffer",
            &[gpu_scene_layout, &frame.bind_group_layout, &bgl],
        )?;
        Ok(SplitGBuffer {
            albedo: view(&textures[0]),
            normal: view(&textures[1]),
            material: view(&textures[2]),
            distance: view(&textures[3]),
            split: Some((pipeline, bind_group)),
            layout,
        })
    }

    /// A bind group of `layout` (made with [`surface_entries`]): `own` at bindings 0.., these surfaces
    /// at 8–11.
    pub fn bind_group(
        &self,
        ctx: &GpuContext,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        own: &[wgpu::BindingResource],
    ) -> wgpu::BindGroup {
        let surfaces = [&self.albedo, &self.normal, &self.material, &self.distance]
            .map(wgpu::BindingResource::TextureView)
            .into_iter()
            .zip(SURFACE_BINDING..);
        let entries: Vec<wgpu::BindGroupEntry> = own
            .iter()
            .cloned()
            .zip(0..)
            .chain(surfaces)
            .map(|(resource, binding)| wgpu::BindGroupEntry { binding, resource })
            .collect();
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &entries,
        })
    }

    /// Records the split (nothing without interleaving).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &wgpu::BindGroup,
        frame: &wgpu::BindGroup,
    ) {
        if let Some((pipeline, group)) = &self.split {
            let (w, h) = self.layout.size();
            compute::dispatch_pixels(encoder, "split gbuffer", pipeline, &[scene, frame, group], w, h);
        }
    }
}

/// Merges an atlas-layout radiance texture back into the image layout, as a packed half-float buffer
/// (the discontinuity filter's input).
pub struct Merge {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
}

impl Merge {
    pub fn new(
        ctx: &GpuContext,
        frame: &FrameResources,
        gpu_scene_layout: &wgpu::BindGroupLayout,
        layout: AtlasLayout,
        atlas: &wgpu::Texture,
        image: &wgpu::Buffer,
    ) -> Result<Self, RenderError> {
        let bgl = compute::layout(
            ctx,
            "merge",
            &[
                compute::texture_entry(0, wgpu::TextureSampleType::Float { filterable: false }),
                compute::storage_buffer_entry(1, false),
            ],
        );
        let a = atlas.create_view(&Default::default());
        let bind_group = compute::bind_group(
            ctx,
            "merge",
            &bgl,
            &[wgpu::BindingResource::TextureView(&a), image.as_entire_binding()],
        );
        let pipeline = compute::pipeline(
            ctx,
            "merge",
            &format!("{ATLAS_WGSL}\n{}", include_str!("merge.wgsl")),
            layout.defines(Defines::new()),
            "merge",
            &[gpu_scene_layout, &frame.bind_group_layout, &bgl],
        )?;
        Ok(Merge { pipeline, bind_group })
    }

    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &wgpu::BindGroup,
        frame: &FrameResources,
    ) {
        compute::dispatch_pixels(
            encoder,
            "merge",
            &self.pipeline,
            &[scene, &frame.bind_group, &self.bind_group],
            frame.width,
            frame.height,
        );
    }
}
