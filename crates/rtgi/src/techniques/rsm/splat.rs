//! `sii`: splatting indirect illumination, optionally interleaved (see `vpl.wgsl` and `splat.wgsl`).

use std::collections::BTreeMap;

use bytemuck::{Pod, Zeroable};

use super::Resolve;
use super::interleave::{self, AtlasLayout, SplitGBuffer};
use super::map::{self, ReflectiveShadowMap};
use crate::frame::OUTPUT_FORMAT;
use crate::gpu::{GpuContext, Profiler, linear_texture, readback};
use crate::shaders::{self, Defines};
use crate::techniques::RenderError;
use crate::techniques::compute;
use crate::techniques::direct::{DirectLighting, DirectOutput};
use crate::techniques::{FrameContext, Measured, Technique, TechniqueSetup};

/// A VPL; mirrors `Vpl` in `vpl_struct.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuVpl {
    pub position: [f32; 3],
    pub radius: f32,
    pub normal: [f32; 3],
    pub area: f32,
    pub intensity: [f32; 3],
    pub subset: u32,
}

/// Mirrors `VplParams` in `vpl.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct VplParams {
    pub count: u32,
    pub subsets: u32,
    pub jitter: f32,
    pub threshold: f32,
}

/// Texels per VPL of the tiled splat's VPL table (`VPL_TABLE_TEXELS` in `vpl_table.wgsl`): position,
/// normal, intensity, atlas rectangle.
pub(super) const VPL_TABLE_TEXELS: u64 = 4;

pub const VPL_STRUCT_WGSL: &str = include_str!("vpl_struct.wgsl");

/// The source of the VPL-selection shader.
pub fn vpl_source() -> String {
    map::reader_source(&format!("{VPL_STRUCT_WGSL}\n{}", include_str!("vpl.wgsl")))
}

/// The source of a splat shader: `body` (raster or tiled) after what both share.
fn splat_shader(body: &str) -> String {
    map::reader_source(&format!(
        "{}\n{}\n{VPL_STRUCT_WGSL}\n{}\n{body}",
        interleave::ATLAS_WGSL,
        interleave::SURFACES_WGSL,
        include_str!("splat_common.wgsl")
    ))
}

/// The source of the raster splat shader.
pub fn splat_source() -> String {
    splat_shader(include_str!("splat.wgsl"))
}

/// The source of the tiled compute splat's set-up passes (VPL rectangles and table, per-tile VPL sets).
pub fn bins_source() -> String {
    splat_shader(&format!("{}\n{}", include_str!("vpl_table.wgsl"), include_str!("splat_bins.wgsl")))
}

/// The source of the tiled compute splat's per-texel pass.
pub fn tiles_source() -> String {
    splat_shader(&format!("{}\n{}", include_str!("vpl_table.wgsl"), include_str!("splat_tiles.wgsl")))
}

/// How VPLs reach the atlas (parameter `splat`).
enum Splatting {
    /// One instanced quad per VPL, additively blended (the paper's way).
    Raster { pipeline: wgpu::RenderPipeline, group: wgpu::BindGroup },
    /// Per-tile VPL sets, then a per-texel loop over its tile's set (`splat_tiles.wgsl`).
    Tiles {
        rects: wgpu::ComputePipeline,
        bins: wgpu::ComputePipeline,
        tiles: wgpu::ComputePipeline,
        /// The tile sets as `splat_bins` writes them, and copied for the per-texel pass.
        sets: wgpu::Buffer,
        set_table: wgpu::Texture,
        /// Group 2 of the rects, sets and per-texel dispatches.
        groups: [wgpu::BindGroup; 3],
        /// Tiles across and down the atlas, 32-VPL words per tile.
        grid: [u32; 3],
    },
}

pub struct Splat {
    direct: DirectLighting,
    rsm: ReflectiveShadowMap,
    layout: AtlasLayout,
    split: SplitGBuffer,
    cdf_pipeline: wgpu::ComputePipeline,
    vpl_pipeline: wgpu::ComputePipeline,
    vpl_group: wgpu::BindGroup,
    params: VplParams,
    params_buffer: wgpu::Buffer,
    pub(super) vpl_buffer: wgpu::Buffer,
    splatting: Splatting,
    pub(super) atlas: wgpu::Texture,
    atlas_view: wgpu::TextureView,
    resolve: Resolve,
    cdf_built: bool,
    atlas_format: wgpu::TextureFormat,
}

