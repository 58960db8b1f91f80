// Light injection (prepended: volume.wgsl): every voxel holding surfaces takes the direct light its
// surfaces reflect, from the shared direct-light routine the camera's pixels use (analytic lights with
// traced shadow rays, INJECT_SAMPLES samples of the emissive triangles and of the environment, the
// same for every run: the random numbers are seeded by the voxel's lattice index and level, so a voxel
// gets the same light wherever its level lies), as a Lambertian surface of the
// voxel's mean albedo facing its mean normal. Level 0 of the radiance volume gets L·α with α = 1.
// The camera's own view of emitters and the environment is the direct pass's: the voxels carry only
// their reflected light.

#import common/direct_light.wgsl

// The surface voxel c of level k stands for, lit on its normal's side; shadow rays leave a voxel out
// along the normal so that they clear the voxel's own surfaces wherever in it they lie.
fn voxel_surface(k: u32, c: vec3i, v: Voxel) -> GSurface {
    let n = voxel_direction(v);
    var s: GSurface;
    s.valid = true;
    s.position = voxel_centre(k, c);
    s.normal = n;
    s.geometric_normal = n;
    s.view = n;
    s.distance = 0.0;
    s.material_index = 0u;
    s.material = SurfaceMaterial(v.albedo, 1.0, 0.0, 1.0, 0.0, vec3f(0.0));
    return s;
}

// One dispatch per level and region (`dispatch_slot`).
@compute @workgroup_size(4, 4, 4)
fn inject(@builtin(global_invocation_id) id: vec3u) {
    let voxel = box_voxel(id);
    if voxel.w == 0 {
        return;
    }
    let k = dispatch_slot.clip;
    let c = voxel.xyz;
    let t = clip_texel(k, vec3u(c));
    let v = load_voxel(t);
    if !v.occupied {
        textureStore(radiance_out, t, vec4f(0.0));
        return;
    }
    let s = voxel_surface(k, c, v);
    let origin = s.position + s.normal * voxel_size(k);
    // The lattice index (16 bits of x and y, z and the level in the second word) keys the numbers.
    let w = bitcast<vec3u>(lattice_voxel(k, c));
    var rng = rng_new(w.xy & vec2u(0xffffu), w.z ^ (k << 28u), frame.seed);
    let radiance = direct_light(s, origin, &rng, INJECT_SAMPLES, INJECT_SAMPLES, true);
    textureStore(radiance_out, t, vec4f(radiance, 1.0));
}

// The second bounce: each voxel adds what its diffuse cones gather from the first bounce's volume
// (bound as radiance_base / radiance_directional) times albedo / π. One dispatch per level and region.
@compute @workgroup_size(4, 4, 4)
fn bounce(@builtin(global_invocation_id) id: vec3u) {
    let voxel = box_voxel(id);
    if voxel.w == 0 {
        return;
    }
    let k = dispatch_slot.clip;
    let c = voxel.xyz;
    let t = clip_texel(k, vec3u(c));
    let v = load_voxel(t);
    let first = textureLoad(radiance_base, t, 0);
    if !v.occupied {
        textureStore(radiance_out, t, first);
        return;
    }
    let n = voxel_direction(v);
    let e = cone_irradiance(voxel_centre(k, c) + n * voxel_size(k), n);
    textureStore(radiance_out, t, vec4f(first.rgb + v.albedo * INV_PI * e, first.a));
}
