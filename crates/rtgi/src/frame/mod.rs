//! The frame inputs every technique shares: camera uniforms, the deferred G-buffer and shadow maps,
//! behind bind group 1 (`common/frame.wgsl`).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use crate::gpu::resources::{buffer_layout_entry, storage_texture_layout_entry};
use crate::gpu::scene::{GpuLight, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT, shadow_layer_count};
use crate::gpu::{GpuContext, GpuError, GpuScene, Profiler, TextureBuilder};
use crate::params::{ParamKind, ParamSpec, ParamValues};
use crate::scene::{Aabb, Camera, Scene};
use crate::shaders::{self, Defines};

/// The per-frame uniforms of bind group 1 (`FrameUniforms` in `common/frame.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    pub view_proj: [[f32; 4]; 4],
    pub inv_view_proj: [[f32; 4]; 4],
    /// The previous frame's view-projection (equal to `view_proj` on the first frame and after a cut).
    pub prev_view_proj: [[f32; 4]; 4],
    pub camera_position: [f32; 3],
    /// Frames rendered since the renderer was created: the dimension of per-frame random numbers.
    pub frame_counter: u32,
    pub size: [u32; 2],
    pub seed: u32,
    pub shadow_filter_radius: u32,
    pub shadow_depth_bias: f32,
    pub shadow_normal_offset: f32,
    pub shadow_map_size: f32,
    /// Frames accumulated into the current image since the view or the scene last changed: progressive
    /// techniques average over it and restart at 0.
    pub sample_index: u32,
    /// Sub-pixel position sampled this frame relative to pixel centres, in pixels (y down; 0 unless
    /// jitter is on, see `renderer::Jitter`).
    pub jitter: [f32; 2],
    /// Scene time in seconds and the time since the previous frame.
    pub time: f32,
    pub delta_time: f32,
    /// 1 when the previous frame's history (screen-space buffers, reprojection) may be reused; 0 after
    /// a camera cut, a parameter change, a resize or on the first frame.
    pub history_valid: u32,
    pub _pad: [u32; 3],
}

/// What a frame looks at and when: the per-frame view data every technique receives
/// ([`crate::techniques::FrameContext::view`]) and the renderer writes into [`FrameUniforms`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameView {
    pub camera: Camera,
    pub view_proj: Mat4,
    pub prev_view_proj: Mat4,
    pub time: f32,
    pub delta_time: f32,
    pub jitter: glam::Vec2,
    pub frame_counter: u32,
    pub sample_index: u32,
    pub history_valid: bool,
}

impl FrameView {
    fn write_into(&self, u: &mut FrameUniforms) {
        u.view_proj = self.view_proj.to_cols_array_2d();
        u.inv_view_proj = self.view_proj.inverse().to_cols_array_2d();
        u.prev_view_proj = self.prev_view_proj.to_cols_array_2d();
        u.camera_position = self.camera.position.into();
        u.frame_counter = self.frame_counter;
        u.sample_index = self.sample_index;
        u.jitter = self.jitter.into();
        u.time = self.time;
        u.delta_time = self.delta_time;
        u.history_valid = u32::from(self.history_valid);
    }