impl Splat {
    pub fn new(setup: &TechniqueSetup, pattern: (u32, u32)) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let p = setup.params;
        let (w, h) = (setup.frame.width, setup.frame.height);
        let direct_target = compute::storage_texture(ctx, "direct", w, h, OUTPUT_FORMAT);
        let direct = DirectLighting::new(setup, &direct_target, DirectOutput::Replace)?;
        let rsm = ReflectiveShadowMap::new(ctx, setup.scene, setup.gpu_scene, p.int("rsm_size") as u32)?;
        let layout = AtlasLayout::interleaved(w, h, pattern.0, pattern.1);
        let count = p.int("vpls") as u32;
        let params = VplParams {
            count,
            subsets: layout.subsets(),
            jitter: 0.5,
            threshold: p.float("splat_threshold") as f32,
        };
        let rescale = p.bool("rescale");
        let scale = if rescale { layout.subsets() as f32 } else { 1.0 };

        // VPL selection.
        let cdf_bytes = u64::from(rsm.texels().max(1)) * 4;
        let limit = ctx.limits().max_storage_buffer_binding_size;
        if cdf_bytes > limit {
            return Err(RenderError::InvalidSettings(format!(
                "the flux CDF of {} RSM texels needs {cdf_bytes} bytes, over the device's \
                 max_storage_buffer_binding_size of {limit}: lower rsm_size",
                rsm.texels()
            )));
        }
        let cdf = compute::storage_buffer(ctx, "rsm luminance cdf", cdf_bytes);
        let vpl_buffer = compute::storage_buffer(ctx, "vpls", u64::from(count) * size_of::<GpuVpl>() as u64);
        let params_buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("vpl params"),
            size: size_of::<VplParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let vpl_layout = compute::layout(
            ctx,
            "vpl selection",
            &[
                compute::storage_buffer_entry(0, false),
                compute::storage_buffer_entry(1, false),
                compute::uniform_entry(2),
            ],
        );
        let vpl_group = compute::bind_group(
            ctx,
            "vpl selection",
            &vpl_layout,
            &[cdf.as_entire_binding(), vpl_buffer.as_entire_binding(), params_buffer.as_entire_binding()],
        );
        let layouts =
            [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &vpl_layout, &rsm.layout];
        let source = vpl_source();
        let cdf_pipeline = compute::pipeline(ctx, "rsm cdf", &source, Defines::new(), "build_cdf", &layouts)?;
        let vpl_pipeline = compute::pipeline(ctx, "vpls", &source, Defines::new(), "make_vpls", &layouts)?;

        // Splatting.
        let split = SplitGBuffer::new(ctx, setup.frame, layout, &setup.gpu_scene.bind_group_layout)?;
        let tiled = p.choice("splat").starts_with("tiles");
        // Blending rgba32float needs an optional feature; storage writes of it do not.
        let atlas_format = if tiled || ctx.device.features().contains(wgpu::Features::FLOAT32_BLENDABLE) {
            wgpu::TextureFormat::Rgba32Float
        } else {
            wgpu::TextureFormat::Rgba16Float
        };
        let (aw, ah) = layout.size();
        let target_usage =
            if tiled { wgpu::TextureUsages::STORAGE_BINDING } else { wgpu::TextureUsages::RENDER_ATTACHMENT };
        let atlas = ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("sii indirect atlas"),
            size: wgpu::Extent3d { width: aw, height: ah, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: atlas_format,
            usage: target_usage | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let atlas_view = atlas.create_view(&Default::default());
        let defines =
            layout.defines(Defines::new()).bool("SPLIT_GBUFFER", layout.is_interleaved()).f32("SCALE", scale);
        let splatting = if tiled {
            // Workgroup memory pays on GPUs; lavapipe's barriers cost more than the texel loads they save
            // (splat_tiles.wgsl).
            let shared = match p.choice("splat") {
                "tiles-shared" => true,
                "tiles-texel" => false,
                _ => ctx.adapter.get_info().device_type != wgpu::DeviceType::Cpu,
            };
            let per_texel = if shared { "splat_tiles_shared" } else { "splat_tiles" };
            Self::tiles(setup, &split, &vpl_buffer, &atlas_view, &rsm, count, (aw, ah), defines, per_texel)?
        } else {
            Self::raster(setup, &split, &vpl_buffer, &rsm, atlas_format, &defines)?
        };

        let resolve = Resolve::new(setup, layout, &atlas, &direct_target)?;
        Ok(Splat {
            direct,
            rsm,
            layout,
            split,
            cdf_pipeline,
            vpl_pipeline,
            vpl_group,
            params,
            params_buffer,
            vpl_buffer,
            splatting,
            atlas,
            atlas_view,
            resolve,
            cdf_built: false,
            atlas_format,
        })
    }
}

