//! Arrays held in 2-D textures, element i at texel (i mod [`TEXELS_PER_ROW`], i / [`TEXELS_PER_ROW`])
//! (`common/linear_texture.wgsl` has the shader side).
//!
//! Data that a shader reads inside a loop goes here rather than in a storage buffer: lavapipe (Mesa
//! 22.3) loads a storage buffer inside control flow lane by lane and component by component, but
//! fetches a texel for all lanes of a batch at once. Measured on lavapipe at 256×256: `sii`'s tiled splat
//! 4.1–4.8× faster with its VPLs in a texture, the path tracer 1.4–1.7× with the BVH in two
//! (docs/measurements/splat-lavapipe.md, traversal-lavapipe.md). A texture also holds more than a CPU
//! adapter's 128 MiB storage binding.
//!
//! Tables read in the hottest loops (the BVH's) are bound as read-only storage textures
//! (`texture_storage_2d<F, read>`, created by [`create_storage`]) rather than sampled ones: lavapipe
//! compiles a sampled texture's `textureLoad` into a call to a generic texel-fetch function that works
//! out each lane's mip size, row pitch and bounds before loading, but an image load inline. Measured with the
//! BVH's two: the path tracer's frame at 0.86× the time on atrium:detail=5 at 256² on lavapipe (best of 6
//! alternating runs, 918 against 1064 ms; images identical).
//!
//! The rule is about loops that run many times per invocation, not about every read: the scene's
//! vertices, triangles and materials, which the path tracer reads once per hit, were tried as linear
//! textures too (bounce loop and raster vertex pulling alike, images bit-identical) and made the path
//! tracer's frame 1.39× slower on atrium:detail=5 and 1.24× on atrium at 256² on lavapipe (`rtgi render
//! --technique path --set spp=1 --frames 4 --stats`, the path pass's mean GPU time, alternating runs of
//! each build, 2026-11-28). They stay storage buffers.

use super::{GpuContext, GpuError, TextureBuilder};

/// Texels per row (`LINEAR_TEXELS_PER_ROW` in `common/linear_texture.wgsl`): a power of two, so the
/// shader finds a texel with a mask and a shift, and rows of any 4- to 16-byte format are whole
/// multiples of the 256 bytes a copy's row pitch needs.
pub const TEXELS_PER_ROW: u32 = 4096;

/// Rows a texture of `texels` texels needs (at least one: no texture is empty).
pub fn rows(texels: u64) -> u64 {
    texels.div_ceil(u64::from(TEXELS_PER_ROW)).max(1)
}

/// Checks that `texels` texels of `texel_bytes` bytes fit the device's 2-D textures:
/// [`GpuError::OverLimit`] naming `what` otherwise.
pub fn check(ctx: &GpuContext, what: &str, texels: u64, texel_bytes: u32) -> Result<(), GpuError> {
    let rows = rows(texels);
    let limit = ctx.limits().max_texture_dimension_2d;
    if rows > u64::from(limit) {
        return Err(GpuError::OverLimit(format!(
            "{what} needs {rows} rows of {TEXELS_PER_ROW} texels ({:.1} MiB), over the device's \
             max_texture_dimension_2d of {limit}",
            (texels * u64::from(texel_bytes)) as f64 / 1_048_576.0
        )));
    }
    Ok(())
}

/// A texture of `format` for `texels` texels (checked), readable with `textureLoad` and a copy
/// destination (and source, for readback).
pub fn create(
    ctx: &GpuContext,
    label: &str,
    format: wgpu::TextureFormat,
    texels: u64,
) -> Result<wgpu::Texture, GpuError> {
    builder(ctx, label, format, texels)?.build(ctx)
}

/// [`create`], also bindable as a storage texture: read-only (a hot loop's table, see above) or
/// written (a table a pass fills for later loops).
pub fn create_storage(
    ctx: &GpuContext,
    label: &str,
    format: wgpu::TextureFormat,
    texels: u64,
) -> Result<wgpu::Texture, GpuError> {
    builder(ctx, label, format, texels)?.storage().build(ctx)
}

fn builder<'a>(
    ctx: &GpuContext,
    label: &'a str,
    format: wgpu::TextureFormat,
    texels: u64,
) -> Result<TextureBuilder<'a>, GpuError> {
    check(ctx, label, texels, texel_bytes(format))?;
    Ok(TextureBuilder::d2(label, TEXELS_PER_ROW, rows(texels) as u32, format).sampled().copy())
}

