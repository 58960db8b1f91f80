// Environment lighting of every pixel from harmonic coefficients (the thesis's §3.5.3): the
// environment's SH turned into the frame of the pixel's normal, converted to HSH (or kept as SH for the
// baseline), and dotted with the BRDF tables at the local outgoing direction; no visibility, as in the
// thesis. The HSH conversion λ = C g enters only through Σ_i λ_i T_i = Σ_j g_j (Σ_i C_ij T_i): the
// tables are folded with C once (fold.wgsl), so HSH shading costs what SH shading does
// (the thesis converted per pixel and paid 1–14 % of its frame rate for it). Everything runs band by
// band (rotations keep bands apart), so no invocation holds more than one band's 2l + 1 colours. The turn is R⁻¹ for R = Rz(φ) Ry(θ), (θ, φ) the normal's spherical angles, with Ry written
// as Rx(−90°) Rz(θ) Rx(90°), so per pixel only two cheap Z turns and two products with the one
// constant X matrix (band by band) are needed. The BASIS_SAMPLED variant instead estimates the same
// unshadowed integral by sampling the BRDF: the reference the harmonic bases are judged against.
// The direct pass's estimate (lights and emitters, the environment left out) is added and the sum
// averaged over frames.

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

const MAX_BAND_WIDTH: u32 = 2u * HSH_MAX_ORDER - 1u;
alias Band = array<vec3f, MAX_BAND_WIDTH>;

// Band l of g(d) = f(Rz(−angle) d), as hsh.rs rotate_z: the (m, −m) pairs turn by m·angle.
fn rotate_z(b: ptr<function, Band>, l: u32, angle: f32) {
    for (var m = 1u; m <= l; m++) {
        let s = sin(f32(m) * angle);
        let co = cos(f32(m) * angle);
        let cos_part = (*b)[l + m];
        let sin_part = (*b)[l - m];
        (*b)[l + m] = cos_part * co - sin_part * s;
        (*b)[l - m] = sin_part * co + cos_part * s;
    }
}

// Band l turned by Rx(90°), or by its inverse (the transposed block).
fn rotate_x90(b: ptr<function, Band>, l: u32, inverse: bool) {
    let n = 2u * l + 1u;
    let block = l * (4u * l * l - 1u) / 3u;
    var out: Band;
    for (var i = 0u; i < n; i++) {
        var sum = vec3f(0.0);
        for (var j = 0u; j < n; j++) {
            let e = select(rotation_x90[block + i * n + j], rotation_x90[block + j * n + i], inverse);
            sum += e * (*b)[j];
        }
        out[i] = sum;
    }
    *b = out;
}

fn harmonic_environment(s: GSurface) -> vec3f {
    let n = s.normal;
    let theta = acos(clamp(n.z, -1.0, 1.0));
    let phi = select(0.0, atan2(n.y, n.x), abs(n.x) + abs(n.y) > 0.0);
    // The view direction in the normal's frame: Ry(−θ) Rz(−φ) v.
    let v = s.view;
    let vz = vec2f(cos(phi) * v.x + sin(phi) * v.y, -sin(phi) * v.x + cos(phi) * v.y);
    let local_v = vec3f(cos(theta) * vz.x - sin(theta) * v.z, vz.y, sin(theta) * vz.x + cos(theta) * v.z);
    let t = brdf_table_lookup(local_v, s.material.roughness);
    let count = shape.order * shape.order;
    var lambert = vec3f(0.0);
    var lambert_fresnel = vec3f(0.0);
    var ggx = vec3f(0.0);
    var ggx_fresnel = vec3f(0.0);
    for (var l = 0u; l < shape.order; l++) {
        var b: Band;
        for (var i = 0u; i < 2u * l + 1u; i++) {
            b[i] = environment_sh[l * l + i].rgb;
        }
        rotate_z(&b, l, -phi);
        rotate_x90(&b, l, false);
        rotate_z(&b, l, -theta);
        rotate_x90(&b, l, true);
        for (var i = 0u; i < 2u * l + 1u; i++) {
            let lobes = brdf_table_lobes(t, l * l + i, count);
            lambert += b[i] * lobes.x;
            lambert_fresnel += b[i] * lobes.y;
            ggx += b[i] * lobes.z;
            ggx_fresnel += b[i] * lobes.w;
        }
    }
    return max(brdf_table_combine(s.material, lambert, lambert_fresnel, ggx, ggx_fresnel), vec3f(0.0));
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
            radiance += harmonic_environment(s);
        }
    }
    let mean = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(mean, 1.0));
}
