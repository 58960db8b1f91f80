//! Copies from GPU resources back to the CPU (for output, tests and metrics).

use super::{GpuContext, GpuError};

/// Reads `size` bytes of `buffer` (which needs `COPY_SRC`) from `offset`.
pub fn read_buffer(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    offset: u64,
    size: u64,
) -> Result<Vec<u8>, GpuError> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buffer, offset, &staging, 0, size);
    ctx.queue.submit([encoder.finish()]);
    map_and_copy(ctx, &staging)
}

/// Maps a `MAP_READ` buffer whose copies were submitted, waits for the device and copies it out.
pub(crate) fn map_and_copy(ctx: &GpuContext, staging: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.wait_idle()?;
    rx.recv()
        .map_err(|e| GpuError::Other(format!("readback channel: {e}")))?
        .map_err(|e| GpuError::Other(format!("mapping a readback buffer: {e}")))?;
    let data = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Other(format!("mapping a readback buffer: {e:?}")))?
        .to_vec();
    staging.unmap();
    Ok(data)
}

/// Reads mip level 0, layer 0 of a 2D texture as tightly packed rows of `bytes_per_pixel` bytes.
pub fn read_texture(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    bytes_per_pixel: u32,
) -> Result<Vec<u8>, GpuError> {
    let size = wgpu::Extent3d { width: texture.width(), height: texture.height(), depth_or_array_layers: 1 };
    read_region(ctx, texture, 0, size, bytes_per_pixel)
}

/// Reads mip `level` of a 2-D, 2-D array or 3-D texture: every layer (or depth slice) in order, rows
/// tightly packed, texels of the format's copy size (colour formats only).
pub fn read_texture_level(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    level: u32,
) -> Result<Vec<u8>, GpuError> {
    let size = texture.size().mip_level_size(level, texture.dimension());
    let texel = texture.format().block_copy_size(None).ok_or_else(|| {
        GpuError::Other(format!("reading back {:?}: no single copy size", texture.format()))
    })?;
    read_region(ctx, texture, level, size, texel)
}

/// Copies `size` texels of `level` from the origin through a staging buffer whose rows are padded to
/// `COPY_BYTES_PER_ROW_ALIGNMENT`, and returns them unpadded.
fn read_region(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    level: u32,
    size: wgpu::Extent3d,
    texel_bytes: u32,
) -> Result<Vec<u8>, GpuError> {
    let unpadded = size.width * texel_bytes;
    let padded = unpadded.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let rows = size.height * size.depth_or_array_layers;
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("texture readback"),
        size: u64::from(padded) * u64::from(rows),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: level,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(size.height),
            },
        },
        size,
    );
    ctx.queue.submit([encoder.finish()]);
    let data = map_and_copy(ctx, &staging)?;
    let mut out = Vec::with_capacity((unpadded * rows) as usize);
    for row in data.chunks_exact(padded as usize) {
        out.extend_from_slice(&row[..unpadded as usize]);
    }
    Ok(out)
}
