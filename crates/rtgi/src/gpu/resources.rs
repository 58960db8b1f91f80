//! One way to create textures and buffers: builders that check the request against the device first,
//! so that an oversized volume or buffer is a [`GpuError::OverLimit`] naming the wgpu limit instead of
//! a validation panic, and that a format used for something it cannot do is named.
//!
//! ```ignore
//! let volume = TextureBuilder::d3("radiance volume", 64, 64, 64, wgpu::TextureFormat::Rgba16Float)
//!     .full_mip_chain()
//!     .storage()
//!     .sampled()
//!     .build(ctx)?;
//! let args = BufferBuilder::new("dispatch args", 12).storage().indirect().build(ctx)?;
//! ```

use super::{GpuContext, GpuError, features};

/// A bind-group layout entry for a whole buffer (`Uniform` or `Storage`, no dynamic offset).
pub fn buffer_layout_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BufferBindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

/// A compute-visible layout entry of a texture of `dimension` read with `textureLoad`.
pub fn texture_layout_entry(
    binding: u32,
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture { sample_type, view_dimension, multisampled: false },
        count: None,
    }
}

/// A compute-visible layout entry of a storage texture of `dimension`.
pub fn storage_texture_layout_entry(
    binding: u32,
    format: wgpu::TextureFormat,
    access: wgpu::StorageTextureAccess,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture { access, format, view_dimension },
        count: None,
    }
}

/// A texture request: 2-D, 2-D array (layers) or 3-D, with a mip chain, usages and an optional clear.
#[derive(Clone, Debug)]
pub struct TextureBuilder<'a> {
    label: &'a str,
    size: wgpu::Extent3d,
    dimension: wgpu::TextureDimension,
    format: wgpu::TextureFormat,
    mip_level_count: u32,
    usage: wgpu::TextureUsages,
    clear: Option<[f64; 4]>,
}

impl<'a> TextureBuilder<'a> {
    fn new(
        label: &'a str,
        size: wgpu::Extent3d,
        dimension: wgpu::TextureDimension,
        format: wgpu::TextureFormat,
    ) -> Self {
        TextureBuilder {
            label,
            size,
            dimension,
            format,
            mip_level_count: 1,
            usage: wgpu::TextureUsages::empty(),
            clear: None,
        }
    }

    pub fn d2(label: &'a str, width: u32, height: u32, format: wgpu::TextureFormat) -> Self {
        Self::d2_array(label, width, height, 1, format)
    }

