// Per-pixel PRT shading: the surface under the pixel's primary ray (cast again through the shared BVH,
// as the ray-cast G-buffer casts it, for the triangle and barycentrics the G-buffer does not keep) gets
// the environment's light through the precomputed transfer of the points about it (points.wgsl, composed
// before this file), by `environment_light` of shade_diffuse.wgsl (transfer vectors), shade_glossy.wgsl
// (transfer matrices) or shade_wavelet.wgsl (wavelet transfer), one of which is composed after this
// file. Back faces (seen against their normals) get none: transfer is for the side the normals point
// to. The direct pass's estimate (lights and emitters, the environment left out) is added and the sum
// averaged over frames.

#import common/frame.wgsl

@group(2) @binding(0) var direct: texture_2d<f32>;
@group(2) @binding(1) var output: texture_storage_2d<rgba32float, read_write>;
struct Shape {
    // A run-time value so that LLVM (lavapipe) does not unroll the per-coefficient loops.
    order: u32,
}
@group(2) @binding(2) var<uniform> shape: Shape;

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
            radiance += environment_light(s, triangle_point(hit.triangle, hit.u, hit.v));
        }
    }
    let mean = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(mean, 1.0));
}
