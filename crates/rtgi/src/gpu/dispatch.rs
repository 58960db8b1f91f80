//! Recording compute dispatches: direct ones share [`compute_pass`] with `techniques::compute`, and
//! indirect ones read their workgroup counts from a buffer a previous GPU pass wrote — with
//! `indirect_args` of `shaders/common/indirect.wgsl`, whose CPU twin is [`workgroups_for`].

/// Bytes of one indirect dispatch's arguments: three `u32` workgroup counts (x, y, z), as WGSL writes
/// them into an `array<u32, 3>` (or a struct of three `u32`) and `wgpu::util::DispatchIndirectArgs`
/// lays them out.
pub const DISPATCH_INDIRECT_ARGS_SIZE: u64 = size_of::<wgpu::util::DispatchIndirectArgs>() as u64;

/// Workgroup counts (x, y, 1) covering `invocations` threads in 1-D workgroups of `workgroup_size`, spread
/// over y once x would exceed `max_per_dimension` (the device's `max_compute_workgroups_per_dimension`);
/// a thread's linear index is then `id.x + id.y · x · workgroup_size`. The CPU twin of WGSL's
/// `indirect_args`.
pub fn workgroups_for(invocations: u32, workgroup_size: u32, max_per_dimension: u32) -> [u32; 3] {
    let groups = invocations.div_ceil(workgroup_size);
    let x = groups.min(max_per_dimension);
    let y = if x > 0 { groups.div_ceil(x) } else { 0 };
    [x, y, 1]
}

/// The compute pipeline of `source`'s `main` with `layouts` as groups 0, 1, ..., compiled inside an
/// error scope (a WGSL or layout error is returned, naming `name`). For the GPU and frame layers' own
/// kernels (mips, display, the ray-cast G-buffer); techniques build theirs through
/// `techniques::compute`.
pub fn compute_pipeline(
    ctx: &super::GpuContext,
    name: &str,
    source: &str,
    defines: &crate::shaders::Defines,
    layouts: &[&wgpu::BindGroupLayout],
) -> Result<wgpu::ComputePipeline, super::GpuError> {
    ctx.checked(name, || -> Result<_, super::GpuError> {
        let module = crate::shaders::create_module(ctx, name, source, defines)
            .map_err(|e| super::GpuError::Other(e.to_string()))?;
        let pipeline_layout = ctx.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(name),
            bind_group_layouts: &layouts.iter().map(|l| Some(*l)).collect::<Vec<_>>(),
            immediate_size: 0,
        });
        Ok(ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: Some(&pipeline_layout),
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        }))
    })?
}

/// Begins a compute pass labelled `label` with `pipeline` and `bind_groups` (as groups 0, 1, ...) set.
pub fn compute_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_groups: &[&wgpu::BindGroup],
) -> wgpu::ComputePass<'e> {
    let mut pass = encoder
        .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
    pass.set_pipeline(pipeline);
    for (i, g) in bind_groups.iter().enumerate() {
        pass.set_bind_group(i as u32, *g, &[]);
    }
    pass
}