    pub fn d2_array(
        label: &'a str,
        width: u32,
        height: u32,
        layers: u32,
        format: wgpu::TextureFormat,
    ) -> Self {
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: layers };
        Self::new(label, size, wgpu::TextureDimension::D2, format)
    }

    pub fn d3(label: &'a str, width: u32, height: u32, depth: u32, format: wgpu::TextureFormat) -> Self {
        let size = wgpu::Extent3d { width, height, depth_or_array_layers: depth };
        Self::new(label, size, wgpu::TextureDimension::D3, format)
    }

    /// `levels` mip levels (checked against the full chain in [`Self::build`]).
    pub fn mips(mut self, levels: u32) -> Self {
        self.mip_level_count = levels;
        self
    }

    /// Every mip level down to 1×1(×1): each halves the size, rounding down (WebGPU's rule).
    pub fn full_mip_chain(mut self) -> Self {
        self.mip_level_count = self.size.max_mips(self.dimension);
        self
    }

    /// Adds `usage` to the usages requested so far.
    pub fn usage(mut self, usage: wgpu::TextureUsages) -> Self {
        self.usage |= usage;
        self
    }

    /// Written and read by compute shaders as a storage texture.
    pub fn storage(self) -> Self {
        self.usage(wgpu::TextureUsages::STORAGE_BINDING)
    }

    /// Read by shaders with `textureLoad` or a sampler.
    pub fn sampled(self) -> Self {
        self.usage(wgpu::TextureUsages::TEXTURE_BINDING)
    }

    /// A render-pass attachment.
    pub fn render(self) -> Self {
        self.usage(wgpu::TextureUsages::RENDER_ATTACHMENT)
    }

    /// Source and destination of copies (readback in tests, uploads).
    pub fn copy(self) -> Self {
        self.usage(wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST)
    }

    /// Fills every texel of every level and layer with `value` (RGBA; channels the format lacks are
    /// ignored) when built, through the queue (so `COPY_DST` is added). wgpu zero-fills new textures
    /// already: this is for other values, e.g. a far depth or a "no data" marker. Float, half and
    /// 32-bit integer formats only.
    pub fn clear(mut self, value: [f64; 4]) -> Self {
        self.clear = Some(value);
        self.usage(wgpu::TextureUsages::COPY_DST)
    }

    /// The descriptor this builder stands for, unchecked (for code that creates textures itself).
    pub fn descriptor(&self) -> wgpu::TextureDescriptor<'a> {
        wgpu::TextureDescriptor {
            label: Some(self.label),
            size: self.size,
            mip_level_count: self.mip_level_count,
            sample_count: 1,
            dimension: self.dimension,
            format: self.format,
            usage: self.usage,
            view_formats: &[],
        }
    }

    /// Checks the request against the device's limits and the format's capabilities.
    pub fn check(&self, ctx: &GpuContext) -> Result<(), GpuError> {
        let limits = ctx.limits();
        let s = self.size;
        let what = self.label;
        if s.width == 0 || s.height == 0 || s.depth_or_array_layers == 0 {
            return Err(GpuError::Other(format!(
                "{what}: a texture of {}x{}x{} is empty",
                s.width, s.height, s.depth_or_array_layers
            )));
        }
        let (edge_limit, edge_name, edges) = match self.dimension {
            wgpu::TextureDimension::D3 => (
                limits.max_texture_dimension_3d,
                "max_texture_dimension_3d",
                vec![s.width, s.height, s.depth_or_array_layers],
            ),
            _ => (limits.max_texture_dimension_2d, "max_texture_dimension_2d", vec![s.width, s.height]),
        };
        if let Some(edge) = edges.iter().find(|e| **e > edge_limit) {
            return Err(GpuError::OverLimit(format!(
                "{what}: a {}x{}x{} texture has an edge of {edge} texels, over the device's {edge_name} \
                 of {edge_limit}",
                s.width, s.height, s.depth_or_array_layers
            )));
        }
        if self.dimension == wgpu::TextureDimension::D2
            && s.depth_or_array_layers > limits.max_texture_array_layers
        {
            return Err(GpuError::OverLimit(format!(
                "{what}: {} layers, over the device's max_texture_array_layers of {}",
                s.depth_or_array_layers, limits.max_texture_array_layers
            )));
        }
        let max_mips = s.max_mips(self.dimension);
        if self.mip_level_count == 0 || self.mip_level_count > max_mips {
            return Err(GpuError::Other(format!(
                "{what}: {} mip levels requested; a {}x{}x{} texture has 1 to {max_mips}",
                self.mip_level_count, s.width, s.height, s.depth_or_array_layers
            )));
        }
        if self.usage.is_empty() {
            return Err(GpuError::Other(format!("{what}: no usage requested")));
        }
        let allowed = features::format_features(ctx, self.format).allowed_usages;
        if !allowed.contains(self.usage) {
            return Err(GpuError::Other(format!(
                "{what}: format {:?} does not support {:?} on this device",
                self.format,
                self.usage - allowed
            )));
        }
        Ok(())
    }

    /// Checks ([`Self::check`]) and creates the texture, filled if [`Self::clear`] asked for it.
    pub fn build(&self, ctx: &GpuContext) -> Result<wgpu::Texture, GpuError> {
        self.check(ctx)?;
        let texel = self.clear.map(|v| texel_bytes(self.format, v, self.label)).transpose()?;
        let texture = ctx.checked(self.label, || ctx.device.create_texture(&self.descriptor()))?;
        if let Some(texel) = texel {
            for level in 0..self.mip_level_count {
                let size = self.size.mip_level_size(level, self.dimension);
                let texels = size.width as usize * size.height as usize * size.depth_or_array_layers as usize;
                ctx.queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &texture,
                        mip_level: level,
                        origin: wgpu::Origin3d::ZERO,
                        aspect: wgpu::TextureAspect::All,
                    },
                    &texel.repeat(texels),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(size.width * texel.len() as u32),
                        rows_per_image: Some(size.height),
                    },
                    size,
                );
            }
        }
        Ok(texture)
    }
}

