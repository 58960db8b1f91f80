// Radiance of the environment (light from infinitely far away) in a direction.
//
// The procedural sky is deliberately simple and fully documented here: above the horizon
//   L(d) = sky_radiance · (1 + 0.5 (1 − d.y)²) + sun_radiance · max(0, d·sun)^32,
// a zenith-to-horizon brightening plus a broad glow around the sun; below the horizon
// L(d) = ground_radiance. The sun disc itself is not part of the sky: scenes that want sunlight pair
// the sky with a directional light, which every technique handles exactly.

#import common/scene.wgsl
#import common/sampling.wgsl

fn sky_radiance(d: vec3f) -> vec3f {
    if d.y < 0.0 {
        return scene_info.ground_radiance;
    }
    let h = 1.0 - d.y;
    let glow = pow(max(dot(d, scene_info.sun_direction), 0.0), 32.0);
    return scene_info.env_radiance * (1.0 + 0.5 * h * h) + scene_info.sun_radiance * glow;
}

// Radiance of the environment in its own frame (before Scene::environment_rotation turns it): what
// the sampling table, the sky bake and SH projections are made of.
fn environment_radiance_unrotated(d: vec3f) -> vec3f {
    switch scene_info.env_kind {
        case ENV_UNIFORM: {
            return scene_info.env_radiance * scene_info.env_intensity;
        }
        case ENV_SKY: {
            return sky_radiance(d) * scene_info.env_intensity;
        }
        case ENV_MAP: {
            let size = vec2f(textureDimensions(environment_map));
            let uv = equirect_uv(d);
            let texel = min(vec2u(uv * size), vec2u(size) - 1u);
            return textureLoad(environment_map, texel, 0).rgb * scene_info.env_intensity;
        }
        default: {
            return vec3f(0.0);
        }
    }
}

// The environment's own frame seen from a world direction.
fn environment_direction(world: vec3f) -> vec3f {
    return transpose(scene_info.world_from_environment) * world;
}

// Radiance arriving from world direction d.
fn environment_radiance(d: vec3f) -> vec3f {
    return environment_radiance_unrotated(environment_direction(d));
}

// ---- Sampling the environment as a light ----
// Maps and the procedural sky are importance-sampled (in the environment's own frame, then turned) in proportion to luminance × sin θ (piecewise
// constant per texel of `environment_map`; table built by gpu/scene.rs `environment_cdf`, for the sky
// from a bake of `environment_radiance` itself); a uniform environment is sampled cosine-weighted about
// the normal, which is already ideal for it.

struct EnvironmentSample {
    direction: vec3f,
    // Solid-angle density; 0 for an unusable sample.
    pdf: f32,
    radiance: vec3f,
}

// Entry i of the sampling table, a linear texture (gpu/linear_texture.rs: it is read in loops).
fn env_cdf_at(i: u32) -> f32 {
    return textureLoad(env_cdf, linear_texel(i), 0).r;
}

// First index i in [0, count) with env_cdf_at(start + i) >= u.
fn env_cdf_search(start: u32, count: u32, u: f32) -> u32 {
    var lo = 0u;
    var hi = count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if env_cdf_at(start + mid) < u {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

fn env_cdf_below(start: u32, i: u32) -> f32 {
    if i == 0u {
        return 0.0;
    }
    return env_cdf_at(start + i - 1u);
}

// Solid-angle density of texel (x, y) of a w × h map at a point of the texel with the given sin θ.
fn env_map_texel_pdf(x: u32, y: u32, w: u32, h: u32, sin_theta: f32) -> f32 {
    let row = h + y * w;
    let p = (env_cdf_at(y) - env_cdf_below(0u, y)) * (env_cdf_at(row + x) - env_cdf_below(row, x));
    return p * f32(w * h) / (2.0 * PI * PI * max(sin_theta, 1e-6));
}

fn sample_environment_map(u: vec2f) -> EnvironmentSample {
    var s: EnvironmentSample;
    let dims = textureDimensions(environment_map);
    let w = dims.x;
    let h = dims.y;
    let y = env_cdf_search(0u, h, u.y);
    let x = env_cdf_search(h + y * w, w, u.x);
    // The position inside the texel reuses what is left of u inside the chosen bucket.
    let y0 = env_cdf_below(0u, y);
    let fy = saturate((u.y - y0) / max(env_cdf_at(y) - y0, 1e-12));
    let row = h + y * w;
    let x0 = env_cdf_below(row, x);
    let fx = saturate((u.x - x0) / max(env_cdf_at(row + x) - x0, 1e-12));
    let uv = vec2f((f32(x) + fx) / f32(w), (f32(y) + fy) / f32(h));
    s.direction = scene_info.world_from_environment * equirect_direction(uv);
    s.pdf = env_map_texel_pdf(x, y, w, h, sin(uv.y * PI));
    // The radiance every other path sees in that direction (for maps, the same texel).
    s.radiance = environment_radiance(s.direction);
    return s;
}

fn environment_is_tabulated() -> bool {
    return scene_info.env_kind == ENV_MAP || scene_info.env_kind == ENV_SKY;
}

fn environment_map_pdf(world: vec3f) -> f32 {
    let d = environment_direction(world);
    let dims = textureDimensions(environment_map);
    let uv = equirect_uv(d);
    let x = min(u32(uv.x * f32(dims.x)), dims.x - 1u);
    let y = min(u32(uv.y * f32(dims.y)), dims.y - 1u);
    return env_map_texel_pdf(x, y, dims.x, dims.y, sqrt(max(0.0, 1.0 - d.y * d.y)));
}

// A direction for next-event estimation of the environment at a surface with normal n.
fn sample_environment_light(n: vec3f, u: vec2f) -> EnvironmentSample {
    if environment_is_tabulated() {
        return sample_environment_map(u);
    }
    var s: EnvironmentSample;
    s.direction = local_to_world(sample_cosine_hemisphere(u), n);
    s.pdf = pdf_cosine_hemisphere(dot(n, s.direction));
    s.radiance = environment_radiance(s.direction);
    return s;
}

// Density with which `sample_environment_light` picks d (for MIS of BRDF-sampled escapes).
fn environment_light_pdf(n: vec3f, d: vec3f) -> f32 {
    if environment_is_tabulated() {
        return environment_map_pdf(d);
    }
    return pdf_cosine_hemisphere(dot(n, d));
}
