// Light injection (prepended: volume.wgsl): every voxel holding surfaces takes the direct light its
// surfaces reflect, from the shared direct-light routine the camera's pixels use (analytic lights with
// traced shadow rays, INJECT_SAMPLES samples of the emissive triangles and of the environment, the
// same for every run: the random numbers are seeded by the voxel), as a Lambertian surface of the
// voxel's mean albedo facing its mean normal. Level 0 of the radiance volume gets L·α with α = 1.
// The camera's own view of emitters and the environment is the direct pass's: the voxels carry only
// their reflected light.

#import common/direct_light.wgsl

@group(2) @binding(3) var radiance_out: texture_storage_3d<rgba16float, write>;

// The surface a voxel stands for, lit on its normal's side; shadow rays leave a voxel out along the
// normal so that they clear the voxel's own surfaces wherever in it they lie.
fn voxel_surface(c: vec3u, v: Voxel) -> GSurface {
    let n = voxel_direction(v);
    var s: GSurface;
    s.valid = true;
    s.position = world_position(vec3f(c) + 0.5);
    s.normal = n;
    s.geometric_normal = n;
    s.view = n;
    s.distance = 0.0;
    s.material_index = 0u;
    s.material = SurfaceMaterial(v.albedo, 1.0, 0.0, 1.0, 0.0, vec3f(0.0));
    return s;
}

@compute @workgroup_size(4, 4, 4)
fn inject(@builtin(global_invocation_id) id: vec3u) {
    if any(id >= vec3u(GRID)) {
        return;
    }
    let v = load_voxel(id);
    if !v.occupied {
        textureStore(radiance_out, id, vec4f(0.0));
        return;
    }
    let s = voxel_surface(id, v);
    let origin = s.position + s.normal * voxel_size();
    var rng = rng_new(id.xy, id.z, frame.seed);
    let radiance = direct_light(s, origin, &rng, INJECT_SAMPLES, INJECT_SAMPLES, true);
    textureStore(radiance_out, id, vec4f(radiance, 1.0));
}

// The second bounce: each voxel adds what its diffuse cones gather from the first bounce's volume
// (bound as radiance_base / radiance_directional) times albedo / π.
@compute @workgroup_size(4, 4, 4)
fn bounce(@builtin(global_invocation_id) id: vec3u) {
    if any(id >= vec3u(GRID)) {
        return;
    }
    let v = load_voxel(id);
    let first = textureLoad(radiance_base, id, 0);
    if !v.occupied {
        textureStore(radiance_out, id, first);
        return;
    }
    let n = voxel_direction(v);
    let e = cone_irradiance(vec3f(id) + 0.5 + n, n);
    textureStore(radiance_out, id, vec4f(first.rgb + v.albedo * INV_PI * e, first.a));
}
