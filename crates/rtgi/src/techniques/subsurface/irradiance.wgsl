// Irradiance of every illumination sample from the analytic lights, emissive triangles and the
// environment, with shadow rays through the BVH, and (INDIRECT_SAMPLES > 0) one bounce of indirect
// light: the light samples of the direct-light routine for camera pixels, taken one by one so that
// each can be weighted by where it enters (the directional
// dipole needs the refracted direction of the light and, as part of its definition, the entry
// Fresnel transmittance T₁₂; the radial dipoles take plain irradiance, as Jensen & Buhler, or with
// ENTRY_FRESNEL T₁₂ E, as Jensen et al. 2001's BSSRDF).

#import common/direct_light.wgsl
#import common/color.wgsl
#import common/indirect.wgsl

// Adds one light sample: `sample` is what a white Lambertian reflects of it (E cos θ / π per unit
// weight), `weight` its share after visibility.
fn add_incident(sum: ptr<function, SampleLight>, n: vec3f, eta: f32, sample: UnshadowedSample, weight: f32) {
    var e = PI * sample.value * weight;
    if ENTRY_FRESNEL {
        e *= 1.0 - fresnel_dielectric(eta, dot(n, sample.direction));
    }
    (*sum).irradiance += e;
    (*sum).direction += luminance(e) * refract(-sample.direction, n, 1.0 / eta);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = indirect_linear_index(id, groups, 64u);
    if i >= arrayLength(&samples) || samples[i].area <= 0.0 {
        return;
    }
    let sample = samples[i];
    let eta = materials[vertex_material(triangle_vertices(sample.triangle)[0])].medium_eta;
    var s: GSurface;
    s.valid = true;
    s.position = sample.position;
    s.normal = sample.normal;
    s.geometric_normal = sample.normal;
    s.view = sample.normal;
    s.distance = 1.0;
    s.material_index = 0u;
    s.material = SurfaceMaterial(vec3f(1.0), 1.0, 0.0, 1.0, 0.0, vec3f(0.0));
    let origin = gsurface_ray_origin(s);
    var rng = rng_new(vec2u(i & 0xffffu, 0x10000u | (i >> 16u)), frame.frame_counter, frame.seed);
    var light: SampleLight;
    for (var l = 0u; l < scene_info.light_count; l++) {
        let unshadowed = analytic_light_unshadowed(s, lights[l]);
        if any(unshadowed.value != vec3f(0.0)) {
            add_incident(&light, s.normal, eta, unshadowed, analytic_visibility(lights[l], s, unshadowed, origin, true));
        }
    }
    if scene_info.emissive_count > 0u && AREA_SAMPLES > 0u {
        for (var k = 0u; k < AREA_SAMPLES; k++) {
            let unshadowed = emissive_sample_unshadowed(s, origin, vec3f(rng_next(&rng), rng_next2(&rng)));
            if any(unshadowed.value != vec3f(0.0)) {
                add_incident(&light, s.normal, eta, unshadowed, sample_visibility(unshadowed, origin) / f32(AREA_SAMPLES));
            }
        }
    }
    if scene_info.env_kind != ENV_NONE && ENV_SAMPLES > 0u {
        for (var k = 0u; k < ENV_SAMPLES; k++) {
            let unshadowed = environment_sample_unshadowed(s, rng_next2(&rng));
            if any(unshadowed.value != vec3f(0.0)) {
                add_incident(&light, s.normal, eta, unshadowed, sample_visibility(unshadowed, origin) / f32(ENV_SAMPLES));
            }
        }
    }
    // One bounce of indirect light: cosine-weighted rays, each bringing the direct light reflected by
    // what it meets (E ≈ π × their mean radiance). Emitters and the environment are the light samples'
    // above, so a ray that meets them adds nothing.
    for (var k = 0u; k < INDIRECT_SAMPLES; k++) {
        let dir = local_to_world(sample_cosine_hemisphere(rng_next2(&rng)), s.normal);
        let hit = trace_closest(Ray(origin, dir), 0.0, FLT_MAX);
        if hit.t == FLT_MAX {
            continue;
        }
        let h = hit_gsurface(surface_at(hit.triangle, hit.u, hit.v, dir), -dir, hit.t);
        let reflected =
            direct_light(h, offset_origin(h.position, h.geometric_normal), &rng, AREA_SAMPLES, ENV_SAMPLES, true);
        add_incident(&light, s.normal, eta, UnshadowedSample(reflected, dir, hit.t), 1.0 / max(f32(INDIRECT_SAMPLES), 1.0));
    }
    sample_light[i] = light;
}
