// Fixed-point sums of the injection to floats (prepended: volume.wgsl): the injected light starts the
// propagation (`source`) and the accumulated result; the geometry volume takes, per cell, whichever of
// its two sources (RSMs, G-buffer) blocks more, so a surface both see counts once (the paper merges
// them alike), and (MULTIPLE_BOUNCES) the mean albedo of both sources' surfaces. The sums are cleared
// for the next frame.

@group(2) @binding(1) var<storage, read_write> light_fixed: array<atomic<i32>>;
@group(2) @binding(2) var<storage, read_write> blocking_fixed: array<atomic<i32>>;
@group(2) @binding(3) var<storage, read_write> source: array<vec4f>;
@group(2) @binding(5) var<storage, read_write> accumulated: array<vec4f>;
@group(2) @binding(6) var<storage, read_write> geometry: array<vec4f>;
@group(2) @binding(7) var<storage, read_write> flux_scale: array<f32>;

fn take_fixed(base: u32) -> vec4f {
    var v = vec4f(0.0);
    for (var k = 0u; k < 4u; k++) {
        v[k] = f32(atomicExchange(&light_fixed[base + k], 0));
    }
    return v;
}

fn take_blocking(base: u32) -> vec4f {
    var v = vec4f(0.0);
    for (var k = 0u; k < 4u; k++) {
        v[k] = f32(atomicExchange(&blocking_fixed[base + k], 0));
    }
    return v;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = indirect_linear_index(gid, groups, 64u);
    if i < lpv.cascade_count * cells_per_cascade() {
        let scale = flux_scale[0];
        let inverse = select(0.0, 1.0 / scale, scale > 0.0);
        for (var k = 0u; k < 3u; k++) {
            let v = take_fixed(i * 12u + 4u * k) * inverse;
            source[3u * i + k] = v;
            accumulated[3u * i + k] = v;
        }
    }
    if i < lpv.cascade_count * geometry_cells_per_cascade() {
        let base = i * GEOMETRY_SUMS;
        let from_lights = take_blocking(base);
        let from_camera = take_blocking(base + 4u);
        let b = select(from_camera, from_lights, from_lights.x >= from_camera.x);
        geometry[GEOMETRY_SLOTS * i] = b * (1.0 / BLOCKING_SCALE);
        if MULTIPLE_BOUNCES {
            // Kept as sums (albedo × covered fraction, covered fraction): interpolated between cells
            // and divided where used, the mean is over the surfaces, not over empty cells too.
            geometry[GEOMETRY_SLOTS * i + 1u] = take_blocking(base + 8u) * (1.0 / BLOCKING_SCALE);
        }
    }
}
