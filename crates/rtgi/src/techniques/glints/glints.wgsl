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
const COUNTER_GROUPS: u32 = 2u;
const COUNTER_CLAMPED: u32 = 3u;

// A footprint is at most this many texels along each axis (counts stay below 2³²).
const MAX_FOOTPRINT: f32 = 8192.0;

// floor(x / d) for d > 0.
fn floor_div(x: i32, d: i32) -> i32 {
    return (x - select(0, d - 1, x < 0)) / d;
}

// Where the cumulative count of every bin at one integer point of the tiled map's texel grid is read
// from: up to four stored rows of counts (`NO_COUNT` where the count is an implicit zero) and their
// multipliers, the whole periods below and left of the point (see `cumulative_point`). A footprint
// finds its points once; then each bin costs only the loads.
struct CountPoint {
    index: vec4u,
    scale: vec4u,
}

const NO_COUNT: u32 = 0xffffffffu;

// First of the bins of the stored cumulative count at (x, y), x and y in 0..=size.
fn stored_index(g: GlintMaterial, x: u32, y: u32) -> u32 {
    if x == 0u || y == 0u {
        return NO_COUNT;
    }
    return g.offset + ((y - 1u) * g.size + (x - 1u)) * (g.bins * g.bins + g.bins);
}

// The normals over texels [0, x) × [0, y) of the map tiled over the plane: whole periods times the
// map's totals plus the remainder, in wrap-around arithmetic (CPU twin: `NormalHistogram::cumulative`).
fn cumulative_point(g: GlintMaterial, x: i32, y: i32) -> CountPoint {
    let size = i32(g.size);
    let qx = floor_div(x, size);
    let qy = floor_div(y, size);
    let rx = u32(x - qx * size);
    let ry = u32(y - qy * size);
    let index = vec4u(
        stored_index(g, rx, ry),
        select(NO_COUNT, stored_index(g, g.size, ry), qx != 0),
        select(NO_COUNT, stored_index(g, rx, g.size), qy != 0),
        select(NO_COUNT, stored_index(g, g.size, g.size), qx != 0 && qy != 0),
    );
    let sx = bitcast<u32>(qx);
    let sy = bitcast<u32>(qy);
    return CountPoint(index, vec4u(1u, sx, sy, sx * sy));
}

fn count_at(p: CountPoint, bin: u32) -> u32 {
    var c = 0u;
    for (var k = 0u; k < 4u; k++) {
        if p.index[k] != NO_COUNT {
            c += p.scale[k] * histograms[p.index[k] + bin];
        }
    }
    return c;
}

// A footprint box [lo, hi) of texel space: the cumulative points on the columns X0, X0 + 1, X1,
// X1 + 1 and the same rows (X0 = ⌊lo.x⌋, X1 = ⌊hi.x⌋), the fractional parts of its corners, and the
// points of the whole texels it touches.
struct Footprint {
    // points[row][column]
    points: array<array<CountPoint, 4>, 4>,
    lo_fraction: vec2f,
    hi_fraction: vec2f,
    touched: array<CountPoint, 4>,
}

fn footprint(g: GlintMaterial, lo: vec2f, hi: vec2f) -> Footprint {
    var f: Footprint;
    let l = vec2i(floor(lo));
    let h = vec2i(floor(hi));
    let xs = vec4i(l.x, l.x + 1, h.x, h.x + 1);
    let ys = vec4i(l.y, l.y + 1, h.y, h.y + 1);
    for (var r = 0u; r < 4u; r++) {
        for (var c = 0u; c < 4u; c++) {
            f.points[r][c] = cumulative_point(g, xs[c], ys[r]);
        }
    }
    f.lo_fraction = lo - floor(lo);
    f.hi_fraction = hi - floor(hi);
    let outer = vec2i(ceil(hi));
    f.touched[0] = cumulative_point(g, l.x, l.y);
    f.touched[1] = cumulative_point(g, outer.x, l.y);
    f.touched[2] = cumulative_point(g, l.x, outer.y);
    f.touched[3] = cumulative_point(g, outer.x, outer.y);
    return f;
}

// Normals in `bin` over the whole texels the footprint touches.
fn touched_count(f: ptr<function, Footprint>, bin: u32) -> u32 {
    return count_at((*f).touched[3], bin) - count_at((*f).touched[2], bin) - count_at((*f).touched[1], bin)
        + count_at((*f).touched[0], bin);
}

// The cumulative count at a fractional corner, texel contents spread evenly over each texel (bilinear
// between the four integer points at row r, column c and one further), split into the integer count at
// the point and the fractional rest, which is made of small differences and so stays exact in f32.
struct FractionalCount {
    whole: u32,
    rest: f32,
}

