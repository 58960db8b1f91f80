// Diffuse PRT (composed after shade.wgsl): the point's transfer vector, its vertices' interpolated
// (the per-vertex shading of Sloan et al., with the interpolation before the dot product rather than
// after: the same image, since both are linear), dotted with the environment's SH gives the
// irradiance, times the diffuse lobe's reflectance / π. With SELF_TRANSFER (transfer.wgsl) a moving
// mesh's transfer is in its own space, and is dotted with the environment turned into that space.

// The environment's SH (env_projection).
@group(2) @binding(4) var<storage, read> environment_sh: array<vec4f>;
// Per vertex, order² transfer coefficients of CHANNELS colours (transfer.wgsl).
@group(2) @binding(3) var<storage, read> transfer: array<f32>;
// SELF_TRANSFER: per vertex its BVH instance (or NO_INSTANCE), and per instance the environment's SH
// in the instance's own space (self_transfer.wgsl).
@group(2) @binding(5) var<storage, read> vertex_instances: array<u32>;
@group(2) @binding(6) var<storage, read> instance_sh: array<vec4f>;

// Coefficient k of the environment as the transfer of a part (`instance`) sees it.
fn part_environment(instance: u32, k: u32, count: u32) -> vec3f {
    if SELF_TRANSFER && instance != NO_INSTANCE {
        return instance_sh[instance * count + k].rgb;
    }
    return environment_sh[k].rgb;
}

fn vertex_transfer(vertex: u32, k: u32, count: u32) -> vec3f {
    let i = (vertex * count + k) * CHANNELS;
    if CHANNELS == 1u {
        return vec3f(transfer[i]);
    }
    return vec3f(transfer[i], transfer[i + 1u], transfer[i + 2u]);
}

// Σ_k L_k T_k(p), T interpolated from the triangle's vertices.
fn transferred_irradiance(p: TrianglePoint) -> vec3f {
    let count = shape.order * shape.order;
    // A triangle's vertices are all of one mesh.
    var instance = NO_INSTANCE;
    if SELF_TRANSFER {
        instance = vertex_instances[indices[p.triangle * 3u]];
    }
    var sum = vec3f(0.0);
    for (var k = 0u; k < count; k++) {
        let t = p.weights.x * vertex_transfer(p.vertices.x, k, count)
            + p.weights.y * vertex_transfer(p.vertices.y, k, count)
            + p.weights.z * vertex_transfer(p.vertices.z, k, count);
        sum += t * part_environment(instance, k, count);
    }
    // Truncated SH can ring below zero.
    return max(sum, vec3f(0.0));
}

fn environment_light(s: GSurface, p: TrianglePoint) -> vec3f {
    let diffuse = brdf_lobe_weights(s.material, saturate(dot(s.normal, s.view))).diffuse;
    return diffuse * INV_PI * transferred_irradiance(p);
}
