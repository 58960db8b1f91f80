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
//
// With GLINT_ENV_SH (part b of the paper) the environment's specular light is integrated in basis
// space instead: the footprint's normal distribution, as SH over the half vector (each bin's GGX lobe,
// a zonal harmonic turned to the bin's normal), dotted with the view's half-vector-space lighting
// (environment.wgsl), gives the unshadowed L_u in one evaluation; shadows multiply it by the ratio
// estimator of Heitz et al. 2018, Σ f̂ L V / p over Σ f̂ L / p of the same environment samples, whose
// sums are accumulated over frames (so the ratio converges) in `env_history`.

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

#if GLINT_ENV_SH
// Per view of environment.wgsl's latitude–longitude grid, the ENV_ORDER² SH coefficients of its
// half-vector-space lighting (rgb).
@group(2) @binding(5) var<storage, read> env_table: array<vec4f>;
// Per roughness step, the GGX lobe's ENV_ORDER zonal coefficients k_l.
@group(2) @binding(6) var<storage, read> lobe_zh: array<f32>;

// Per pixel, the running means over the frames since the last restart.
struct EnvHistory {
    // Everything but the environment's specular light.
    rest: vec4f,
    // L_u, the unshadowed specular light of the environment by the SH integration.
    unshadowed: vec4f,
    // The environment samples' specular light, Σ f̂ L V / p and Σ f̂ L / p.
    sampled_shadowed: vec4f,
    sampled_unshadowed: vec4f,
}
@group(2) @binding(7) var<storage, read_write> env_history: array<EnvHistory>;
#endif

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
    // The analytic light's index, NO_LIGHT for a sample of emissive triangles, ENV_LIGHT for one of
    // the environment.
    analytic: array<u32, SLOTS>,
    // Σ_b w_b f(n_b; v, l) (n_b·l)⁺ over the bins so far (without the specular part for environment
    // samples under GLINT_ENV_SH, which goes to `specular`).
    reflectance: array<vec3f, SLOTS>,
    specular: array<vec3f, SLOTS>,
    count: u32,
}

const NO_LIGHT: u32 = 0xffffffffu;
const ENV_LIGHT: u32 = 0xfffffffeu;
// A slot's `distance` for a direction below the surface: occluded by the surface itself.
const BELOW_SURFACE: f32 = -1.0;

fn add_slot(slots: ptr<function, LightSlots>, s: GSurface, direction: vec3f, light: vec3f, distance: f32, analytic: u32) {
    var d = distance;
    if dot(s.geometric_normal, direction) <= 0.0 {
        // The ratio estimator's denominator must see environment light from below the surface too,
        // since L_u includes what tilted microfacets would reflect of it; the surface occludes it.
        if !(GLINT_ENV_SH && analytic == ENV_LIGHT) {
            return;
        }
        d = BELOW_SURFACE;
    }
    if max3(light) <= 0.0 {
        return;
    }
    let k = (*slots).count;
    (*slots).direction[k] = direction;
    (*slots).light[k] = light;
    (*slots).distance[k] = d;
    (*slots).analytic[k] = analytic;
    (*slots).reflectance[k] = vec3f(0.0);
    (*slots).specular[k] = vec3f(0.0);
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
                add_slot(slots, s, sample.direction, sample.weight / f32(env_n), sample.distance, ENV_LIGHT);
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
            if GLINT_ENV_SH && (*slots).analytic[k] == ENV_LIGHT {
                let specular = brdf_eval_specular(m, n, view, l);
                (*slots).reflectance[k] += w * (brdf_eval(m, n, view, l) - specular) * cos_theta;
                (*slots).specular[k] += w * specular * cos_theta;
            } else {
                (*slots).reflectance[k] += w * brdf_eval(m, n, view, l) * cos_theta;
            }
        }
    }
}

// The environment samples' specular light with and without their shadow tests (the ratio
// estimator's numerator and denominator).
struct RatioSums {
    shadowed: vec3f,
    unshadowed: vec3f,
}

