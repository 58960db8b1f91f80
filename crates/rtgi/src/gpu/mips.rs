//! Mip chains generated on the GPU: a compute box filter (`mips.wgsl`, exact for odd sizes by weighting
//! partly covered texels) for 2-D, 2-D array and 3-D textures of float storage formats, one dispatch
//! per level recorded into the caller's encoder.

use std::collections::HashMap;
use std::sync::Mutex;

use super::dispatch::{compute_pass, compute_pipeline};
use super::resources::{storage_texture_layout_entry, texture_layout_entry};
use super::{GpuContext, GpuError};
use crate::shaders::Defines;

const KERNEL: &str = include_str!("mips.wgsl");

/// Bindings and accessors of `mips.wgsl` for 2-D (array) textures: p = (x, y, layer).
const PRELUDE_2D: &str = "@group(0) @binding(0) var src: texture_2d_array<f32>;
@group(0) @binding(1) var dst: texture_storage_2d_array<MIP_FORMAT, write>;
fn src_size() -> vec3u { return vec3u(textureDimensions(src), textureNumLayers(src)); }
fn dst_size() -> vec3u { return vec3u(textureDimensions(dst), textureNumLayers(dst)); }
fn load_src(p: vec3u) -> vec4f { return textureLoad(src, p.xy, p.z, 0); }
fn store_dst(p: vec3u, v: vec4f) { textureStore(dst, p.xy, p.z, v); }
";

/// Bindings and accessors of `mips.wgsl` for 3-D textures.
const PRELUDE_3D: &str = "@group(0) @binding(0) var src: texture_3d<f32>;
@group(0) @binding(1) var dst: texture_storage_3d<MIP_FORMAT, write>;
fn src_size() -> vec3u { return textureDimensions(src); }
fn dst_size() -> vec3u { return textureDimensions(dst); }
fn load_src(p: vec3u) -> vec4f { return textureLoad(src, p, 0); }
fn store_dst(p: vec3u, v: vec4f) { textureStore(dst, p, v); }
";

/// Workgroup of 2-D levels (one layer per z) and of 3-D levels: 64 invocations each.
const WORKGROUP_2D: [u32; 3] = [8, 8, 1];
const WORKGROUP_3D: [u32; 3] = [4, 4, 4];

/// The formats whose mips this module generates, with their WGSL storage-format names: float formats
/// every WebGPU device can write as storage.
const FORMATS: [(wgpu::TextureFormat, &str); 3] = [
    (wgpu::TextureFormat::Rgba16Float, "rgba16float"),
    (wgpu::TextureFormat::Rgba32Float, "rgba32float"),
    (wgpu::TextureFormat::R32Float, "r32float"),
];

/// Which shape a texture's views take in the kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Shape {
    /// 2-D textures, viewed as arrays (one layer or more).
    D2,
    D3,
}

impl Shape {
    fn of(texture: &wgpu::Texture) -> Result<Shape, GpuError> {
        match texture.dimension() {
            wgpu::TextureDimension::D2 => Ok(Shape::D2),
            wgpu::TextureDimension::D3 => Ok(Shape::D3),
            wgpu::TextureDimension::D1 => {
                Err(GpuError::Other("mips of 1-D textures are not supported".into()))
            }
        }
    }

    fn view_dimension(self) -> wgpu::TextureViewDimension {
        match self {
            Shape::D2 => wgpu::TextureViewDimension::D2Array,
            Shape::D3 => wgpu::TextureViewDimension::D3,
        }
    }

    fn workgroup(self) -> [u32; 3] {
        match self {
            Shape::D2 => WORKGROUP_2D,
            Shape::D3 => WORKGROUP_3D,
        }
    }

    fn prelude(self) -> &'static str {
        match self {
            Shape::D2 => PRELUDE_2D,
            Shape::D3 => PRELUDE_3D,
        }
    }
}

