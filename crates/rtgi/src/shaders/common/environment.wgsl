// Radiance of the environment (light from infinitely far away) in a direction.
//
// The procedural sky is deliberately simple and fully documented here: above the horizon
//   L(d) = sky_radiance · (1 + 0.5 (1 − d.y)²) + sun_radiance · max(0, d·sun)^32,
// a zenith-to-horizon brightening plus a broad glow around the sun; below the horizon
// L(d) = ground_radiance. The sun disc itself is not part of the sky: scenes that want sunlight pair
// the sky with a directional light, which every technique handles exactly.

#import common/scene.wgsl

fn sky_radiance(d: vec3f) -> vec3f {
    if d.y < 0.0 {
        return scene_info.ground_radiance;
    }
    let h = 1.0 - d.y;
    let glow = pow(max(dot(d, scene_info.sun_direction), 0.0), 32.0);
    return scene_info.env_radiance * (1.0 + 0.5 * h * h) + scene_info.sun_radiance * glow;
}

fn environment_radiance(d: vec3f) -> vec3f {
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
