//! Non-linear motion blur (seed 003, article 1: "High Performance Non-linear Motion Blur", report
//! `../shared/research/003-distribution-effects-ddgi.md` §1) as a post-process of any technique.
//!
//! The shutter is open from t − shutter/2 to t + shutter/2 around the frame's time t. Every pixel's
//! surface point is followed to where it is at the opening and at the closing (its mesh's animation and
//! the camera's, evaluated exactly from the scene's animation: the paper's two extra position buffers,
//! one of which needs the next frame's pose); a quadratic Bézier through the three screen positions is
//! cut into `segments` lines and rasterised with additive blending (the colour of the pixel times a
//! Gaussian of the curve parameter, and the weight), depth-tested against the frame's visible surfaces;
//! a resolve divides, keeping each pixel's own radiance with the constant weight `background_weight`
//! (`motion_blur.wgsl`).
//!
//! What the paper states and this keeps: cost independent of the scene's triangles, curved motion of any
//! length, static occluders hiding the curves behind them, and the unblurred image staying visible
//! under the streaks (the background behind a moving object is unknown to a post-process).
//! `method=linear` is the baseline the paper measures against: a gather along one straight motion
//! vector per pixel (McGuire et al. 2012). The brute-force reference it is measured against is [`crate::renderer::Renderer::render_shutter_reference`].

#[cfg(test)]
mod tests;

use bytemuck::{Pod, Zeroable};
use glam::Mat4;
use wgpu::util::DeviceExt;

use crate::frame::{FrameResources, OUTPUT_FORMAT};
use crate::gpu::resources::{buffer_layout_entry, storage_texture_layout_entry, texture_layout_entry};
use crate::gpu::{BufferBuilder, GpuContext, GpuScene, Profiler, TextureBuilder};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::shaders::{self, Defines};
use crate::techniques::{RenderError, compute};

pub const SOURCE: &str = include_str!("motion_blur.wgsl");

/// The post-process's parameters (`rtgi render --motion-blur-set KEY=VALUE`). Defaults are the
/// paper's {w_b, Δ, σ} = {5, 11 points, 2}.
pub const MOTION_BLUR_PARAMS: [ParamSpec; 9] = [
    ParamSpec {
        name: "method",
        kind: ParamKind::Choice(&["curves", "linear"]),
        default: "curves",
        doc: "curves: the paper's scatter of quadratic curves; linear: the baseline it compares with, a gather \
              along one straight motion vector per pixel (McGuire et al. 2012: tile and neighbourhood maximum \
              velocities, depth-weighted taps)",
    },
    ParamSpec {
        name: "max_radius",
        // A tile's maximum is one invocation's loop over max_radius² pixels: lavapipe ends loops after
        // 65535 iterations (README), so 128² is the most that stays exact there.
        kind: ParamKind::Int { min: 1, max: 128 },
        default: "20",
        doc: "linear: the longest blur in pixels towards either end of the shutter, and the edge of its \
              velocity tiles",
    },
    ParamSpec {
        name: "samples",
        kind: ParamKind::Int { min: 1, max: 64 },
        default: "15",
        doc: "linear: taps along each pixel's neighbourhood velocity",
    },
    ParamSpec {
        name: "segments",
        kind: ParamKind::Int { min: 1, max: 64 },
        default: "10",
        doc: "lines each pixel's curve is cut into (the paper's Δ = 11 points)",
    },
    ParamSpec {
        name: "sigma",
        kind: ParamKind::Float { min: 0.01, max: 100.0 },
        default: "2",
        doc: "σ of the Gaussian weight over the curve parameter s in [0, 1], centred at the frame's time",
    },
    ParamSpec {
        name: "weights",
        kind: ParamKind::Choice(&["paper", "coverage"]),
        default: "paper",
        doc: "curves: paper: every fragment weighs the Gaussian alone, so a streak's opacity grows with the \
              number of curves crossing a pixel (the object's size in pixels) against w_b; coverage: each \
              curve's fragments share one unit of weight (the Gaussian over the curve's fragment count), the \
              fraction of the shutter the pixel's surface spends over each pixel, which does not depend on \
              the resolution (pair it with background_weight=1)",
    },
    ParamSpec {
        name: "background_weight",
        kind: ParamKind::Float { min: 0.001, max: 1e6 },
        default: "5",
        doc: "w_b, the weight of each pixel's own radiance against the curves' weights (> 0)",
    },
    ParamSpec {
        name: "min_motion",
        kind: ParamKind::Float { min: 0.0, max: 1e4 },
        default: "0.5",
        doc: "pixels whose surface moves less than this many pixels towards both ends of the shutter are \
              not scattered",
    },
    ParamSpec {
        name: "depth_tolerance",
        kind: ParamKind::Float { min: 0.0, max: 10.0 },
        default: "0.02",
        doc: "a curve is hidden where it passes behind the visible surface by more than this fraction of \
              the surface's view depth",
    },
];

