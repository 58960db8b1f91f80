//! `path`: the reference unidirectional path tracer (see `path.wgsl` for the estimator).
//!
//! It samples pixel centres by default, like the G-buffer of the raster techniques, so that images
//! compare pixel for pixel; `pixel_jitter=true` box-filters each pixel instead.

use std::collections::BTreeMap;

use wgpu::util::DeviceExt;

use crate::frame::OUTPUT_FORMAT;
use crate::gpu::{GpuContext, Profiler, readback};
use crate::params::{ParamKind, ParamSpec};
use crate::shaders::Defines;
use crate::techniques::RenderError;

use super::compute::{self, DispatchSlots, storage_buffer_entry, storage_texture_entry};
use super::{FrameContext, FrameNeeds, Measured, Technique, TechniqueInfo, TechniqueSetup};

const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        name: "spp",
        kind: ParamKind::Int { min: 1, max: 65536 },
        default: "16",
        doc: "samples per pixel and frame (frames accumulate)",
    },
    ParamSpec {
        name: "max_bounces",
        kind: ParamKind::Int { min: -1, max: 1024 },
        default: "-1",
        doc: "indirect bounces; -1 = unlimited (Russian roulette), 0 = direct light only, 1 = one bounce",
    },
    ParamSpec {
        name: "nee",
        kind: ParamKind::Choice(&["mis", "light", "brdf"]),
        default: "mis",
        doc: "how area lights and the environment are sampled: MIS of both, light sampling or BRDF sampling only",
    },
    ParamSpec {
        name: "pixel_jitter",
        kind: ParamKind::Bool,
        default: "false",
        doc: "box-filter each pixel (true) or sample its centre like the raster techniques (false)",
    },
    ParamSpec {
        name: "subsurface",
        kind: ParamKind::Choice(&["walk", "lambertian"]),
        default: "walk",
        doc: "translucent materials: a random walk through the medium under a rough dielectric boundary (walk, \
              the ground truth of `subsurface`), or the Lambertian of the medium's total diffuse reflectance that \
              techniques without subsurface transport see (lambertian)",
    },
    ParamSpec {
        name: "walk_steps",
        kind: ParamKind::Int { min: 1, max: 60000 },
        default: "4096",
        doc: "scattering events after which a random walk is cut short (counted in `truncated_walks`)",
    },
    ParamSpec {
        name: "seed",
        kind: ParamKind::Int { min: 0, max: 4294967295 },
        default: "0",
        doc: "random seed",
    },
];

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "path",
    description: "reference path tracer: NEE for every light, GGX VNDF + Lambert BRDF sampling, MIS, roulette",
    params: PARAMS,
    needs: FrameNeeds { gbuffer: false },
    features: &[super::ACCUMULATES_OUTPUT],
    motion: super::Motion::Restarts,
    validate: super::independent_params,
    create,
};

const PASS: &str = "path trace";
/// Rays traced (a 64-bit count as two words) and random walks cut short (path.wgsl `ray_count`).
const RAY_COUNTER_BYTES: usize = 12;

struct PathTracer {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    ray_counter: wgpu::Buffer,
    spp: u32,
    sample_indices: DispatchSlots,
    samples: u64,
    samples_per_frame: u64,
    walk_steps: i64,
    /// Set when the stats are read: random walks were cut short.
    warnings: Vec<String>,
}

fn create(setup: &TechniqueSetup) -> Result<Box<dyn Technique>, RenderError> {
    let device = &setup.ctx.device;
    let p = setup.params;
    let spp = p.int("spp") as u32;
    // One sample per dispatch (the lavapipe loop bug, see README).
    let sample_indices = DispatchSlots::new(setup.ctx, "sample indices", &(0..spp).collect::<Vec<u32>>());
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("path"),
        entries: &[
            storage_texture_entry(0, OUTPUT_FORMAT, wgpu::StorageTextureAccess::ReadWrite),
            storage_buffer_entry(1, false),
            sample_indices.entry(2),
        ],
    });
    let ray_counter = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("ray counter"),
        contents: &[0u8; RAY_COUNTER_BYTES],
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
    });
    let view = setup.output.create_view(&Default::default());
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("path"),
        layout: &layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
            wgpu::BindGroupEntry { binding: 1, resource: ray_counter.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 2, resource: sample_indices.resource() },
        ],
    });
    let nee = match p.choice("nee") {
        "light" => 1,
        "brdf" => 2,
        _ => 0,
    };
    let defines = Defines::new()
        .u32("SPP", spp)
        .i32("MAX_BOUNCES", p.int("max_bounces") as i32)
        .u32("NEE_MODE", nee)
        .bool("PIXEL_JITTER", p.bool("pixel_jitter"))
        // Compiled out of scenes without a translucent material, so their paths pay nothing for it.
        .bool(
            "SUBSURFACE_WALK",
            p.choice("subsurface") == "walk" && setup.scene.materials.iter().any(|m| m.subsurface.is_some()),
        )
        .u32("MAX_WALK_STEPS", p.int("walk_steps") as u32);
    let pipeline = compute::pipeline(
        setup.ctx,
        "path",
        include_str!("path.wgsl"),
        setup.gpu_scene.bvh_defines(defines),
        "main",
        &[&setup.gpu_scene.bind_group_layout, &setup.frame.bind_group_layout, &layout],
    )?;
    Ok(Box::new(PathTracer {
        pipeline,
        bind_group,
        ray_counter,
        spp,
        sample_indices,
        samples: 0,
        samples_per_frame: 0,
        walk_steps: p.int("walk_steps"),
        warnings: Vec::new(),
    }))
}

