// Irradiance of every illumination sample from the analytic lights, emissive triangles and the
// environment, with shadow rays through the BVH: the direct-light routine of camera pixels applied to
// a white Lambertian surface (which reflects E/π).

#import common/direct_light.wgsl
#import common/indirect.wgsl

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = indirect_linear_index(id, groups, 64u);
    if i >= arrayLength(&samples) || samples[i].area <= 0.0 {
        return;
    }
    let sample = samples[i];
    var s: GSurface;
    s.valid = true;
    s.position = sample.position;
    s.normal = sample.normal;
    s.geometric_normal = sample.normal;
    s.view = sample.normal;
    s.distance = 1.0;
    s.material_index = 0u;
    s.material = SurfaceMaterial(vec3f(1.0), 1.0, 0.0, 1.0, 0.0, vec3f(0.0));
    var rng = rng_new(vec2u(i & 0xffffu, 0x10000u | (i >> 16u)), frame.frame_counter, frame.seed);
    let reflected = direct_light(s, gsurface_ray_origin(s), &rng, AREA_SAMPLES, ENV_SAMPLES, true);
    sample_irradiance[i] = vec4f(PI * reflected, 0.0);
}