    /// The first frame of a still: frame 0, sample 0, no history.
    pub fn still(camera: Camera, width: u32, height: u32) -> Self {
        let view_proj = camera.view_projection(width as f32 / height as f32);
        FrameView {
            camera,
            view_proj,
            prev_view_proj: view_proj,
            time: 0.0,
            delta_time: 0.0,
            jitter: glam::Vec2::ZERO,
            frame_counter: 0,
            sample_index: 0,
            history_valid: false,
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ShadowView {
    pub view_proj: [[f32; 4]; 4],
    pub params: [f32; 4],
}

/// Shadow-map parameters, shared by every technique that uses shadow maps.
pub const SHADOW_PARAMS: [ParamSpec; 4] = [
    ParamSpec {
        name: "shadow_map_size",
        kind: ParamKind::Int { min: 64, max: 8192 },
        default: "1024",
        doc: "edge of each shadow-map layer in texels (point lights use six layers)",
    },
    ParamSpec {
        name: "shadow_filter",
        kind: ParamKind::Int { min: 0, max: 4 },
        default: "1",
        doc: "PCF radius r: (2r+1)² bilinear comparison taps",
    },
    ParamSpec {
        name: "shadow_bias",
        kind: ParamKind::Float { min: 0.0, max: 0.1 },
        default: "0.0001",
        doc: "constant depth bias in NDC depth units",
    },
    ParamSpec {
        name: "shadow_normal_offset",
        kind: ParamKind::Float { min: 0.0, max: 16.0 },
        default: "1.5",
        doc: "offset of the lookup point along the geometric normal, in shadow-map texels",
    },
];

/// Technique parameters that feed only [`FrameUniforms`] (the random seed and the shadow filter, bias
/// and offset): changing them between frames rebuilds nothing.
pub const FRAME_UNIFORM_PARAMS: [&str; 4] =
    ["seed", SHADOW_PARAMS[1].name, SHADOW_PARAMS[2].name, SHADOW_PARAMS[3].name];

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowSettings {
    pub size: u32,
    pub filter_radius: u32,
    pub depth_bias: f32,
    pub normal_offset: f32,
}

impl ShadowSettings {
    /// The settings when the technique declares [`SHADOW_PARAMS`]; `None` means no shadow maps.
    pub fn from_params(params: &ParamValues) -> Option<Self> {
        params.get("shadow_map_size")?;
        Some(ShadowSettings {
            size: params.int("shadow_map_size") as u32,
            filter_radius: params.int("shadow_filter") as u32,
            depth_bias: params.float("shadow_bias") as f32,
            normal_offset: params.float("shadow_normal_offset") as f32,
        })
    }
}

/// How the G-buffer is made: both write the same texels (`common/gbuffer.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrimaryVisibility {
    /// Rasterise the scene into the seven targets (one draw per mesh).
    Raster,
    /// Cast one ray per pixel through the BVH in a compute pass and store the targets.
    Trace,
}

impl PrimaryVisibility {
    const ALL: [PrimaryVisibility; 2] = [PrimaryVisibility::Raster, PrimaryVisibility::Trace];

    /// The value of [`PRIMARY_PARAM`] that asks for it.
    pub fn name(self) -> &'static str {
        match self {
            PrimaryVisibility::Raster => "raster",
            PrimaryVisibility::Trace => "trace",
        }
    }
}

/// The primary-visibility parameter, taken by every technique that renders a G-buffer.
pub const PRIMARY_PARAM: ParamSpec = ParamSpec {
    name: "primary",
    kind: ParamKind::Choice(&["auto", "raster", "trace"]),
    default: "auto",
    doc: "how the G-buffer is made: rasterised, ray-cast through the BVH in compute, or auto (the faster \
          on this kind of adapter, see docs/measurements/primary-*.md)",
};

/// What the frame resources are built with, from a technique's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameSettings {
    /// `None`: no shadow maps.
    pub shadows: Option<ShadowSettings>,
    /// `None`: auto, resolved for the adapter by [`FrameResources::new`].
    pub primary: Option<PrimaryVisibility>,
}

impl FrameSettings {
    pub fn from_params(params: &ParamValues) -> Self {
        // Absent (a technique without a G-buffer) or `auto`: None.
        let primary = match params.get(PRIMARY_PARAM.name) {
            Some(crate::params::ParamValue::Choice(c)) => {
                PrimaryVisibility::ALL.into_iter().find(|p| p.name() == c)
            }
            _ => None,
        };
        FrameSettings { shadows: ShadowSettings::from_params(params), primary }
    }

    /// No shadow maps, automatic primary visibility.
    pub fn plain() -> Self {
        FrameSettings { shadows: None, primary: None }
    }
}

pub const ALBEDO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const MATERIAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Uint;
pub const EMISSION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DISTANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// Screen-space motion in pixels, from the pixel to where its surface point was in the previous frame.
/// 32-bit floats: half floats would be coarser than half a pixel beyond 1024 pixels of motion.
pub const MOTION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
/// The mesh (instance) index + 1 of the visible surface; 0 where the primary ray left the scene.
pub const INSTANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The radiance output of every technique.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// Bytes per pixel of the G-buffer's colour targets (the raster pass adds a 4-byte depth buffer).
pub const GBUFFER_BYTES_PER_PIXEL: u32 = 8 + 8 + 8 + 8 + 4 + 8 + 4;

pub(crate) const SHADOW_VIEW_STRIDE: u64 = 256;

pub struct GBuffer {
    pub albedo: wgpu::Texture,
    pub normal: wgpu::Texture,
    pub material: wgpu::Texture,
    pub emission: wgpu::Texture,
    pub distance: wgpu::Texture,
    pub motion: wgpu::Texture,
    pub instance: wgpu::Texture,
}

impl GBuffer {
    /// The colour targets in `GBufferOut` order.
    fn targets(&self) -> [&wgpu::Texture; 7] {
        [
            &self.albedo,
            &self.normal,
            &self.material,
            &self.emission,
            &self.distance,
            &self.motion,
            &self.instance,
        ]
    }
}

/// Camera, G-buffer and shadow maps for one resolution and one set of shadow settings.
pub struct FrameResources {
    pub width: u32,
    pub height: u32,
    pub uniforms: FrameUniforms,
    /// The view of the frame being rendered (the last one set).
    pub view: FrameView,
    pub uniform_buffer: wgpu::Buffer,
    pub gbuffer: GBuffer,
    pub shadow_layers: u32,
    pub shadow_views: Vec<ShadowView>,
    pub shadow_settings: Option<ShadowSettings>,
    pub bind_group_layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    mesh_motion: wgpu::Buffer,
    /// What `mesh_motion` holds, so a static scene writes it once, not every frame.
    mesh_motion_written: Vec<Mat4>,
    /// How the G-buffer is made (resolved from `requested_primary`).
    pub primary: PrimaryVisibility,
    /// The setting it was resolved from (`None`: auto).
    pub requested_primary: Option<PrimaryVisibility>,
    primary_pass: PrimaryPass,
    shadow_maps: wgpu::Texture,
    shadow_view_buffer: wgpu::Buffer,
    shadow_slots: ViewSlots,
    shadow_pipeline: Option<wgpu::RenderPipeline>,
    /// The [`GpuScene::lights_version`] and geometry the shadow maps were rendered for.
    shadows_rendered: Option<(u64, u64)>,
}

