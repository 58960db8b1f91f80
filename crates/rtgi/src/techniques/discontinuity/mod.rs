//! The discontinuity filter of interleaved sampling, shared by every technique that interleaves
//! (`igi`, `igi-sh`, `rsm-interleaved`): see `filter.wgsl` for what it averages and where it stops.

use crate::gpu::Profiler;
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute;
use super::{FrameContext, TechniqueSetup};

/// Where the filter stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterSettings {
    /// Window in pixels; for interleaved sampling, the interleaving pattern n × m.
    pub window: [u32; 2],
    /// Largest distance of a neighbour from the centre's tangent plane, relative to the camera distance.
    pub depth_threshold: f32,
    /// Smallest cosine between shading normals; `None` lets the filter cross normal changes.
    pub normal_cos: Option<f32>,
    /// Stop at material (object) boundaries.
    pub material_test: bool,
}

/// Bytes of a buffer holding `vec4s` packed half-float vec4s per pixel.
pub fn packed_buffer_bytes(width: u32, height: u32, vec4s: u32) -> u64 {
    u64::from(width) * u64::from(height) * u64::from(vec4s) * 8
}

pub struct DiscontinuityFilter {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
}

impl DiscontinuityFilter {
    /// Filters `input` into `output`, both of [`packed_buffer_bytes`] for the frame size.
    pub fn new(
        setup: &TechniqueSetup,
        input: &wgpu::Buffer,
        output: &wgpu::Buffer,
        vec4s_per_pixel: u32,
        settings: &FilterSettings,
    ) -> Result<Self, RenderError> {
        let ctx = setup.ctx;
        let layout = compute::layout(
            ctx,
            "discontinuity filter",
            &[compute::storage_buffer_entry(0, true), compute::storage_buffer_entry(1, false)],
        );
        let bind_group = compute::bind_group(
            ctx,
            "discontinuity filter",
            &layout,
            &[input.as_entire_binding(), output.as_entire_binding()],
        );
        let pipeline = compute::pipeline(
            ctx,
            "discontinuity filter",
            include_str!("filter.wgsl"),
            defines(vec4s_per_pixel, settings),
            "main",
            &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout],
        )?;
        Ok(DiscontinuityFilter { pipeline, bind_group })
    }

    /// Records the filter as the pass `name`.
    pub fn render(&self, fc: &FrameContext, profiler: &mut Profiler, name: &str) -> Result<(), RenderError> {
        compute::frame_pass(fc, profiler, name, &self.pipeline, &self.bind_group)
    }
}

