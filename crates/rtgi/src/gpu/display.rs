//! The display image of a radiance texture: the PNG tone map of [`crate::image`] (exposure, ACES fit,
//! sRGB) run on the GPU into an 8-bit texture holding the PNG's values, so a viewer can show every
//! frame without reading the radiance back. The WGSL (`tone_map` of `shaders/common/color.wgsl`) is the twin of
//! [`crate::image::tone_map_pixel`]; a test holds them to one 8-bit step of each other.

use super::dispatch::{compute_pass, compute_pipeline};
use super::resources::{storage_texture_layout_entry, texture_layout_entry};
use super::{BufferBuilder, GpuContext, GpuError, TextureBuilder};
use crate::shaders::Defines;

const KERNEL: &str = include_str!("display.wgsl");

/// Format of the display texture: sRGB-encoded values (the bytes of the PNG) in a unorm texture, as
/// egui composites gamma-space textures (and WebGPU cannot write sRGB formats as storage).
pub const DISPLAY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const WORKGROUP: u32 = 8;
/// The radiance is only loaded, and 32-bit floats need not be filterable.
const UNFILTERABLE: wgpu::TextureSampleType = wgpu::TextureSampleType::Float { filterable: false };

/// A tone-mapped, 8-bit copy of a radiance texture, updated by [`Display::update`].
pub struct Display {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
    texture: wgpu::Texture,
    /// The source texture the bind group reads and the bind group: rebuilt only when the source
    /// changes (a resize or technique switch), not per frame.
    bound: Option<(wgpu::Texture, wgpu::BindGroup)>,
    exposure_ev: Option<f32>,
}

impl Display {
    pub fn new(ctx: &GpuContext) -> Result<Self, GpuError> {
        let layout = ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("display"),
            entries: &[
                texture_layout_entry(0, UNFILTERABLE, wgpu::TextureViewDimension::D2),
                storage_texture_layout_entry(
                    1,
                    DISPLAY_FORMAT,
                    wgpu::StorageTextureAccess::WriteOnly,
                    wgpu::TextureViewDimension::D2,
                ),
                super::resources::buffer_layout_entry(
                    2,
                    wgpu::ShaderStages::COMPUTE,
                    wgpu::BufferBindingType::Uniform,
                ),
            ],
        });
        let pipeline = compute_pipeline(ctx, "display", KERNEL, &defines(), &[&layout])?;
        let uniforms = BufferBuilder::new("display uniforms", 16).uniform().copy().build(ctx)?;
        let texture = display_texture(ctx, 1, 1)?;
        Ok(Display { pipeline, layout, uniforms, texture, bound: None, exposure_ev: None })
    }

    /// The display image ([`DISPLAY_FORMAT`]); replaced (a new texture) when [`Self::update`] meets a
    /// source of another size.
    pub fn texture(&self) -> &wgpu::Texture {
        &self.texture
    }

    /// Tone-maps `radiance` (an rgba32float texture, e.g. [`crate::renderer::Renderer::output`]) into the
    /// display texture with `exposure_ev` stops and submits the work. The display texture follows the
    /// source's size (a new texture then: a caller holding one compares it with [`Self::texture`]).
    pub fn update(
        &mut self,
        ctx: &GpuContext,
        radiance: &wgpu::Texture,
        exposure_ev: f32,
    ) -> Result<(), GpuError> {
        if self.texture.size() != radiance.size() {
            self.texture = display_texture(ctx, radiance.width(), radiance.height())?;
            self.bound = None;
        }
        if self.bound.as_ref().is_none_or(|(source, _)| source != radiance) {
            let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("display"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(
                            &radiance.create_view(&Default::default()),
                        ),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(
                            &self.texture.create_view(&Default::default()),
                        ),
                    },
                    wgpu::BindGroupEntry { binding: 2, resource: self.uniforms.as_entire_binding() },
                ],
            });
            self.bound = Some((radiance.clone(), group));
        }
        if self.exposure_ev != Some(exposure_ev) {
            let uniforms = [exposure_ev.exp2(), 0.0, 0.0, 0.0];
            ctx.queue.write_buffer(&self.uniforms, 0, bytemuck::cast_slice(&uniforms));
            self.exposure_ev = Some(exposure_ev);
        }
        let Some((_, group)) = &self.bound else {
            return Err(GpuError::Other("display: no bind group".into()));
        };
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("display") });
        compute_pass(&mut encoder, "display", &self.pipeline, &[group]).dispatch_workgroups(
            self.texture.width().div_ceil(WORKGROUP),
            self.texture.height().div_ceil(WORKGROUP),
            1,
        );
        ctx.queue.submit([encoder.finish()]);
        Ok(())
    }
}

fn defines() -> Defines {
    Defines::new().u32("DISPLAY_WG", WORKGROUP)
}

fn display_texture(ctx: &GpuContext, width: u32, height: u32) -> Result<wgpu::Texture, GpuError> {
    TextureBuilder::d2("display", width, height, DISPLAY_FORMAT).storage().sampled().copy().build(ctx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::GpuOptions;
    use crate::image::{ToneMap, tone_map_pixel, unorm8};

    #[test]
    fn kernel_validates() {
        crate::shaders::validate("display", KERNEL, &defines());
    }

    /// Radiance spanning the tone curve (black, the linear sRGB toe, mid-tones, the shoulder, far
    /// past white) at two exposures: the GPU's 8-bit display values against the PNG's.
    #[test]
    fn gpu_tone_map_matches_the_png_tone_map() {
        let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU");
        let (width, height) = (64u32, 4u32);
        let radiance: Vec<f32> = (0..width * height)
            .flat_map(|i| {
                let x = (i as f32 / (width * height) as f32 * 14.0 - 10.0).exp2();
                let v = if i == 0 { 0.0 } else { x };
                [v, v * 0.5, v * 2.0, 1.0]
            })
            .collect();
        let source = TextureBuilder::d2("radiance", width, height, wgpu::TextureFormat::Rgba32Float)
            .sampled()
            .copy()
            .build(&ctx)
            .expect("texture");
        ctx.queue.write_texture(
            source.as_image_copy(),
            bytemuck::cast_slice(&radiance),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(width * 16), rows_per_image: None },
            source.size(),
        );
        let mut display = Display::new(&ctx).expect("display");
        let mut shown: Option<wgpu::Texture> = None;
        for exposure_ev in [0.0f32, -1.5] {
            display.update(&ctx, &source, exposure_ev).expect("update");
            assert_eq!(display.texture().size(), source.size());
            // Replaced only when the size first changes.
            assert!(shown.as_ref().is_none_or(|t| t == display.texture()), "replaced at the same size");
            shown = Some(display.texture().clone());
            let bytes = crate::gpu::readback::read_texture(&ctx, display.texture(), 4).expect("readback");
            let mut worst = 0;
            for (texel, rgba) in radiance.chunks(4).zip(bytes.chunks(4)) {
                let expected = tone_map_pixel([texel[0], texel[1], texel[2]], &ToneMap { exposure_ev });
                for c in 0..3 {
                    worst = worst.max((i32::from(unorm8(expected[c])) - i32::from(rgba[c])).abs());
                }
                assert_eq!(rgba[3], 255);
            }
            // Measured 0 on lavapipe; one step allows for another driver's pow and unorm rounding.
            assert!(worst <= 1, "exposure {exposure_ev}: display differs from the PNG by {worst} steps");
        }
    }
}
