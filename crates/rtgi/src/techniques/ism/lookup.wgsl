// Visibility between a VPL and a receiver, for the gather passes: from the VPL's imperfect shadow map
// when ISM is set and the map covers the VPL, else by a shadow ray through the shared BVH. The
// including shader binds the filled atlas as the linear texture `ism_maps: texture_2d<f32>` (ISM_SIZE²
// texels per VPL, see common/linear_texture.wgsl).
//
// The map lookup is a 2×2 percentage-closer filter. Its depth bias grows with the distance and with
// the slope of the receiver seen from the VPL: one texel spans ism_texel_angle radians, over which a
// surface at angle θ to the VPL's ray recedes by about distance · angle · tan θ (tan θ at most
// ISM_MAX_SLOPE), plus the relative ISM_BIAS against the points' own scatter.

#import common/scene.wgsl
#import common/math.wgsl
#import common/linear_texture.wgsl

fn ism_depth(k: u32, texel: vec2i) -> f32 {
    let t = vec2u(clamp(texel, vec2i(0), vec2i(i32(ISM_SIZE) - 1)));
    return textureLoad(ism_maps, linear_texel(k * ISM_SIZE * ISM_SIZE + t.y * ISM_SIZE + t.x), 0).r;
}

fn ism_visibility(k: u32, v: Vpl, x: vec3f, ng: vec3f) -> f32 {
    let d = x - v.position;
    let distance = length(d);
    let dir = d / max(distance, 1e-12);
    let local = world_to_local(dir, v.normal);
    if local.z <= 0.0 {
        return 0.0;
    }
    let cos_r = max(abs(dot(ng, dir)), 1e-3);
    let slope = min(sqrt(max(1.0 - cos_r * cos_r, 0.0)) / cos_r, ISM_MAX_SLOPE);
    let reach = distance * (1.0 - ISM_BIAS - ism_texel_angle(local.z) * slope);
    let t = ism_texel_coords(local) - 0.5;
    let base = vec2i(floor(t));
    let f = t - floor(t);
    let lit = vec4f(
        select(0.0, 1.0, ism_depth(k, base) >= reach),
        select(0.0, 1.0, ism_depth(k, base + vec2i(1, 0)) >= reach),
        select(0.0, 1.0, ism_depth(k, base + vec2i(0, 1)) >= reach),
        select(0.0, 1.0, ism_depth(k, base + vec2i(1, 1)) >= reach),
    );
    return mix(mix(lit.x, lit.y, f.x), mix(lit.z, lit.w, f.x), f.y);
}

// Visibility of VPL `k` (v) from the receiver at x (geometric normal ng; `origin` is x offset for
// rays), along `inc` as vpl_incidence gave it.
fn vpl_visibility(k: u32, v: Vpl, x: vec3f, ng: vec3f, origin: vec3f, inc: VplIncidence) -> f32 {
    if ISM && ism_covers(v.kind) {
        return ism_visibility(k, v, x, ng);
    }
    return select(1.0, 0.0, trace_any(Ray(origin, inc.direction), 0.0, inc.distance * (1.0 - 1e-4)));
}