/// How a frame is blurred: the shutter and the post-process's parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionBlurSettings {
    /// Scene seconds the shutter is open, centred on the frame's time.
    pub shutter: f32,
    pub params: ParamValues,
}

impl MotionBlurSettings {
    /// Validates `shutter` and `key=value` settings against [`MOTION_BLUR_PARAMS`].
    pub fn new(shutter: f32, settings: &[(String, String)]) -> Result<Self, String> {
        if !(shutter.is_finite() && shutter > 0.0) {
            return Err(format!("shutter {shutter} must be a positive, finite number of seconds"));
        }
        let params = ParamValues::from_settings("motion blur", &MOTION_BLUR_PARAMS, settings)?;
        Ok(MotionBlurSettings { shutter, params })
    }

    fn segments(&self) -> u32 {
        self.params.int("segments") as u32
    }

    fn defines(&self) -> Defines {
        let p = &self.params;
        Defines::new()
            .u32("SEGMENTS", self.segments())
            .u32("MAX_RADIUS", p.int("max_radius") as u32)
            .u32("SAMPLES", p.int("samples") as u32)
            .u32("COVERAGE", u32::from(p.choice("weights") == "coverage"))
    }
}

/// `MotionBlurUniforms` in `motion_blur.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MotionBlurUniforms {
    pub open_view_proj: [[f32; 4]; 4],
    pub close_view_proj: [[f32; 4]; 4],
    pub min_motion: f32,
    pub sigma: f32,
    pub background_weight: f32,
    pub depth_tolerance: f32,
}

/// Where things are when the shutter opens and closes, relative to the frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ShutterPose {
    pub open_view_proj: Mat4,
    pub close_view_proj: Mat4,
    /// Per mesh: the matrix from its world position in the frame to the opening's, and to the closing's.
    pub mesh_motion: Vec<[Mat4; 2]>,
}

/// The quadratic Bézier through `open`, `now` and `close` at s = 0, ½ and 1: its control points
/// (the CPU twin of `pixel_curve` in `motion_blur.wgsl`).
pub fn curve_control_points(open: [f32; 2], now: [f32; 2], close: [f32; 2]) -> [[f32; 2]; 3] {
    let b1 = std::array::from_fn(|i| 2.0 * now[i] - 0.5 * (open[i] + close[i]));
    [open, b1, close]
}

/// B(s) of control points `b` (the CPU twin of `curve_at`).
pub fn curve_at(b: &[[f32; 2]; 3], s: f32) -> [f32; 2] {
    let w = [(1.0 - s) * (1.0 - s), 2.0 * (1.0 - s) * s, s * s];
    std::array::from_fn(|i| w[0] * b[0][i] + w[1] * b[1][i] + w[2] * b[2][i])
}

