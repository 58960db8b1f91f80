//! Recording compute dispatches: direct ones share [`compute_pass`] with `techniques::compute`, and
//! indirect ones read their workgroup counts from a buffer a previous GPU pass wrote.

/// Bytes of one indirect dispatch's arguments: three `u32` workgroup counts (x, y, z), as WGSL writes
/// them into an `array<u32, 3>` (or a struct of three `u32`) and `wgpu::util::DispatchIndirectArgs`
/// lays them out.
pub const DISPATCH_INDIRECT_ARGS_SIZE: u64 = size_of::<wgpu::util::DispatchIndirectArgs>() as u64;

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

    fn pipeline(ctx: &GpuContext, name: &str, source: &str) -> wgpu::ComputePipeline {
        let module = create_module(&ctx.device, name, source, &Defines::new().u32("WORKGROUP", WORKGROUP))
            .expect("shader");
        ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(name),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        })
    }

    /// A kernel derives the workgroup counts from data on the GPU; an indirect dispatch of a kernel that
    /// counts its invocations with an atomic must then run exactly that many workgroups.
    #[test]
    fn indirect_dispatch_runs_the_gpu_written_workgroup_count() {
        let ctx = GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (lavapipe)");
        let write_args = pipeline(
            &ctx,
            "write args",
            "@group(0) @binding(0) var<storage, read> items: array<u32>;
@group(0) @binding(1) var<storage, read_write> args: array<u32, 3>;
@compute @workgroup_size(1)
fn main() {
    // Enough workgroups for items[0] invocations on x; y and z from the data too.
    args[0] = (items[0] + WORKGROUP - 1u) / WORKGROUP;
    args[1] = items[1];
    args[2] = items[2];
}",
        );
        let count = pipeline(
            &ctx,
            "count invocations",
            "@group(0) @binding(0) var<storage, read_write> counter: atomic<u32>;
@compute @workgroup_size(WORKGROUP)
fn main() {
    atomicAdd(&counter, 1u);
}",
        );
        let items: [u32; 3] = [1000, 3, 2];
        let items = BufferBuilder::with_contents("items", bytemuck::cast_slice(&items)).storage().build(&ctx);
        let args =
            BufferBuilder::new("args", DISPATCH_INDIRECT_ARGS_SIZE).storage().indirect().copy().build(&ctx);
        let counter = BufferBuilder::new("counter", 4).storage().copy().build(&ctx);
        let (items, args, counter) = (items.expect("items"), args.expect("args"), counter.expect("counter"));
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
        let (args_group, count_group) = (group(&write_args, &[&items, &args]), group(&count, &[&counter]));
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        compute_pass(&mut encoder, "write args", &write_args, &[&args_group]).dispatch_workgroups(1, 1, 1);
        dispatch_indirect(&mut encoder, "count", &count, &[&count_group], &args, 0);
        ctx.queue.submit([encoder.finish()]);

        let args = readback::read_buffer(&ctx, &args, 0, DISPATCH_INDIRECT_ARGS_SIZE).expect("args");
        assert_eq!(bytemuck::cast_slice::<u8, u32>(&args), &[16, 3, 2]);
        let counted = readback::read_buffer(&ctx, &counter, 0, 4).expect("counter");
        assert_eq!(bytemuck::cast_slice::<u8, u32>(&counted), &[16 * 3 * 2 * WORKGROUP]);
    }
}
