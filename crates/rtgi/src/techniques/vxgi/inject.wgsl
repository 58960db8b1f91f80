// Light injection (prepended: volume.wgsl): every voxel holding surfaces takes the direct light its
// surfaces reflect, from the shared direct-light routine the camera's pixels use (analytic lights with
// traced shadow rays, INJECT_SAMPLES samples of the emissive triangles and of the environment, the
// same for every run: the random numbers are seeded by the voxel), as a Lambertian surface of the
// voxel's mean albedo facing its mean normal. Level 0 of the radiance volume gets L·α with α = 1.
// The camera's own view of emitters and the environment is the direct pass's: the voxels carry only
// their reflected light.

#import common/direct_light.wgsl

@group(2) @binding(3) var radiance_out: texture_storage_3d<rgba16float, write>;

// The surface voxel c of level k stands for, lit on its normal's side; shadow rays leave a voxel out
// along the normal so that they clear the voxel's own surfaces wherever in it they lie.
fn voxel_surface(k: u32, c: vec3u, v: Voxel) -> GSurface {
    let n = voxel_direction(v);
    var s: GSurface;
    s.valid = true;
    s.position = world_position(k, vec3f(c) + 0.5);
    s.normal = n;
    s.geometric_normal = n;
    s.view = n;
    s.distance = 0.0;
    s.material_index = 0u;
    s.material = SurfaceMaterial(v.albedo, 1.0, 0.0, 1.0, 0.0, vec3f(0.0));
    return s;
}

// One dispatch per level (`dispatch_slot.clip`).
@compute @workgroup_size(4, 4, 4)
fn inject(@builtin(global_invocation_id) id: vec3u) {
    if any(id >= vec3u(GRID)) {
        return;
    }
    let k = dispatch_slot.clip;
    let t = clip_texel(k, id);
    let v = load_voxel(t);
    if !v.occupied {
        textureStore(radiance_out, t, vec4f(0.0));
        return;
    }
    let s = voxel_surface(k, id, v);
    let origin = s.position + s.normal * voxel_size(k);
    var rng = rng_new(t.xy, t.z, frame.seed);
    let radiance = direct_light(s, origin, &rng, INJECT_SAMPLES, INJECT_SAMPLES, true);
    textureStore(radiance_out, t, vec4f(radiance, 1.0));
}

// The second bounce: each voxel adds what its diffuse cones gather from the first bounce's volume
// (bound as radiance_base / radiance_directional) times albedo / π. One dispatch per level.
@compute @workgroup_size(4, 4, 4)
fn bounce(@builtin(global_invocation_id) id: vec3u) {
    if any(id >= vec3u(GRID)) {
        return;
    }
    let k = dispatch_slot.clip;
    let t = clip_texel(k, id);
    let v = load_voxel(t);
    let first = textureLoad(radiance_base, t, 0);
    if !v.occupied {
        textureStore(radiance_out, t, first);
        return;
    }
    let n = voxel_direction(v);
    let e = cone_irradiance(world_position(k, vec3f(id) + 0.5) + n * voxel_size(k), n);
    textureStore(radiance_out, t, vec4f(first.rgb + v.albedo * INV_PI * e, first.a));
}