/// The composed kernel for `shape` writing `wgsl_format`, and its defines.
fn source(shape: Shape, wgsl_format: &str) -> (String, Defines) {
    let [x, y, z] = shape.workgroup();
    let source = format!("{}\n{KERNEL}", shape.prelude().replace("MIP_FORMAT", wgsl_format));
    (source, Defines::new().u32("MIP_WG_X", x).u32("MIP_WG_Y", y).u32("MIP_WG_Z", z))
}

struct MipPipeline {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

/// Generates mip chains. Pipelines are created on first use per (format, dimension) and kept; share
/// one generator (it is `Sync`) rather than making one per call.
#[derive(Default)]
pub struct MipGenerator {
    pipelines: Mutex<HashMap<(wgpu::TextureFormat, Shape), MipPipeline>>,
}

impl MipGenerator {
    pub fn new() -> Self {
        Self::default()
    }

    /// How many pipelines have been created so far (one per format and dimension used).
    pub fn pipeline_count(&self) -> usize {
        self.pipelines.lock().map(|p| p.len()).unwrap_or(0)
    }

    /// Records into `encoder` the passes that fill mip levels 1.. of `texture` from level 0, each level
    /// from the one above (every layer of a 2-D array on its own). The texture needs `TEXTURE_BINDING`
    /// and `STORAGE_BINDING` usage and a format of `FORMATS`; nothing is submitted.
    pub fn record(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
    ) -> Result<(), GpuError> {
        let shape = Shape::of(texture)?;
        let format = texture.format();
        let wgsl_format =
            FORMATS.iter().find(|(f, _)| *f == format).map(|(_, name)| *name).ok_or_else(|| {
                GpuError::Other(format!(
                    "mip generation of {format:?}: supported formats are {}",
                    FORMATS.map(|(_, n)| n).join(", ")
                ))
            })?;
        let needed = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING;
        if !texture.usage().contains(needed) {
            return Err(GpuError::Other(format!(
                "mip generation needs TEXTURE_BINDING and STORAGE_BINDING usage; the texture has {:?}",
                texture.usage()
            )));
        }
        if texture.mip_level_count() < 2 {
            return Ok(());
        }
        let mut pipelines =
            self.pipelines.lock().map_err(|_| GpuError::Other("mip pipeline cache poisoned".into()))?;
        let entry = match pipelines.entry((format, shape)) {
            std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::hash_map::Entry::Vacant(e) => {
                e.insert(create_pipeline(ctx, shape, format, wgsl_format)?)
            }
        };
        let view = |level: u32| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("mip level"),
                dimension: Some(shape.view_dimension()),
                base_mip_level: level,
                mip_level_count: Some(1),
                ..Default::default()
            })
        };
        let groups: Vec<(wgpu::BindGroup, wgpu::Extent3d)> = (1..texture.mip_level_count())
            .map(|level| {
                let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("mip level"),
                    layout: &entry.layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: wgpu::BindingResource::TextureView(&view(level - 1)),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::TextureView(&view(level)),
                        },
                    ],
                });
                (group, texture.size().mip_level_size(level, texture.dimension()))
            })
            .collect();
        // One pass, one dispatch per level: wgpu orders each dispatch's reads after the previous
        // dispatch's writes (every dispatch is its own usage scope).
        let mut pass = compute_pass(encoder, "mips", &entry.pipeline, &[]);
        let [wx, wy, wz] = shape.workgroup();
        for (group, size) in &groups {
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(
                size.width.div_ceil(wx),
                size.height.div_ceil(wy),
                size.depth_or_array_layers.div_ceil(wz),
            );
        }
        Ok(())
    }
}

