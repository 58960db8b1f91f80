// Per-pixel PRT shading: the surface under the pixel's primary ray (cast again through the shared BVH,
// as the ray-cast G-buffer casts it, for the triangle and barycentrics the G-buffer does not keep), its
// vertices' transfer vectors interpolated (the per-vertex shading of Sloan et al., with the
// interpolation after the transfer rather than after the dot product: the same image, since both are
// linear), dotted with the environment's SH: irradiance, times the diffuse lobe's reflectance / π.
// Back faces (seen against their normals) get none: transfer is for the side the normals point to.
// The direct pass's estimate (lights and emitters, the environment left out) is added and the sum
// averaged over frames.

#import common/frame.wgsl

@group(2) @binding(0) var direct: texture_2d<f32>;
@group(2) @binding(1) var output: texture_storage_2d<rgba32float, read_write>;
@group(2) @binding(2) var<storage, read> environment_sh: array<vec4f>;
// Per vertex, order² transfer coefficients of CHANNELS colours (transfer.wgsl).
@group(2) @binding(3) var<storage, read> transfer: array<f32>;
struct Shape {
    // A run-time value so that LLVM (lavapipe) does not unroll the per-coefficient loop.
    order: u32,
}
@group(2) @binding(4) var<uniform> shape: Shape;

fn vertex_transfer(vertex: u32, k: u32, count: u32) -> vec3f {
    let i = (vertex * count + k) * CHANNELS;
    if CHANNELS == 1u {
        return vec3f(transfer[i]);
    }
    return vec3f(transfer[i], transfer[i + 1u], transfer[i + 2u]);
}

// Σ_k L_k T_k(p) at barycentrics (u, v) of `triangle`, T interpolated from its vertices.
fn transferred_irradiance(triangle: u32, u: f32, v: f32) -> vec3f {
    let a = indices[triangle * 3u];
    let b = indices[triangle * 3u + 1u];
    let c = indices[triangle * 3u + 2u];
    let count = shape.order * shape.order;
    let w = vec3f(1.0 - u - v, u, v);
    var sum = vec3f(0.0);
    for (var k = 0u; k < count; k++) {
        let t = w.x * vertex_transfer(a, k, count) + w.y * vertex_transfer(b, k, count)
            + w.z * vertex_transfer(c, k, count);
        sum += t * environment_sh[k].rgb;
    }
    // Truncated SH can ring below zero.
    return max(sum, vec3f(0.0));
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    var radiance = textureLoad(direct, id.xy, 0).rgb;
    let s = load_gsurface(id.xy);
    if s.valid {
        let dir = primary_ray_direction(id.xy);
        let hit = trace_closest(Ray(frame.camera_position, dir), 0.0, FLT_MAX);
        // Transfer is for the side the normals point to: back faces get no environment light.
        if hit_found(hit) && !hits_back_face(hit.triangle, hit.u, hit.v, dir) {
            let diffuse = brdf_lobe_weights(s.material, saturate(dot(s.normal, s.view))).diffuse;
            radiance += diffuse * INV_PI * transferred_irradiance(hit.triangle, hit.u, hit.v);
        }
    }
    let mean = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(mean, 1.0));
}