/// A G-buffer target: rendered (or stored by the ray-cast pass), read by techniques and read back for
/// AOVs.
fn target(
    ctx: &GpuContext,
    label: &str,
    (w, h): (u32, u32),
    format: wgpu::TextureFormat,
    primary: PrimaryVisibility,
) -> Result<wgpu::Texture, GpuError> {
    let builder = TextureBuilder::d2(label, w, h, format).sampled().copy();
    match primary {
        PrimaryVisibility::Raster => builder.render(),
        PrimaryVisibility::Trace => builder.storage(),
    }
    .build(ctx)
}

/// The G-buffer's colour targets, in `GBufferOut` / binding order of the two G-buffer passes.
const GBUFFER_TARGET_FORMATS: [wgpu::TextureFormat; 7] = [
    ALBEDO_FORMAT,
    NORMAL_FORMAT,
    MATERIAL_FORMAT,
    EMISSION_FORMAT,
    DISTANCE_FORMAT,
    MOTION_FORMAT,
    INSTANCE_FORMAT,
];

/// Why the ray-cast G-buffer cannot run on this device (`None`: it can).
fn trace_unsupported(ctx: &GpuContext) -> Option<String> {
    let storage_textures = ctx.limits().max_storage_textures_per_shader_stage;
    if storage_textures < GBUFFER_TARGET_FORMATS.len() as u32 {
        return Some(format!(
            "max_storage_textures_per_shader_stage is {storage_textures}, the ray-cast G-buffer stores {}",
            GBUFFER_TARGET_FORMATS.len()
        ));
    }
    let lacking: Vec<String> = GBUFFER_TARGET_FORMATS
        .iter()
        .filter(|&&f| {
            !crate::gpu::context::format_features_of(&ctx.adapter, f)
                .allowed_usages
                .contains(wgpu::TextureUsages::STORAGE_BINDING)
        })
        .map(|f| format!("{f:?}"))
        .collect();
    (!lacking.is_empty()).then(|| format!("no storage use of {}", lacking.join(", ")))
}

/// `primary=auto`: the faster G-buffer pass on this kind of adapter, where it can run.
fn automatic_primary(ctx: &GpuContext) -> PrimaryVisibility {
    if trace_unsupported(ctx).is_some() {
        return PrimaryVisibility::Raster;
    }
    // docs/measurements/primary-lavapipe.md: llvmpipe rasterises the seven targets 1.3-4.9x faster than
    // it casts the rays, except the 1.4 M-triangle atrium at 256x256 (there the rays win by 2.7x). On
    // GPUs, rtgi's raster G-buffer cost 2.5-7 ms at 1080p on an H100 (research/platform.md), several
    // times what a primary ray per pixel costs at the BVH's measured rates there.
    if ctx.adapter.get_info().device_type == wgpu::DeviceType::Cpu {
        PrimaryVisibility::Raster
    } else {
        PrimaryVisibility::Trace
    }
}

/// How the G-buffer is drawn: the raster pipeline with its depth buffer and target views, or the
/// ray-cast compute pipeline with the targets bound as storage.
enum PrimaryPass {
    Raster {
        pipeline: wgpu::RenderPipeline,
        bind_group: wgpu::BindGroup,
        targets: Vec<wgpu::TextureView>,
        depth: wgpu::TextureView,
    },
    Trace {
        pipeline: wgpu::ComputePipeline,
        bind_group: wgpu::BindGroup,
    },
}

fn any_perpendicular(d: Vec3) -> Vec3 {
    if d.y.abs() < 0.99 { Vec3::Y } else { Vec3::Z }
}

