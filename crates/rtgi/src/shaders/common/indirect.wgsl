// Arguments of indirect dispatches written on the GPU (gpu/dispatch.rs records the dispatch).
//
// A 1-D workload of `invocations` threads needs ceil(invocations / workgroup_size) workgroups, which can
// exceed the device's max_compute_workgroups_per_dimension (65535 on most): the counts spread over y
// then, and kernels recover their linear index with `indirect_linear_index`. `workgroups_for` in
// gpu/dispatch.rs is the CPU twin.

// Workgroup counts (x, y, 1) covering `invocations` threads; `max_per_dimension` is the device limit,
// passed by the host.
fn indirect_args(invocations: u32, workgroup_size: u32, max_per_dimension: u32) -> vec3u {
    // Written without invocations + workgroup_size - 1, which overflows near the top of u32.
    let groups = invocations / workgroup_size + select(0u, 1u, invocations % workgroup_size != 0u);
    let x = min(groups, max_per_dimension);
    let y = select(0u, (groups + x - 1u) / x, x > 0u);
    return vec3u(x, y, 1u);
}

// The linear index of a thread of a dispatch sized by `indirect_args` (1-D workgroups of
// `workgroup_size`); threads at or past the workload's `invocations` must return early.
fn indirect_linear_index(global_id: vec3u, num_workgroups: vec3u, workgroup_size: u32) -> u32 {
    return global_id.x + global_id.y * num_workgroups.x * workgroup_size;
}
