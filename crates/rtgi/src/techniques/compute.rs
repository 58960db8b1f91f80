//! Helpers for the common shape of a technique pass: a compute pipeline over bind groups 0 (scene),
//! 1 (frame) and 2 (the technique's own resources), and the textures and buffers those passes use.

use crate::gpu::GpuContext;
use crate::gpu::resources::{buffer_layout_entry, storage_texture_layout_entry, texture_layout_entry};
use crate::shaders::{self, Defines, ShaderError};

pub use crate::frame::TILE;

pub fn pipeline(
    ctx: &GpuContext,
    name: &str,
    source: &str,
    defines: Defines,
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
) -> Result<wgpu::ComputePipeline, ShaderError> {
    let module = shaders::create_module(ctx, name, source, &defines.u32("TILE", TILE))?;
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().map(|l| Some(*l)).collect();
    let layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(name),
        bind_group_layouts: &layouts,
        immediate_size: 0,
    });
    Ok(ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(name),
        layout: Some(&layout),
        module: &module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    }))
}

/// A bind-group layout entry for a storage texture visible to compute shaders.
pub fn storage_texture_entry(
    binding: u32,
    format: wgpu::TextureFormat,
    access: wgpu::StorageTextureAccess,
) -> wgpu::BindGroupLayoutEntry {
    storage_texture_layout_entry(binding, format, access, wgpu::TextureViewDimension::D2)
}

/// A bind-group layout entry for a sampled (read with `textureLoad`) 2D texture.
pub fn texture_entry(binding: u32, sample_type: wgpu::TextureSampleType) -> wgpu::BindGroupLayoutEntry {
    texture_layout_entry(binding, sample_type, wgpu::TextureViewDimension::D2)
}

/// A bind-group layout entry for a 3-D storage texture visible to compute shaders.
pub fn storage_texture_3d_entry(
    binding: u32,
    format: wgpu::TextureFormat,
    access: wgpu::StorageTextureAccess,
) -> wgpu::BindGroupLayoutEntry {
    storage_texture_layout_entry(binding, format, access, wgpu::TextureViewDimension::D3)
}

/// A bind-group layout entry for a sampled 3-D texture.
pub fn texture_3d_entry(binding: u32, sample_type: wgpu::TextureSampleType) -> wgpu::BindGroupLayoutEntry {
    texture_layout_entry(binding, sample_type, wgpu::TextureViewDimension::D3)
}

/// A bind-group layout entry for a filtering sampler.
pub fn filtering_sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// A bind-group layout entry for a storage buffer.
pub fn storage_buffer_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    buffer_layout_entry(binding, wgpu::ShaderStages::COMPUTE, wgpu::BufferBindingType::Storage { read_only })
}

/// A bind-group layout entry for a uniform buffer.
pub fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    buffer_layout_entry(binding, wgpu::ShaderStages::COMPUTE, wgpu::BufferBindingType::Uniform)
}

/// A bind group whose entries are `resources` in binding order 0, 1, 2...
pub fn bind_group(
    ctx: &GpuContext,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    resources: &[wgpu::BindingResource],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = resources
        .iter()
        .enumerate()
        .map(|(i, r)| wgpu::BindGroupEntry { binding: i as u32, resource: r.clone() })
        .collect();
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries: &entries })
}

/// A bind-group layout from `entries`.
pub fn layout(
    ctx: &GpuContext,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> wgpu::BindGroupLayout {
    ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
}

/// A screen-sized (or any) 2D texture that compute passes write as storage and read with `textureLoad`.
pub fn storage_texture(
    ctx: &GpuContext,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    let texture = crate::gpu::TextureBuilder::d2(label, width, height, format).storage().sampled();
    ctx.device.create_texture(&texture.usage(wgpu::TextureUsages::COPY_SRC).descriptor())
}

/// A storage buffer of `size` bytes (zeroed), readable back for tests and counters.
pub fn storage_buffer(ctx: &GpuContext, label: &str, size: u64) -> wgpu::Buffer {
    ctx.device.create_buffer(&crate::gpu::BufferBuilder::new(label, size).storage().copy().descriptor())
}

/// The common screen-space pass: one thread per pixel of the frame over the scene (group 0), the frame
/// (group 1) and the technique's `group` (group 2), recorded as the profiler pass `name`.
pub fn frame_pass(
    fc: &super::FrameContext,
    profiler: &mut crate::gpu::Profiler,
    name: &str,
    pipeline: &wgpu::ComputePipeline,
    group: &wgpu::BindGroup,
) -> Result<(), super::RenderError> {
    profiler.pass(fc.ctx, name, |encoder| {
        dispatch_pixels(
            encoder,
            name,
            pipeline,
            &[&fc.gpu_scene.bind_group, &fc.frame.bind_group, group],
            fc.frame.width,
            fc.frame.height,
        );
    })?;
    Ok(())
}

/// Dispatches one thread per pixel in TILE×TILE workgroups.
pub fn dispatch_pixels(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_groups: &[&wgpu::BindGroup],
    width: u32,
    height: u32,
) {
    dispatch(encoder, label, pipeline, bind_groups, [width.div_ceil(TILE), height.div_ceil(TILE), 1]);
}

/// Dispatches `workgroups` workgroups.
pub fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_groups: &[&wgpu::BindGroup],
    workgroups: [u32; 3],
) {
    crate::gpu::dispatch::compute_pass(encoder, label, pipeline, bind_groups).dispatch_workgroups(
        workgroups[0],
        workgroups[1],
        workgroups[2],
    );
}

/// Per-dispatch constants (a sample index, a chunk of work) in one uniform buffer, one aligned slot per
/// dispatch, picked with a dynamic offset: one bind group serves every dispatch of a pass. (Long loops
/// inside one invocation are unsafe on lavapipe, so passes split their work across dispatches.)
pub struct DispatchSlots {
    buffer: wgpu::Buffer,
    stride: u32,
    size: u64,
    count: u32,
}

impl DispatchSlots {
    pub fn new<T: bytemuck::Pod>(ctx: &GpuContext, label: &str, values: &[T]) -> Self {
        use wgpu::util::DeviceExt;
        let size = size_of::<T>();
        let stride =
            (ctx.limits().min_uniform_buffer_offset_alignment as usize).max(size).next_multiple_of(16);
        let mut bytes = vec![0u8; stride * values.len().max(1)];
        for (i, v) in values.iter().enumerate() {
            bytes[i * stride..i * stride + size].copy_from_slice(bytemuck::bytes_of(v));
        }
        let buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &bytes,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        DispatchSlots { buffer, stride: stride as u32, size: size as u64, count: values.len() as u32 }
    }

    /// The layout entry of the slot's uniform (dynamic offset).
    pub fn entry(&self, binding: u32) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: true,
                min_binding_size: wgpu::BufferSize::new(self.size),
            },
            count: None,
        }
    }

    pub fn resource(&self) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &self.buffer,
            offset: 0,
            size: wgpu::BufferSize::new(self.size),
        })
    }

    /// The dynamic offset of every dispatch, in order.
    pub fn offsets(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.count).map(|i| i * self.stride)
    }
}