/// The shadow views of every light, at the layers the lights carry (point lights take six), framing
/// `bounds` (the scene seen from the light).
pub fn shadow_views(lights: &[GpuLight], bounds: Aabb, size: u32) -> Vec<ShadowView> {
    let center = bounds.center();
    let radius = bounds.bounding_radius();
    let mut views = Vec::new();
    let perspective = |pos: Vec3, dir: Vec3, fov: f32| {
        // Near and far enclose the scene seen from the light.
        let far = (pos - center).length() + radius;
        let near = (far * 1e-4).max(1e-3);
        let view = glam::camera::rh::view::look_to_mat4(pos, dir, any_perpendicular(dir));
        let proj = glam::camera::rh::proj::directx::perspective(fov, 1.0, near, far);
        ShadowView {
            view_proj: (proj * view).to_cols_array_2d(),
            params: [2.0 * (fov * 0.5).tan() / size as f32, 0.0, near, far],
        }
    };
    for light in lights {
        debug_assert_eq!(
            light.shadow_layer,
            if shadow_layer_count(light.kind) > 0 { views.len() as i32 } else { -1 }
        );
        let pos = Vec3::from(light.position);
        let dir = Vec3::from(light.direction);
        match light.kind {
            LIGHT_SPOT => {
                // A little beyond the outer cone so PCF at the cone's edge stays inside the map.
                let fov = (2.0 * light.cos_outer.clamp(-1.0, 1.0).acos() + 0.05).min(3.0);
                views.push(perspective(pos, dir, fov));
            }
            LIGHT_POINT => {
                let faces = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
                for f in faces {
                    views.push(perspective(pos, f, std::f32::consts::FRAC_PI_2));
                }
            }
            LIGHT_DIRECTIONAL => {
                let eye = center - dir * (2.0 * radius);
                let view = glam::camera::rh::view::look_to_mat4(eye, dir, any_perpendicular(dir));
                let proj = glam::camera::rh::proj::directx::orthographic(
                    -radius,
                    radius,
                    -radius,
                    radius,
                    0.0,
                    4.0 * radius,
                );
                views.push(ShadowView {
                    view_proj: (proj * view).to_cols_array_2d(),
                    params: [2.0 * radius / size as f32, 1.0, 0.0, 4.0 * radius],
                });
            }
            _ => {}
        }
    }
    views
}

fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    // Vertex shaders too: splats place their quads with the camera.
    let vis = wgpu::ShaderStages::COMPUTE | wgpu::ShaderStages::VERTEX_FRAGMENT;
    let tex = |binding, sample_type| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: vis,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    };
    let float = wgpu::TextureSampleType::Float { filterable: false };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("frame"),
        entries: &[
            buffer_layout_entry(0, vis, wgpu::BufferBindingType::Uniform),
            tex(1, float),
            tex(2, float),
            tex(3, wgpu::TextureSampleType::Uint),
            tex(4, float),
            tex(5, float),
            tex(9, float),
            tex(10, wgpu::TextureSampleType::Uint),
            wgpu::BindGroupLayoutEntry {
                binding: 6,
                visibility: vis,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Depth,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 7,
                visibility: vis,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                count: None,
            },
            buffer_layout_entry(8, vis, wgpu::BufferBindingType::Storage { read_only: true }),
        ],
    })
}

pub(crate) fn uniform_layout(device: &wgpu::Device, dynamic: bool) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("pass uniforms"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: dynamic,
                min_binding_size: None,
            },
            count: None,
        }],
    })
}

/// A pipeline that rasterises the whole scene (one indexed draw of the GPU scene's vertex buffer) with
/// a less-than depth test and no culling (rtgi shades both sides of every surface).
/// A colour attachment cleared to transparent black and stored.
pub(crate) fn cleared_target(view: &wgpu::TextureView) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            store: wgpu::StoreOp::Store,
        },
    })
}

/// A 2D view of one layer of an array texture (a render target of a per-view pass).
pub(crate) fn layer_view(texture: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2),
        base_array_layer: layer,
        array_layer_count: Some(1),
        ..Default::default()
    })
}

/// Per-view uniforms, one per [`SHADOW_VIEW_STRIDE`]-byte slot of a uniform buffer, bound (with
/// `layout` from [`uniform_layout`]`(device, true)`) for a pass per view selected by the dynamic offset
/// `index * SHADOW_VIEW_STRIDE`.
pub(crate) struct ViewSlots {
    buffer: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
}

fn slot_bytes<T: bytemuck::Pod>(views: &[T]) -> Vec<u8> {
    let stride = SHADOW_VIEW_STRIDE as usize;
    let mut slots = vec![0u8; stride * views.len().max(1)];
    for (i, v) in views.iter().enumerate() {
        slots[i * stride..i * stride + size_of::<T>()].copy_from_slice(bytemuck::bytes_of(v));
    }
    slots
}

impl ViewSlots {
    pub(crate) fn new<T: bytemuck::Pod>(
        device: &wgpu::Device,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        views: &[T],
    ) -> Self {
        let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &slot_bytes(views),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(size_of::<T>() as u64),
                }),
            }],
        });
        ViewSlots { buffer, bind_group }
    }

    /// Rewrites the views in place (as many as at creation).
    pub(crate) fn write<T: bytemuck::Pod>(&self, ctx: &GpuContext, views: &[T]) {
        ctx.queue.write_buffer(&self.buffer, 0, &slot_bytes(views));
    }
}

pub(crate) fn scene_raster_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    targets: &[Option<wgpu::ColorTargetState>],
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(GpuScene::vertex_layout())],
        },
        primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// How [`draw_scene`] draws the scene's meshes.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Draws {
    /// One indexed draw of every triangle.
    One,
    /// One draw per mesh with `instance_index` = the mesh's index (for per-mesh data in the shader).
    PerMesh,
}