fn create_pipeline(
    ctx: &GpuContext,
    shape: Shape,
    format: wgpu::TextureFormat,
    wgsl_format: &str,
) -> Result<MipPipeline, GpuError> {
    let name = format!("mips {wgsl_format} {shape:?}");
    let (source, defines) = source(shape, wgsl_format);
    let layout = ctx.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(&name),
        entries: &[
            // Unfilterable: the kernel only loads, and 32-bit floats need not be filterable.
            texture_layout_entry(
                0,
                wgpu::TextureSampleType::Float { filterable: false },
                shape.view_dimension(),
            ),
            storage_texture_layout_entry(
                1,
                format,
                wgpu::StorageTextureAccess::WriteOnly,
                shape.view_dimension(),
            ),
        ],
    });
    let pipeline = compute_pipeline(ctx, &name, &source, &defines, &[&layout])?;
    Ok(MipPipeline { pipeline, layout })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::GpuOptions;
    use crate::gpu::readback::read_texture_level;
    use crate::gpu::resources::TextureBuilder;

    #[test]
    fn kernels_validate() {
        for shape in [Shape::D2, Shape::D3] {
            for (_, name) in FORMATS {
                let (source, defines) = source(shape, name);
                crate::shaders::validate(&format!("mips {name} {shape:?}"), &source, &defines);
            }
        }
    }

    /// The CPU twin of `mips.wgsl`: destination texel j averages source interval [j·s, (j+1)·s) per
    /// axis, partly covered texels weighted by the covered length (f64). `size` is (w, h, d) and
    /// `filter_z` is false for array layers.
    fn box_downsample(src: &[f64], channels: usize, size: [u32; 3], filter_z: bool) -> (Vec<f64>, [u32; 3]) {
        let half = |n: u32| (n / 2).max(1);
        let dst = [half(size[0]), half(size[1]), if filter_z { half(size[2]) } else { size[2] }];
        let weights = |j: u32, n: u32, m: u32| -> Vec<(u32, f64)> {
            let s = f64::from(n) / f64::from(m);
            let (lo, hi) = (f64::from(j) * s, f64::from(j + 1) * s);
            (0..n)
                .map(|i| (i, (f64::from(i + 1).min(hi) - f64::from(i).max(lo)).max(0.0)))
                .filter(|(_, w)| *w > 0.0)
                .collect()
        };
        let mut out = Vec::new();
        for z in 0..dst[2] {
            let wz = if filter_z { weights(z, size[2], dst[2]) } else { vec![(z, 1.0)] };
            for y in 0..dst[1] {
                for x in 0..dst[0] {
                    let mut sum = vec![0.0; channels];
                    let mut total = 0.0;
                    for &(sz, a) in &wz {
                        for (sy, b) in weights(y, size[1], dst[1]) {
                            for (sx, c) in weights(x, size[0], dst[0]) {
                                let i = ((sz * size[1] + sy) * size[0] + sx) as usize * channels;
                                for (k, s) in sum.iter_mut().enumerate() {
                                    *s += a * b * c * src[i + k];
                                }
                                total += a * b * c;
                            }
                        }
                    }
                    out.extend(sum.iter().map(|s| s / total));
                }
            }
        }
        (out, dst)
    }

    #[test]
    fn box_downsample_by_hand() {
        // 5 texels → 2: [0, 2.5) and [2.5, 5).
        let (out, size) = box_downsample(&[1.0, 2.0, 3.0, 4.0, 5.0], 1, [5, 1, 1], true);
        assert_eq!(size, [2, 1, 1]);
        assert_eq!(out, vec![(1.0 + 2.0 + 1.5) / 2.5, (1.5 + 4.0 + 5.0) / 2.5]);
    }

    /// Texel values of `format` as f64 (half floats decoded).
    fn decode(format: wgpu::TextureFormat, bytes: &[u8]) -> Vec<f64> {
        match format {
            wgpu::TextureFormat::Rgba16Float => {
                bytemuck::cast_slice::<u8, half::f16>(bytes).iter().map(|h| h.to_f64()).collect()
            }
            _ => bytemuck::cast_slice::<u8, f32>(bytes).iter().map(|f| f64::from(*f)).collect(),
        }
    }

    /// Fills level 0 with pseudo-random values in [0, 4), generates the chain, and checks every level
    /// against the CPU box filter of the level above as the GPU wrote it (so half-float rounding of
    /// one level does not count against the next), within `tolerance` relative to the value.
    fn check_chain(ctx: &GpuContext, mips: &MipGenerator, texture: &wgpu::Texture, tolerance: f64) {
        let format = texture.format();
        let channels = format.components() as usize;
        let size0 = texture.size();
        let texels = (size0.width * size0.height * size0.depth_or_array_layers) as usize;
        let values: Vec<f32> = (0..texels * channels)
            .map(|i| ((i as u32).wrapping_mul(2_654_435_761) >> 8) as f32 / 16_777_216.0 * 4.0)
            .collect();
        let bytes: Vec<u8> = match format {
            wgpu::TextureFormat::Rgba16Float => {
                values.iter().flat_map(|v| half::f16::from_f32(*v).to_le_bytes()).collect()
            }
            _ => bytemuck::cast_slice(&values).to_vec(),
        };
        let texel = format.block_copy_size(None).expect("colour format");
        ctx.queue.write_texture(
            texture.as_image_copy(),
            &bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size0.width * texel),
                rows_per_image: Some(size0.height),
            },
            size0,
        );
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        mips.record(ctx, &mut encoder, texture).expect("record mips");
        ctx.queue.submit([encoder.finish()]);

        let filter_z = texture.dimension() == wgpu::TextureDimension::D3;
        let mut above = decode(format, &read_texture_level(ctx, texture, 0).expect("level 0"));
        let mut size = [size0.width, size0.height, size0.depth_or_array_layers];
        for level in 1..texture.mip_level_count() {
            let (want, want_size) = box_downsample(&above, channels, size, filter_z);
            let got = decode(format, &read_texture_level(ctx, texture, level).expect("level"));
            let s = texture.size().mip_level_size(level, texture.dimension());
            assert_eq!(want_size, [s.width, s.height, s.depth_or_array_layers], "level {level} size");
            assert_eq!(got.len(), want.len(), "level {level}");
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(
                    (g - w).abs() <= tolerance * w.abs().max(1.0),
                    "{format:?} {size0:?}, level {level} value {i}: GPU {g}, CPU {w}"
                );
            }
            (above, size) = (got, want_size);
        }
    }

    #[test]
    fn mip_chains_match_the_cpu_box_filter() {
        let ctx =
            GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (lavapipe) for the mip tests");
        let mips = MipGenerator::new();
        let cases = [
            TextureBuilder::d3("odd volume", 5, 3, 7, wgpu::TextureFormat::Rgba32Float),
            TextureBuilder::d3("volume", 16, 9, 12, wgpu::TextureFormat::R32Float),
            TextureBuilder::d2("odd map", 13, 7, wgpu::TextureFormat::Rgba32Float),
            TextureBuilder::d2_array("layers", 10, 6, 3, wgpu::TextureFormat::Rgba16Float),
            TextureBuilder::d3("cube volume", 9, 9, 9, wgpu::TextureFormat::Rgba32Float),
        ];
        for case in cases {
            let texture = case.full_mip_chain().storage().sampled().copy().build(&ctx).expect("texture");
            let tolerance = if texture.format() == wgpu::TextureFormat::Rgba16Float { 1e-3 } else { 1e-5 };
            check_chain(&ctx, &mips, &texture, tolerance);
        }
        // Five textures, four (format, dimension) pairs: the second rgba32float volume reused a pipeline.
        assert_eq!(mips.pipeline_count(), 4);
    }

    #[test]
    fn unsupported_textures_are_refused() {
        let ctx =
            GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (lavapipe) for the mip tests");
        let mips = MipGenerator::new();
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        let ldr =
            TextureBuilder::d2("ldr", 4, 4, wgpu::TextureFormat::Rgba8Unorm).mips(2).sampled().build(&ctx);
        let e = mips.record(&ctx, &mut encoder, &ldr.expect("texture")).unwrap_err().to_string();
        assert!(e.contains("rgba16float, rgba32float, r32float"), "{e}");
        let sampled_only =
            TextureBuilder::d2("no storage", 4, 4, wgpu::TextureFormat::R32Float).mips(2).sampled();
        let e = mips.record(&ctx, &mut encoder, &sampled_only.build(&ctx).expect("texture")).unwrap_err();
        assert!(e.to_string().contains("STORAGE_BINDING"), "{e}");
        assert_eq!(mips.pipeline_count(), 0);
    }
}
