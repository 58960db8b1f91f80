// Constants and small geometric helpers used everywhere.

const PI: f32 = 3.14159265358979;
const TWO_PI: f32 = 6.28318530717959;
const INV_PI: f32 = 0.318309886183791;
const INV_TWO_PI: f32 = 0.159154943091895;
const INV_FOUR_PI: f32 = 0.0795774715459477;
const FLT_MAX: f32 = 3.402823e38;

fn saturate(x: f32) -> f32 {
    return clamp(x, 0.0, 1.0);
}

fn max3(v: vec3f) -> f32 {
    return max(v.x, max(v.y, v.z));
}

fn sqr(x: f32) -> f32 {
    return x * x;
}

// Orthonormal basis around a unit normal (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"):
// branchless and continuous except at n.z = -1's sign flip.
fn basis_tangent(n: vec3f) -> vec3f {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return vec3f(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
}

fn basis_bitangent(n: vec3f) -> vec3f {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return vec3f(b, s + n.y * n.y * a, -n.y);
}

// Transforms a direction given in the local frame (z = normal) to world space.
fn local_to_world(v: vec3f, n: vec3f) -> vec3f {
    return v.x * basis_tangent(n) + v.y * basis_bitangent(n) + v.z * n;
}

fn world_to_local(v: vec3f, n: vec3f) -> vec3f {
    return vec3f(dot(v, basis_tangent(n)), dot(v, basis_bitangent(n)), dot(v, n));
}

// Octahedral mapping of unit vectors to [-1, 1]² (Cigolle et al. 2014); used to pack normals.
fn oct_wrap(v: vec2f) -> vec2f {
    return (1.0 - abs(v.yx)) * select(vec2f(-1.0), vec2f(1.0), v.xy >= vec2f(0.0));
}

fn oct_encode(n: vec3f) -> vec2f {
    var p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    if n.z < 0.0 {
        p = oct_wrap(p);
    }
    return p;
}

fn oct_decode(e: vec2f) -> vec3f {
    var n = vec3f(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    let t = saturate(-n.z);
    n.x += select(t, -t, n.x >= 0.0);
    n.y += select(t, -t, n.y >= 0.0);
    return normalize(n);
}

// Unit vector from the latitude-longitude parametrisation of the environment map: +Y up, u = 0 at -Z,
// growing towards +X (matches `EnvironmentMap` in scene/mod.rs).
fn equirect_direction(uv: vec2f) -> vec3f {
    let phi = uv.x * TWO_PI;
    let theta = uv.y * PI;
    let s = sin(theta);
    return vec3f(s * sin(phi), cos(theta), -s * cos(phi));
}

fn equirect_uv(d: vec3f) -> vec2f {
    let phi = atan2(d.x, -d.z);
    let u = select(phi, phi + TWO_PI, phi < 0.0) * INV_TWO_PI;
    let v = acos(clamp(d.y, -1.0, 1.0)) * INV_PI;
    return vec2f(u, v);
}

// The largest finite half float: beyond it pack2x16float gives ±∞ (or, in WGSL, an undefined value).
const HALF_MAX: f32 = 65504.0;

// Four half floats in two words: the storage format of per-pixel intermediate data (SH coefficients,
// irradiance) that does not need f32 precision. Values beyond the half range saturate instead of turning
// into ∞, which a filter would spread to the neighbours and a later ×0 would turn into NaN; writers that
// can overflow (VPL spikes) scale their data into range first (see `fit_half` in igi/gather.wgsl).
fn pack_half4(v: vec4f) -> vec2u {
    let c = clamp(v, vec4f(-HALF_MAX), vec4f(HALF_MAX));
    return vec2u(pack2x16float(c.xy), pack2x16float(c.zw));
}

// Per channel, the factor that brings a channel whose largest magnitude is `largest` into the half range
// (1 where it fits): data scaled by it keep their shape across coefficients and lose only magnitude.
fn half_fit_scale(largest: vec3f) -> vec3f {
    return select(vec3f(1.0), HALF_MAX / largest, largest > vec3f(HALF_MAX));
}

fn unpack_half4(p: vec2u) -> vec4f {
    return vec4f(unpack2x16float(p.x), unpack2x16float(p.y));
}