/// Records a draw of the whole scene into a depth (and optional colour) pass.
pub(crate) fn draw_scene(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    colors: &[Option<wgpu::RenderPassColorAttachment>],
    depth: &wgpu::TextureView,
    pipeline: &wgpu::RenderPipeline,
    (scene, draws): (&GpuScene, Draws),
    (group1, group1_offsets): (&wgpu::BindGroup, &[u32]),
) {
    let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: colors,
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, &scene.bind_group, &[]);
    pass.set_bind_group(1, group1, group1_offsets);
    pass.set_vertex_buffer(0, scene.vertex_buffer.slice(..));
    pass.set_index_buffer(scene.index_buffer.slice(..), wgpu::IndexFormat::Uint32);
    match draws {
        Draws::One => pass.draw_indexed(0..scene.index_count, 0, 0..1),
        Draws::PerMesh => {
            for (mesh, range) in scene.mesh_ranges.iter().enumerate().filter(|(_, r)| !r.is_empty()) {
                pass.draw_indexed(range.clone(), 0, mesh as u32..mesh as u32 + 1);
            }
        }
    }
}

/// Workgroup edge of screen-space compute passes (passed to WGSL as `TILE`): the ray-cast G-buffer and
/// the techniques' passes (`techniques::compute`).
pub const TILE: u32 = 8;

fn shader_error(e: impl std::fmt::Display) -> GpuError {
    GpuError::Other(e.to_string())
}

/// The raster G-buffer pass: the frame uniforms and the mesh motion in bind group 1, one draw per mesh.
fn raster_primary_pass(
    ctx: &GpuContext,
    gpu_scene: &GpuScene,
    gbuffer: &GBuffer,
    uniforms: &wgpu::Buffer,
    mesh_motion: &wgpu::Buffer,
) -> Result<PrimaryPass, GpuError> {
    let device = &ctx.device;
    let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("gbuffer frame"),
        entries: &[
            buffer_layout_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT, wgpu::BufferBindingType::Uniform),
            buffer_layout_entry(
                1,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::BufferBindingType::Storage { read_only: true },
            ),
        ],
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("gbuffer frame"),
        layout: &group_layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: mesh_motion.as_entire_binding() },
        ],
    });
    let module = shaders::create_module(ctx, "gbuffer", include_str!("gbuffer.wgsl"), &Defines::new())
        .map_err(shader_error)?;
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("gbuffer"),
        bind_group_layouts: &[Some(&gpu_scene.bind_group_layout), Some(&group_layout)],
        immediate_size: 0,
    });
    let colors: Vec<_> = GBUFFER_TARGET_FORMATS
        .iter()
        .map(|&format| {
            Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })
        })
        .collect();
    let pipeline = scene_raster_pipeline(device, "gbuffer", &layout, &module, &colors);
    let (width, height) = (gbuffer.albedo.width(), gbuffer.albedo.height());
    let depth = TextureBuilder::d2("gbuffer depth", width, height, DEPTH_FORMAT).render().build(ctx)?;
    Ok(PrimaryPass::Raster {
        pipeline,
        bind_group,
        targets: gbuffer.targets().iter().map(|t| t.create_view(&Default::default())).collect(),
        depth: depth.create_view(&Default::default()),
    })
}

/// (first triangle, mesh) of every non-empty mesh, ordered by first triangle (the ray-cast pass's
/// binary search from a hit triangle to its mesh).
pub(crate) fn mesh_starts(mesh_ranges: &[std::ops::Range<u32>]) -> Vec<[u32; 2]> {
    let mut starts: Vec<[u32; 2]> = mesh_ranges
        .iter()
        .enumerate()
        .filter(|(_, r)| !r.is_empty())
        .map(|(mesh, r)| [r.start / 3, mesh as u32])
        .collect();
    starts.sort_unstable();
    if starts.is_empty() {
        starts.push([0, 0]);
    }
    starts
}

/// The ray-cast G-buffer pass: the frame uniforms, mesh motion, mesh starts and the targets as storage
/// textures in bind group 1.
fn trace_primary_pass(
    ctx: &GpuContext,
    gpu_scene: &GpuScene,
    gbuffer: &GBuffer,
    uniforms: &wgpu::Buffer,
    mesh_motion: &wgpu::Buffer,
) -> Result<PrimaryPass, GpuError> {
    let device = &ctx.device;
    let compute = wgpu::ShaderStages::COMPUTE;
    let storage = wgpu::BufferBindingType::Storage { read_only: true };
    let mut entries = vec![
        buffer_layout_entry(0, compute, wgpu::BufferBindingType::Uniform),
        buffer_layout_entry(1, compute, storage),
        buffer_layout_entry(2, compute, storage),
    ];
    entries.extend(GBUFFER_TARGET_FORMATS.iter().enumerate().map(|(i, &format)| {
        storage_texture_layout_entry(
            3 + i as u32,
            format,
            wgpu::StorageTextureAccess::WriteOnly,
            wgpu::TextureViewDimension::D2,
        )
    }));
    let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("gbuffer trace"),
        entries: &entries,
    });
    let starts = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("mesh starts"),
        contents: bytemuck::cast_slice(&mesh_starts(&gpu_scene.mesh_ranges)),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let views: Vec<wgpu::TextureView> =
        gbuffer.targets().iter().map(|t| t.create_view(&Default::default())).collect();
    let mut group_entries = vec![
        wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() },
        wgpu::BindGroupEntry { binding: 1, resource: mesh_motion.as_entire_binding() },
        wgpu::BindGroupEntry { binding: 2, resource: starts.as_entire_binding() },
    ];
    group_entries.extend(views.iter().enumerate().map(|(i, v)| wgpu::BindGroupEntry {
        binding: 3 + i as u32,
        resource: wgpu::BindingResource::TextureView(v),
    }));
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("gbuffer trace"),
        layout: &group_layout,
        entries: &group_entries,
    });
    let pipeline = crate::gpu::dispatch::compute_pipeline(
        ctx,
        "gbuffer trace",
        include_str!("gbuffer_trace.wgsl"),
        &gpu_scene.bvh_defines(Defines::new().u32("TILE", TILE)),
        &[&gpu_scene.bind_group_layout, &group_layout],
    )?;
    Ok(PrimaryPass::Trace { pipeline, bind_group })
}

