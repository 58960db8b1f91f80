// Visibility and accumulation: every pixel gathers the VPLs of its interleaving set,
// (x mod n) + n (y mod m), each through a shadow ray in the shared BVH, and stores per pixel either
// (classic IGI) the reflected radiance divided by the BRDF factor of brdf_lobe_weights (for a Lambertian surface
// exactly irradiance / π, as classic IGI filters), or (SH) the
// incident light projected on order-2 real SH: c_i += weight · Y_i(ω) (the VPLs are the Monte-Carlo
// samples of the projection). One dispatch covers VPLs [chunk.begin, chunk.begin + CHUNK) of each set,
// adding to what earlier chunks stored (long per-invocation loops are unsafe on lavapipe).
//
// Bounded geometry term: when the VPL's part of the geometry term, G = cos θ_vpl / d², exceeds
// G_MAX (> 0), the VPL's light is scaled by G_MAX / G. (The receiver's cos θ_x is left out so that both
// variants bound the same thing: the SH variant applies the receiver's cosine only after filtering, and a
// VPL beside a receiver at a grazing angle would otherwise ring through the band-limited cosine.) The
// luminance × cos θ_x of the unoccluded VPLs' light kept and lost is written to `clamp_stats`, and in
// its w whether the pixel's data had to be scaled into the half-float range (`fit_half`). With
// COMPENSATE, one uniformly sampled hemisphere ray per pixel adds back the clamped part (Kollig & Keller
// 2004, one level): if it hits y with G(x, y) > G_MAX, y's outgoing radiance towards x — its emission
// (unless direct light comes from rasterisation) plus the same VPLs gathered at y — weighted by
// 1 − G_MAX / G.

#import common/frame.wgsl
#import common/sh.wgsl
#import common/color.wgsl
#import common/random.wgsl
#import common/sampling.wgsl
#import common/linear_texture.wgsl

// This frame's VPLs, copied into a linear texture (VPL_TABLE_TEXELS texels each) for the loops over
// them: see gpu/linear_texture.rs.
@group(2) @binding(0) var vpl_table: texture_2d<u32>;
@group(2) @binding(1) var<storage, read_write> accum: array<vec2u>;
// Per pixel: luminance of incident light kept, lost to clamping, and added back by compensation.
@group(2) @binding(2) var<storage, read_write> clamp_stats: array<vec4f>;
@group(2) @binding(3) var<uniform> chunk: Chunk;
// The VPLs' imperfect shadow maps (ism/lookup.wgsl), with visibility=ism; a placeholder otherwise.
@group(2) @binding(4) var ism_maps: texture_2d<f32>;

const VPL_TABLE_TEXELS: u32 = 5u;

fn table_vpl(k: u32) -> Vpl {
    let first = VPL_TABLE_TEXELS * k;
    let a = textureLoad(vpl_table, linear_texel(first), 0);
    let b = textureLoad(vpl_table, linear_texel(first + 1u), 0);
    let c = bitcast<vec4f>(textureLoad(vpl_table, linear_texel(first + 2u), 0));
    let d = bitcast<vec4f>(textureLoad(vpl_table, linear_texel(first + 3u), 0));
    let e = bitcast<vec4f>(textureLoad(vpl_table, linear_texel(first + 4u), 0));
    return Vpl(bitcast<vec3f>(a.xyz), a.w, bitcast<vec3f>(b.xyz), b.w, c.xyz, c.w, d.xyz, d.w, e.xyz, e.w);
}