/// The scatter of curves: moving pixels listed, their curves drawn, the sums resolved.
struct Curves {
    count_pipeline: wgpu::ComputePipeline,
    offset_pipeline: wgpu::ComputePipeline,
    list_pipeline: wgpu::ComputePipeline,
    list_group: wgpu::BindGroup,
    /// Per tile its moving pixels' count, then their first index; the list; the draw's arguments.
    tile_moving: wgpu::Buffer,
    moving_pixels: wgpu::Buffer,
    draw_args: wgpu::Buffer,
    draw_pipeline: wgpu::RenderPipeline,
    draw_group: wgpu::BindGroup,
    resolve_pipeline: wgpu::ComputePipeline,
    resolve_group: wgpu::BindGroup,
    accumulation: wgpu::Texture,
    accumulation_view: wgpu::TextureView,
}

/// The linear gather: velocities, tile maxima, taps.
struct Linear {
    velocity_pipeline: wgpu::ComputePipeline,
    velocity_group: wgpu::BindGroup,
    tile_max_pipeline: wgpu::ComputePipeline,
    neighbour_max_pipeline: wgpu::ComputePipeline,
    tiles_group: wgpu::BindGroup,
    gather_pipeline: wgpu::ComputePipeline,
    gather_group: wgpu::BindGroup,
    tiles: (u32, u32),
    velocity: wgpu::Texture,
    tile_max: wgpu::Buffer,
    neighbour_max: wgpu::Buffer,
}

enum Method {
    Curves(Curves),
    Linear(Linear),
}

/// What both methods bind: the uniforms, the meshes' motion, the radiance and the blurred image.
struct Shared<'a> {
    ctx: &'a GpuContext,
    gpu_scene: &'a GpuScene,
    frame: &'a FrameResources,
    uniform_buffer: &'a wgpu::Buffer,
    mesh_buffer: &'a wgpu::Buffer,
    radiance: wgpu::TextureView,
    blurred: wgpu::TextureView,
    defines: Defines,
}

impl Shared<'_> {
    fn compute(
        &self,
        entry: &str,
        layout: &wgpu::BindGroupLayout,
    ) -> Result<wgpu::ComputePipeline, RenderError> {
        let layouts = [&self.gpu_scene.bind_group_layout, &self.frame.bind_group_layout, layout];
        Ok(compute::pipeline(
            self.ctx,
            &format!("motion blur {entry}"),
            SOURCE,
            self.defines.clone(),
            entry,
            &layouts,
        )?)
    }

    fn group(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        entries: &[(u32, wgpu::BindingResource)],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = entries
            .iter()
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding: *binding, resource: resource.clone() })
            .collect();
        self.ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &entries,
        })
    }
}

const FLOAT: wgpu::TextureSampleType = wgpu::TextureSampleType::Float { filterable: false };
const D2: wgpu::TextureViewDimension = wgpu::TextureViewDimension::D2;

