// Hemispherical harmonics and real spherical harmonics of any order up to HSH_MAX_ORDER, by the
// associated-Legendre recurrence: the GPU twin of hsh.rs (which documents the conventions, checks
// orthonormality and the conversion matrix; a GPU test checks this file against it). Same indexing,
// l(l+1)+m, and no Condon–Shortley phase, so an SH vector of order 5 is also sh.wgsl's.

#import common/math.wgsl

const HSH_MAX_ORDER: u32 = 10u;
const HSH_MAX_COEFFICIENTS: u32 = 100u;
const HSH_SQRT_2: f32 = 1.41421356237310;

// Y_l^m (sphere, `x` = cos θ, `measure` 4π) or H_l^m (hemisphere, `x` = 2 cos θ − 1, `measure` 2π) at
// the unit vector `d`, one basis function at a time: passes give each invocation one coefficient
// rather than all of them in a function-local array, which lavapipe's compiler takes minutes over
// once it is indexed at run time.
fn harmonic_one(l: u32, m: i32, d: vec3f, x: f32, measure: f32) -> f32 {
    let am = u32(abs(m));
    let s = sqrt(max(0.0, 1.0 - x * x));
    var pmm = 1.0;
    for (var k = 1u; k <= am; k++) {
        pmm *= f32(2u * k - 1u) * s;
    }
    var p = pmm;
    if l > am {
        var p_prev = pmm;
        p = x * f32(2u * am + 1u) * pmm;
        for (var k = am + 2u; k <= l; k++) {
            let next = (x * f32(2u * k - 1u) * p - f32(k + am - 1u) * p_prev) / f32(k - am);
            p_prev = p;
            p = next;
        }
    }
    // (l − |m|)! / (l + |m|)!
    var ratio = 1.0;
    for (var k = l - am + 1u; k <= l + am; k++) {
        ratio /= f32(k);
    }
    let scale = sqrt(f32(2u * l + 1u) * ratio / measure) * p;
    if m == 0 {
        return scale;
    }
    let r = length(d.xy);
    let e = select(vec2f(1.0, 0.0), d.xy / r, r > 1e-20);
    var turn = vec2f(1.0, 0.0);
    for (var k = 0u; k < am; k++) {
        turn = vec2f(turn.x * e.x - turn.y * e.y, turn.x * e.y + turn.y * e.x);
    }
    return HSH_SQRT_2 * scale * select(turn.y, turn.x, m > 0);
}

// The band and m of coefficient index k = l(l+1)+m.
fn harmonic_lm(k: u32) -> vec2i {
    let l = u32(sqrt(f32(k) + 0.5));
    return vec2i(i32(l), i32(k) - i32(l * l + l));
}

fn hsh_one(k: u32, d: vec3f) -> f32 {
    let lm = harmonic_lm(k);
    return harmonic_one(u32(lm.x), lm.y, d, 2.0 * saturate(d.z) - 1.0, 2.0 * PI);
}

// Where band l's (2l+1)² matrix starts in an SH rotation's band matrices laid out band after band
// (hsh.rs ShRotationN::bands_f32): Σ_{j<l} (2j+1)² = l(4l² − 1)/3 (0 for l = 0, the wrapped
// subtraction multiplied by 0). For l = order it is the floats of all bands.
fn sh_band_matrix_start(l: u32) -> u32 {
    return l * (4u * l * l - 1u) / 3u;
}

fn sh_one(k: u32, d: vec3f) -> f32 {
    let lm = harmonic_lm(k);
    return harmonic_one(u32(lm.x), lm.y, d, clamp(d.z, -1.0, 1.0), 4.0 * PI);
}

// The Heidrich–Seidel paraboloid map of the upper hemisphere, the BRDF tables' parameterisation of
// outgoing directions (hsh.rs paraboloid_uv / paraboloid_direction).
fn paraboloid_uv(d: vec3f) -> vec2f {
    return 0.5 * (1.0 + d.xy / (max(d.z, 0.0) + 1.0));
}

// The inverse of paraboloid_uv; (u, v) outside the disc maps to the horizon.
fn paraboloid_direction(uv: vec2f) -> vec3f {
    var p = 2.0 * uv - 1.0;
    let r2 = dot(p, p);
    if r2 > 1.0 {
        p /= sqrt(r2);
    }
    let q = min(r2, 1.0);
    return vec3f(2.0 * p, 1.0 - q) / (1.0 + q);
}