struct Chunk {
    begin: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Radiance leaving the surface hit `y` towards -dir from the VPLs [first, last), clamped like the
// primary gather, plus y's emission when `with_emission`.
fn outgoing_from_vpls(y: SurfaceHit, dir: vec3f, first: u32, last: u32, with_emission: bool) -> vec3f {
    var l = select(vec3f(0.0), y.material.emission, with_emission);
    let origin = offset_origin(y.position, y.geometric_normal);
    for (var k = first; k < last; k++) {
        let v = table_vpl(k);
        if v.kind == VPL_EMPTY {
            continue;
        }
        let inc = vpl_incidence(v, y.position);
        let cos_y = dot(y.normal, inc.direction);
        if max3(inc.weight) <= 0.0 || cos_y <= 0.0 || dot(y.geometric_normal, inc.direction) <= 0.0 {
            continue;
        }
        let visible = vpl_visibility(k, v, y.position, y.geometric_normal, origin, inc);
        if visible <= 0.0 {
            continue;
        }
        var w = inc.weight * visible;
        if inc.geometry > G_MAX {
            w *= G_MAX / inc.geometry;
        }
        l += brdf_eval(y.material, y.normal, -dir, inc.direction) * w * cos_y;
    }
    return l;
}

// Scales each colour channel's stored values together so that the largest fits a half float, and says
// whether it had to. A VPL spike (a VPL almost touching a glossy receiver) can exceed the half range;
// saturating each coefficient alone would distort the SH lobe, scaling keeps its shape and loses only
// magnitude, and nothing turns into ∞ for the filter to spread.
fn fit_half(data: ptr<function, array<vec4f, VEC4S>>) -> bool {
    // 3 channels interleaved: 9 SH coefficients each in 7 vec4s, or one value each in 1.
    let per_channel = VEC4S * 4u / 3u;
    var largest = vec3f(0.0);
    for (var i = 0u; i < per_channel; i++) {
        for (var c = 0u; c < 3u; c++) {
            let f = 3u * i + c;
            largest[c] = max(largest[c], abs((*data)[f / 4u][f % 4u]));
        }
    }
    let scale = half_fit_scale(largest);
    for (var i = 0u; i < per_channel; i++) {
        for (var c = 0u; c < 3u; c++) {
            let f = 3u * i + c;
            (*data)[f / 4u][f % 4u] *= scale[c];
        }
    }
    return any(scale < vec3f(1.0));
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let pixel = id.y * frame.size.x + id.x;
    let base = pixel * VEC4S;
    let s = load_gsurface(id.xy);
    var data: array<vec4f, VEC4S>;
    var kept = 0.0;
    var lost = 0.0;
    var compensated = 0.0;
    var overflowed = 0.0;
    if s.valid {
        let set_index = (id.x % INTERLEAVE_X) + INTERLEAVE_X * (id.y % INTERLEAVE_Y);
        let first = set_index * SLOTS_PER_SET + chunk.begin;
        let last = set_index * SLOTS_PER_SET + min(chunk.begin + CHUNK, SLOTS_PER_SET);
        let origin = gsurface_ray_origin(s);
        let n_dot_v = dot(s.normal, s.view);
        let weights = brdf_lobe_weights(s.material, n_dot_v);
        let demodulate = weights.diffuse + weights.specular;
        var sh: array<vec3f, 9>;
        var radiance = vec3f(0.0);
        for (var k = first; k < last; k++) {
            let v = table_vpl(k);
            if v.kind == VPL_EMPTY {
                continue;
            }
            let inc = vpl_incidence(v, s.position);
            if max3(inc.weight) <= 0.0 || dot(s.geometric_normal, inc.direction) <= 0.0 {
                continue;
            }
            // Occluded VPLs deliver nothing, so the bound removes nothing of theirs either: the
            // visibility test comes before the bookkeeping of what the bound keeps and loses.
            let visible = vpl_visibility(k, v, s.position, s.geometric_normal, origin, inc);
            if visible <= 0.0 {
                continue;
            }
            let cos_x = max(dot(s.normal, inc.direction), 0.0);
            var w = inc.weight * visible;
            if G_MAX > 0.0 && inc.geometry > G_MAX {
                let kept_fraction = G_MAX / inc.geometry;
                lost += luminance(w) * cos_x * (1.0 - kept_fraction);
                w *= kept_fraction;
            }
            kept += luminance(w) * cos_x;
            if SH {
                let y = sh9_basis(inc.direction);
                for (var i = 0u; i < 9u; i++) {
                    sh[i] += w * y[i];
                }
            } else {
                radiance += brdf_eval(s.material, s.normal, s.view, inc.direction) * w * cos_x;
            }
        }
        if COMPENSATE && G_MAX > 0.0 {
            // The same direction in every chunk: the chunks' partial sums add up to one estimate.
            var rng = rng_new(id.xy, frame.frame_counter, frame.seed ^ 0x51ed270bu);
            let dir = local_to_world(sample_cone(rng_next2(&rng), 0.0), s.geometric_normal);
            let cos_x = max(dot(s.normal, dir), 0.0);
            let hit = trace_closest(Ray(origin, dir), 0.0, FLT_MAX);
            if hit_found(hit) {
                let y = surface_at(hit.triangle, hit.u, hit.v, dir);
                let g = abs(dot(y.geometric_normal, dir)) / max(hit.t * hit.t, 1e-12);
                if g > G_MAX {
                    let with_emission = !DIRECT_RASTER && chunk.begin == 0u;
                    // Uniform hemisphere: pdf 1 / 2π.
                    let li = outgoing_from_vpls(y, dir, first, last, with_emission) * ((1.0 - G_MAX / g) * TWO_PI);
                    compensated += luminance(li) * cos_x;
                    if SH {
                        let yd = sh9_basis(dir);
                        for (var i = 0u; i < 9u; i++) {
                            sh[i] += li * yd[i];
                        }
                    } else {
                        radiance += brdf_eval(s.material, s.normal, s.view, dir) * li * cos_x;
                    }
                }
            }
        }
        if SH {
            for (var i = 0u; i < 9u; i++) {
                for (var c = 0u; c < 3u; c++) {
                    let f = 3u * i + c;
                    data[f / 4u][f % 4u] = sh[i][c];
                }
            }
        } else {
            data[0] = vec4f(select(vec3f(0.0), radiance / demodulate, demodulate > vec3f(1e-6)), 0.0);
        }
    }
    if chunk.begin > 0u {
        for (var k = 0u; k < VEC4S; k++) {
            data[k] += unpack_half4(accum[base + k]);
        }
        let previous = clamp_stats[pixel];
        kept += previous.x;
        lost += previous.y;
        compensated += previous.z;
        overflowed = previous.w;
    }
    if fit_half(&data) {
        overflowed = 1.0;
    }
    for (var k = 0u; k < VEC4S; k++) {
        accum[base + k] = pack_half4(data[k]);
    }
    clamp_stats[pixel] = vec4f(kept, lost, compensated, overflowed);
}
