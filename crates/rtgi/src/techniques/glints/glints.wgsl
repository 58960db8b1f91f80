// Glints: direct light on normal-mapped surfaces, the reflectance filtered over each pixel's footprint
// in the normal map (Gamboa, Guertin & Nowrouzezahrai 2018; seed 003, article 2).
//
// A pixel on a glint material re-casts its primary ray (the G-buffer keeps no texture coordinates),
// bounds the ray differentials' footprint by a box of texels, and reads the histogram of the
// micronormals in the box from the cumulative histogram (four lookups per bin, any box size). The
// filtered reflectance towards direction l is then the histogram's weighted sum of the shared BRDF with
// each non-empty bin's normal as shading normal:  f̂(l) cos = Σ_b w_b f(n_b; v, l) (n_b·l)⁺,  w_b the
// bin's share of the footprint's normals. Analytic lights use it exactly (one shadow test per light);
// emissive triangles and the environment use light samples weighted by it. Other pixels are shaded as
// the `direct` pass shades them. Progressive: the stochastic light samples average over frames.

#import common/direct_light.wgsl
#import common/ray_differentials.wgsl

struct GlintMaterial {
    // First u32 of this material's cumulative histogram in `histograms`.
    offset: u32,
    // Texels along each side of the normal map; 0 for a material without glints.
    size: u32,
    // Bins along each axis of the projected disc of normals.
    bins: u32,
    // Normals each texel contributes.
    weight_per_texel: u32,
    // First of this material's bin normals in `bin_normals`.
    normal_offset: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(2) @binding(0) var<storage, read> glint_materials: array<GlintMaterial>;
@group(2) @binding(1) var<storage, read> histograms: array<u32>;
// Per bin: the mean tangent-space normal of the map's micronormals in it (xyz).
@group(2) @binding(2) var<storage, read> bin_normals: array<vec4f>;
// COUNTER_* below.
@group(2) @binding(3) var<storage, read_write> counters: array<atomic<u32>>;
@group(2) @binding(4) var output: texture_storage_2d<rgba32float, read_write>;

const COUNTER_PIXELS: u32 = 0u;
const COUNTER_BINS: u32 = 1u;
const COUNTER_CHUNKS: u32 = 2u;
const COUNTER_CLAMPED: u32 = 3u;

// A footprint is at most this many texels along each axis (counts stay below 2³²).
const MAX_FOOTPRINT: f32 = 8192.0;

// floor(x / d) for d > 0.
fn floor_div(x: i32, d: i32) -> i32 {
    return (x - select(0, d - 1, x < 0)) / d;
}

fn stored_count(g: GlintMaterial, x: u32, y: u32, bin: u32) -> u32 {
    if x == 0u || y == 0u {
        return 0u;
    }
    return histograms[g.offset + ((y - 1u) * g.size + (x - 1u)) * g.bins * g.bins + bin];
}

// Normals in `bin` over texels [0, x) × [0, y) of the map tiled over the plane: whole periods times
// the map's totals plus the remainder, in wrap-around arithmetic (CPU twin:
// `NormalHistogram::cumulative`).
fn cumulative_count(g: GlintMaterial, x: i32, y: i32, bin: u32) -> u32 {
    let size = i32(g.size);
    let qx = floor_div(x, size);
    let qy = floor_div(y, size);
    let rx = u32(x - qx * size);
    let ry = u32(y - qy * size);
    var c = stored_count(g, rx, ry, bin);
    if qx != 0 {
        c += bitcast<u32>(qx) * stored_count(g, g.size, ry, bin);
    }
    if qy != 0 {
        c += bitcast<u32>(qy) * stored_count(g, rx, g.size, bin);
        if qx != 0 {
            c += bitcast<u32>(qx) * bitcast<u32>(qy) * stored_count(g, g.size, g.size, bin);
        }
    }
    return c;
}

// The cumulative count at a fractional point (x + a, y + b), texel contents spread evenly over each
// texel (bilinear between the four integer corners), split into the integer count at (x, y) and the
// fractional rest, which is made of small differences and so stays exact in f32.
struct FractionalCount {
    whole: u32,
    rest: f32,
}

fn fractional_count(g: GlintMaterial, corner: vec2i, f: vec2f, bin: u32) -> FractionalCount {
    let c00 = cumulative_count(g, corner.x, corner.y, bin);
    var rest = 0.0;
    if f.x > 0.0 || f.y > 0.0 {
        let c10 = cumulative_count(g, corner.x + 1, corner.y, bin);
        let c01 = cumulative_count(g, corner.x, corner.y + 1, bin);
        let c11 = cumulative_count(g, corner.x + 1, corner.y + 1, bin);
        let dx = f32(bitcast<i32>(c10 - c00));
        let dy = f32(bitcast<i32>(c01 - c00));
        let dxy = f32(bitcast<i32>(c11 - c10 - c01 + c00));
        rest = f.x * dx + f.y * dy + f.x * f.y * dxy;
    }
    return FractionalCount(c00, rest);
}

// Normals in `bin` over the whole texels [lo, hi).
fn texel_box_count(g: GlintMaterial, lo: vec2i, hi: vec2i, bin: u32) -> u32 {
    return cumulative_count(g, hi.x, hi.y, bin) - cumulative_count(g, lo.x, hi.y, bin)
        - cumulative_count(g, hi.x, lo.y, bin) + cumulative_count(g, lo.x, lo.y, bin);
}

// Normals in `bin` over the box [lo, hi) of texel space (any real corners: texels partly inside count
// in proportion; CPU twin: `NormalHistogram::box_count`).
fn box_count(g: GlintMaterial, lo: vec2f, hi: vec2f, bin: u32) -> f32 {
    let li = vec2i(floor(lo));
    let hi_i = vec2i(floor(hi));
    let lf = lo - floor(lo);
    let hf = hi - floor(hi);
    let a = fractional_count(g, hi_i, hf, bin);
    let b = fractional_count(g, vec2i(li.x, hi_i.y), vec2f(lf.x, hf.y), bin);
    let c = fractional_count(g, vec2i(hi_i.x, li.y), vec2f(hf.x, lf.y), bin);
    let d = fractional_count(g, li, lf, bin);
    let whole = a.whole - b.whole - c.whole + d.whole;
    return f32(whole) + (a.rest - b.rest - c.rest + d.rest);
}

// What shading a chunk of bins needs about the pixel.
struct GlintPixel {
    s: GSurface,
    // Tangent frame (tangent, bitangent, macro normal) of the normal map.
    frame: mat3x3f,
    origin: vec3f,
    pixel: vec2u,
}

const CHUNK: u32 = 32u;

struct BinChunk {
    // Bins, their world-space normals and their shares of the footprint's normals.
    bins: array<u32, CHUNK>,
    normals: array<vec3f, CHUNK>,
    weights: array<f32, CHUNK>,
    count: u32,
}

// The filtered reflectance towards l, times the cosine: Σ_b w_b f(n_b; v, l) (n_b·l)⁺ over the chunk.
fn filtered_reflectance(p: GlintPixel, chunk: ptr<function, BinChunk>, l: vec3f) -> vec3f {
    var f = vec3f(0.0);
    for (var k = 0u; k < (*chunk).count; k++) {
        let n = (*chunk).normals[k];
        let cos_theta = dot(n, l);
        if cos_theta > 0.0 {
            f += (*chunk).weights[k] * brdf_eval(p.s.material, n, p.s.view, l) * cos_theta;
        }
    }
    return f;
}

// The chunk's share of the pixel's direct light. Every chunk draws the same light samples (the same
// random sequence), so the chunks of one pixel add up to one estimate with the whole histogram.
fn shade_chunk(p: GlintPixel, chunk: ptr<function, BinChunk>) -> vec3f {
    let s = p.s;
    var radiance = vec3f(0.0);
    for (var i = 0u; i < scene_info.light_count; i++) {
        let light = lights[i];
        let inc = light_incidence(light, s.position);
        if dot(s.geometric_normal, inc.direction) <= 0.0 || max3(inc.irradiance) <= 0.0 {
            continue;
        }
        let value = filtered_reflectance(p, chunk, inc.direction) * inc.irradiance;
        if max3(value) <= 0.0 {
            continue;
        }
        let sample = UnshadowedSample(value, inc.direction, inc.distance * (1.0 - 1e-4));
        radiance += value * analytic_visibility(light, s, sample, p.origin, false);
    }
    var rng = rng_new(p.pixel, frame.frame_counter, frame.seed);
    if scene_info.emissive_count > 0u && AREA_SAMPLES > 0u {
        var sum = vec3f(0.0);
        for (var k = 0u; k < AREA_SAMPLES; k++) {
            sum += incident_light(p, chunk, emissive_incident(p.origin, vec3f(rng_next(&rng), rng_next2(&rng))));
        }
        radiance += sum / f32(AREA_SAMPLES);
    }
    if scene_info.env_kind != ENV_NONE && ENV_SAMPLES > 0u {
        var sum = vec3f(0.0);
        for (var k = 0u; k < ENV_SAMPLES; k++) {
            sum += incident_light(p, chunk, environment_incident(s.normal, rng_next2(&rng)));
        }
        radiance += sum / f32(ENV_SAMPLES);
    }
    return radiance;
}

// One light sample reflected by the chunk's bins, shadow ray included.
fn incident_light(p: GlintPixel, chunk: ptr<function, BinChunk>, i: IncidentSample) -> vec3f {
    if dot(p.s.geometric_normal, i.direction) <= 0.0 || max3(i.weight) <= 0.0 {
        return vec3f(0.0);
    }
    let value = filtered_reflectance(p, chunk, i.direction) * i.weight;
    if max3(value) <= 0.0 {
        return vec3f(0.0);
    }
    return value * sample_visibility(UnshadowedSample(value, i.direction, i.distance), p.origin);
}

// Gives a chunk's bins their share of the footprint box [lo, hi) (of `total` normals) and their
// world-space normals; drops bins with no normal inside the box or facing away from the viewer (they
// reflect nothing towards it, as `brdf_eval` says, but count in the total). Returns the bins kept,
// which are also the chunk's new count.
fn weigh_chunk(
    g: GlintMaterial,
    p: ptr<function, GlintPixel>,
    chunk: ptr<function, BinChunk>,
    lo: vec2f,
    hi: vec2f,
    total: f32,
) -> u32 {
    var kept = 0u;
    for (var k = 0u; k < (*chunk).count; k++) {
        let b = (*chunk).bins[k];
        let c = box_count(g, lo, hi, b);
        let n = normalize((*p).frame * bin_normals[g.normal_offset + b].xyz);
        // Counts are whole or fractions of a texel's normals; f32 rounding leaves far less.
        if c > 1e-3 && dot(n, (*p).s.view) > 0.0 {
            (*chunk).normals[kept] = n;
            (*chunk).weights[kept] = c / total;
            kept++;
        }
    }
    (*chunk).count = kept;
    return kept;
}

fn weigh_and_shade(
    g: GlintMaterial,
    p: ptr<function, GlintPixel>,
    chunk: ptr<function, BinChunk>,
    lo: vec2f,
    hi: vec2f,
    total: f32,
) -> vec3f {
    if weigh_chunk(g, p, chunk, lo, hi, total) == 0u {
        return vec3f(0.0);
    }
    return shade_chunk(*p, chunk);
}

// Direct light of glint pixel `pixel`, whose primary ray hits `hit` through framebuffer point xy.
fn shade_glints(g: GlintMaterial, s: GSurface, hit: Hit, pixel: vec2u, xy: vec2f, dir: vec3f) -> vec3f {
    let t = triangle_vertices(hit.triangle);
    let vf = vertex_frame(t, hit.u, hit.v, dir);
    var p: GlintPixel;
    p.s = s;
    p.s.normal = vf.normal;
    p.s.geometric_normal = vf.geometric_normal;
    p.frame = tangent_frame(vf.normal, vf.tangent);
    p.origin = gsurface_ray_origin(p.s);
    p.pixel = pixel;

    // The footprint: the bounding box of the pixel's parallelogram in texel space, its origin folded
    // into the first period of the tiled map.
    let size = f32(g.size);
    let uv = t[0].uv * (1.0 - hit.u - hit.v) + t[1].uv * hit.u + t[2].uv * hit.v;
    let j = primary_uv_differentials(hit.triangle, xy, dir, hit.t);
    let centre = uv * size;
    let half_extent = 0.5 * (abs(j[0]) + abs(j[1])) * size;
    // At least a hundredth of a texel, so the box holds normals; at most MAX_FOOTPRINT.
    let clamped = clamp(half_extent, vec2f(0.005), vec2f(0.5 * MAX_FOOTPRINT));
    if any(clamped < half_extent) {
        atomicAdd(&counters[COUNTER_CLAMPED], 1u);
    }
    let lo_world = centre - clamped;
    let shift = floor(lo_world / size) * size;
    let lo = lo_world - shift;
    let hi = centre + clamped - shift;
    let total = 4.0 * clamped.x * clamped.y * f32(g.weight_per_texel);

    // Bins with normals in the whole texels the box touches are gathered in chunks (four lookups per
    // bin); only those get the box's exact, fractional count (twelve more). Deciding per bin instead
    // would make neighbouring threads wait for each other's bins.
    var chunk: BinChunk;
    chunk.count = 0u;
    var radiance = vec3f(0.0);
    var active_bins = 0u;
    var chunks = 0u;
    let outer_lo = vec2i(floor(lo));
    let outer_hi = vec2i(ceil(hi));
    let bins = g.bins * g.bins;
    for (var b = 0u; b < bins; b++) {
        if texel_box_count(g, outer_lo, outer_hi, b) == 0u {
            continue;
        }
        chunk.bins[chunk.count] = b;
        chunk.count++;
        if chunk.count == CHUNK {
            radiance += weigh_and_shade(g, &p, &chunk, lo, hi, total);
            active_bins += chunk.count;
            chunk.count = 0u;
            chunks++;
        }
    }
    if chunk.count > 0u {
        radiance += weigh_and_shade(g, &p, &chunk, lo, hi, total);
        active_bins += chunk.count;
        chunks++;
    }
    atomicAdd(&counters[COUNTER_PIXELS], 1u);
    atomicAdd(&counters[COUNTER_BINS], active_bins);
    atomicAdd(&counters[COUNTER_CHUNKS], chunks);
    return radiance;
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let s = load_gsurface(id.xy);
    var radiance = vec3f(0.0);
    if !s.valid {
        radiance = environment_radiance(-s.view);
    } else {
        let g = glint_materials[s.material_index];
        var shaded = false;
        if g.size > 0u {
            let xy = vec2f(id.xy) + 0.5 + frame.jitter;
            let dir = primary_ray_through(xy);
            let hit = trace_closest(Ray(frame.camera_position, dir), 0.0, FLT_MAX);
            // The G-buffer may see another surface where rasterisation and the ray disagree (edges):
            // such pixels are shaded as `direct` shades them.
            if hit_found(hit) && vertex_material(triangle_vertices(hit.triangle)[0]) == s.material_index {
                radiance = s.material.emission + shade_glints(g, s, hit, id.xy, xy, dir);
                shaded = true;
            }
        }
        if !shaded {
            var rng = rng_new(id.xy, frame.frame_counter, frame.seed);
            radiance = s.material.emission
                + direct_light(s, gsurface_ray_origin(s), &rng, AREA_SAMPLES, ENV_SAMPLES, false);
        }
    }
    radiance = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
