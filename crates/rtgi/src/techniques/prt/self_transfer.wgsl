// Self-transfer of moving meshes (transfer.wgsl's SELF_TRANSFER): the environment's SH turned into
// each BVH instance's own space, L_i = R(W_i) L, with W_i the rotation of the instance's world-to-object
// map (host: `hsh::sh_rotation`, band matrices row-major band after band, per instance), whenever the
// environment or an instance's placement changes. One coefficient of one instance per invocation.

#import common/hsh.wgsl

struct Parts {
    order: u32,
    instances: u32,
}

@group(2) @binding(0) var<storage, read> environment_sh: array<vec4f>;
@group(2) @binding(1) var<storage, read> rotations: array<f32>;
@group(2) @binding(2) var<storage, read_write> instance_sh: array<vec4f>;
@group(2) @binding(3) var<uniform> parts: Parts;

@compute @workgroup_size(64)
fn turn_into_instances(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = parts.order * parts.order;
    let element = id.x + id.y * groups.x * 64u;
    if element >= parts.instances * count {
        return;
    }
    let instance = element / count;
    let k = element % count;
    let l = u32(sqrt(f32(k) + 0.5));
    let n = 2u * l + 1u;
    let row = instance * sh_band_matrix_start(parts.order) + sh_band_matrix_start(l) + (k - l * l) * n;
    var sum = vec3f(0.0);
    for (var j = 0u; j < n; j++) {
        sum += rotations[row + j] * environment_sh[l * l + j].rgb;
    }
    instance_sh[element] = vec4f(sum, 0.0);
}