impl Curves {
    fn new(s: &Shared, width: u32, height: u32, segments: u32) -> Result<Self, RenderError> {
        let ctx = s.ctx;
        let vertices = u64::from(width) * u64::from(height) * 2 * u64::from(segments);
        u32::try_from(vertices).map_err(|_| {
            RenderError::InvalidSettings(format!(
                "motion blur: {width}x{height} pixels with {segments} segments need {vertices} vertices, more \
                 than a draw can hold (2^32 - 1): fewer segments or a smaller image"
            ))
        })?;
        // Blending rgba32float needs an optional feature; half floats hold the sums otherwise.
        let accumulation_format = if ctx.device.features().contains(wgpu::Features::FLOAT32_BLENDABLE) {
            wgpu::TextureFormat::Rgba32Float
        } else {
            wgpu::TextureFormat::Rgba16Float
        };
        let accumulation = TextureBuilder::d2("motion blur accumulation", width, height, accumulation_format)
            .render()
            .sampled()
            .build(ctx)?;
        let tiles = u64::from(width.div_ceil(compute::TILE)) * u64::from(height.div_ceil(compute::TILE));
        let tile_moving = BufferBuilder::new("motion blur tiles", tiles * 4).storage().build(ctx)?;
        let pixels = u64::from(width) * u64::from(height);
        let moving_pixels =
            BufferBuilder::new("motion blur moving pixels", pixels * 4).storage().copy().build(ctx)?;
        let draw_args = BufferBuilder::new("motion blur draw", 16).storage().indirect().build(ctx)?;

        let draw_layout = compute::layout(
            ctx,
            "motion blur curves",
            &[
                buffer_layout_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT, wgpu::BufferBindingType::Uniform),
                buffer_layout_entry(
                    1,
                    wgpu::ShaderStages::VERTEX,
                    wgpu::BufferBindingType::Storage { read_only: true },
                ),
                wgpu::BindGroupLayoutEntry {
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ..texture_layout_entry(2, FLOAT, D2)
                },
                buffer_layout_entry(
                    8,
                    wgpu::ShaderStages::VERTEX,
                    wgpu::BufferBindingType::Storage { read_only: true },
                ),
            ],
        );
        let list_layout = compute::layout(
            ctx,
            "motion blur moving pixels",
            &[
                compute::uniform_entry(0),
                compute::storage_buffer_entry(1, true),
                compute::storage_buffer_entry(5, false),
                compute::storage_buffer_entry(6, false),
                compute::storage_buffer_entry(7, false),
            ],
        );
        let resolve_layout = compute::layout(
            ctx,
            "motion blur resolve",
            &[
                compute::uniform_entry(0),
                texture_layout_entry(2, FLOAT, D2),
                texture_layout_entry(3, FLOAT, D2),
                storage_texture_layout_entry(4, OUTPUT_FORMAT, wgpu::StorageTextureAccess::WriteOnly, D2),
            ],
        );
        let accumulation_view = accumulation.create_view(&Default::default());
        let uniforms = s.uniform_buffer.as_entire_binding();
        let draw_group = s.group(
            "motion blur curves",
            &draw_layout,
            &[
                (0, uniforms.clone()),
                (1, s.mesh_buffer.as_entire_binding()),
                (2, wgpu::BindingResource::TextureView(&s.radiance)),
                (8, moving_pixels.as_entire_binding()),
            ],
        );
        let list_group = s.group(
            "motion blur moving pixels",
            &list_layout,
            &[
                (0, uniforms.clone()),
                (1, s.mesh_buffer.as_entire_binding()),
                (5, tile_moving.as_entire_binding()),
                (6, moving_pixels.as_entire_binding()),
                (7, draw_args.as_entire_binding()),
            ],
        );
        let resolve_group = s.group(
            "motion blur resolve",
            &resolve_layout,
            &[
                (0, uniforms),
                (2, wgpu::BindingResource::TextureView(&s.radiance)),
                (3, wgpu::BindingResource::TextureView(&accumulation_view)),
                (4, wgpu::BindingResource::TextureView(&s.blurred)),
            ],
        );
        let module = shaders::create_module(
            ctx,
            "motion blur curves",
            SOURCE,
            &s.defines.clone().u32("TILE", compute::TILE),
        )?;
        let pipeline_layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("motion blur curves"),
            bind_group_layouts: &[
                Some(&s.gpu_scene.bind_group_layout),
                Some(&s.frame.bind_group_layout),
                Some(&draw_layout),
            ],
            immediate_size: 0,
        });
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let draw_pipeline = ctx.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("motion blur curves"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_curve"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::LineList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_curve"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: accumulation_format,
                    blend: Some(wgpu::BlendState { color: add, alpha: add }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        Ok(Curves {
            count_pipeline: s.compute("count_moving", &list_layout)?,
            offset_pipeline: s.compute("offset_tiles", &list_layout)?,
            list_pipeline: s.compute("list_moving", &list_layout)?,
            list_group,
            tile_moving,
            moving_pixels,
            draw_args,
            draw_pipeline,
            draw_group,
            resolve_pipeline: s.compute("resolve", &resolve_layout)?,
            resolve_group,
            accumulation,
            accumulation_view,
        })
    }

    fn bytes(&self) -> u64 {
        let (w, h) = (self.accumulation.width(), self.accumulation.height());
        let texel = match self.accumulation.format() {
            wgpu::TextureFormat::Rgba32Float => 16,
            _ => 8,
        };
        u64::from(w) * u64::from(h) * texel
            + self.moving_pixels.size()
            + self.tile_moving.size()
            + self.draw_args.size()
    }

    fn record(
        &self,
        ctx: &GpuContext,
        groups: [&wgpu::BindGroup; 2],
        (width, height): (u32, u32),
        profiler: &mut Profiler,
    ) -> Result<(), RenderError> {
        let [scene, frame] = groups;
        let list = [scene, frame, &self.list_group];
        profiler.pass(ctx, "motion blur moving pixels", |encoder| {
            let label = "motion blur moving pixels";
            compute::dispatch_pixels(encoder, label, &self.count_pipeline, &list, width, height);
            compute::dispatch(encoder, label, &self.offset_pipeline, &list, [1, 1, 1]);
            compute::dispatch_pixels(encoder, label, &self.list_pipeline, &list, width, height);
        })?;
        profiler.pass(ctx, "motion blur curves", |encoder| {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("motion blur curves"),
                color_attachments: &[crate::frame::cleared_target(&self.accumulation_view)],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.draw_pipeline);
            pass.set_bind_group(0, scene, &[]);
            pass.set_bind_group(1, frame, &[]);
            pass.set_bind_group(2, &self.draw_group, &[]);
            pass.draw_indirect(&self.draw_args, 0);
        })?;
        profiler.pass(ctx, "motion blur resolve", |encoder| {
            compute::dispatch_pixels(
                encoder,
                "motion blur resolve",
                &self.resolve_pipeline,
                &[scene, frame, &self.resolve_group],
                width,
                height,
            );
        })?;
        Ok(())
    }
}