/// The bytes of one texel of `format` holding `value` (as many channels as the format has).
fn texel_bytes(format: wgpu::TextureFormat, value: [f64; 4], what: &str) -> Result<Vec<u8>, GpuError> {
    use wgpu::TextureFormat as F;
    let channels = format.components() as usize;
    let v = &value[..channels];
    let bytes = match format {
        F::R32Float | F::Rg32Float | F::Rgba32Float => {
            v.iter().flat_map(|x| (*x as f32).to_le_bytes()).collect()
        }
        F::R16Float | F::Rg16Float | F::Rgba16Float => {
            v.iter().flat_map(|x| half::f16::from_f64(*x).to_le_bytes()).collect()
        }
        F::R32Uint | F::Rg32Uint | F::Rgba32Uint => {
            v.iter().flat_map(|x| (*x as u32).to_le_bytes()).collect()
        }
        F::R32Sint | F::Rg32Sint | F::Rgba32Sint => {
            v.iter().flat_map(|x| (*x as i32).to_le_bytes()).collect()
        }
        _ => {
            return Err(GpuError::Other(format!(
                "{what}: clearing {format:?} to a value is not supported (float, half and 32-bit integer \
                 formats are)"
            )));
        }
    };
    Ok(bytes)
}

/// A buffer request: size or initial contents, usages, checked against the device's limits.
#[derive(Clone, Debug)]
pub struct BufferBuilder<'a> {
    label: &'a str,
    size: u64,
    contents: Option<&'a [u8]>,
    usage: wgpu::BufferUsages,
}

/// Buffers are at least this large: an empty binding is invalid and WGSL's smallest struct member
/// with 16-byte alignment is a vec4.
pub const MIN_BUFFER_SIZE: u64 = 16;

impl<'a> BufferBuilder<'a> {
    /// A zero-filled buffer of `size` bytes (rounded up to a multiple of 4, at least [`MIN_BUFFER_SIZE`]).
    pub fn new(label: &'a str, size: u64) -> Self {
        BufferBuilder { label, size, contents: None, usage: wgpu::BufferUsages::empty() }
    }

    /// A buffer holding `contents` (zero-padded to the rounded size).
    pub fn with_contents(label: &'a str, contents: &'a [u8]) -> Self {
        BufferBuilder {
            label,
            size: contents.len() as u64,
            contents: Some(contents),
            usage: wgpu::BufferUsages::empty(),
        }
    }

    /// Adds `usage` to the usages requested so far.
    pub fn usage(mut self, usage: wgpu::BufferUsages) -> Self {
        self.usage |= usage;
        self
    }

    pub fn storage(self) -> Self {
        self.usage(wgpu::BufferUsages::STORAGE)
    }

    pub fn uniform(self) -> Self {
        self.usage(wgpu::BufferUsages::UNIFORM)
    }

    /// Arguments of indirect dispatches and draws.
    pub fn indirect(self) -> Self {
        self.usage(wgpu::BufferUsages::INDIRECT)
    }

    /// Source and destination of copies (readback in tests, updates from the queue).
    pub fn copy(self) -> Self {
        self.usage(wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST)
    }

