// Diffuse PRT (composed after shade.wgsl): the point's transfer vector, its vertices' interpolated
// (the per-vertex shading of Sloan et al., with the interpolation before the dot product rather than
// after: the same image, since both are linear), dotted with the environment's SH gives the
// irradiance, times the diffuse lobe's reflectance / π.

// The environment's SH (env_projection).
@group(2) @binding(4) var<storage, read> environment_sh: array<vec4f>;
// Per vertex, order² transfer coefficients of CHANNELS colours (transfer.wgsl).
@group(2) @binding(3) var<storage, read> transfer: array<f32>;

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
    var sum = vec3f(0.0);
    for (var k = 0u; k < count; k++) {
        let t = p.weights.x * vertex_transfer(p.vertices.x, k, count)
            + p.weights.y * vertex_transfer(p.vertices.y, k, count)
            + p.weights.z * vertex_transfer(p.vertices.z, k, count);
        sum += t * environment_sh[k].rgb;
    }
    // Truncated SH can ring below zero.
    return max(sum, vec3f(0.0));
}

fn environment_light(s: GSurface, p: TrianglePoint) -> vec3f {
    let diffuse = brdf_lobe_weights(s.material, saturate(dot(s.normal, s.view))).diffuse;
    return diffuse * INV_PI * transferred_irradiance(p);
}