fn corner_count(f: ptr<function, Footprint>, r: u32, c: u32, fraction: vec2f, bin: u32) -> FractionalCount {
    let c00 = count_at((*f).points[r][c], bin);
    var rest = 0.0;
    if fraction.x > 0.0 || fraction.y > 0.0 {
        let c10 = count_at((*f).points[r][c + 1u], bin);
        let c01 = count_at((*f).points[r + 1u][c], bin);
        let c11 = count_at((*f).points[r + 1u][c + 1u], bin);
        let dx = f32(bitcast<i32>(c10 - c00));
        let dy = f32(bitcast<i32>(c01 - c00));
        let dxy = f32(bitcast<i32>(c11 - c10 - c01 + c00));
        rest = fraction.x * dx + fraction.y * dy + fraction.x * fraction.y * dxy;
    }
    return FractionalCount(c00, rest);
}

// Normals in `bin` over the footprint's box (texels partly inside count in proportion; CPU twin:
// `NormalHistogram::box_count`).
fn box_count(f: ptr<function, Footprint>, bin: u32) -> f32 {
    let lf = (*f).lo_fraction;
    let hf = (*f).hi_fraction;
    let a = corner_count(f, 2u, 2u, hf, bin);
    let b = corner_count(f, 2u, 0u, vec2f(lf.x, hf.y), bin);
    let c = corner_count(f, 0u, 2u, vec2f(hf.x, lf.y), bin);
    let d = corner_count(f, 0u, 0u, lf, bin);
    let whole = a.whole - b.whole - c.whole + d.whole;
    return f32(whole) + (a.rest - b.rest - c.rest + d.rest);
}

// The light a glint pixel reflects comes through slots: each analytic light, and each light sample of
// the emissive triangles and the environment, is one slot with a direction, the light it brings
// (irradiance, or radiance over the sampling density) and its shadow ray. One pass over the bins adds
// each bin's reflectance towards every slot; the slots' shadows are tested afterwards, once each.
const SLOTS: u32 = 16u;

struct LightSlots {
    direction: array<vec3f, SLOTS>,
    light: array<vec3f, SLOTS>,
    distance: array<f32, SLOTS>,
    // The analytic light's index, or NO_LIGHT for a traced sample.
    analytic: array<u32, SLOTS>,
    // Σ_b w_b f(n_b; v, l) (n_b·l)⁺ over the bins so far.
    reflectance: array<vec3f, SLOTS>,
    count: u32,
}

const NO_LIGHT: u32 = 0xffffffffu;

fn add_slot(slots: ptr<function, LightSlots>, s: GSurface, direction: vec3f, light: vec3f, distance: f32, analytic: u32) {
    if dot(s.geometric_normal, direction) <= 0.0 || max3(light) <= 0.0 {
        return;
    }
    let k = (*slots).count;
    (*slots).direction[k] = direction;
    (*slots).light[k] = light;
    (*slots).distance[k] = distance;
    (*slots).analytic[k] = analytic;
    (*slots).reflectance[k] = vec3f(0.0);
    (*slots).count = k + 1u;
}

// The slots numbered first .. first + SLOTS − 1 of the pixel's sequence: the analytic lights, then
// AREA_SAMPLES samples of the emissive triangles and ENV_SAMPLES of the environment (drawn from the
// pixel's random sequence, the same for every group). Slots whose light cannot reach the surface are
// left out. Returns the slots' sequence length, so the caller knows whether another group follows.
fn fill_slots(slots: ptr<function, LightSlots>, s: GSurface, origin: vec3f, pixel: vec2u, first: u32) -> u32 {
    (*slots).count = 0u;
    let lights_n = scene_info.light_count;
    let area_n = select(0u, AREA_SAMPLES, scene_info.emissive_count > 0u);
    let env_n = select(0u, ENV_SAMPLES, scene_info.env_kind != ENV_NONE);
    let end = min(first + SLOTS, lights_n + area_n + env_n);
    var rng = rng_new(pixel, frame.frame_counter, frame.seed);
    for (var i = 0u; i < end; i++) {
        if i < lights_n {
            if i >= first {
                let inc = light_incidence(lights[i], s.position);
                add_slot(slots, s, inc.direction, inc.irradiance, inc.distance * (1.0 - 1e-4), i);
            }
        } else if i < lights_n + area_n {
            let sample = emissive_incident(origin, vec3f(rng_next(&rng), rng_next2(&rng)));
            if i >= first {
                add_slot(slots, s, sample.direction, sample.weight / f32(area_n), sample.distance, NO_LIGHT);
            }
        } else {
            let sample = environment_incident(s.normal, rng_next2(&rng));
            if i >= first {
                add_slot(slots, s, sample.direction, sample.weight / f32(env_n), sample.distance, NO_LIGHT);
            }
        }
    }
    return lights_n + area_n + env_n;
}