impl Technique for PathTracer {
    // Lights, shadow maps and the environment are read from the scene every frame.
    fn scene_changed(
        &mut self,
        _: &crate::gpu::GpuContext,
        _: &crate::gpu::GpuScene,
        _: super::SceneChange,
    ) -> Result<bool, RenderError> {
        Ok(true)
    }

    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        profiler.pass(fc.ctx, PASS, |encoder| {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(PASS),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &fc.gpu_scene.bind_group, &[]);
            pass.set_bind_group(1, &fc.frame.bind_group, &[]);
            let (wx, wy) = (fc.frame.width.div_ceil(compute::TILE), fc.frame.height.div_ceil(compute::TILE));
            for offset in self.sample_indices.offsets() {
                pass.set_bind_group(2, &self.bind_group, &[offset]);
                pass.dispatch_workgroups(wx, wy, 1);
            }
        })?;
        self.samples_per_frame = u64::from(fc.frame.width) * u64::from(fc.frame.height) * u64::from(self.spp);
        self.samples += self.samples_per_frame;
        Ok(())
    }

    fn counters(
        &mut self,
        ctx: &GpuContext,
        measured: &Measured,
    ) -> Result<BTreeMap<String, f64>, RenderError> {
        let count = readback::read_buffer(ctx, &self.ray_counter, 0, RAY_COUNTER_BYTES as u64)?;
        let words: &[u32] = bytemuck::cast_slice(&count);
        let rays = (u64::from(words[1]) << 32 | u64::from(words[0])) as f64;
        let samples = self.samples as f64;
        // Rates over steady frames (a first frame's time includes pipeline compilation on lavapipe),
        // with the rays per sample of every frame rendered. Over all frames where steady times are
        // unknown; the path tracer is the frame's only pass, so the frames' wall time stands in for
        // it where per-pass times are unknown (frame timing without reliable timestamps).
        let samples_per_second = match measured.pass_steady_ms(PASS) {
            Some(ms) => self.samples_per_frame as f64 / (ms / 1e3).max(1e-12),
            None => samples / (measured.pass_ms(PASS).unwrap_or(measured.frames_wall_ms) / 1e3).max(1e-9),
        };
        let rays_per_sample = rays / samples.max(1.0);
        self.warnings.clear();
        if words[2] > 0 {
            self.warnings.push(format!(
                "path: {} random walks through translucent media were cut short after walk_steps={} scattering \
                 events; their light is missing (raise walk_steps)",
                words[2], self.walk_steps
            ));
        }
        Ok(BTreeMap::from([
            ("samples".to_string(), samples),
            ("rays".to_string(), rays),
            ("rays_per_sample".to_string(), rays_per_sample),
            ("samples_per_second".to_string(), samples_per_second),
            ("rays_per_second".to_string(), rays_per_sample * samples_per_second),
            ("truncated_walks".to_string(), f64::from(words[2])),
        ]))
    }

    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }
}

#[cfg(test)]
mod tests {
    use crate::shaders::{Defines, validate};

    #[test]
    fn shader_validates() {
        validate(
            "path",
            include_str!("path.wgsl"),
            &Defines::new()
                .u32("TILE", 8)
                .u32("SPP", 4)
                .i32("MAX_BOUNCES", -1)
                .u32("NEE_MODE", 0)
                .bool("PIXEL_JITTER", false)
                .bool("SUBSURFACE_WALK", true)
                .u32("MAX_WALK_STEPS", 4096),
        );
    }
}
