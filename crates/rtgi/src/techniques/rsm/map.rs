//! Reflective shadow maps: for every analytic light (spot: one layer, point: six cube-face layers,
//! directional: one fitted orthographic layer, the same views as the frame core's shadow maps), the
//! scene rendered from the light with three render targets: world position (+ the texel's beam
//! cross-section), normal, and reflected radiant intensity I_p = Φ_p/π.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::frame::{self, DEPTH_FORMAT, SHADOW_VIEW_STRIDE};
use crate::gpu::resources::buffer_layout_entry;
use crate::gpu::scene::{GpuLight, LIGHT_DIRECTIONAL};
use crate::gpu::{GpuContext, GpuScene, Profiler};
use crate::scene::Scene;
use crate::shaders::{self, Defines};
use crate::techniques::{RenderError, SceneChange};

pub const POSITION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const INTENSITY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Bytes per RSM texel (position, normal, intensity and depth).
pub const BYTES_PER_TEXEL: u32 = 16 + 8 + 16 + 4;

/// One RSM layer's view; mirrors `RsmView` in `view.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct RsmView {
    pub view_proj: [[f32; 4]; 4],
    pub light: u32,
    pub orthographic: u32,
    pub texel: f32,
    pub size: f32,
}

/// The source of `view.wgsl` (the `RsmView` struct), to prepend to every shader that uses it.
pub const VIEW_WGSL: &str = include_str!("view.wgsl");
/// The source of `rsm.wgsl` (bind group 3 and the pixel-light kernel).
pub const RSM_WGSL: &str = include_str!("rsm.wgsl");

/// The RSM pixel-light kernel alone (no bindings).
pub const KERNEL_WGSL: &str = include_str!("kernel.wgsl");

/// `view.wgsl` + `kernel.wgsl` + `rsm.wgsl` + `body`: the source of a shader that reads the RSM.
pub fn reader_source(body: &str) -> String {
    format!("{VIEW_WGSL}\n{KERNEL_WGSL}\n{RSM_WGSL}\n{body}")
}

/// The reflective shadow maps of a scene's analytic lights.
pub struct ReflectiveShadowMap {
    pub size: u32,
    /// Sampling discs of a gather: one per spot or directional light, six per point light (its cube).
    pub light_discs: u32,
    pub views: Vec<RsmView>,
    pub position: wgpu::Texture,
    pub normal: wgpu::Texture,
    pub intensity: wgpu::Texture,
    depth: wgpu::Texture,
    pipeline: Option<wgpu::RenderPipeline>,
    view_slots: frame::ViewSlots,
    views_buffer: wgpu::Buffer,
    /// Bind group 3 of the shaders built with [`reader_source`].
    pub layout: wgpu::BindGroupLayout,
    pub bind_group: wgpu::BindGroup,
    /// What the RSM cannot represent (emissive triangles, environment light).
    pub warnings: Vec<String>,
    /// The GPU scene's (lights version, geometry version) the maps were rendered for.
    rendered: Option<(u64, u64)>,
}

/// One view per RSM layer: the lights' shadow views at the layers the lights carry, framing `bounds`.
fn rsm_views(lights: &[GpuLight], bounds: crate::scene::Aabb, size: u32) -> Vec<RsmView> {
    let shadow_views = frame::shadow_views(lights, bounds, size);
    let mut views = Vec::with_capacity(shadow_views.len());
    for (index, light) in lights.iter().enumerate() {
        for k in 0..crate::gpu::scene::shadow_layer_count(light.kind) {
            let v = &shadow_views[(light.shadow_layer + k) as usize];
            views.push(RsmView {
                view_proj: v.view_proj,
                light: index as u32,
                orthographic: u32::from(light.kind == LIGHT_DIRECTIONAL),
                texel: v.params[0],
                size: size as f32,
            });
        }
    }
    views
}

fn array_texture(
    ctx: &GpuContext,
    label: &str,
    size: u32,
    layers: u32,
    format: wgpu::TextureFormat,
) -> Result<wgpu::Texture, crate::gpu::GpuError> {
    crate::gpu::TextureBuilder::d2_array(label, size, size, layers, format)
        .render()
        .sampled()
        .copy()
        .build(ctx)
}

/// Visibility of the RSM bindings: compute passes, and the vertex and fragment stages of splats.
pub const READ_STAGES: wgpu::ShaderStages =
    wgpu::ShaderStages::COMPUTE.union(wgpu::ShaderStages::VERTEX_FRAGMENT);

fn read_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
    let tex = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: READ_STAGES,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    };
    let buf = |binding| {
        buffer_layout_entry(binding, READ_STAGES, wgpu::BufferBindingType::Storage { read_only: true })
    };
    ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("rsm read"),
        entries: &[tex(0), tex(1), tex(2), buf(3)],
    })
}