fn texel_bytes(format: wgpu::TextureFormat) -> u32 {
    format.block_copy_size(None).unwrap_or(16)
}

/// Bytes of GPU memory `texture` (from [`create`]) takes, its last row's padding included.
pub fn bytes(texture: &wgpu::Texture) -> u64 {
    u64::from(texture.width()) * u64::from(texture.height()) * u64::from(texel_bytes(texture.format()))
}

/// The whole rows, then what is left of the last row, of `bytes` bytes laid out from the first texel:
/// (first row, rows, texels across, byte offset).
fn pieces(bytes: u64, texel_bytes: u32) -> impl Iterator<Item = (u32, u32, u32, u64)> {
    let row_bytes = u64::from(TEXELS_PER_ROW * texel_bytes);
    let full_rows = bytes / row_bytes;
    let rest = bytes % row_bytes;
    let full = (full_rows > 0).then_some((0, full_rows as u32, TEXELS_PER_ROW, 0));
    let last = (rest > 0)
        .then(|| (full_rows as u32, 1, (rest / u64::from(texel_bytes)) as u32, full_rows * row_bytes));
    full.into_iter().chain(last)
}

fn origin(texture: &wgpu::Texture, row: u32) -> wgpu::TexelCopyTextureInfo<'_> {
    wgpu::TexelCopyTextureInfo {
        texture,
        mip_level: 0,
        origin: wgpu::Origin3d { x: 0, y: row, z: 0 },
        aspect: wgpu::TextureAspect::All,
    }
}

/// Writes `data` (whole texels) into `texture` from its first texel on, through the queue.
pub fn write(ctx: &GpuContext, texture: &wgpu::Texture, data: &[u8]) {
    let texel = texel_bytes(texture.format());
    for (row, rows, width, offset) in pieces(data.len() as u64, texel) {
        let end = offset as usize + (rows * width * texel) as usize;
        ctx.queue.write_texture(
            origin(texture, row),
            &data[offset as usize..end],
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(width * texel),
                rows_per_image: Some(rows),
            },
            wgpu::Extent3d { width, height: rows, depth_or_array_layers: 1 },
        );
    }
}

/// Copies the first `bytes` bytes (whole texels) of `buffer` into `texture` from its first texel on:
/// for arrays a shader writes into a buffer (atomics, structs) and loops read.
pub fn copy_from_buffer(
    encoder: &mut wgpu::CommandEncoder,
    buffer: &wgpu::Buffer,
    texture: &wgpu::Texture,
    bytes: u64,
) {
    let texel = texel_bytes(texture.format());
    for (row, rows, width, offset) in pieces(bytes, texel) {
        encoder.copy_buffer_to_texture(
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset,
                    bytes_per_row: Some(TEXELS_PER_ROW * texel),
                    rows_per_image: Some(rows),
                },
            },
            origin(texture, row),
            wgpu::Extent3d { width, height: rows, depth_or_array_layers: 1 },
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_cover_the_bytes_in_whole_rows_then_the_rest() {
        let row = u64::from(TEXELS_PER_ROW) * 16;
        assert_eq!(pieces(0, 16).count(), 0);
        assert_eq!(pieces(48, 16).collect::<Vec<_>>(), vec![(0, 1, 3, 0)]);
        assert_eq!(pieces(2 * row, 16).collect::<Vec<_>>(), vec![(0, 2, TEXELS_PER_ROW, 0)]);
        assert_eq!(
            pieces(2 * row + 32, 16).collect::<Vec<_>>(),
            vec![(0, 2, TEXELS_PER_ROW, 0), (2, 1, 2, 2 * row)]
        );
    }

    #[test]
    fn the_wgsl_twin_has_the_row_length() {
        let src = crate::shaders::COMMON_MODULES
            .iter()
            .find(|(p, _)| *p == "common/linear_texture.wgsl")
            .map(|(_, s)| *s)
            .expect("linear_texture.wgsl is registered");
        let line = format!("const LINEAR_TEXELS_PER_ROW: u32 = {TEXELS_PER_ROW}u;");
        assert!(src.contains(&line), "linear_texture.wgsl lacks `{line}`");
    }
}