impl FrameResources {
    pub fn new(
        ctx: &GpuContext,
        gpu_scene: &GpuScene,
        scene: &Scene,
        width: u32,
        height: u32,
        settings: FrameSettings,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let (shadows, requested_primary) = (settings.shadows, settings.primary);
        let primary = match requested_primary {
            Some(PrimaryVisibility::Trace) => {
                if let Some(why) = trace_unsupported(ctx) {
                    return Err(GpuError::Other(format!(
                        "primary=trace is not available on this device: {why}"
                    )));
                }
                PrimaryVisibility::Trace
            }
            Some(PrimaryVisibility::Raster) => PrimaryVisibility::Raster,
            None => automatic_primary(ctx),
        };
        let max = ctx.limits().max_texture_dimension_2d;
        if width > max || height > max {
            return Err(GpuError::OverLimit(format!(
                "image size {width}x{height} exceeds the device's max_texture_dimension_2d of {max}"
            )));
        }
        let view = FrameView::still(scene.camera, width, height);
        let settings = shadows.unwrap_or(ShadowSettings {
            size: 1,
            filter_radius: 0,
            depth_bias: 0.0,
            normal_offset: 0.0,
        });
        let views = if shadows.is_some() {
            shadow_views(&gpu_scene.lights, gpu_scene.bounds(), settings.size)
        } else {
            Vec::new()
        };
        let shadow_layers = views.len().max(1) as u32;
        let max_layers = ctx.limits().max_texture_array_layers;
        if shadow_layers > max_layers || settings.size > max {
            return Err(GpuError::OverLimit(format!(
                "{shadow_layers} shadow-map layers of {0}x{0} exceed the device's limits \
                 (max_texture_array_layers {max_layers}, max_texture_dimension_2d {max})",
                settings.size
            )));
        }
        let mut uniforms = FrameUniforms {
            size: [width, height],
            shadow_filter_radius: settings.filter_radius,
            shadow_depth_bias: settings.depth_bias,
            shadow_normal_offset: settings.normal_offset,
            shadow_map_size: settings.size as f32,
            ..FrameUniforms::zeroed()
        };
        view.write_into(&mut uniforms);
        let uniform_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("frame uniforms"),
            contents: bytemuck::bytes_of(&uniforms),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let size = (width, height);
        let gbuffer = GBuffer {
            albedo: target(ctx, "gbuffer albedo", size, ALBEDO_FORMAT, primary)?,
            normal: target(ctx, "gbuffer normal", size, NORMAL_FORMAT, primary)?,
            material: target(ctx, "gbuffer material", size, MATERIAL_FORMAT, primary)?,
            emission: target(ctx, "gbuffer emission", size, EMISSION_FORMAT, primary)?,
            distance: target(ctx, "gbuffer distance", size, DISTANCE_FORMAT, primary)?,
            motion: target(ctx, "gbuffer motion", size, MOTION_FORMAT, primary)?,
            instance: target(ctx, "gbuffer instance", size, INSTANCE_FORMAT, primary)?,
        };
        let shadow_maps = TextureBuilder::d2_array(
            "shadow maps",
            settings.size,
            settings.size,
            shadow_layers,
            DEPTH_FORMAT,
        )
        .render()
        .sampled()
        .build(ctx)?;
        let shadow_view_data: Vec<ShadowView> = if views.is_empty() {
            vec![ShadowView { view_proj: Mat4::IDENTITY.to_cols_array_2d(), params: [0.0; 4] }]
        } else {
            views.clone()
        };
        let shadow_view_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shadow views"),
            contents: bytemuck::cast_slice(&shadow_view_data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let comparison = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow comparison"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });

        let bind_group_layout = frame_layout(device);
        let texture_view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let shadow_array_view = shadow_maps.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &bind_group_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform_buffer.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&texture_view(&gbuffer.albedo)),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&texture_view(&gbuffer.normal)),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&texture_view(&gbuffer.material)),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&texture_view(&gbuffer.emission)),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(&texture_view(&gbuffer.distance)),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::TextureView(&shadow_array_view),
                },
                wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::Sampler(&comparison) },
                wgpu::BindGroupEntry { binding: 8, resource: shadow_view_buffer.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 9,
                    resource: wgpu::BindingResource::TextureView(&texture_view(&gbuffer.motion)),
                },
                wgpu::BindGroupEntry {
                    binding: 10,
                    resource: wgpu::BindingResource::TextureView(&texture_view(&gbuffer.instance)),
                },
            ],
        });

        // Per mesh, the matrix from its current world position to the previous frame's (object motion).
        let mesh_motion = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mesh motion"),
            contents: bytemuck::cast_slice(&vec![Mat4::IDENTITY; gpu_scene.mesh_ranges.len().max(1)]),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let primary_pass = match primary {
            PrimaryVisibility::Raster => {
                raster_primary_pass(ctx, gpu_scene, &gbuffer, &uniform_buffer, &mesh_motion)?
            }
            PrimaryVisibility::Trace => {
                trace_primary_pass(ctx, gpu_scene, &gbuffer, &uniform_buffer, &mesh_motion)?
            }
        };

        // Shadow pipeline (only when shadow maps are in use).
        let shadow_layout = uniform_layout(device, true);
        // The same views again, for the dynamic-offset uniform of the depth pass.
        let shadow_slots = ViewSlots::new(device, "shadow view", &shadow_layout, &shadow_view_data);
        let shadow_pipeline = if views.is_empty() {
            None
        } else {
            let module = shaders::create_module(ctx, "shadow", include_str!("shadow.wgsl"), &Defines::new())
                .map_err(|e| GpuError::Other(e.to_string()))?;
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("shadow"),
                bind_group_layouts: &[Some(&gpu_scene.bind_group_layout), Some(&shadow_layout)],
                immediate_size: 0,
            });
            Some(scene_raster_pipeline(device, "shadow", &layout, &module, &[]))
        };

        Ok(FrameResources {
            width,
            height,
            uniforms,
            view,
            uniform_buffer,
            gbuffer,
            shadow_layers,
            shadow_views: views,
            shadow_settings: shadows,
            bind_group_layout,
            bind_group,
            mesh_motion,
            mesh_motion_written: vec![Mat4::IDENTITY; gpu_scene.mesh_ranges.len()],
            primary,
            requested_primary,
            primary_pass,
            shadow_maps,
            shadow_view_buffer,
            shadow_slots,
            shadow_pipeline,
            shadows_rendered: None,
        })
    }

    /// Bytes per pixel of the G-buffer as made: its targets, and the raster pass's depth buffer.
    pub fn gbuffer_bytes_per_pixel(&self) -> u32 {
        match self.primary {
            PrimaryVisibility::Raster => GBUFFER_BYTES_PER_PIXEL + 4,
            PrimaryVisibility::Trace => GBUFFER_BYTES_PER_PIXEL,
        }
    }

    /// Writes this frame's view data (camera, previous camera, counters, time, history) and `seed`.
    pub fn set_view(&mut self, ctx: &GpuContext, view: &FrameView, seed: u32) {
        view.write_into(&mut self.uniforms);
        self.view = *view;
        self.uniforms.seed = seed;
        ctx.queue.write_buffer(&self.uniform_buffer, 0, bytemuck::bytes_of(&self.uniforms));
    }

    /// Sets each mesh's object motion: the matrix from its current world position to the previous
    /// frame's (identity for meshes that did not move). Only the motion AOV reads it.
    pub fn set_mesh_motion(
        &mut self,
        ctx: &GpuContext,
        previous_from_current: &[Mat4],
    ) -> Result<(), GpuError> {
        if previous_from_current.len() != self.mesh_motion_written.len() {
            return Err(GpuError::Other(format!(
                "{} mesh motions for {} meshes",
                previous_from_current.len(),
                self.mesh_motion_written.len()
            )));
        }
        if previous_from_current != self.mesh_motion_written.as_slice() {
            ctx.queue.write_buffer(&self.mesh_motion, 0, bytemuck::cast_slice(previous_from_current));
            self.mesh_motion_written = previous_from_current.to_vec();
        }
        Ok(())
    }

    /// Changes the shadow filter, bias and normal offset (uniforms only). The map size and whether
    /// there are shadow maps at all are fixed at creation: a change of those needs new frame resources.
    pub fn set_shadow_settings(&mut self, settings: ShadowSettings) -> Result<(), GpuError> {
        let same_maps = match self.shadow_settings {
            Some(current) => current.size == settings.size,
            None => false,
        };
        if !same_maps {
            return Err(GpuError::Other(
                "the shadow-map size changed: the frame resources must be rebuilt".into(),
            ));
        }
        self.shadow_settings = Some(settings);
        self.uniforms.shadow_filter_radius = settings.filter_radius;
        self.uniforms.shadow_depth_bias = settings.depth_bias;
        self.uniforms.shadow_normal_offset = settings.normal_offset;
        Ok(())
    }

    /// Re-aims the shadow views at the lights of `gpu_scene` (after they moved); the maps re-render on
    /// the next [`Self::render_inputs`].
    pub fn update_shadow_views(&mut self, ctx: &GpuContext, gpu_scene: &GpuScene) {
        let Some(settings) = self.shadow_settings else { return };
        let views = shadow_views(&gpu_scene.lights, gpu_scene.bounds(), settings.size);
        if views.is_empty() {
            return;
        }
        ctx.queue.write_buffer(&self.shadow_view_buffer, 0, bytemuck::cast_slice(&views));
        self.shadow_slots.write(ctx, &views);
        self.shadow_views = views;
        self.shadows_rendered = None;
    }

    /// Renders the shadow maps (when the lights changed since they were last rendered) and the G-buffer.
    pub fn render_inputs(
        &mut self,
        ctx: &GpuContext,
        scene: &GpuScene,
        profiler: &mut Profiler,
    ) -> Result<(), GpuError> {
        let state = (scene.lights_version, scene.geometry_version);
        if self.shadows_rendered != Some(state) {
            if let Some(pipeline) = &self.shadow_pipeline {
                profiler.pass(ctx, "shadow maps", |encoder| {
                    for layer in 0..self.shadow_views.len() as u32 {
                        let view = layer_view(&self.shadow_maps, layer);
                        let offset = layer * SHADOW_VIEW_STRIDE as u32;
                        draw_scene(
                            encoder,
                            "shadow map",
                            &[],
                            &view,
                            pipeline,
                            (scene, Draws::One),
                            (&self.shadow_slots.bind_group, &[offset]),
                        );
                    }
                })?;
            }
            self.shadows_rendered = Some(state);
        }
        let (width, height) = (self.width, self.height);
        profiler.pass(ctx, "gbuffer", |encoder| match &self.primary_pass {
            PrimaryPass::Raster { pipeline, bind_group, targets, depth } => {
                let attachments: Vec<_> = targets.iter().map(cleared_target).collect();
                draw_scene(
                    encoder,
                    "gbuffer",
                    &attachments,
                    depth,
                    pipeline,
                    (scene, Draws::PerMesh),
                    (bind_group, &[]),
                );
            }
            PrimaryPass::Trace { pipeline, bind_group } => {
                crate::gpu::dispatch::compute_pass(
                    encoder,
                    "gbuffer trace",
                    pipeline,
                    &[&scene.bind_group, bind_group],
                )
                .dispatch_workgroups(width.div_ceil(TILE), height.div_ceil(TILE), 1);
            }
        })?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use crate::shaders::{Defines, validate};

    // Its `FrameUniforms` is the shared module's, whose layout gpu/scene.rs checks against Rust.
    #[test]
    fn gbuffer_shader_validates() {
        validate("gbuffer", include_str!("gbuffer.wgsl"), &Defines::new());
    }

    /// Meshes uploaded out of scene order (moving meshes after the static ones) and empty meshes: the
    /// table is ordered by first triangle, skips empty meshes, and its search finds every triangle's mesh.
    #[test]
    fn mesh_starts_find_every_triangles_mesh() {
        let ranges = [6..12, 0..0, 0..6, 12..21];
        let starts = super::mesh_starts(&ranges);
        assert_eq!(starts, vec![[0, 2], [2, 0], [4, 3]]);
        // The WGSL binary search (gbuffer_trace.wgsl, mesh_of_triangle), step for step.
        let mesh_of = |triangle: u32| {
            let (mut lo, mut hi) = (0usize, starts.len());
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if starts[mid][0] <= triangle { lo = mid } else { hi = mid }
            }
            starts[lo][1]
        };
        for (mesh, range) in ranges.iter().enumerate() {
            for triangle in range.start / 3..range.end / 3 {
                assert_eq!(mesh_of(triangle), mesh as u32, "triangle {triangle}");
            }
        }
        assert_eq!(super::mesh_starts(&[]), vec![[0, 0]]);
    }

    #[test]
    fn gbuffer_trace_shader_validates() {
        validate("gbuffer trace", include_str!("gbuffer_trace.wgsl"), &Defines::new().u32("TILE", 8));
    }

    /// The adapter check (`gpu::context::REQUIRED_FORMAT_USAGES`, a layer below, which cannot name these
    /// formats) asks every adapter for what the frame does with its textures.
    #[test]
    fn the_adapter_check_covers_the_frame_formats() {
        use super::*;
        use wgpu::TextureUsages as U;
        let required = crate::gpu::context::REQUIRED_FORMAT_USAGES;
        let needs = [
            (ALBEDO_FORMAT, U::RENDER_ATTACHMENT),
            (NORMAL_FORMAT, U::RENDER_ATTACHMENT),
            (MATERIAL_FORMAT, U::RENDER_ATTACHMENT),
            (EMISSION_FORMAT, U::RENDER_ATTACHMENT),
            (DISTANCE_FORMAT, U::RENDER_ATTACHMENT),
            (MOTION_FORMAT, U::RENDER_ATTACHMENT),
            (INSTANCE_FORMAT, U::RENDER_ATTACHMENT),
            (DEPTH_FORMAT, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING),
            (OUTPUT_FORMAT, U::STORAGE_BINDING),
        ];
        for (format, usages) in needs {
            assert!(
                required.iter().any(|(f, u)| *f == format && u.contains(usages)),
                "{format:?} needs {usages:?} but the adapter check does not ask for it"
            );
        }
    }
}
