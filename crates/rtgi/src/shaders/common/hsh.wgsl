// Hemispherical harmonics and real spherical harmonics of any order up to HSH_MAX_ORDER, by the
// associated-Legendre recurrence: the GPU twin of hsh.rs (which documents the conventions, checks
// orthonormality and the conversion matrix; a GPU test checks this file against it). Same indexing,
// l(l+1)+m, and no Condon–Shortley phase, so an SH vector of order 5 is also sh.wgsl's.

#import common/math.wgsl

const HSH_MAX_ORDER: u32 = 10u;
const HSH_MAX_COEFFICIENTS: u32 = 100u;
const HSH_SQRT_2: f32 = 1.41421356237310;

// Y_l^m (sphere, `x` = cos θ, `measure` 4π) or H_l^m (hemisphere, `x` = 2 cos θ − 1, `measure` 2π) of
// the bands below `order` at the unit vector `d`, into `out[0 .. order²]`.
fn harmonics_into(out: ptr<function, array<f32, HSH_MAX_COEFFICIENTS>>, order: u32, d: vec3f, x: f32, measure: f32) {
    let n = min(order, HSH_MAX_ORDER);
    let s = sqrt(max(0.0, 1.0 - x * x));
    // cos φ, sin φ without atan2; φ = 0 at the pole, as hsh.rs's atan2(0, 0).
    let r = length(d.xy);
    let e = select(vec2f(1.0, 0.0), d.xy / r, r > 1e-20);
    // (cos mφ, sin mφ) by complex multiplication, and P_m^m, advanced once per m.
    var turn = vec2f(1.0, 0.0);
    var pmm = 1.0;
    for (var m = 0u; m < n; m++) {
        if m > 0u {
            pmm *= f32(2u * m - 1u) * s;
            turn = vec2f(turn.x * e.x - turn.y * e.y, turn.x * e.y + turn.y * e.x);
        }
        // (l − m)! / (l + m)!, from l = m (1 / (2m)!) upwards.
        var ratio = 1.0;
        for (var k = 1u; k <= 2u * m; k++) {
            ratio /= f32(k);
        }
        var p_prev = 0.0;
        var p = pmm;
        for (var l = m; l < n; l++) {
            if l == m + 1u {
                p_prev = p;
                p = x * f32(2u * m + 1u) * pmm;
            } else if l > m + 1u {
                let next = (x * f32(2u * l - 1u) * p - f32(l + m - 1u) * p_prev) / f32(l - m);
                p_prev = p;
                p = next;
            }
            if l > m {
                // (l − m)! / (l + m)! from (l − 1 − m)! / (l − 1 + m)!.
                ratio *= f32(l - m) / f32(l + m);
            }
            let k = sqrt(f32(2u * l + 1u) * ratio / measure);
            let centre = l * l + l;
            if m == 0u {
                (*out)[centre] = k * p;
            } else {
                let scale = HSH_SQRT_2 * k * p;
                (*out)[centre + m] = scale * turn.x;
                (*out)[centre - m] = scale * turn.y;
            }
        }
    }
}

// H_l^m(d), l < order, for d with d.z ≥ 0 (clamped to the horizon below it, as hsh.rs).
fn hsh_basis_into(out: ptr<function, array<f32, HSH_MAX_COEFFICIENTS>>, order: u32, d: vec3f) {
    harmonics_into(out, order, d, 2.0 * saturate(d.z) - 1.0, 2.0 * PI);
}

// Y_l^m(d), l < order.
fn sh_basis_into(out: ptr<function, array<f32, HSH_MAX_COEFFICIENTS>>, order: u32, d: vec3f) {
    harmonics_into(out, order, d, clamp(d.z, -1.0, 1.0), 4.0 * PI);
}

// One basis function, index l(l+1)+m, by the same recurrence without the arrays of harmonics_into:
// for passes that give each invocation one coefficient (a function-local array indexed at run time
// costs lavapipe's compiler minutes).
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

fn sh_one(k: u32, d: vec3f) -> f32 {
    let lm = harmonic_lm(k);
    return harmonic_one(u32(lm.x), lm.y, d, clamp(d.z, -1.0, 1.0), 4.0 * PI);
}
