// Sample warps with their densities. Each maps uniform numbers in [0,1)² to a direction or point.

#import common/math.wgsl

// Cosine-weighted direction about +Z; pdf = cos θ / π.
fn sample_cosine_hemisphere(u: vec2f) -> vec3f {
    let r = sqrt(u.x);
    let phi = TWO_PI * u.y;
    return vec3f(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
}

fn pdf_cosine_hemisphere(cos_theta: f32) -> f32 {
    return max(cos_theta, 0.0) * INV_PI;
}

// Uniform direction on the unit sphere; pdf = 1 / 4π.
fn sample_uniform_sphere(u: vec2f) -> vec3f {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = TWO_PI * u.y;
    return vec3f(r * cos(phi), r * sin(phi), z);
}

// Uniform barycentrics on a triangle (the square-root warp); returns (b1, b2).
fn sample_triangle(u: vec2f) -> vec2f {
    let s = sqrt(u.x);
    return vec2f(1.0 - s, u.y * s);
}

// Uniform direction in a cone of half-angle acos(cos_max) about +Z; pdf = 1 / (2π(1 − cos_max)).
fn sample_cone(u: vec2f, cos_max: f32) -> vec3f {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = TWO_PI * u.y;
    return vec3f(r * cos(phi), r * sin(phi), z);
}

// GGX visible-normal sampling with spherical caps (Dupuy & Benyoub 2023). `wo` in the local frame
// (z = normal), returns a microfacet normal distributed as D_wo(h).
fn sample_ggx_vndf(wo: vec3f, alpha: f32, u: vec2f) -> vec3f {
    let wi_std = normalize(vec3f(wo.xy * alpha, wo.z));
    let phi = TWO_PI * u.x;
    let z = (1.0 - u.y) * (1.0 + wi_std.z) - wi_std.z;
    let sin_theta = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
    let c = vec3f(sin_theta * cos(phi), sin_theta * sin(phi), z);
    let h_std = c + wi_std;
    return normalize(vec3f(h_std.xy * alpha, max(h_std.z, 1e-6)));
}

// Power heuristic with β = 2 (Veach 1997).
fn mis_power(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    return select(0.0, a / (a + b), a > 0.0);
}

// Point i of n on the spherical Fibonacci spiral (Keinert et al. 2015): n nearly evenly spread unit
// vectors, each standing for 4π/n of the sphere.
fn spherical_fibonacci(i: u32, n: u32) -> vec3f {
    // The golden ratio's fractional part, (√5 − 1) / 2.
    let phi = TWO_PI * fract(f32(i) * 0.618033988749895);
    let cos_theta = 1.0 - (2.0 * f32(i) + 1.0) / f32(n);
    let sin_theta = sqrt(saturate(1.0 - cos_theta * cos_theta));
    return vec3f(cos(phi) * sin_theta, sin(phi) * sin_theta, cos_theta);
}