impl ReflectiveShadowMap {
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        gpu_scene: &GpuScene,
        size: u32,
    ) -> Result<Self, RenderError> {
        let device = &ctx.device;
        let limits = ctx.limits();
        if size > limits.max_texture_dimension_2d {
            return Err(RenderError::InvalidSettings(format!(
                "rsm_size {size} exceeds the device's max_texture_dimension_2d of {}",
                limits.max_texture_dimension_2d
            )));
        }
        let lights = &gpu_scene.lights;
        let views = rsm_views(lights, gpu_scene.bounds(), size);
        let mut warnings = Vec::new();
        if gpu_scene.info.emissive_count > 0 {
            warnings.push(
                "RSM techniques only handle analytic lights: the light of emissive triangles gets no \
                 indirect bounce (it is still in the direct term)"
                    .to_string(),
            );
        }
        if !matches!(scene.environment, crate::scene::Environment::None) {
            warnings.push(
                "RSM techniques only handle analytic lights: the environment's light gets no indirect \
                 bounce (it is still in the direct term)"
                    .to_string(),
            );
        }
        if views.is_empty() {
            warnings.push("no analytic light: RSM techniques add no indirect light".to_string());
        }
        let layers = views.len().max(1) as u32;
        if layers > limits.max_texture_array_layers {
            return Err(RenderError::InvalidSettings(format!(
                "{layers} RSM layers exceed the device's max_texture_array_layers of {}",
                limits.max_texture_array_layers
            )));
        }
        let position = array_texture(ctx, "rsm position", size, layers, POSITION_FORMAT)?;
        let normal = array_texture(ctx, "rsm normal", size, layers, NORMAL_FORMAT)?;
        let intensity = array_texture(ctx, "rsm intensity", size, layers, INTENSITY_FORMAT)?;
        let depth = array_texture(ctx, "rsm depth", size, layers, DEPTH_FORMAT)?;

        let view_data: Vec<RsmView> = if views.is_empty() { vec![RsmView::zeroed()] } else { views.clone() };
        let view_layout = frame::uniform_layout(device, true);
        let view_slots = frame::ViewSlots::new(device, "rsm view", &view_layout, &view_data);
        let pipeline = if views.is_empty() {
            None
        } else {
            let module = shaders::create_module(
                ctx,
                "rsm map",
                &format!("{VIEW_WGSL}\n{}", include_str!("map.wgsl")),
                &Defines::new(),
            )?;
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("rsm map"),
                bind_group_layouts: &[Some(&gpu_scene.bind_group_layout), Some(&view_layout)],
                immediate_size: 0,
            });
            let color = |format| {
                Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })
            };
            Some(frame::scene_raster_pipeline(
                device,
                "rsm map",
                &layout,
                &module,
                &[color(POSITION_FORMAT), color(NORMAL_FORMAT), color(INTENSITY_FORMAT)],
            ))
        };

        let views_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rsm views"),
            contents: bytemuck::cast_slice(&view_data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let layout = read_layout(ctx);
        let array_view = |t: &wgpu::Texture| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        };
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("rsm read"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&array_view(&position)),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&array_view(&normal)),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&array_view(&intensity)),
                },
                wgpu::BindGroupEntry { binding: 3, resource: views_buffer.as_entire_binding() },
            ],
        });
        Ok(ReflectiveShadowMap {
            size,
            light_discs: lights.iter().map(|l| crate::gpu::scene::shadow_layer_count(l.kind) as u32).sum(),
            views,
            position,
            normal,
            intensity,
            depth,
            pipeline,
            view_slots,
            views_buffer,
            layout,
            bind_group,
            warnings,
            rendered: None,
        })
    }

    /// Texels of all layers.
    pub fn texels(&self) -> u32 {
        self.size * self.size * self.views.len() as u32
    }

    /// Follows a change of the GPU scene: moved lights (same count and kinds) re-aim the views, and the
    /// maps render again on the next [`Self::render`]; the environment does not bounce in RSMs. Returns
    /// whether the maps will change.
    pub fn scene_changed(&mut self, ctx: &GpuContext, gpu_scene: &GpuScene, change: SceneChange) -> bool {
        // The GPU scene keeps the count and kinds of its lights, so the views keep their layers. Moved
        // geometry changes the bounds the views frame; `render` sees the new geometry version.
        if matches!(change, SceneChange::Environment | SceneChange::EnvironmentRotation)
            || gpu_scene.lights.is_empty()
        {
            return false;
        }
        let views = rsm_views(&gpu_scene.lights, gpu_scene.bounds(), self.size);
        if !views.is_empty() {
            ctx.queue.write_buffer(&self.views_buffer, 0, bytemuck::cast_slice(&views));
            self.view_slots.write(ctx, &views);
        }
        self.views = views;
        self.rendered = None;
        true
    }

    /// Renders the maps as the pass "rsm" when the lights or the geometry changed since the last time.
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        scene: &GpuScene,
        profiler: &mut Profiler,
    ) -> Result<(), RenderError> {
        let state = (scene.lights_version, scene.geometry_version);
        if self.rendered == Some(state) {
            return Ok(());
        }
        self.rendered = Some(state);
        let Some(pipeline) = &self.pipeline else {
            return Ok(());
        };
        profiler.pass(ctx, "rsm", |encoder| {
            let layer_view = frame::layer_view;
            for layer in 0..self.views.len() as u32 {
                let targets = [&self.position, &self.normal, &self.intensity].map(|t| layer_view(t, layer));
                let colors: Vec<_> = targets.iter().map(frame::cleared_target).collect();
                let depth = layer_view(&self.depth, layer);
                frame::draw_scene(
                    encoder,
                    "rsm layer",
                    &colors,
                    &depth,
                    pipeline,
                    (scene, frame::Draws::One),
                    (&self.view_slots.bind_group, &[layer * SHADOW_VIEW_STRIDE as u32]),
                );
            }
        })?;
        Ok(())
    }
}