impl Linear {
    fn new(s: &Shared, width: u32, height: u32, max_radius: u32) -> Result<Self, RenderError> {
        let ctx = s.ctx;
        let velocity =
            TextureBuilder::d2("motion blur velocity", width, height, wgpu::TextureFormat::Rgba32Float)
                .storage()
                .sampled()
                .build(ctx)?;
        let tiles = (width.div_ceil(max_radius), height.div_ceil(max_radius));
        let tile_bytes = u64::from(tiles.0) * u64::from(tiles.1) * 8;
        let tile_max = BufferBuilder::new("motion blur tile max", tile_bytes).storage().build(ctx)?;
        let neighbour_max =
            BufferBuilder::new("motion blur neighbour max", tile_bytes).storage().build(ctx)?;
        let velocity_view = velocity.create_view(&Default::default());
        let velocity_layout = compute::layout(
            ctx,
            "motion blur velocity",
            &[
                compute::uniform_entry(0),
                compute::storage_buffer_entry(1, true),
                storage_texture_layout_entry(
                    10,
                    wgpu::TextureFormat::Rgba32Float,
                    wgpu::StorageTextureAccess::WriteOnly,
                    D2,
                ),
            ],
        );
        let tiles_layout = compute::layout(
            ctx,
            "motion blur tiles",
            &[
                compute::uniform_entry(0),
                texture_layout_entry(11, FLOAT, D2),
                compute::storage_buffer_entry(12, false),
                compute::storage_buffer_entry(13, false),
            ],
        );
        let gather_layout = compute::layout(
            ctx,
            "motion blur gather",
            &[
                compute::uniform_entry(0),
                texture_layout_entry(2, FLOAT, D2),
                storage_texture_layout_entry(4, OUTPUT_FORMAT, wgpu::StorageTextureAccess::WriteOnly, D2),
                texture_layout_entry(11, FLOAT, D2),
                compute::storage_buffer_entry(13, false),
            ],
        );
        let uniforms = s.uniform_buffer.as_entire_binding();
        let velocity_group = s.group(
            "motion blur velocity",
            &velocity_layout,
            &[
                (0, uniforms.clone()),
                (1, s.mesh_buffer.as_entire_binding()),
                (10, wgpu::BindingResource::TextureView(&velocity_view)),
            ],
        );
        let tiles_group = s.group(
            "motion blur tiles",
            &tiles_layout,
            &[
                (0, uniforms.clone()),
                (11, wgpu::BindingResource::TextureView(&velocity_view)),
                (12, tile_max.as_entire_binding()),
                (13, neighbour_max.as_entire_binding()),
            ],
        );
        let gather_group = s.group(
            "motion blur gather",
            &gather_layout,
            &[
                (0, uniforms),
                (2, wgpu::BindingResource::TextureView(&s.radiance)),
                (4, wgpu::BindingResource::TextureView(&s.blurred)),
                (11, wgpu::BindingResource::TextureView(&velocity_view)),
                (13, neighbour_max.as_entire_binding()),
            ],
        );
        Ok(Linear {
            velocity_pipeline: s.compute("linear_velocity", &velocity_layout)?,
            velocity_group,
            tile_max_pipeline: s.compute("linear_tile_max", &tiles_layout)?,
            neighbour_max_pipeline: s.compute("linear_neighbour_max", &tiles_layout)?,
            tiles_group,
            gather_pipeline: s.compute("linear_gather", &gather_layout)?,
            gather_group,
            tiles,
            velocity,
            tile_max,
            neighbour_max,
        })
    }