// Adds a bin of normal n (world space) and weight w to every slot's reflectance.
fn reflect_bin(slots: ptr<function, LightSlots>, m: SurfaceMaterial, view: vec3f, n: vec3f, w: f32) {
    for (var k = 0u; k < (*slots).count; k++) {
        let l = (*slots).direction[k];
        let cos_theta = dot(n, l);
        if cos_theta > 0.0 {
            (*slots).reflectance[k] += w * brdf_eval(m, n, view, l) * cos_theta;
        }
    }
}

// The slots' light, each through its shadow test.
fn shade_slots(slots: ptr<function, LightSlots>, s: GSurface, origin: vec3f) -> vec3f {
    var radiance = vec3f(0.0);
    for (var k = 0u; k < (*slots).count; k++) {
        let value = (*slots).reflectance[k] * (*slots).light[k];
        if max3(value) <= 0.0 {
            continue;
        }
        let sample = UnshadowedSample(value, (*slots).direction[k], (*slots).distance[k]);
        let light = (*slots).analytic[k];
        var visible = 0.0;
        if light == NO_LIGHT {
            visible = sample_visibility(sample, origin);
        } else {
            visible = analytic_visibility(lights[light], s, sample, origin, false);
        }
        radiance += value * visible;
    }
    return radiance;
}

// Direct light of glint pixel `pixel`, whose primary ray hits `hit` through framebuffer point xy.
fn shade_glints(g: GlintMaterial, gbuffer: GSurface, hit: Hit, pixel: vec2u, xy: vec2f, dir: vec3f) -> vec3f {
    let t = triangle_vertices(hit.triangle);
    let vf = vertex_frame(t, hit.u, hit.v, dir);
    var s = gbuffer;
    s.normal = vf.normal;
    s.geometric_normal = vf.geometric_normal;
    let tangents = tangent_frame(vf.normal, vf.tangent);
    let origin = gsurface_ray_origin(s);

    // The footprint: the pixel's parallelogram in texel space (spanned by the ray differentials) as the
    // axis-aligned box with its spread along u and along v (the same second moments: half extents
    // ½ √(j_x² + j_y²)), which is exact for a parallelogram along the axes and smaller than its
    // bounding box when it is sheared (the bounding box blurred the glints: twice the relative MSE on
    // `glints`); its origin folded into the first period of the tiled map.
    let size = f32(g.size);
    let uv = t[0].uv * (1.0 - hit.u - hit.v) + t[1].uv * hit.u + t[2].uv * hit.v;
    let j = primary_uv_differentials(hit.triangle, xy, dir, hit.t);
    let centre = uv * size;
    let half_extent = 0.5 * sqrt(j[0] * j[0] + j[1] * j[1]) * size;
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
    var fp = footprint(g, lo, hi);

    // Every occupied row's bins are asked whether the whole texels the box touches hold any of their
    // normals (four lookups); only those get the box's exact, fractional count (twelve more) and are
    // shaded.
    var radiance = vec3f(0.0);
    var active_bins = 0u;
    var groups = 0u;
    var slots: LightSlots;
    let bins = g.bins * g.bins;
    var first = 0u;
    loop {
        let sequence = fill_slots(&slots, s, origin, pixel, first);
        groups++;
        for (var b = 0u; b < bins; b++) {
            // At a row's first bin, skip the row when none of its bins is occupied.
            if b % g.bins == 0u && touched_count(&fp, bins + b / g.bins) == 0u {
                b += g.bins - 1u;
                continue;
            }
            if touched_count(&fp, b) == 0u {
                continue;
            }
            let c = box_count(&fp, b);
            let n = normalize(tangents * bin_normals[g.normal_offset + b].xyz);
            // Counts are whole or fractions of a texel's normals (f32 rounding leaves far less).
            // Microfacets facing away from the viewer reflect nothing towards it (as `brdf_eval`
            // says) but count in the footprint's total.
            if c > 1e-3 && dot(n, s.view) > 0.0 {
                reflect_bin(&slots, s.material, s.view, n, c / total);
                active_bins += select(0u, 1u, first == 0u);
            }
        }
        radiance += shade_slots(&slots, s, origin);
        first += SLOTS;
        if first >= sequence {
            break;
        }
    }
    atomicAdd(&counters[COUNTER_PIXELS], 1u);
    atomicAdd(&counters[COUNTER_BINS], active_bins);
    atomicAdd(&counters[COUNTER_GROUPS], groups);
    return radiance;
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let s = load_gsurface(id.xy);
    var radiance = vec3f(0.0);
    var shaded = false;
    var g: GlintMaterial;
    if s.valid {
        g = glint_materials[s.material_index];
    }
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
        radiance = direct_pixel_radiance(s, id.xy, AREA_SAMPLES, ENV_SAMPLES);
    }
    radiance = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
