// The imperfect shadow map of a VPL (Ritschel et al. 2008): the depths of a sparse point sampling of
// the scene over the VPL's hemisphere, in a paraboloid map oriented along the VPL's normal (Brabec et
// al. 2002), ISM_SIZE² texels, one map per VPL in one atlas. Shared by the splat pass and the lookup,
// so that both place a direction on the same texel.

// Whether a VPL's light leaves over the hemisphere of its normal, so that one paraboloid map holds all
// it can see. Analytic lights and directional VPLs keep their shadow rays.
fn ism_covers(kind: u32) -> bool {
    return kind == VPL_SURFACE || kind == VPL_EMITTER;
}

// Texel coordinates in [0, ISM_SIZE]² of a unit direction in the VPL's frame (z along its normal, z > 0).
fn ism_texel_coords(local_dir: vec3f) -> vec2f {
    return (local_dir.xy / (1.0 + local_dir.z) * 0.5 + 0.5) * f32(ISM_SIZE);
}

// Radians of the hemisphere one texel spans at a direction of local height z: the map's scale is
// d(tan(θ/2))/dθ = 1 / (1 + cos θ), and the unit disc spans ISM_SIZE / 2 texels.
fn ism_texel_angle(z: f32) -> f32 {
    return 2.0 * (1.0 + z) / f32(ISM_SIZE);
}

// The first point of the shared pool that VPL `k` uses (it takes ISM_POINTS_PER_VPL consecutive
// points from there, wrapping): a hash, so that neighbouring VPLs see different subsets.
fn ism_pool_start(k: u32) -> u32 {
    var h = k * 0x9e3779b9u;
    h ^= h >> 16u;
    h *= 0x85ebca6bu;
    h ^= h >> 13u;
    return h % ISM_POOL;
}
