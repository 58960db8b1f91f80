// RSM gather (Dachsbacher & Stamminger 2005): every atlas texel sums the light of RSM pixel lights
// around its own projection into each light's RSM. The sample offsets (Rust: `gather_samples`) follow
// the paper's polar pattern (r_max·ξ1·sin 2πξ2, r_max·ξ1·cos 2πξ2), denser near the centre, with the
// weight of each sample (growing with ξ1) precomputed in `.z`. Interleaved, atlas sub-buffer k uses
// only subset k of the samples. BRUTE_FORCE sums every texel of every RSM layer instead (the converged
// value of the method: indirect light without indirect occlusion). The samples are split over several
// dispatches (`chunk`) because lavapipe loses work in very long per-invocation loops.

#import common/frame.wgsl

struct Chunk {
    // First sample (of this texel's subset) or first texel (brute force) of this dispatch, and how many.
    first: u32,
    count: u32,
    // 0: the first chunk (overwrite), 1: add to what earlier chunks wrote.
    accumulate: u32,
    _pad: u32,
}

@group(2) @binding(0) var indirect: texture_storage_2d<rgba32float, read_write>;
@group(2) @binding(1) var<storage, read> samples: array<vec4f>;
@group(2) @binding(2) var<uniform> chunk: Chunk;

fn gather_sampled(s: GSurface, subset: u32) -> vec3f {
    var sum = vec3f(0.0);
    let first = subset * SAMPLES_PER_SUBSET + chunk.first;
    let last = first + chunk.count;
    for (var l = 0u; l < scene_info.light_count; l++) {
        let light = lights[l];
        if light.shadow_layer < 0 {
            continue;
        }
        // A point light's cube: one disc on each of the six faces (the light of a face the point does not
        // project into still reaches it).
        let faces = select(1, 6, light.kind == LIGHT_POINT);
        for (var f = 0; f < faces; f++) {
            let layer = light.shadow_layer + f;
            let centre = rsm_project_layer(layer, s.position);
            let size = rsm_views[layer].size;
            for (var k = first; k < last; k++) {
                let smp = samples[k];
                let uv = centre + smp.xy;
                if any(uv < vec2f(0.0)) || any(uv >= vec2f(1.0)) {
                    continue;
                }
                let p = load_pixel_light(vec2i(uv * size), layer);
                if p.valid {
                    sum += pixel_light_radiance(s, p) * smp.z;
                }
            }
        }
    }
    return sum;
}

fn gather_all(s: GSurface) -> vec3f {
    var sum = vec3f(0.0);
    let size = u32(rsm_views[0].size);
    let per_layer = size * size;
    for (var t = chunk.first; t < chunk.first + chunk.count; t++) {
        let layer = t / per_layer;
        let i = t % per_layer;
        let p = load_pixel_light(vec2i(vec2u(i % size, i / size)), i32(layer));
        if p.valid {
            sum += pixel_light_radiance(s, p);
        }
    }
    return sum;
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let a = id.xy;
    if any(a >= atlas_size()) {
        return;
    }
    var flag = 1.0;
    if FIXUP {
        // Only the pixels the upsampling could not interpolate (alpha 0).
        flag = textureLoad(indirect, a).a;
        if flag > 0.5 {
            return;
        }
    }
    let s = atlas_surface(a);
    var sum = vec3f(0.0);
    if s.valid {
        if BRUTE_FORCE {
            sum = gather_all(s);
        } else {
            sum = gather_sampled(s, atlas_subset(a));
        }
    }
    if chunk.accumulate != 0u {
        sum += textureLoad(indirect, a).rgb;
    }
    textureStore(indirect, a, vec4f(sum, flag));
}
