// The radiance cache's own resources (bind group 2), one layout for all its passes.

@group(2) @binding(0) var<storage, read_write> records: array<Record>;
@group(2) @binding(1) var<storage, read_write> state: CacheState;
// Per record of the range being splatted: its framebuffer rectangle (x0, y0, x1, y1).
@group(2) @binding(2) var<storage, read_write> rects: array<vec4f>;
// Per BIN_TILE² tile: a bit set (BIN_WORDS words) of the records of the range whose rectangle meets it.
@group(2) @binding(3) var<storage, read_write> bins: array<u32>;
// Per candidate tile of this round: the complement of the best miss's key (0 = no miss).
@group(2) @binding(4) var<storage, read_write> candidates: array<atomic<u32>>;
// The pixels (x | y << 16) of this round's new records, in the order of their slots.
@group(2) @binding(5) var<storage, read_write> new_pixels: array<u32>;
// Per pixel: Σ w_k E_k(p) (rgb) and Σ w_k (a) over the records splatted so far.
@group(2) @binding(6) var splat_buffer: texture_storage_2d<rgba32float, read_write>;
@group(2) @binding(7) var direct_light_texture: texture_2d<f32>;
@group(2) @binding(8) var output: texture_storage_2d<rgba32float, write>;
// Radiance records' incoming radiance in HSH of the record's frame (local_to_world of its normal):
// per record, per coefficient i, λ_i (rgb), then its translational gradient along the frame's tangent
// (rgb) and bitangent (rgb), RADIANCE_FLOATS floats per coefficient.
@group(2) @binding(9) var<storage, read_write> radiance: array<f32>;
struct CacheUniforms {
    // HSH order of radiance records, a run-time value (see env_harmonics/shade.wgsl).
    order: u32,
    // Temporal mode: scene seconds the record pass predicts ahead (0: no prediction this frame).
    step: f32,
    // Temporal mode: 1 when the analytic lights move in that step.
    lights_move: u32,
    _pad: u32,
}
@group(2) @binding(10) var<uniform> cache_uniforms: CacheUniforms;
// HSH BRDF tables of `cache_uniforms.order` (brdf_tables/lookup.wgsl).
@group(2) @binding(11) var<storage, read> brdf_tables: array<f32>;

// Per hemisphere cell of the record pass and HSH coefficient i (radiance_cache::cell_harmonics): ∫_cell
// H_i dω; sin θ cos θ ∫ H_i dφ along the cell's lower θ boundary; ∫ H_i dθ along its lower φ boundary.
@group(2) @binding(12) var<storage, read> cell_harmonics: array<f32>;

// Temporal mode: per record, the last frame a pixel used it (the thesis's occlusion query).
@group(2) @binding(13) var<storage, read_write> record_used: array<atomic<u32>>;
// Temporal mode: the analytic lights and, per mesh, the world-space motion of the next time step.
@group(2) @binding(14) var<storage, read> next_lights: array<Light>;
@group(2) @binding(15) var<storage, read> next_motion: array<mat4x4f>;
// Temporal mode, per frame: expired records asking to be refreshed, records deleted.
@group(2) @binding(16) var<storage, read_write> temporal_counters: array<atomic<u32>, 2>;

// (first triangle, mesh) of every mesh (common/mesh_of_triangle.wgsl), for the motion of a hit.
@group(2) @binding(17) var<storage, read> mesh_starts: array<vec2u>;

// `photon-irradiance-cache`: the photon map (photon_map/lookup.wgsl).
@group(2) @binding(18) var<storage, read> photons: array<Photon>;
@group(2) @binding(19) var<storage, read> photon_grid: array<u32>;
// `photon-irradiance-cache`'s final gather: per slot of this round's records, per hemisphere cell, the
// radiance its ray brought (rgb) and 1 / the ray's hit distance (a), from the record-ray pass.
@group(2) @binding(20) var<storage, read_write> gathered_cells: array<vec4f>;

fn predicted_light(i: u32) -> Light {
    return next_lights[i];
}

const RADIANCE_FLOATS: u32 = 9u;

fn radiance_coefficients() -> u32 {
    return cache_uniforms.order * cache_uniforms.order;
}

// First float of coefficient i of record k in `plane` (0: as computed; 1: the temporal prediction).
fn radiance_index(k: u32, i: u32, plane: u32) -> u32 {
    return ((plane * CAPACITY + k) * radiance_coefficients() + i) * RADIANCE_FLOATS;
}

// Coefficient i of plane `plane` of radiance record k at offset (dx, dy) in its tangent frame.
fn record_radiance_plane(k: u32, i: u32, plane: u32, dx: f32, dy: f32) -> vec3f {
    let e = radiance_index(k, i, plane);
    return vec3f(radiance[e], radiance[e + 1u], radiance[e + 2u])
        + dx * vec3f(radiance[e + 3u], radiance[e + 4u], radiance[e + 5u])
        + dy * vec3f(radiance[e + 6u], radiance[e + 7u], radiance[e + 8u]);
}

// Coefficient i of radiance record r (index k) extrapolated to p by its translational gradients
// (and in time by its prediction).
fn record_radiance(k: u32, r: Record, i: u32, p: vec3f) -> vec3f {
    let dp = p - r.position_radius.xyz;
    let dx = dot(dp, basis_tangent(r.normal.xyz));
    let dy = dot(dp, basis_bitangent(r.normal.xyz));
    let now = record_radiance_plane(k, i, 0u, dx, dy);
    let progress = record_progress(r);
    if progress <= 0.0 {
        return now;
    }
    return now + progress * (record_radiance_plane(k, i, 1u, dx, dy) - now);
}

// Irradiance of record r (index k) at (p, n), by its gradients and in time by its prediction.
fn record_irradiance_now(k: u32, r: Record, p: vec3f, n: vec3f) -> vec3f {
    let progress = record_progress(r);
    if progress <= 0.0 {
        return record_irradiance(r, p, n);
    }
    let now = record_irradiance_unclamped(r, p, n);
    let next = record_irradiance_unclamped(records[CAPACITY + k], p, n);
    return max(now + progress * (next - now), vec3f(0.0));
}

// Temporal mode: notes that record k served a pixel this frame.
fn mark_used(k: u32) {
    if TEMPORAL && atomicLoad(&record_used[k]) != frame.frame_counter {
        atomicStore(&record_used[k], frame.frame_counter);
    }
}
