// The directional mips of the radiance volume (ANISOTROPIC): level m of direction d from the 2×2×2
// children at level m − 1, each of the four lines of two children along d's axis composited front to
// back as seen marching along d (near + (1 − α_near)·far), the four averaged. The blocks of the six
// directions lie side by side along x: +x, −x, +y, −y, +z, −z. Level 1 reads the isotropic level 0.

@group(0) @binding(0) var source: texture_3d<f32>;
@group(0) @binding(1) var destination: texture_storage_3d<rgba16float, write>;
// The clipmap level a dispatch filters (x): one dispatch per level whose voxels changed.
@group(0) @binding(2) var<uniform> clip: vec4u;

fn over(near: vec4f, far: vec4f) -> vec4f {
    return near + (1.0 - near.a) * far;
}

fn directional_level(local: vec3u, directional_source: bool) {
    // Clipmap levels are stacked along z (depth CLIPS × size): each level's children stay in its block.
    let size = textureDimensions(destination).y;
    if any(local >= vec3u(size)) {
        return;
    }
    let id = local + vec3u(0u, 0u, clip.x * size);
    for (var d = 0u; d < 6u; d++) {
        let axis = d / 2u;
        let forward = d % 2u == 0u;
        let offset = select(vec3u(0u), vec3u(2u * size * d, 0u, 0u), directional_source);
        var sum = vec4f(0.0);
        for (var k = 0u; k < 4u; k++) {
            var near = 2u * id;
            near[(axis + 1u) % 3u] += k & 1u;
            near[(axis + 2u) % 3u] += k >> 1u;
            var far = near;
            near[axis] += select(1u, 0u, forward);
            far[axis] += select(0u, 1u, forward);
            sum += over(textureLoad(source, near + offset, 0), textureLoad(source, far + offset, 0));
        }
        textureStore(destination, id + vec3u(size * d, 0u, 0u), 0.25 * sum);
    }
}

@compute @workgroup_size(4, 4, 4)
fn from_base(@builtin(global_invocation_id) id: vec3u) {
    directional_level(id, false);
}

@compute @workgroup_size(4, 4, 4)
fn from_directional(@builtin(global_invocation_id) id: vec3u) {
    directional_level(id, true);
}