impl Splat {
    fn raster(
        setup: &TechniqueSetup,
        split: &SplitGBuffer,
        vpl_buffer: &wgpu::Buffer,
        rsm: &ReflectiveShadowMap,
        atlas_format: wgpu::TextureFormat,
        defines: &Defines,
    ) -> Result<Splatting, RenderError> {
        let ctx = setup.ctx;
        let mut entries = vec![wgpu::BindGroupLayoutEntry {
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ..compute::storage_buffer_entry(0, true)
        }];
        entries.extend(interleave::surface_entries(wgpu::ShaderStages::FRAGMENT));
        let splat_layout = compute::layout(ctx, "splat", &entries);
        let group = split.bind_group(ctx, "splat", &splat_layout, &[vpl_buffer.as_entire_binding()]);
        let module = shaders::create_module(ctx, "splat", &splat_source(), defines)?;
        let pipeline_layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("splat"),
            bind_group_layouts: &[
                Some(&setup.gpu_scene.bind_group_layout),
                Some(&setup.frame.bind_group_layout),
                Some(&splat_layout),
                Some(&rsm.layout),
            ],
            immediate_size: 0,
        });
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let pipeline = ctx.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("splat"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: atlas_format,
                    blend: Some(wgpu::BlendState { color: add, alpha: add }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        Ok(Splatting::Raster { pipeline, group })
    }

    #[allow(clippy::too_many_arguments)]
    fn tiles(
        setup: &TechniqueSetup,
        split: &SplitGBuffer,
        vpl_buffer: &wgpu::Buffer,
        atlas_view: &wgpu::TextureView,
        rsm: &ReflectiveShadowMap,
        count: u32,
        (aw, ah): (u32, u32),
        defines: Defines,
        per_texel_entry: &str,
    ) -> Result<Splatting, RenderError> {
        let ctx = setup.ctx;
        let (tiles_x, tiles_y, words) =
            (aw.div_ceil(compute::TILE), ah.div_ceil(compute::TILE), count.div_ceil(32));
        let bin_bytes = u64::from(tiles_x) * u64::from(tiles_y) * u64::from(words) * 4;
        let limit = ctx.limits().max_storage_buffer_binding_size;
        if bin_bytes > limit {
            return Err(RenderError::InvalidSettings(format!(
                "sii tiles: {count} VPLs over {tiles_x}x{tiles_y} tiles need {bin_bytes} bytes of VPL sets, over \
                 the device's max_storage_buffer_binding_size of {limit}: fewer vpls, a smaller image or \
                 splat=raster"
            )));
        }
        let max_groups = ctx.limits().max_compute_workgroups_per_dimension;
        if words.div_ceil(64).max(tiles_x).max(tiles_y) > max_groups {
            return Err(RenderError::InvalidSettings(format!(
                "sii tiles: {tiles_x}x{tiles_y} tiles of {words} words exceed the device's \
                 max_compute_workgroups_per_dimension of {max_groups}"
            )));
        }
        let bins = compute::storage_buffer(ctx, "splat tile sets", bin_bytes);
        let bin_table =
            linear_texture::create(ctx, "splat tile set table", wgpu::TextureFormat::R32Uint, bin_bytes / 4)?;
        let table = linear_texture::create_storage(
            ctx,
            "splat vpl table",
            wgpu::TextureFormat::Rgba32Float,
            u64::from(count) * VPL_TABLE_TEXELS,
        )?;
        let table_view = table.create_view(&Default::default());
        let table_write = compute::storage_texture_entry(
            2,
            wgpu::TextureFormat::Rgba32Float,
            wgpu::StorageTextureAccess::WriteOnly,
        );
        let table_read =
            |binding| compute::texture_entry(binding, wgpu::TextureSampleType::Float { filterable: false });
        // Bindings as `splat_bins.wgsl` and `splat_tiles.wgsl` number them; the table is written by one
        // dispatch and read by the next ones, so each gets a group of its own.
        let group = |label: &str, entries: &[(wgpu::BindGroupLayoutEntry, wgpu::BindingResource)]| {
            let layout_entries: Vec<_> = entries.iter().map(|(e, _)| *e).collect();
            let layout = compute::layout(ctx, label, &layout_entries);
            let bind_entries: Vec<_> = entries
                .iter()
                .map(|(e, r)| wgpu::BindGroupEntry { binding: e.binding, resource: r.clone() })
                .collect();
            let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &layout,
                entries: &bind_entries,
            });
            (layout, group)
        };
        let table_resource = wgpu::BindingResource::TextureView(&table_view);
        let (rects_layout, rects_group) = group(
            "splat rects",
            &[
                (compute::storage_buffer_entry(0, true), vpl_buffer.as_entire_binding()),
                (table_write, table_resource.clone()),
            ],
        );
        let (bins_layout, bins_group) = group(
            "splat tile sets",
            &[
                (compute::storage_buffer_entry(1, false), bins.as_entire_binding()),
                (table_read(3), table_resource.clone()),
            ],
        );
        let mut tiles_entries = vec![
            compute::storage_buffer_entry(0, true),
            compute::texture_entry(1, wgpu::TextureSampleType::Uint),
            compute::storage_texture_entry(
                2,
                wgpu::TextureFormat::Rgba32Float,
                wgpu::StorageTextureAccess::WriteOnly,
            ),
            table_read(3),
        ];
        tiles_entries.extend(interleave::surface_entries(wgpu::ShaderStages::COMPUTE));
        let tiles_layout = compute::layout(ctx, "splat tiles", &tiles_entries);
        let tiles_group = split.bind_group(
            ctx,
            "splat tiles",
            &tiles_layout,
            &[
                vpl_buffer.as_entire_binding(),
                wgpu::BindingResource::TextureView(&bin_table.create_view(&Default::default())),
                wgpu::BindingResource::TextureView(atlas_view),
                table_resource,
            ],
        );
        let defines = defines.u32("VPL_COUNT", count).u32("BIN_WORDS", words).u32("TILES_X", tiles_x);
        let pipeline = |source: &str, entry: &str, layout: &wgpu::BindGroupLayout| {
            let layouts =
                [&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, layout, &rsm.layout];
            compute::pipeline(ctx, "splat tiles", source, defines.clone(), entry, &layouts)
        };
        let (set_up, per_texel) = (bins_source(), tiles_source());
        Ok(Splatting::Tiles {
            rects: pipeline(&set_up, "splat_rects", &rects_layout)?,
            bins: pipeline(&set_up, "splat_bins", &bins_layout)?,
            tiles: pipeline(&per_texel, per_texel_entry, &tiles_layout)?,
            groups: [rects_group, bins_group, tiles_group],
            sets: bins,
            set_table: bin_table,
            grid: [tiles_x, tiles_y, words],
        })
    }

    /// Records the splat of this frame's VPLs into the atlas.
    fn record_splat(&self, e: &mut wgpu::CommandEncoder, scene: &wgpu::BindGroup, frame: &wgpu::BindGroup) {
        match &self.splatting {
            Splatting::Raster { pipeline, group } => {
                let mut pass = e.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("splat"),
                    color_attachments: &[crate::frame::cleared_target(&self.atlas_view)],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, scene, &[]);
                pass.set_bind_group(1, frame, &[]);
                pass.set_bind_group(2, group, &[]);
                pass.set_bind_group(3, &self.rsm.bind_group, &[]);
                pass.draw(0..6, 0..self.params.count);
            }
            Splatting::Tiles {
                rects,
                bins,
                tiles,
                groups: [rects_group, bins_group, tiles_group],
                sets,
                set_table,
                grid: [tiles_x, tiles_y, words],
            } => {
                // Without an RSM (no analytic light) no VPL carries light, and the RSM layers are fixed
                // for the technique's life: the atlas stays as created, zero, and nothing is dispatched.
                if self.rsm.texels() == 0 {
                    return;
                }
                let groups = |own| [scene, frame, own, &self.rsm.bind_group];
                compute::dispatch(
                    e,
                    "splat rects",
                    rects,
                    &groups(rects_group),
                    [self.params.count.div_ceil(64), 1, 1],
                );
                compute::dispatch(
                    e,
                    "splat tile sets",
                    bins,
                    &groups(bins_group),
                    [words.div_ceil(64), *tiles_x, *tiles_y],
                );
                linear_texture::copy_from_buffer(e, sets, set_table, sets.size());
                compute::dispatch(e, "splat tiles", tiles, &groups(tiles_group), [*tiles_x, *tiles_y, 1]);
            }
        }
    }
}

