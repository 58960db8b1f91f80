// Probe rays: every probe casts RAYS rays on this frame's rotated spherical Fibonacci pattern, in one
// batch (one thread per ray), and shades what they hit with the routine camera pixels use: direct light
// (shadow rays) plus the diffuse light of the previous frame's probes, which adds a bounce per frame.
// Each ray leaves (radiance, hit distance): a miss the environment or nothing (see EMITTERS_IN_PROBES)
// at MAX_DISTANCE; a back face (the probe sits inside geometry) no radiance and a negative distance,
// shortened so the probe's visibility treats the inside as close.

#import common/direct_light.wgsl
#import common/indirect.wgsl

@group(2) @binding(0) var<storage, read_write> ray_data: array<vec4f>;
@group(2) @binding(1) var probe_irradiance: texture_2d<f32>;
@group(2) @binding(2) var probe_distance: texture_2d<f32>;
@group(2) @binding(3) var probe_sampler: sampler;
@group(2) @binding(4) var<uniform> probe_frame: ProbeFrame;
// [0]: rays that hit a back face, since the technique was created (for the stats).
@group(2) @binding(5) var<storage, read_write> ray_stats: array<atomic<u32>, 1>;

const WORKGROUP: u32 = 64u;
// A back-face hit is recorded at this fraction of its distance (negated).
const BACKFACE_SHORTENING: f32 = 0.2;

// Whether the ray met the back of the triangle: the side its authored normals point away from.
fn hits_back_face(triangle: u32, u: f32, v: f32, dir: vec3f) -> bool {
    let t = triangle_vertices(triangle);
    let n = vertex_normal(t[0]) * (1.0 - u - v) + vertex_normal(t[1]) * u + vertex_normal(t[2]) * v;
    return dot(n, dir) > 0.0;
}

@compute @workgroup_size(WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let index = indirect_linear_index(id, groups, WORKGROUP);
    if index >= probe_count() * RAYS {
        return;
    }
    let probe = index / RAYS;
    let dir = probe_ray_direction(index % RAYS);
    let origin = probe_position(probe_grid(probe));
    let hit = trace_closest(Ray(origin, dir), 0.0, FLT_MAX);
    if hit.t == FLT_MAX {
        var sky = vec3f(0.0);
        if EMITTERS_IN_PROBES {
            sky = environment_radiance(dir);
        }
        ray_data[index] = vec4f(sky, MAX_DISTANCE);
        return;
    }
    if hits_back_face(hit.triangle, hit.u, hit.v, dir) {
        ray_data[index] = vec4f(0.0, 0.0, 0.0, -BACKFACE_SHORTENING * hit.t);
        atomicAdd(&ray_stats[0], 1u);
        return;
    }
    let s = hit_gsurface(surface_at(hit.triangle, hit.u, hit.v, dir), -dir, hit.t);
    var rng = rng_new(vec2u(index, 0u), frame.frame_counter, hash2(frame.seed, 0x64646769u));
    var radiance = direct_light(
        s, offset_origin(s.position, s.geometric_normal), &rng, SURFEL_AREA_SAMPLES, SURFEL_ENV_SAMPLES, true
    );
    if EMITTERS_IN_PROBES {
        radiance += s.material.emission;
    }
    radiance += probe_diffuse_light(s);
    ray_data[index] = vec4f(radiance, hit.t);
}