/// Records a dispatch whose workgroup counts are the three `u32` at `offset` (a multiple of 4) in
/// `args`, a buffer with `INDIRECT` usage. The pass that writes them must clamp each count to
/// `max_compute_workgroups_per_dimension`: the count is only known on the GPU, so no host check can.
pub fn dispatch_indirect(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_groups: &[&wgpu::BindGroup],
    args: &wgpu::Buffer,
    offset: u64,
) {
    compute_pass(encoder, label, pipeline, bind_groups).dispatch_workgroups_indirect(args, offset);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::resources::BufferBuilder;
    use crate::gpu::{GpuContext, GpuOptions, readback};
    use crate::shaders::{Defines, create_module};

    const WORKGROUP: u32 = 64;

    fn pipeline(ctx: &GpuContext, name: &str, source: &str, max_per_dimension: u32) -> wgpu::ComputePipeline {
        let defines = Defines::new().u32("WORKGROUP", WORKGROUP).u32("MAX_PER_DIMENSION", max_per_dimension);
        let module = create_module(ctx, name, source, &defines).expect("shader");
        ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        })
    }

    #[test]
    fn workgroups_cover_the_workload_within_the_limit() {
        assert_eq!(workgroups_for(1000, 64, 65535), [16, 1, 1]);
        assert_eq!(workgroups_for(0, 64, 65535), [0, 0, 1]);
        assert_eq!(workgroups_for(1000, 64, 4), [4, 4, 1]);
        // 2^26 workgroups for u32::MAX threads: 65535 × 1025 of them.
        let [x, y, _] = workgroups_for(u32::MAX, 64, 65535);
        assert_eq!((x, y), (65535, 1025));
        assert!(u64::from(x) * u64::from(y) * 64 >= u64::from(u32::MAX));
    }

    /// A kernel derives the workgroup counts from data on the GPU (`indirect_args`, with a limit of 4
    /// per dimension so that they spread over y); the indirectly dispatched kernel then counts every
    /// invocation with an atomic, and every linear index inside the workload per index: the count must
    /// be the dispatched workgroups × 64, and every index below the workload reached exactly once.
    #[test]
    fn indirect_dispatch_runs_the_gpu_written_workgroup_count() {
        const MAX_PER_DIMENSION: u32 = 4;
        const INVOCATIONS: u32 = 1000;
        let ctx = GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (lavapipe)");
        let write_args = pipeline(
            &ctx,
            "write args",
            "#import common/indirect.wgsl
@group(0) @binding(0) var<storage, read> items: array<u32>;
@group(0) @binding(1) var<storage, read_write> args: array<u32, 3>;
@compute @workgroup_size(1)
fn main() {
    let a = indirect_args(items[0], WORKGROUP, MAX_PER_DIMENSION);
    args[0] = a.x;
    args[1] = a.y;
    args[2] = a.z;
}",
            MAX_PER_DIMENSION,
        );
        let count = pipeline(
            &ctx,
            "count invocations",
            "#import common/indirect.wgsl
@group(0) @binding(0) var<storage, read> items: array<u32>;
@group(0) @binding(1) var<storage, read_write> counter: atomic<u32>;
@group(0) @binding(2) var<storage, read_write> seen: array<atomic<u32>>;
@compute @workgroup_size(WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    atomicAdd(&counter, 1u);
    let i = indirect_linear_index(id, groups, WORKGROUP);
    if i >= items[0] {
        return;
    }
    atomicAdd(&seen[i], 1u);
}",
            MAX_PER_DIMENSION,
        );
        let items =
            BufferBuilder::with_contents("items", bytemuck::bytes_of(&INVOCATIONS)).storage().build(&ctx);
        let args =
            BufferBuilder::new("args", DISPATCH_INDIRECT_ARGS_SIZE).storage().indirect().copy().build(&ctx);
        let counter = BufferBuilder::new("counter", 4).storage().copy().build(&ctx);
        let seen = BufferBuilder::new("seen", 4 * u64::from(INVOCATIONS)).storage().copy().build(&ctx);
        let (items, args) = (items.expect("items"), args.expect("args"));
        let (counter, seen) = (counter.expect("counter"), seen.expect("seen"));
        let group = |pipeline: &wgpu::ComputePipeline, buffers: &[&wgpu::Buffer]| {
            let entries: Vec<_> = buffers
                .iter()
                .enumerate()
                .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
                .collect();
            ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            })
        };
        let args_group = group(&write_args, &[&items, &args]);
        let count_group = group(&count, &[&items, &counter, &seen]);
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        compute_pass(&mut encoder, "write args", &write_args, &[&args_group]).dispatch_workgroups(1, 1, 1);
        dispatch_indirect(&mut encoder, "count", &count, &[&count_group], &args, 0);
        ctx.queue.submit([encoder.finish()]);

        let want = workgroups_for(INVOCATIONS, WORKGROUP, MAX_PER_DIMENSION);
        assert_eq!(want, [4, 4, 1]);
        let args = readback::read_buffer(&ctx, &args, 0, DISPATCH_INDIRECT_ARGS_SIZE).expect("args");
        assert_eq!(bytemuck::cast_slice::<u8, u32>(&args), &want);
        let counted = readback::read_buffer(&ctx, &counter, 0, 4).expect("counter");
        assert_eq!(bytemuck::cast_slice::<u8, u32>(&counted), &[want.iter().product::<u32>() * WORKGROUP]);
        let seen = readback::read_buffer(&ctx, &seen, 0, 4 * u64::from(INVOCATIONS)).expect("seen");
        let seen: &[u32] = bytemuck::cast_slice(&seen);
        assert!(
            seen.iter().all(|n| *n == 1),
            "indices not reached exactly once: {:?}",
            seen.iter().enumerate().filter(|(_, n)| **n != 1).take(8).collect::<Vec<_>>()
        );
    }
}