// The slots' light, each through its shadow test; environment samples' specular light goes to `ratio`.
fn shade_slots(slots: ptr<function, LightSlots>, s: GSurface, origin: vec3f, ratio: ptr<function, RatioSums>) -> vec3f {
    var radiance = vec3f(0.0);
    for (var k = 0u; k < (*slots).count; k++) {
        let value = (*slots).reflectance[k] * (*slots).light[k];
        let specular = (*slots).specular[k] * (*slots).light[k];
        if max3(value + specular) <= 0.0 {
            continue;
        }
        let sample = UnshadowedSample(value, (*slots).direction[k], (*slots).distance[k]);
        let light = (*slots).analytic[k];
        var visible = 0.0;
        if sample.distance == BELOW_SURFACE {
            visible = 0.0;
        } else if light == NO_LIGHT || light == ENV_LIGHT {
            visible = sample_visibility(sample, origin);
        } else {
            visible = analytic_visibility(lights[light], s, sample, origin, false);
        }
        radiance += value * visible;
        (*ratio).shadowed += specular * visible;
        (*ratio).unshadowed += specular;
    }
    return radiance;
}

#if GLINT_ENV_SH

// ---- Basis-space integration of the environment (GLINT_ENV_SH) ----

// The four views of the lighting table around a direction (environment frame) and their bilinear
// weights: first coefficient of each view's row of env_table.
struct ViewCells {
    first: vec4u,
    weight: vec4f,
}

fn view_cells(v: vec3f) -> ViewCells {
    let theta = acos(clamp(v.z, -1.0, 1.0));
    var phi = atan2(v.y, v.x);
    if phi < 0.0 {
        phi += TWO_PI;
    }
    let row = min(theta / PI * f32(ENV_VIEW_ROWS - 1u), f32(ENV_VIEW_ROWS - 1u) - 1e-4);
    let column = phi / TWO_PI * f32(ENV_VIEW_COLUMNS);
    let r0 = u32(row);
    let c0 = u32(column) % ENV_VIEW_COLUMNS;
    let c1 = (c0 + 1u) % ENV_VIEW_COLUMNS;
    let t = vec2f(fract(column), row - f32(r0));
    let count = ENV_ORDER * ENV_ORDER;
    let first = vec4u(r0 * ENV_VIEW_COLUMNS + c0, r0 * ENV_VIEW_COLUMNS + c1,
        (r0 + 1u) * ENV_VIEW_COLUMNS + c0, (r0 + 1u) * ENV_VIEW_COLUMNS + c1) * count;
    let weight = vec4f((1.0 - t.x) * (1.0 - t.y), t.x * (1.0 - t.y), (1.0 - t.x) * t.y, t.x * t.y);
    return ViewCells(first, weight);
}

// Coefficient k of the view's half-vector-space lighting.
fn view_lighting(c: ViewCells, k: u32) -> vec3f {
    return c.weight.x * env_table[c.first.x + k].rgb + c.weight.y * env_table[c.first.y + k].rgb
        + c.weight.z * env_table[c.first.z + k].rgb + c.weight.w * env_table[c.first.w + k].rgb;
}

// The GGX lobe's zonal coefficient k_l at a roughness (linear between the table's steps).
fn lobe_coefficient(roughness: f32, l: u32) -> f32 {
    let x = saturate(roughness) * f32(ENV_ROUGHNESS_STEPS - 1u);
    let i = min(u32(x), ENV_ROUGHNESS_STEPS - 2u);
    let t = x - f32(i);
    return mix(lobe_zh[i * ENV_ORDER + l], lobe_zh[(i + 1u) * ENV_ORDER + l], t);
}

// Up to SH_LANES bins at a time, one lane each (z, azimuth and weight per bin) in vec4 halves, so
// the SH recurrences run as vector arithmetic and each coefficient of the view's lighting is read once
// per group.
const SH_LANES: u32 = 8u;

struct ShBins {
    z: array<vec4f, 2>,
    cos_phi: array<vec4f, 2>,
    sin_phi: array<vec4f, 2>,
    weight_r: array<vec4f, 2>,
    weight_g: array<vec4f, 2>,
    weight_b: array<vec4f, 2>,
    count: u32,
}