    /// The size the buffer gets: rounded up to `COPY_BUFFER_ALIGNMENT`, at least [`MIN_BUFFER_SIZE`].
    pub fn padded_size(&self) -> u64 {
        self.size.max(MIN_BUFFER_SIZE).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT)
    }

    /// The descriptor this builder stands for, unchecked and without contents.
    pub fn descriptor(&self) -> wgpu::BufferDescriptor<'a> {
        wgpu::BufferDescriptor {
            label: Some(self.label),
            size: self.padded_size(),
            usage: self.usage,
            mapped_at_creation: false,
        }
    }

    /// Checks the size against `max_buffer_size` and, for the binding kinds requested, against
    /// `max_storage_buffer_binding_size` / `max_uniform_buffer_binding_size` (a buffer bound whole).
    pub fn check(&self, ctx: &GpuContext) -> Result<(), GpuError> {
        let limits = ctx.limits();
        let size = self.padded_size();
        if self.usage.is_empty() {
            return Err(GpuError::Other(format!("{}: no usage requested", self.label)));
        }
        let mut checks = vec![("max_buffer_size", limits.max_buffer_size)];
        if self.usage.contains(wgpu::BufferUsages::STORAGE) {
            checks.push(("max_storage_buffer_binding_size", limits.max_storage_buffer_binding_size));
        }
        if self.usage.contains(wgpu::BufferUsages::UNIFORM) {
            checks.push(("max_uniform_buffer_binding_size", limits.max_uniform_buffer_binding_size));
        }
        match checks.into_iter().find(|(_, limit)| size > *limit) {
            Some((name, limit)) => Err(GpuError::buffer_over_limit(self.label, size, name, limit)),
            None => Ok(()),
        }
    }

    /// Checks ([`Self::check`]) and creates the buffer.
    pub fn build(&self, ctx: &GpuContext) -> Result<wgpu::Buffer, GpuError> {
        self.check(ctx)?;
        let mut descriptor = self.descriptor();
        descriptor.mapped_at_creation = self.contents.is_some();
        let buffer = ctx.checked(self.label, || ctx.device.create_buffer(&descriptor))?;
        if let Some(contents) = self.contents {
            // Mapped at creation: the contents land without a queue write, like `create_buffer_init`.
            let mut view = buffer
                .slice(..)
                .get_mapped_range_mut()
                .map_err(|e| GpuError::Other(format!("{}: mapping at creation: {e:?}", self.label)))?;
            view.slice(..contents.len()).copy_from_slice(contents);
            drop(view);
            buffer.unmap();
        }
        Ok(buffer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::GpuOptions;

    fn context() -> GpuContext {
        GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (lavapipe) for the resource tests")
    }

    #[test]
    fn limits_are_named() {
        let ctx = context();
        let l = ctx.limits();
        let f = wgpu::TextureFormat::Rgba16Float;
        let e = TextureBuilder::d3("volume", 4, l.max_texture_dimension_3d + 1, 4, f).storage().build(&ctx);
        let e = e.unwrap_err();
        assert!(
            matches!(e, GpuError::OverLimit(_)) && e.to_string().contains("max_texture_dimension_3d"),
            "{e}"
        );
        let e = TextureBuilder::d2("map", l.max_texture_dimension_2d + 1, 4, f)
            .sampled()
            .build(&ctx)
            .unwrap_err();
        assert!(e.to_string().contains("max_texture_dimension_2d"), "{e}");
        let e =
            TextureBuilder::d2_array("maps", 4, 4, l.max_texture_array_layers + 1, f).sampled().build(&ctx);
        assert!(e.unwrap_err().to_string().contains("max_texture_array_layers"));
        let e = TextureBuilder::d3("volume", 5, 3, 7, f).mips(4).sampled().build(&ctx).unwrap_err();
        assert!(e.to_string().contains("1 to 3"), "{e}");
        let rw8 = TextureBuilder::d2("ldr", 4, 4, wgpu::TextureFormat::Rgba8UnormSrgb).storage().build(&ctx);
        assert!(rw8.unwrap_err().to_string().contains("STORAGE_BINDING"));

        let e = BufferBuilder::new("voxels", l.max_storage_buffer_binding_size + 4).storage().build(&ctx);
        let e = e.unwrap_err();
        assert!(matches!(e, GpuError::OverLimit(_)), "{e}");
        let name = if l.max_storage_buffer_binding_size < l.max_buffer_size {
            "max_storage_buffer_binding_size"
        } else {
            "max_buffer_size"
        };
        assert!(e.to_string().contains(name) && e.to_string().starts_with("voxels needs"), "{e}");
        let e = BufferBuilder::new("constants", l.max_uniform_buffer_binding_size + 4).uniform();
        assert!(e.build(&ctx).unwrap_err().to_string().contains("max_uniform_buffer_binding_size"));
    }

    #[test]
    fn buffers_hold_their_contents_and_textures_their_clear_value() {
        let ctx = context();
        let words: Vec<u32> = (0..5).collect();
        let b = BufferBuilder::with_contents("words", bytemuck::cast_slice(&words)).storage().copy();
        assert_eq!(b.padded_size(), 20);
        let buffer = b.build(&ctx).expect("buffer");
        let back = crate::gpu::readback::read_buffer(&ctx, &buffer, 0, 20).expect("readback");
        assert_eq!(bytemuck::cast_slice::<u8, u32>(&back), &words[..]);
        assert_eq!(BufferBuilder::new("tiny", 1).padded_size(), MIN_BUFFER_SIZE);

        let t = TextureBuilder::d3("cleared", 3, 2, 5, wgpu::TextureFormat::Rgba32Float)
            .full_mip_chain()
            .sampled()
            .copy()
            .clear([0.25, -1.0, 3.0, 1.0])
            .build(&ctx)
            .expect("texture");
        assert_eq!(t.mip_level_count(), 3);
        for level in 0..3 {
            let texels: Vec<f32> = bytemuck::cast_slice(
                &crate::gpu::readback::read_texture_level(&ctx, &t, level).expect("read"),
            )
            .to_vec();
            let size = t.size().mip_level_size(level, t.dimension());
            assert_eq!(texels.len() as u32, 4 * size.width * size.height * size.depth_or_array_layers);
            assert!(texels.chunks(4).all(|px| px == [0.25, -1.0, 3.0, 1.0]), "level {level}");
        }
    }
}
