// Real spherical harmonics up to band 4 (25 coefficients, index l(l+1)+m), the GPU twin of sh.rs
// (which documents the conventions and is checked against quadrature; a GPU test checks this file
// against it).

#import common/math.wgsl

const SH_BANDS: u32 = 5u;
const SH_COEFFICIENTS: u32 = 25u;

fn sh_basis(d: vec3f) -> array<f32, 25> {
    let x = d.x;
    let y = d.y;
    let z = d.z;
    let x2 = x * x;
    let y2 = y * y;
    let z2 = z * z;
    return array<f32, 25>(
        0.282094791773878,
        0.488602511902920 * y,
        0.488602511902920 * z,
        0.488602511902920 * x,
        1.092548430592079 * x * y,
        1.092548430592079 * y * z,
        0.315391565252520 * (3.0 * z2 - 1.0),
        1.092548430592079 * x * z,
        0.546274215296040 * (x2 - y2),
        0.590043589926644 * y * (3.0 * x2 - y2),
        2.890611442640554 * x * y * z,
        0.457045799464466 * y * (5.0 * z2 - 1.0),
        0.373176332590115 * z * (5.0 * z2 - 3.0),
        0.457045799464466 * x * (5.0 * z2 - 1.0),
        1.445305721320277 * z * (x2 - y2),
        0.590043589926644 * x * (x2 - 3.0 * y2),
        2.503342941796705 * x * y * (x2 - y2),
        1.770130769779931 * y * z * (3.0 * x2 - y2),
        0.946174695757560 * x * y * (7.0 * z2 - 1.0),
        0.669046543557289 * y * z * (7.0 * z2 - 3.0),
        0.105785546915204 * (35.0 * z2 * z2 - 30.0 * z2 + 3.0),
        0.669046543557289 * x * z * (7.0 * z2 - 3.0),
        0.473087347878780 * (x2 - y2) * (7.0 * z2 - 1.0),
        1.770130769779931 * x * z * (x2 - 3.0 * y2),
        0.625835735449176 * (x2 * (x2 - 3.0 * y2) - y2 * (3.0 * x2 - y2)),
    );
}

// Bands 0–2 only (the 9 coefficients of order-2 SH).
fn sh9_basis(d: vec3f) -> array<f32, 9> {
    let x = d.x;
    let y = d.y;
    let z = d.z;
    return array<f32, 9>(
        0.282094791773878,
        0.488602511902920 * y,
        0.488602511902920 * z,
        0.488602511902920 * x,
        1.092548430592079 * x * y,
        1.092548430592079 * y * z,
        0.315391565252520 * (3.0 * z * z - 1.0),
        1.092548430592079 * x * z,
        0.546274215296040 * (x * x - y * y),
    );
}

fn sh_band(i: u32) -> u32 {
    return u32(sqrt(f32(i) + 0.5));
}

// Â_l of the normalised Phong lobe (n+1)/(2π) max(0, cos θ)ⁿ (see sh.rs `phong`).
fn sh_phong(n: f32, l: u32) -> f32 {
    var i0 = 1.0 / (n + 1.0);
    var i1 = 1.0 / (n + 2.0);
    for (var k = 2u; k <= l; k++) {
        let next = (n - f32(k) + 2.0) / (n + f32(k) + 1.0);
        if k % 2u == 0u {
            i0 *= next;
        } else {
            i1 *= next;
        }
    }
    return (n + 1.0) * select(i1, i0, l % 2u == 0u);
}

// Â_l of the clamped cosine: π, 2π/3, π/4, 0, −π/24.
fn sh_lambert(l: u32) -> f32 {
    return PI * sh_phong(1.0, l);
}

// Bands 0–1 only (order-1 SH, the 4 coefficients of light propagation volumes), as a vec4f.
fn sh4_basis(d: vec3f) -> vec4f {
    return vec4f(0.282094791773878, 0.488602511902920 * d.y, 0.488602511902920 * d.z, 0.488602511902920 * d.x);
}

// Order-1 SH of the clamped cosine max(0, ⟨n, ω⟩): Â_l Y_lm(n) (a zonal function's coefficients).
fn sh4_cosine_lobe(n: vec3f) -> vec4f {
    return sh4_basis(n) * vec4f(PI, vec3f(2.0 * PI / 3.0));
}