    fn bytes(&self) -> u64 {
        u64::from(self.velocity.width()) * u64::from(self.velocity.height()) * 16
            + self.tile_max.size()
            + self.neighbour_max.size()
    }

    fn record(
        &self,
        ctx: &GpuContext,
        groups: [&wgpu::BindGroup; 2],
        (width, height): (u32, u32),
        profiler: &mut Profiler,
    ) -> Result<(), RenderError> {
        let [scene, frame] = groups;
        profiler.pass(ctx, "motion blur velocity", |encoder| {
            compute::dispatch_pixels(
                encoder,
                "motion blur velocity",
                &self.velocity_pipeline,
                &[scene, frame, &self.velocity_group],
                width,
                height,
            );
        })?;
        profiler.pass(ctx, "motion blur tiles", |encoder| {
            let tiles = [scene, frame, &self.tiles_group];
            let (tx, ty) = self.tiles;
            compute::dispatch_pixels(encoder, "motion blur tiles", &self.tile_max_pipeline, &tiles, tx, ty);
            compute::dispatch_pixels(
                encoder,
                "motion blur tiles",
                &self.neighbour_max_pipeline,
                &tiles,
                tx,
                ty,
            );
        })?;
        profiler.pass(ctx, "motion blur gather", |encoder| {
            compute::dispatch_pixels(
                encoder,
                "motion blur gather",
                &self.gather_pipeline,
                &[scene, frame, &self.gather_group],
                width,
                height,
            );
        })?;
        Ok(())
    }
}

/// The post-process for one output size.
pub struct MotionBlur {
    settings: MotionBlurSettings,
    width: u32,
    height: u32,
    uniform_buffer: wgpu::Buffer,
    mesh_buffer: wgpu::Buffer,
    mesh_written: Vec<[Mat4; 2]>,
    method: Method,
    blurred: wgpu::Texture,
}

