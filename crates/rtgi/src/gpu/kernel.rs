//! Runs a small WGSL compute kernel over an input buffer and reads back its f32 output: how unit tests
//! check functions of the shared WGSL library against their CPU twins.

use wgpu::util::DeviceExt;

use super::resources::buffer_layout_entry;
use super::{GpuContext, GpuError, readback};
use crate::shaders::{Defines, create_module};

/// `source` declares `@group(0) @binding(0) var<storage, read> input: array<...>` and
/// `@group(0) @binding(1) var<storage, read_write> output: array<f32>` and an entry point `main` with
/// `@workgroup_size(64)`; it runs `invocations` times and `output_len` floats come back.
pub fn run_kernel(
    ctx: &GpuContext,
    name: &str,
    source: &str,
    input: &[u8],
    invocations: u32,
    output_len: usize,
) -> Result<Vec<f32>, GpuError> {
    let device = &ctx.device;
    let padded;
    let input = if input.is_empty() {
        padded = [0u8; 16];
        &padded[..]
    } else {
        input
    };
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(name),
        contents: input,
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (output_len.max(4) * 4) as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(name),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let module =
        create_module(ctx, name, source, &Defines::new()).map_err(|e| GpuError::Other(e.to_string()))?;
    // An explicit layout: the automatic one would drop a binding the kernel does not read.
    let entry = |binding, read_only| {
        buffer_layout_entry(
            binding,
            wgpu::ShaderStages::COMPUTE,
            wgpu::BufferBindingType::Storage { read_only },
        )
    };
    let group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(name),
        entries: &[entry(0, true), entry(1, false)],
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(name),
        bind_group_layouts: &[Some(&group_layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(name),
        layout: Some(&layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(name),
        layout: &group_layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: input.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: output.as_entire_binding() },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(invocations.div_ceil(64), 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    let bytes = readback::read_buffer(ctx, &output, 0, size)?;
    let mut out: Vec<f32> = bytemuck::cast_slice(&bytes).to_vec();
    out.truncate(output_len);
    Ok(out)
}

/// Busy work for [`keep_busy`]: a chain of multiply-adds per invocation, its result stored so that
/// the compiler keeps it.
const BUSY_KERNEL: &str = "@group(0) @binding(0) var<storage, read_write> sink: array<f32, 64>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    var x = f32(id.x);
    for (var i = 0u; i < 4096u; i++) {
        x = fma(x, 0.999, 0.5);
    }
    if x == 12345.0 {
        sink[id.x % 64u] = x;
    }
}";

/// Keeps a discrete GPU busy for `duration` so that it raises its clocks before something is timed (an
/// H100 idling between benchmark cells ran cornell's path tracer at 1080p 5.5× slower than after a
/// few hundred busy milliseconds). A CPU driver has no clocks to raise: there it returns at once.
pub fn keep_busy(ctx: &GpuContext, duration: std::time::Duration) -> Result<(), GpuError> {
    if ctx.adapter.get_info().device_type == wgpu::DeviceType::Cpu {
        return Ok(());
    }
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("keep busy"),
        source: wgpu::ShaderSource::Wgsl(BUSY_KERNEL.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("keep busy"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let sink = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("keep busy"),
        size: 256,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("keep busy"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry { binding: 0, resource: sink.as_entire_binding() }],
    });
    let start = std::time::Instant::now();
    while start.elapsed() < duration {
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &group, &[]);
            pass.dispatch_workgroups(4096, 1, 1);
        }
        ctx.queue.submit([encoder.finish()]);
        ctx.wait_idle()?;
    }
    Ok(())
}

/// Loops as long as `input[0]`, then `input[1]`, and stores how many iterations each ran.
const LOOP_PROBE_KERNEL: &str = "@group(0) @binding(0) var<storage, read> input: array<u32>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    var first = 0u;
    for (var i = 0u; i < input[0]; i++) {
        first += 1u;
    }
    var second = 0u;
    for (var i = 0u; i < input[1]; i++) {
        second += 1u;
    }
    if id.x == 0u {
        output[0] = f32(first);
        output[1] = f32(second);
    }
}";