fn defines(vec4s: u32, s: &FilterSettings) -> Defines {
    Defines::new()
        .u32("VEC4S", vec4s)
        .u32("WINDOW_X", s.window[0].max(1))
        .u32("WINDOW_Y", s.window[1].max(1))
        .f32("DEPTH_THRESHOLD", s.depth_threshold)
        .f32("NORMAL_COS", s.normal_cos.unwrap_or(-2.0))
        .bool("MATERIAL_TEST", s.material_test)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FrameResources, FrameSettings};
    use crate::gpu::{GpuContext, GpuOptions, GpuScene, readback};
    use crate::params::ParamValues;
    use crate::shaders::validate;
    use wgpu::util::DeviceExt;

    fn half(x: f32) -> u16 {
        half::f16::from_f32(x).to_bits()
    }

    fn unhalf(bits: u16) -> f32 {
        half::f16::from_bits(bits).to_f32()
    }

    /// On the Cornell box's G-buffer, filters per pixel (material index, interleaving set of a 4×4
    /// pattern, 1, 0): the material channel must come out unchanged everywhere (the filter never mixes
    /// materials), and wherever the whole 4×4 window lies on one wall the set channel must be the mean
    /// of all 16 sets, 7.5 (each set seen exactly once).
    #[test]
    fn filter_averages_one_cell_and_never_mixes_materials() {
        let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
        let scene = crate::scene::builtin::build("cornell", &[]).expect("cornell");
        let gpu_scene = GpuScene::new(&ctx, &scene).expect("scene upload");
        let (w, h) = (48u32, 48u32);
        let mut frame =
            FrameResources::new(&ctx, &gpu_scene, &scene, w, h, FrameSettings::plain()).expect("frame");
        let mut profiler = Profiler::new(&ctx, crate::gpu::TimingMode::Passes);
        let view = frame.view;
        frame.set_view(&ctx, &view, 0);
        frame.render_inputs(&ctx, &gpu_scene, &mut profiler).expect("gbuffer");
        let material: Vec<u32> = bytemuck::cast_slice::<u8, u32>(
            &readback::read_texture(&ctx, &frame.gbuffer.material, 8).expect("readback"),
        )
        .chunks_exact(2)
        .map(|m| m[0])
        .collect();
        let distance: Vec<f32> = bytemuck::cast_slice(
            &readback::read_texture(&ctx, &frame.gbuffer.distance, 4).expect("readback"),
        )
        .to_vec();
        let normal: Vec<[f32; 4]> = bytemuck::cast_slice::<u8, u16>(
            &readback::read_texture(&ctx, &frame.gbuffer.normal, 8).expect("readback"),
        )
        .chunks_exact(4)
        .map(|n| [unhalf(n[0]), unhalf(n[1]), unhalf(n[2]), unhalf(n[3])])
        .collect();
        let set = |x: u32, y: u32| (x % 4 + 4 * (y % 4)) as f32;
        let mut input: Vec<u16> = Vec::new();
        for y in 0..h {
            for x in 0..w {
                input.extend([
                    half(material[(y * w + x) as usize] as f32),
                    half(set(x, y)),
                    half(1.0),
                    half(HALF_MAX),
                ]);
            }
        }
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let input_buffer = ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("filter input"),
            contents: bytemuck::cast_slice(&input),
            usage,
        });
        let output_buffer =
            super::compute::storage_buffer(&ctx, "filter output", packed_buffer_bytes(w, h, 1));
        let output_texture =
            super::compute::storage_texture(&ctx, "unused", 1, 1, crate::frame::OUTPUT_FORMAT);
        let params = ParamValues::default();
        let setup = TechniqueSetup {
            ctx: &ctx,
            scene: &scene,
            gpu_scene: &gpu_scene,
            frame: &frame,
            params: &params,
            output: &output_texture,
        };
        let settings =
            FilterSettings { window: [4, 4], depth_threshold: 0.02, normal_cos: None, material_test: true };
        let filter =
            DiscontinuityFilter::new(&setup, &input_buffer, &output_buffer, 1, &settings).expect("filter");
        let fc = FrameContext::still(&ctx, &gpu_scene, &frame);
        filter.render(&fc, &mut profiler, "filter").expect("filter pass");
        let out: Vec<f32> = bytemuck::cast_slice::<u8, u16>(
            &readback::read_buffer(&ctx, &output_buffer, 0, packed_buffer_bytes(w, h, 1)).expect("readback"),
        )
        .iter()
        .map(|&b| unhalf(b))
        .collect();
        let mut interior = 0;
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                if distance[i] <= 0.0 {
                    continue;
                }
                assert_eq!(out[i * 4], material[i] as f32, "pixel ({x}, {y}) mixed materials");
                assert_eq!(out[i * 4 + 2], 1.0, "pixel ({x}, {y}): weights do not sum to one");
                assert_eq!(out[i * 4 + 3], HALF_MAX, "pixel ({x}, {y}): the largest half did not survive");
                // Is the whole window (x−1..x+2, y−1..y+2) on the centre's wall?
                let on_wall = (0..16).all(|k| {
                    let (qx, qy) = (x as i32 - 1 + k % 4, y as i32 - 1 + k / 4);
                    if qx < 0 || qy < 0 || qx >= w as i32 || qy >= h as i32 {
                        return false;
                    }
                    let q = (qy as u32 * w + qx as u32) as usize;
                    material[q] == material[i]
                        && (normal[q][2] - normal[i][2]).abs() < 1e-3
                        && (normal[q][3] - normal[i][3]).abs() < 1e-3
                        && (distance[q] - distance[i]).abs() < 0.05 * distance[i]
                });
                if on_wall {
                    interior += 1;
                    assert_eq!(out[i * 4 + 1], 7.5, "pixel ({x}, {y}) did not see every set once");
                }
            }
        }
        // 477 of 2304 pixels measured (the side walls are seen at grazing angles).
        assert!(interior > (w * h / 6) as usize, "only {interior} pixels had a full window on one wall");
    }

    const HALF_MAX: f32 = 65504.0;

    const HALF_KERNEL: &str = "#import common/math.wgsl