fn lane_sums(g: ShBins, q: array<vec4f, 2>) -> vec3f {
    return vec3f(dot(g.weight_r[0], q[0]) + dot(g.weight_r[1], q[1]),
        dot(g.weight_g[0], q[0]) + dot(g.weight_g[1], q[1]),
        dot(g.weight_b[0], q[0]) + dot(g.weight_b[1], q[1]));
}

// Σ_b w_b Σ_lm k_l L̂_lm(v) y_lm(n_b) over the bins, the SH double product of the bins' lobes with the
// view's lighting, by the normalised associated-Legendre recurrences (hsh.rs's real SH: index
// l(l+1)+m, cos mφ for m > 0, sin |m|φ for m < 0, no Condon–Shortley phase).
fn sh_bins_light(g: ShBins, cells: ViewCells, roughness: f32) -> vec3f {
    var sin_theta: array<vec4f, 2>;
    var q_mm: array<vec4f, 2>;
    var cos_m: array<vec4f, 2>;
    var sin_m: array<vec4f, 2>;
    for (var h = 0u; h < 2u; h++) {
        sin_theta[h] = sqrt(max(vec4f(0.0), 1.0 - g.z[h] * g.z[h]));
        q_mm[h] = vec4f(0.28209479177387814);
        cos_m[h] = vec4f(1.0);
        sin_m[h] = vec4f(0.0);
    }
    var light = vec3f(0.0);
    for (var m = 0u; m < ENV_ORDER; m++) {
        if m > 0u {
            let growth = sqrt(f32(2u * m + 1u) / f32(2u * m));
            for (var h = 0u; h < 2u; h++) {
                q_mm[h] *= sin_theta[h] * growth;
                let c = cos_m[h] * g.cos_phi[h] - sin_m[h] * g.sin_phi[h];
                sin_m[h] = sin_m[h] * g.cos_phi[h] + cos_m[h] * g.sin_phi[h];
                cos_m[h] = c;
            }
        }
        var q = q_mm;
        var q_prev: array<vec4f, 2>;
        for (var l = m; l < ENV_ORDER; l++) {
            if l > m {
                let fl = f32(l);
                let fm = f32(m);
                let a = sqrt((4.0 * fl * fl - 1.0) / (fl * fl - fm * fm));
                let b = sqrt(max(0.0, ((fl - 1.0) * (fl - 1.0) - fm * fm) / (4.0 * (fl - 1.0) * (fl - 1.0) - 1.0)));
                for (var h = 0u; h < 2u; h++) {
                    let next = a * (g.z[h] * q[h] - b * q_prev[h]);
                    q_prev[h] = q[h];
                    q[h] = next;
                }
            }
            let k = lobe_coefficient(roughness, l);
            let centre = l * l + l;
            let dc = lane_sums(g, array<vec4f, 2>(q[0] * cos_m[0], q[1] * cos_m[1]));
            if m == 0u {
                light += k * dc * view_lighting(cells, centre);
            } else {
                let ds = lane_sums(g, array<vec4f, 2>(q[0] * sin_m[0], q[1] * sin_m[1]));
                light += (k * 1.4142135623730951) * (dc * view_lighting(cells, centre + m) + ds * view_lighting(cells, centre - m));
            }
        }
    }
    return light;
}

// Adds a bin (normal in the environment's frame, weight w_b times its F·G/(4 n_b·v) factor) to the
// group; a full group is integrated into `light` and emptied.
fn push_sh_bin(g: ptr<function, ShBins>, n: vec3f, weight: vec3f, cells: ViewCells, roughness: f32, light: ptr<function, vec3f>) {
    let i = (*g).count;
    let h = i / 4u;
    let lane = i % 4u;
    let r = length(n.xy);
    let e = select(vec2f(1.0, 0.0), n.xy / r, r > 1e-20);
    (*g).z[h][lane] = n.z;
    (*g).cos_phi[h][lane] = e.x;
    (*g).sin_phi[h][lane] = e.y;
    (*g).weight_r[h][lane] = weight.r;
    (*g).weight_g[h][lane] = weight.g;
    (*g).weight_b[h][lane] = weight.b;
    (*g).count = i + 1u;
    if (*g).count == SH_LANES {
        *light += sh_bins_light(*g, cells, roughness);
        *g = ShBins();
    }
}
#endif

