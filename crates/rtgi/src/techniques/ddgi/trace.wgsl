// Probe rays: every active probe of this frame's update casts RAYS rays on this frame's rotated spherical
// Fibonacci pattern, in one batch (one thread per ray), and shades what they hit with the routine camera pixels use: direct light
// (shadow rays) plus the diffuse light of the previous frame's probes, which adds a bounce per frame.
// Each ray leaves (radiance, hit distance): a miss the environment or nothing (see EMITTERS_IN_PROBES)
// at MAX_DISTANCE; a back face (the probe sits inside geometry) no radiance and a negative distance,
// shortened so the probe's visibility treats the inside as close.

#import common/indirect.wgsl

@group(2) @binding(0) var<storage, read_write> ray_data: array<vec4f>;
@group(2) @binding(1) var probe_irradiance: texture_2d<f32>;
@group(2) @binding(2) var probe_distance: texture_2d<f32>;
@group(2) @binding(3) var probe_sampler: sampler;
@group(2) @binding(4) var<uniform> probe_frame: ProbeFrame;
// Since the technique was created (for the stats): [0] rays that hit a back face, [1] rays traced.
@group(2) @binding(5) var<storage, read_write> ray_stats: array<atomic<u32>, 2>;
@group(2) @binding(6) var<storage, read> probe_states: array<ProbeState>;

const WORKGROUP: u32 = 64u;
// A back-face hit is recorded at this fraction of its distance (negated).
const BACKFACE_SHORTENING: f32 = 0.2;

@compute @workgroup_size(WORKGROUP)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let index = indirect_linear_index(id, groups, WORKGROUP);
    if index >= probe_frame.update_count * RAYS {
        return;
    }
    let probe = (probe_frame.update_start + index / RAYS) % probe_count();
    let state = probe_states[probe];
    if (state.flags & PROBE_ACTIVE) == 0u {
        return;
    }
    let ray = index % RAYS;
    if ray == 0u {
        atomicAdd(&ray_stats[1], RAYS);
    }
    let dir = probe_ray_direction(ray);
    let origin = cell_position(slot_cell(probe, probe_frame.scroll)) + state.offset;
    let slot = probe * RAYS + ray;
    let hit = trace_closest(Ray(origin, dir), 0.0, FLT_MAX);
    if hit.t < FLT_MAX && hits_back_face(hit.triangle, hit.u, hit.v, dir) {
        ray_data[slot] = vec4f(0.0, 0.0, 0.0, -BACKFACE_SHORTENING * hit.t);
        atomicAdd(&ray_stats[0], 1u);
        return;
    }
    var rng = rng_new(vec2u(slot, 0u), frame.frame_counter, hash2(frame.seed, 0x64646769u));
    ray_data[slot] = vec4f(ray_radiance(hit, dir, &rng), min(hit.t, MAX_DISTANCE));
}