/// Iterations of the two loops of an invocation asked to run `first` then `second` iterations.
pub fn loop_probe(ctx: &GpuContext, first: u32, second: u32) -> Result<[u32; 2], GpuError> {
    let out = run_kernel(ctx, "loop probe", LOOP_PROBE_KERNEL, bytemuck::cast_slice(&[first, second]), 1, 2)?;
    Ok([out[0] as u32, out[1] as u32])
}

/// The loop iterations the driver lets one invocation run in all, if it stops them: lavapipe
/// (llvmpipe's gallivm) ends every loop of an invocation once 65535 iterations have run, counted
/// over all its loops together, without error, so a longer shader silently computes less. `None`
/// where a million iterations run (a hardware driver).
pub fn loop_iteration_limit(ctx: &GpuContext) -> Result<Option<u32>, GpuError> {
    const ASKED: u32 = 1 << 20;
    let [ran, _] = loop_probe(ctx, ASKED, 0)?;
    Ok((ran < ASKED).then_some(ran))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::GpuOptions;
    use crate::sequences::radical_inverse;

    /// `halton` of `common/random.wgsl`: the radical inverse in the dim-th prime base, rotated.
    #[test]
    fn halton_is_the_radical_inverse_in_prime_bases() {
        const PRIMES: [u32; 32] = [
            2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71, 73, 79, 83, 89, 97,
            101, 103, 107, 109, 113, 127, 131,
        ];
        let source = "#import common/random.wgsl
@group(0) @binding(0) var<storage, read> input: array<u32>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= 32u * 512u { return; }
    let dim = id.x / 512u;
    let index = id.x % 512u;
    output[2u * id.x] = halton(index, dim, 0.0);
    output[2u * id.x + 1u] = halton(index, dim, 0.75);
}";
        let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
        let out = run_kernel(&ctx, "halton test", source, &[], 32 * 512, 2 * 32 * 512).expect("kernel");
        for dim in 0..32u32 {
            for index in 0..512u32 {
                let k = (dim * 512 + index) as usize;
                let want = radical_inverse(PRIMES[dim as usize], index);
                assert!(
                    (f64::from(out[2 * k]) - want).abs() < 1e-6,
                    "dim {dim} index {index}: {}",
                    out[2 * k]
                );
                let rotated = (want + 0.75).fract();
                let got = f64::from(out[2 * k + 1]);
                // fract() wraps near 1 (0.99999 vs 0.0): compare on the circle.
                let d = (got - rotated).abs();
                assert!(d.min(1.0 - d) < 1e-6, "dim {dim} index {index} rotated: {got} vs {rotated}");
            }
        }
    }

    /// Where the driver stops loops, it stops them at one count shared by all of an invocation's loops
    /// (so a pass's budget is its loops' sum), and loops within it run in full.
    #[test]
    fn loop_limits_are_per_invocation_and_shared_by_its_loops() {
        let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
        let limit = loop_iteration_limit(&ctx).expect("probe");
        eprintln!("{}: loop iteration limit {limit:?}", ctx.summary.name);
        let Some(limit) = limit else {
            assert_eq!(loop_probe(&ctx, 100_000, 100_000).expect("probe"), [100_000, 100_000]);
            return;
        };
        // Measured on lavapipe: 65535 (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS).
        assert!(limit >= 65535, "{limit}");
        let half = limit / 2;
        assert_eq!(loop_probe(&ctx, half, half).expect("probe"), [half, half]);
        // Measured on lavapipe: [40000, 25534]: the first loop's exit test counts as one iteration.
        let [first, second] = loop_probe(&ctx, half + 5000, half + 5000).expect("probe");
        assert_eq!(first, half + 5000);
        assert!(second < half + 5000 && first + second + 1 >= limit, "{first} + {second} against {limit}");
    }
}