// Direct light of glint pixel `pixel`, whose primary ray hits `hit` through framebuffer point xy.
// The light of a glint pixel: `rest` is final; under GLINT_ENV_SH the environment's specular light is
// `sh_unshadowed` times the ratio of `ratio`'s sums, which the caller accumulates over frames.
struct GlintLight {
    rest: vec3f,
    sh_unshadowed: vec3f,
    ratio: RatioSums,
}

fn shade_glints(g: GlintMaterial, gbuffer: GSurface, hit: Hit, pixel: vec2u, xy: vec2f, dir: vec3f) -> GlintLight {
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
    var ratio = RatioSums();
    var sh_light = vec3f(0.0);
#if GLINT_ENV_SH
    let cells = view_cells(environment_direction(s.view));
    let peak_d = ggx_d(ggx_alpha(s.material.roughness), 1.0);
    var sh_bins = ShBins();
#endif
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
#if GLINT_ENV_SH
                if first == 0u {
                    // The bin's F G / (4 n_b·v) at its mirror direction: the shared specular BRDF there
                    // over its D(1) (the paper's FG, per bin).
                    let mirror = 2.0 * dot(n, s.view) * n - s.view;
                    let fg = brdf_eval_specular(s.material, n, s.view, mirror) * dot(n, mirror) / peak_d;
                    push_sh_bin(&sh_bins, environment_direction(n), (c / total) * fg, cells,
                        s.material.roughness, &sh_light);
                }
#endif
            }
        }
        radiance += shade_slots(&slots, s, origin, &ratio);
        first += SLOTS;
        if first >= sequence {
            break;
        }
    }
#if GLINT_ENV_SH
    if sh_bins.count > 0u {
        sh_light += sh_bins_light(sh_bins, cells, s.material.roughness);
    }
#endif
    atomicAdd(&counters[COUNTER_PIXELS], 1u);
    atomicAdd(&counters[COUNTER_BINS], active_bins);
    atomicAdd(&counters[COUNTER_GROUPS], groups);
    return GlintLight(radiance, sh_light, ratio);
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let s = load_gsurface(id.xy);
    var light = GlintLight();
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
            light = shade_glints(g, s, hit, id.xy, xy, dir);
            light.rest += s.material.emission;
            shaded = true;
        }
    }
    if !shaded {
        light.rest = direct_pixel_radiance(s, id.xy, AREA_SAMPLES, ENV_SAMPLES);
    }
#if GLINT_ENV_SH
    let pixel = id.y * frame.size.x + id.x;
    var h = env_history[pixel];
    h.rest = vec4f(accumulate_mean(h.rest.rgb, light.rest, frame.sample_index), 0.0);
    h.unshadowed = vec4f(accumulate_mean(h.unshadowed.rgb, light.sh_unshadowed, frame.sample_index), 0.0);
    h.sampled_shadowed = vec4f(accumulate_mean(h.sampled_shadowed.rgb, light.ratio.shadowed, frame.sample_index), 0.0);
    h.sampled_unshadowed = vec4f(accumulate_mean(h.sampled_unshadowed.rgb, light.ratio.unshadowed, frame.sample_index), 0.0);
    env_history[pixel] = h;
    // Where no sample has yet seen the lobe's light the ratio is unknown: unshadowed until one does.
    let known = h.sampled_unshadowed.rgb > vec3f(0.0);
    let visible = select(vec3f(1.0), h.sampled_shadowed.rgb / max(h.sampled_unshadowed.rgb, vec3f(1e-30)), known);
    let radiance = h.rest.rgb + h.unshadowed.rgb * visible;
#else
    let radiance = accumulate_mean(textureLoad(output, id.xy).rgb, light.rest, frame.sample_index);
#endif
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
