// Direct light reflected by a surface: analytic lights (through the frame's shadow maps or shadow
// rays), emissive triangles and the environment (light samples with shadow rays). One routine for
// camera pixels (the `direct` pass every technique adds indirect light to) and for secondary hits that
// must be shaded the same way (DDGI's probe rays), so both see the same lights. Emission of the surface
// itself is the caller's: whether it counts depends on who looks.

#import common/frame.wgsl
#import common/environment.wgsl
#import common/random.wgsl
#import common/sampling.wgsl
#import common/light_sampling.wgsl

// A surface to light: the G-buffer's decoded form, which ray hits convert to with `hit_gsurface`.
fn hit_gsurface(hit: SurfaceHit, towards_viewer: vec3f, distance: f32) -> GSurface {
    var s: GSurface;
    s.valid = true;
    s.position = hit.position;
    s.normal = hit.normal;
    s.geometric_normal = hit.geometric_normal;
    s.view = towards_viewer;
    s.distance = distance;
    s.material_index = hit.material_index;
    s.material = hit.material;
    return s;
}

// A light sample's reflected radiance without visibility (value), and the shadow ray that decides
// it (from the caller's origin along `direction`, up to `distance`).
struct UnshadowedSample {
    value: vec3f,
    direction: vec3f,
    distance: f32,
}

// A light sample before any BRDF: the direction and length of its shadow ray and its radiance over
// the sampling density (zero for a failed sample), for shaders whose reflectance is not `brdf_eval`'s.
struct IncidentSample {
    direction: vec3f,
    distance: f32,
    weight: vec3f,
}

// One sample of light from emissive triangles seen from `origin`.
fn emissive_incident(origin: vec3f, u: vec3f) -> IncidentSample {
    let ls = sample_area_light(origin, u);
    let weight = select(vec3f(0.0), ls.radiance / ls.pdf, ls.pdf > 0.0);
    return IncidentSample(ls.direction, ls.distance * (1.0 - 1e-3), weight);
}

// One sample of the environment (importance-sampled for maps, cosine-weighted about n otherwise).
fn environment_incident(n: vec3f, u: vec2f) -> IncidentSample {
    let es = sample_environment_light(n, u);
    let weight = select(vec3f(0.0), es.radiance / es.pdf, es.pdf > 0.0);
    return IncidentSample(es.direction, FLT_MAX, weight);
}

// An incident sample reflected by s's BRDF towards s.view.
fn reflect_incident(s: GSurface, i: IncidentSample) -> UnshadowedSample {
    var r = UnshadowedSample(vec3f(0.0), i.direction, i.distance);
    let cos_theta = dot(s.normal, i.direction);
    if cos_theta > 0.0 && dot(s.geometric_normal, i.direction) > 0.0 && max3(i.weight) > 0.0 {
        r.value = brdf_eval(s.material, s.normal, s.view, i.direction) * i.weight * cos_theta;
    }
    return r;
}

// One sample of light from emissive triangles, leaving from `origin` (off the surface), unshadowed.
fn emissive_sample_unshadowed(s: GSurface, origin: vec3f, u: vec3f) -> UnshadowedSample {
    return reflect_incident(s, emissive_incident(origin, u));
}

// One sample of the environment (importance-sampled for maps, cosine-weighted otherwise), unshadowed.
fn environment_sample_unshadowed(s: GSurface, u: vec2f) -> UnshadowedSample {
    return reflect_incident(s, environment_incident(s.normal, u));
}

// The light an analytic light reflects off s towards s.view, unshadowed.
fn analytic_light_unshadowed(s: GSurface, light: Light) -> UnshadowedSample {
    let inc = light_incidence(light, s.position);
    var r = UnshadowedSample(vec3f(0.0), inc.direction, inc.distance * (1.0 - 1e-4));
    let cos_theta = dot(s.normal, inc.direction);
    if cos_theta > 0.0 && dot(s.geometric_normal, inc.direction) > 0.0 && max3(inc.irradiance) > 0.0 {
        r.value = brdf_eval(s.material, s.normal, s.view, inc.direction) * inc.irradiance * cos_theta;
    }
    return r;
}