impl Technique for Splat {
    // The direct term reads the scene's lights, shadow maps and environment every frame; the RSMs
    // re-aim and render again when lights move (the environment does not bounce in RSM techniques).
    fn scene_changed(
        &mut self,
        ctx: &GpuContext,
        gpu_scene: &crate::gpu::GpuScene,
        change: crate::techniques::SceneChange,
    ) -> Result<bool, RenderError> {
        if self.rsm.scene_changed(ctx, gpu_scene, change) {
            // The VPL distribution follows the new flux.
            self.cdf_built = false;
        }
        Ok(true)
    }

    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        let ctx = fc.ctx;
        // A different stratification offset every frame (frame 0: the slice centres).
        self.params.jitter = if fc.sample_index() == 0 {
            0.5
        } else {
            let h =
                (fc.view.frame_counter ^ fc.frame.uniforms.seed.rotate_left(16)).wrapping_mul(0x9e37_79b9);
            (h >> 8) as f32 / (1u32 << 24) as f32
        };
        ctx.queue.write_buffer(&self.params_buffer, 0, bytemuck::bytes_of(&self.params));
        self.rsm.render(ctx, fc.gpu_scene, profiler)?;
        self.direct.render(fc, profiler)?;
        let (scene, frame) = (&fc.gpu_scene.bind_group, &fc.frame.bind_group);
        let groups = [scene, frame, &self.vpl_group, &self.rsm.bind_group];
        if !self.cdf_built {
            self.cdf_built = true;
            profiler.pass(ctx, "rsm flux cdf", |e| {
                compute::dispatch(e, "rsm cdf", &self.cdf_pipeline, &groups, [1, 1, 1])
            })?;
        }
        profiler.pass(ctx, "vpl selection", |e| {
            compute::dispatch(e, "vpls", &self.vpl_pipeline, &groups, [self.params.count.div_ceil(64), 1, 1])
        })?;
        if self.layout.is_interleaved() {
            profiler.pass(ctx, "split", |e| self.split.record(e, scene, frame))?;
        }
        profiler.pass(ctx, "splat", |e| self.record_splat(e, scene, frame))?;
        self.resolve.render(fc, profiler)
    }

    fn counters(&mut self, ctx: &GpuContext, _: &Measured) -> Result<BTreeMap<String, f64>, RenderError> {
        let mut c = BTreeMap::new();
        // Splat fragments shaded in the last frame (the atlas's alpha counts them) and the splat radius.
        let atlas =
            readback::read_texture(ctx, &self.atlas, self.atlas_format.block_copy_size(None).unwrap_or(16))?;
        let fragments: f64 = if self.atlas_format == wgpu::TextureFormat::Rgba32Float {
            bytemuck::cast_slice::<u8, f32>(&atlas).chunks_exact(4).map(|t| f64::from(t[3])).sum()
        } else {
            bytemuck::cast_slice::<u8, u16>(&atlas)
                .chunks_exact(4)
                .map(|t| f64::from(half::f16::from_bits(t[3]).to_f32()))
                .sum()
        };
        c.insert("splat_fragments".into(), fragments);
        let (aw, ah) = self.layout.size();
        c.insert("splat_fragments_per_pixel".into(), fragments / f64::from(aw * ah));
        let bytes = readback::read_buffer(
            ctx,
            &self.vpl_buffer,
            0,
            u64::from(self.params.count) * size_of::<GpuVpl>() as u64,
        )?;
        let vpls: &[GpuVpl] = bytemuck::cast_slice(&bytes);
        let mean_radius = vpls.iter().map(|v| f64::from(v.radius)).sum::<f64>() / vpls.len().max(1) as f64;
        c.insert("mean_splat_radius_m".into(), mean_radius);
        c.insert("rsm_texels".into(), f64::from(self.rsm.texels()));
        c.insert("rsm_layers".into(), self.rsm.views.len() as f64);
        c.insert("rsm_bytes".into(), f64::from(self.rsm.texels() * map::BYTES_PER_TEXEL));
        c.insert("vpls".into(), f64::from(self.params.count));
        c.insert(
            "vpls_per_subbuffer".into(),
            f64::from(self.params.count) / f64::from(self.layout.subsets()),
        );
        c.insert("sample_subsets".into(), f64::from(self.layout.subsets()));
        c.insert(
            "atlas_bytes_per_texel".into(),
            f64::from(self.atlas_format.block_copy_size(None).unwrap_or(0)),
        );
        Ok(c)
    }

    fn warnings(&self) -> Vec<String> {
        self.rsm.warnings.clone()
    }
}
