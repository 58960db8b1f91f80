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
struct GlossyShape {
    // HSH order of radiance records, a run-time value (see env_harmonics/shade.wgsl).
    order: u32,
}
@group(2) @binding(10) var<uniform> glossy: GlossyShape;
// HSH BRDF tables of `glossy.order` (brdf_tables/lookup.wgsl).
@group(2) @binding(11) var<storage, read> brdf_tables: array<f32>;

// Per hemisphere cell of the record pass and HSH coefficient i (radiance_cache::cell_harmonics): ∫_cell
// H_i dω; sin θ cos θ ∫ H_i dφ along the cell's lower θ boundary; ∫ H_i dθ along its lower φ boundary.
@group(2) @binding(12) var<storage, read> cell_harmonics: array<f32>;

const RADIANCE_FLOATS: u32 = 9u;

fn radiance_coefficients() -> u32 {
    return glossy.order * glossy.order;
}

// First float of coefficient i of record k.
fn radiance_index(k: u32, i: u32) -> u32 {
    return (k * radiance_coefficients() + i) * RADIANCE_FLOATS;
}

// Coefficient i of radiance record r (index k) extrapolated to p by its translational gradients.
fn record_radiance(k: u32, r: Record, i: u32, p: vec3f) -> vec3f {
    let e = radiance_index(k, i);
    let dp = p - r.position_radius.xyz;
    let dx = dot(dp, basis_tangent(r.normal.xyz));
    let dy = dot(dp, basis_bitangent(r.normal.xyz));
    return vec3f(radiance[e], radiance[e + 1u], radiance[e + 2u])
        + dx * vec3f(radiance[e + 3u], radiance[e + 4u], radiance[e + 5u])
        + dy * vec3f(radiance[e + 6u], radiance[e + 7u], radiance[e + 8u]);
}
