// Deferred G-buffer by ray casting: one primary ray per pixel through the shared BVH (the path tracer's
// first ray), written in compute as the raster pass (gbuffer.wgsl) writes it (common/gbuffer.wgsl).
// Compute GPUs without much raster hardware fill the seven targets faster this way.

#import common/gbuffer.wgsl
#import common/mesh_of_triangle.wgsl
#import common/ray_differentials.wgsl

// Per mesh: current world position -> the previous frame's (object motion; identity when static).
@group(1) @binding(1) var<storage, read> mesh_motion: array<mat4x4f>;
// (first triangle, mesh) of every non-empty mesh, by first triangle: which mesh a hit triangle is on.
@group(1) @binding(2) var<storage, read> mesh_starts: array<vec2u>;
@group(1) @binding(3) var out_albedo: texture_storage_2d<rgba16float, write>;
@group(1) @binding(4) var out_normal: texture_storage_2d<rgba16float, write>;
@group(1) @binding(5) var out_material: texture_storage_2d<rg32uint, write>;
@group(1) @binding(6) var out_emission: texture_storage_2d<rgba16float, write>;
@group(1) @binding(7) var out_distance: texture_storage_2d<r32float, write>;
@group(1) @binding(8) var out_motion: texture_storage_2d<rg32float, write>;
@group(1) @binding(9) var out_instance: texture_storage_2d<r32uint, write>;

// The mip level the raster pass's screen-space derivatives would pick at a primary hit.
fn primary_texture_lod(triangle: u32, xy: vec2f, dir: vec3f, t: f32) -> f32 {
    let size = vec2f(textureDimensions(textures_srgb));
    let j = primary_uv_differentials(triangle, xy, dir, t);
    let widest = max(dot(j[0] * size, j[0] * size), dot(j[1] * size, j[1] * size));
    return select(0.0, max(0.0, 0.5 * log2(widest)), widest > 0.0 && widest < FLT_MAX);
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    let pixel = vec2i(id.xy);
    let xy = vec2f(id.xy) + 0.5 + frame.jitter;
    let dir = primary_ray_through(xy);
    let hit = trace_closest(Ray(frame.camera_position, dir), 0.0, FLT_MAX);
    var t = GBufferTexels(vec4f(0.0), vec4f(0.0), vec2u(0u), vec4f(0.0), 0.0, vec2f(0.0), 0u);
    if hit_found(hit) {
        let lod = primary_texture_lod(hit.triangle, xy, dir, hit.t);
        let s = surface_at_lod(hit.triangle, hit.u, hit.v, dir, lod);
        let mesh = mesh_of_triangle(hit.triangle);
        // Motion is unjittered, as in the raster pass: from the pixel centre.
        let motion = previous_pixel(mesh_motion[mesh], s.position) - (vec2f(id.xy) + 0.5);
        t = gbuffer_texels(s.material_index, s.material, s.normal, s.geometric_normal, hit.t, motion, mesh);
    }
    textureStore(out_albedo, pixel, t.albedo);
    textureStore(out_normal, pixel, t.normal);
    textureStore(out_material, pixel, vec4u(t.material, 0u, 0u));
    textureStore(out_emission, pixel, t.emission);
    textureStore(out_distance, pixel, vec4f(t.distance, 0.0, 0.0, 0.0));
    textureStore(out_motion, pixel, vec4f(t.motion, 0.0, 0.0));
    textureStore(out_instance, pixel, vec4u(t.instance, 0u, 0u, 0u));
}