@group(0) @binding(0) var<storage, read> input: array<vec4f>;
@group(0) @binding(1) var<storage, read_write> output: array<vec4f>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= arrayLength(&input) { return; }
    let v = input[id.x];
    // The packed bits go out as they are (unpacked on the CPU): NVIDIA's compiler folds a pack and
    // unpack in one shader into nothing, and in rtgi they meet only across passes, through memory.
    let packed = pack_half4(v);
    output[2u * id.x] = vec4f(bitcast<f32>(packed.x), bitcast<f32>(packed.y), 0.0, 0.0);
    let largest = max(abs(v.xyz), vec3f(0.0));
    output[2u * id.x + 1u] = vec4f(v.xyz * half_fit_scale(largest), 0.0);
}";

    /// Values beyond the half range saturate when packed (no ±∞ for the filter to spread), values in
    /// range round to the nearest half, and `half_fit_scale` brings a channel just into range.
    #[test]
    fn half_storage_saturates_and_fits_values_beyond_its_range() {
        let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
        let input: Vec<[f32; 4]> = vec![
            [1e5, -1e6, 65504.0, 70000.0],
            [1.0, -2.5, 3e-3, 65519.0],
            [1e30, 0.0, -1e30, 12.0],
            [-65504.0, 4e4, 131008.0, 0.5],
        ];
        let out = crate::gpu::kernel::run_kernel(
            &ctx,
            "half storage",
            HALF_KERNEL,
            bytemuck::cast_slice(&input),
            input.len() as u32,
            input.len() * 8,
        )
        .expect("kernel");
        for (k, v) in input.iter().enumerate() {
            let words = [out[8 * k].to_bits(), out[8 * k + 1].to_bits()];
            for c in 0..4 {
                let packed = unhalf((words[c / 2] >> (16 * (c % 2))) as u16);
                let clamped = v[c].clamp(-HALF_MAX, HALF_MAX);
                // WGSL lets a conversion to a narrower float round either way: the packed value must
                // be one of the two halves around it.
                let nearest = half(clamped);
                let other = if unhalf(nearest) == clamped {
                    nearest
                } else if (unhalf(nearest) < clamped) == (clamped > 0.0) {
                    nearest + 1
                } else {
                    nearest - 1
                };
                assert!(
                    packed == unhalf(nearest) || packed == unhalf(other),
                    "input {k} channel {c}: {} packed as {packed}, expected {} or {}",
                    v[c],
                    unhalf(nearest),
                    unhalf(other)
                );
            }
            for c in 0..3 {
                let fitted = out[8 * k + 4 + c];
                let expected = if v[c].abs() > HALF_MAX { HALF_MAX * v[c].signum() } else { v[c] };
                assert!(
                    (fitted - expected).abs() <= 1e-6 * HALF_MAX,
                    "input {k} channel {c}: {} fitted to {fitted}, expected {expected}",
                    v[c]
                );
            }
        }
    }

    #[test]
    fn shader_validates() {
        let s = FilterSettings {
            window: [4, 4],
            depth_threshold: 0.02,
            normal_cos: Some(0.9),
            material_test: true,
        };
        validate("discontinuity filter", include_str!("filter.wgsl"), &defines(7, &s).u32("TILE", 8));
    }
}
