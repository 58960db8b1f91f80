// Incident light from the analytic lights (point, spot, directional), without visibility.

#import common/scene.wgsl

struct LightIncidence {
    // Unit vector from the shaded point towards the light.
    direction: vec3f,
    // Distance to the light (FLT_MAX for directional lights).
    distance: f32,
    // Irradiance on a surface facing the light: reflected radiance is brdf · irradiance · cos θ.
    irradiance: vec3f,
}

// KHR_lights_punctual's spot cone: a linear ramp in cos between the outer and inner cone, squared.
fn spot_attenuation(light: Light, to_point: vec3f) -> f32 {
    let cd = dot(light.direction, to_point);
    let scale = 1.0 / max(0.001, light.cos_inner - light.cos_outer);
    let a = saturate((cd - light.cos_outer) * scale);
    return a * a;
}

fn light_incidence(light: Light, p: vec3f) -> LightIncidence {
    var r: LightIncidence;
    if light.kind == LIGHT_DIRECTIONAL {
        r.direction = -light.direction;
        r.distance = FLT_MAX;
        r.irradiance = light.intensity;
        return r;
    }
    let d = light.position - p;
    let dist2 = max(dot(d, d), 1e-12);
    r.distance = sqrt(dist2);
    r.direction = d / r.distance;
    r.irradiance = light.intensity / dist2;
    if light.kind == LIGHT_SPOT {
        r.irradiance *= spot_attenuation(light, -r.direction);
    }
    return r;
}