// 1 where nothing blocks the sample's shadow ray from `origin`, else 0.
fn sample_visibility(sample: UnshadowedSample, origin: vec3f) -> f32 {
    return select(1.0, 0.0, trace_any(Ray(origin, sample.direction), 0.0, sample.distance));
}

// One sample of light from emissive triangles, leaving from `origin` (off the surface).
fn direct_emissive_sample(s: GSurface, origin: vec3f, u: vec3f) -> vec3f {
    let sample = emissive_sample_unshadowed(s, origin, u);
    if all(sample.value == vec3f(0.0)) {
        return vec3f(0.0);
    }
    return sample.value * sample_visibility(sample, origin);
}

// One sample of the environment.
fn direct_environment_sample(s: GSurface, origin: vec3f, u: vec2f) -> vec3f {
    let sample = environment_sample_unshadowed(s, u);
    if all(sample.value == vec3f(0.0)) {
        return vec3f(0.0);
    }
    return sample.value * sample_visibility(sample, origin);
}

// Whether analytic `light` reaches s, by its shadow map or (`traced`) the sample's shadow ray.
fn analytic_visibility(light: Light, s: GSurface, sample: UnshadowedSample, origin: vec3f, traced: bool) -> f32 {
    if traced {
        return sample_visibility(sample, origin);
    }
    return shadow_visibility(light, s.position, s.geometric_normal);
}

// Light from the analytic lights. Shadow maps are fitted to what the camera sees well; surfaces
// anywhere else (a probe ray's hit behind the camera) use `traced_shadows`.
fn direct_analytic(s: GSurface, origin: vec3f, traced_shadows: bool) -> vec3f {
    var radiance = vec3f(0.0);
    for (var i = 0u; i < scene_info.light_count; i++) {
        let light = lights[i];
        let sample = analytic_light_unshadowed(s, light);
        if all(sample.value == vec3f(0.0)) {
            continue;
        }
        radiance += sample.value * analytic_visibility(light, s, sample, origin, traced_shadows);
    }
    return radiance;
}

// Direct light reflected towards `s.view`: the analytic lights plus `area_samples` samples of the
// emissive triangles and `env_samples` of the environment (each averaged), shadow rays from `origin`.
fn direct_light(
    s: GSurface,
    origin: vec3f,
    rng: ptr<function, Rng>,
    area_samples: u32,
    env_samples: u32,
    traced_shadows: bool,
) -> vec3f {
    var radiance = direct_analytic(s, origin, traced_shadows);
    if scene_info.emissive_count > 0u && area_samples > 0u {
        var sum = vec3f(0.0);
        for (var k = 0u; k < area_samples; k++) {
            sum += direct_emissive_sample(s, origin, vec3f(rng_next(rng), rng_next2(rng)));
        }
        radiance += sum / f32(area_samples);
    }
    if scene_info.env_kind != ENV_NONE && env_samples > 0u {
        var sum = vec3f(0.0);
        for (var k = 0u; k < env_samples; k++) {
            sum += direct_environment_sample(s, origin, rng_next2(rng));
        }
        radiance += sum / f32(env_samples);
    }
    return radiance;
}

// What the `direct` technique shows at camera pixel `pixel` whose G-buffer surface is `s` (the
// environment where nothing was hit): emission plus direct light with the frame's random numbers of
// that pixel and shadow maps. Techniques that shade some pixels their own way shade the rest with it,
// so that they agree with `direct` there.
fn direct_pixel_radiance(s: GSurface, pixel: vec2u, area_samples: u32, env_samples: u32) -> vec3f {
    if !s.valid {
        return environment_radiance(-s.view);
    }
    var rng = rng_new(pixel, frame.frame_counter, frame.seed);
    return s.material.emission + direct_light(s, gsurface_ray_origin(s), &rng, area_samples, env_samples, false);
}
