// Direct light of a surface in this frame and predicted for the next one, with the same light
// samples: the prediction shades the surface where its mesh will be (`next`: position, normals and
// view at the next frame's pose) under the next frame's analytic lights, which the including shader
// provides as `fn predicted_light(i: u32) -> Light` (i < scene_info.light_count). Visibility is this
// frame's (the next frame's geometry has no BVH yet), so a shadow that starts to move only shows in
// the next prediction; emissive triangles and the environment stay where they are, their samples
// re-evaluated from the moved surface. `radiance-cache-temporal` predicts its records' incoming light
// with it (Gautron et al. 2006 shade the reprojected hemisphere at t + 1 the same way).

#import common/direct_light.wgsl

struct DirectPair {
    now: vec3f,
    next: vec3f,
}

fn direct_light_pair(
    now: GSurface,
    next: GSurface,
    origin: vec3f,
    next_origin: vec3f,
    rng: ptr<function, Rng>,
    area_samples: u32,
    env_samples: u32,
) -> DirectPair {
    var r = DirectPair(vec3f(0.0), vec3f(0.0));
    for (var i = 0u; i < scene_info.light_count; i++) {
        let a = analytic_light_unshadowed(now, lights[i]);
        let b = analytic_light_unshadowed(next, predicted_light(i));
        if any(a.value != vec3f(0.0)) || any(b.value != vec3f(0.0)) {
            let vis = sample_visibility(a, origin);
            r.now += a.value * vis;
            r.next += b.value * vis;
        }
    }
    if scene_info.emissive_count > 0u && area_samples > 0u {
        for (var k = 0u; k < area_samples; k++) {
            let u = vec3f(rng_next(rng), rng_next2(rng));
            let a = emissive_sample_unshadowed(now, origin, u);
            let b = emissive_sample_unshadowed(next, next_origin, u);
            if any(a.value != vec3f(0.0)) || any(b.value != vec3f(0.0)) {
                let vis = sample_visibility(a, origin);
                r.now += a.value * vis / f32(area_samples);
                r.next += b.value * vis / f32(area_samples);
            }
        }
    }
    if scene_info.env_kind != ENV_NONE && env_samples > 0u {
        for (var k = 0u; k < env_samples; k++) {
            let u = rng_next2(rng);
            let a = environment_sample_unshadowed(now, u);
            let b = environment_sample_unshadowed(next, u);
            if any(a.value != vec3f(0.0)) || any(b.value != vec3f(0.0)) {
                let vis = sample_visibility(a, origin);
                r.now += a.value * vis / f32(env_samples);
                r.next += b.value * vis / f32(env_samples);
            }
        }
    }
    return r;
}
