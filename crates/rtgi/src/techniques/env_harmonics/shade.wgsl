// Environment lighting of every pixel from harmonic coefficients (the thesis's §3.5.3): the
// environment's SH shaded through the BRDF tables by brdf_tables/shading.wgsl, in HSH (tables folded
// with C) or SH for the baseline; no visibility, as in the thesis. The HSH conversion λ = C g enters
// only through Σ_i λ_i T_i = Σ_j g_j (Σ_i C_ij T_i): the tables are folded with C once (fold.wgsl), so
// HSH shading costs what SH shading does (the thesis converted per pixel and paid 1–14 % of its frame
// rate for it). The BASIS_SAMPLED variant instead estimates the same unshadowed integral by sampling
// the BRDF: the reference the harmonic bases are judged against. The direct pass's estimate (lights
// and emitters, the environment left out) is added and the sum averaged over frames.

#import common/frame.wgsl
#import common/environment.wgsl
#import common/hsh.wgsl
#import common/random.wgsl

@group(2) @binding(0) var direct: texture_2d<f32>;
@group(2) @binding(1) var output: texture_storage_2d<rgba32float, read_write>;
@group(2) @binding(2) var<storage, read> environment_sh: array<vec4f>;
// Band l's (2l+1)² block of the SH matrix of Rx(90°), row-major, from l(4l² − 1)/3.
@group(2) @binding(3) var<storage, read> rotation_x90: array<f32>;
// The BRDF tables (brdf_tables/build.wgsl, read by its lookup.wgsl) in the SH of the environment:
// for HSH, already folded with C (fold.wgsl).
@group(2) @binding(4) var<storage, read> brdf_tables: array<f32>;
// The order as a run-time value: a compile-time bound lets LLVM (lavapipe) unroll the per-band
// loops and scalarise the coefficient arrays, which takes minutes to compile from order 8 on.
struct Shape {
    order: u32,
}
@group(2) @binding(5) var<uniform> shape: Shape;

// The radiance shading.wgsl integrates: the environment's, unoccluded.
fn incident_sh(k: u32) -> vec3f {
    return environment_sh[k].rgb;
}

// The same integral, ∫ L f cos over the hemisphere without visibility, by sampling the BRDF.
fn sampled_environment(s: GSurface, pixel: vec2u) -> vec3f {
    var rng = rng_new(pixel, frame.frame_counter, frame.seed);
    var sum = vec3f(0.0);
    for (var i = 0u; i < REFERENCE_SAMPLES; i++) {
        let u = vec3f(rng_next(&rng), rng_next2(&rng));
        let b = brdf_sample(s.material, s.normal, s.view, u);
        if b.pdf > 0.0 {
            sum += b.weight * environment_radiance(b.direction);
        }
    }
    return sum / f32(REFERENCE_SAMPLES);
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    var radiance = textureLoad(direct, id.xy, 0).rgb;
    let s = load_gsurface(id.xy);
    if s.valid {
        if BASIS_SAMPLED {
            radiance += sampled_environment(s, id.xy);
        } else {
            radiance += harmonic_shading(s, shape.order);
        }
    }
    let mean = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(mean, 1.0));
}