impl MotionBlur {
    /// Blurs `radiance` (the technique's output, `frame`'s size).
    pub fn new(
        ctx: &GpuContext,
        gpu_scene: &GpuScene,
        frame: &FrameResources,
        radiance: &wgpu::Texture,
        settings: MotionBlurSettings,
    ) -> Result<Self, RenderError> {
        let (width, height) = (frame.width, frame.height);
        let blurred = TextureBuilder::d2("motion blurred radiance", width, height, OUTPUT_FORMAT)
            .storage()
            .sampled()
            .copy()
            .build(ctx)?;
        let uniform_buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("motion blur uniforms"),
            size: size_of::<MotionBlurUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let identity = vec![[Mat4::IDENTITY; 2]; gpu_scene.mesh_ranges.len().max(1)];
        let mesh_buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("motion blur mesh motion"),
            contents: bytemuck::cast_slice(&identity),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let shared = Shared {
            ctx,
            gpu_scene,
            frame,
            uniform_buffer: &uniform_buffer,
            mesh_buffer: &mesh_buffer,
            radiance: view(radiance),
            blurred: view(&blurred),
            defines: settings.defines(),
        };
        let method = match settings.params.choice("method") {
            "linear" => {
                Method::Linear(Linear::new(&shared, width, height, settings.params.int("max_radius") as u32)?)
            }
            _ => Method::Curves(Curves::new(&shared, width, height, settings.segments())?),
        };
        Ok(MotionBlur {
            settings,
            width,
            height,
            uniform_buffer,
            mesh_buffer,
            mesh_written: identity,
            method,
            blurred,
        })
    }

    pub fn settings(&self) -> &MotionBlurSettings {
        &self.settings
    }

    /// The blurred radiance (rgba32float), written by [`Self::record`].
    pub fn blurred(&self) -> &wgpu::Texture {
        &self.blurred
    }

    /// Bytes of the blurred image and the method's own buffers and textures.
    pub fn bytes(&self) -> u64 {
        let blurred = u64::from(self.width) * u64::from(self.height) * 16;
        blurred
            + match &self.method {
                Method::Curves(c) => c.bytes(),
                Method::Linear(l) => l.bytes(),
            }
    }

    /// Records the method's passes (curves: "motion blur moving pixels", "motion blur curves", "motion
    /// blur resolve"; linear: "motion blur velocity", "motion blur tiles", "motion blur gather") for the
    /// frame whose G-buffer is in `frame` and whose technique wrote the radiance this was created with.
    pub fn record(
        &mut self,
        ctx: &GpuContext,
        gpu_scene: &GpuScene,
        frame: &FrameResources,
        pose: &ShutterPose,
        profiler: &mut Profiler,
    ) -> Result<(), RenderError> {
        let p = &self.settings.params;
        let uniforms = MotionBlurUniforms {
            open_view_proj: pose.open_view_proj.to_cols_array_2d(),
            close_view_proj: pose.close_view_proj.to_cols_array_2d(),
            min_motion: p.float("min_motion") as f32,
            sigma: p.float("sigma") as f32,
            background_weight: p.float("background_weight") as f32,
            depth_tolerance: p.float("depth_tolerance") as f32,
        };
        ctx.queue.write_buffer(&self.uniform_buffer, 0, bytemuck::bytes_of(&uniforms));
        // A static scene writes the meshes' matrices once.
        if !pose.mesh_motion.is_empty() && pose.mesh_motion != self.mesh_written {
            if pose.mesh_motion.len() != self.mesh_written.len() {
                return Err(RenderError::InvalidSettings(format!(
                    "motion blur: {} mesh motions for {} meshes",
                    pose.mesh_motion.len(),
                    self.mesh_written.len()
                )));
            }
            ctx.queue.write_buffer(&self.mesh_buffer, 0, bytemuck::cast_slice(&pose.mesh_motion));
            self.mesh_written.clone_from(&pose.mesh_motion);
        }
        let groups = [&gpu_scene.bind_group, &frame.bind_group];
        let size = (self.width, self.height);
        match &self.method {
            Method::Curves(c) => c.record(ctx, groups, size, profiler),
            Method::Linear(l) => l.record(ctx, groups, size, profiler),
        }
    }
}
