// The SH projection of the environment (the thesis's step 1 of §3.5.3) in its own frame, in two passes,
// and its rotation into the world (a third). `partial`: one
// invocation per coefficient of each band of equal area in z (PROJECTION_BANDS of them, midpoints in
// z), adding PHI_PER_DISPATCH of the band's PROJECTION_BANDS uniform steps in φ per dispatch into its
// own partial sum. `reduce`: one invocation per coefficient sums the rows and scales by the 4π / N weight
// of every direction. `rotate`: one invocation per coefficient applies its band's rotation matrix
// (hsh.rs sh_rotation, written by the host whenever the environment's turn changes). Radiance is read through common/environment.wgsl, the same function the path
// tracer sees.

#import common/environment.wgsl
#import common/hsh.wgsl

struct Slot {
    first_phi: u32,
    // A run-time value so that LLVM (lavapipe) does not unroll the per-band loops (see shade.wgsl).
    order: u32,
}

@group(2) @binding(0) var<storage, read_write> partials: array<vec4f>;
@group(2) @binding(1) var<storage, read_write> unrotated_sh: array<vec4f>;
@group(2) @binding(2) var<uniform> slot: Slot;
@group(2) @binding(3) var<storage, read_write> environment_sh: array<vec4f>;
@group(2) @binding(4) var<storage, read> rotation_matrices: array<f32>;

@compute @workgroup_size(64)
fn partial(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = slot.order * slot.order;
    // Linear over the (x, y) spread of gpu::dispatch::workgroups_for.
    let index = id.x + id.y * groups.x * 64u;
    let band = index / count;
    let k = index % count;
    if band >= PROJECTION_BANDS {
        return;
    }
    let z = 1.0 - 2.0 * (f32(band) + 0.5) / f32(PROJECTION_BANDS);
    let r = sqrt(max(0.0, 1.0 - z * z));
    var sum = vec3f(0.0);
    for (var s = 0u; s < PHI_PER_DISPATCH; s++) {
        let step = slot.first_phi + s;
        if step >= PROJECTION_BANDS {
            break;
        }
        let phi = TWO_PI * (f32(step) + 0.5) / f32(PROJECTION_BANDS);
        let d = vec3f(r * cos(phi), r * sin(phi), z);
        sum += environment_radiance_unrotated(d) * sh_one(k, d);
    }
    partials[index] += vec4f(sum, 0.0);
}

@compute @workgroup_size(64)
fn reduce(@builtin(global_invocation_id) id: vec3u) {
    let count = slot.order * slot.order;
    let k = id.x;
    if k >= count {
        return;
    }
    var sum = vec3f(0.0);
    for (var band = 0u; band < PROJECTION_BANDS; band++) {
        sum += partials[band * count + k].rgb;
    }
    let weight = 4.0 * PI / f32(PROJECTION_BANDS * PROJECTION_BANDS);
    unrotated_sh[k] = vec4f(sum * weight, 0.0);
}

@compute @workgroup_size(64)
fn rotate(@builtin(global_invocation_id) id: vec3u) {
    let k = id.x;
    if k >= slot.order * slot.order {
        return;
    }
    let l = u32(sqrt(f32(k) + 0.5));
    let n = 2u * l + 1u;
    let row = k - l * l;
    let band = sh_band_matrix_start(l) + row * n;
    var sum = vec3f(0.0);
    for (var j = 0u; j < n; j++) {
        sum += rotation_matrices[band + j] * unrotated_sh[l * l + j].rgb;
    }
    environment_sh[k] = vec4f(sum, 0.0);
}
