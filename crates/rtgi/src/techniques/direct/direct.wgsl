// Direct lighting from the G-buffer: emission, analytic lights through shadow maps, and (ray traced
// through the shared BVH) emissive triangles and the environment. Progressive: frame k averages its
// estimate into the output with weight 1/(k+1), so `--frames N` converges the stochastic terms
// (unless ACCUMULATE is false: then a GI technique adds its indirect light and accumulates the sum).

#import common/frame.wgsl
#import common/environment.wgsl
#import common/random.wgsl
#import common/sampling.wgsl
#import common/light_sampling.wgsl

@group(2) @binding(0) var output: texture_storage_2d<rgba32float, read_write>;

// One sample of light from emissive triangles.
fn sample_emissive(s: GSurface, u: vec3f) -> vec3f {
    let o = gsurface_ray_origin(s);
    let ls = sample_area_light(o, u);
    let cos_surf = dot(s.normal, ls.direction);
    if ls.pdf <= 0.0 || cos_surf <= 0.0 || dot(s.geometric_normal, ls.direction) <= 0.0 {
        return vec3f(0.0);
    }
    if trace_any(Ray(o, ls.direction), 0.0, ls.distance * (1.0 - 1e-3)) {
        return vec3f(0.0);
    }
    return brdf_eval(s.material, s.normal, s.view, ls.direction) * ls.radiance * cos_surf / ls.pdf;
}

// One sample of the environment (importance-sampled for maps, cosine-weighted otherwise).
fn sample_environment(s: GSurface, u: vec2f) -> vec3f {
    let es = sample_environment_light(s.normal, u);
    let cos_theta = dot(s.normal, es.direction);
    if es.pdf <= 0.0 || cos_theta <= 0.0 || dot(s.geometric_normal, es.direction) <= 0.0 {
        return vec3f(0.0);
    }
    if trace_any(Ray(gsurface_ray_origin(s), es.direction), 0.0, FLT_MAX) {
        return vec3f(0.0);
    }
    return brdf_eval(s.material, s.normal, s.view, es.direction) * es.radiance * cos_theta / es.pdf;
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let s = load_gsurface(id.xy);
    var radiance = vec3f(0.0);
    if !s.valid {
        radiance = environment_radiance(-s.view);
    } else {
        radiance = s.material.emission;
        for (var i = 0u; i < scene_info.light_count; i++) {
            let light = lights[i];
            let inc = light_incidence(light, s.position);
            let cos_theta = dot(s.normal, inc.direction);
            if cos_theta <= 0.0 || dot(s.geometric_normal, inc.direction) <= 0.0 {
                continue;
            }
            let vis = shadow_visibility(light, s.position, s.geometric_normal);
            radiance += brdf_eval(s.material, s.normal, s.view, inc.direction) * inc.irradiance * cos_theta * vis;
        }
        var rng = rng_new(id.xy, frame.frame_counter, frame.seed);
        if scene_info.emissive_count > 0u && AREA_SAMPLES > 0u {
            var sum = vec3f(0.0);
            for (var k = 0u; k < AREA_SAMPLES; k++) {
                sum += sample_emissive(s, vec3f(rng_next(&rng), rng_next2(&rng)));
            }
            radiance += sum / f32(AREA_SAMPLES);
        }
        if scene_info.env_kind != ENV_NONE && ENV_SAMPLES > 0u {
            var sum = vec3f(0.0);
            for (var k = 0u; k < ENV_SAMPLES; k++) {
                sum += sample_environment(s, rng_next2(&rng));
            }
            radiance += sum / f32(ENV_SAMPLES);
        }
    }
    if ACCUMULATE {
        radiance = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    }
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
