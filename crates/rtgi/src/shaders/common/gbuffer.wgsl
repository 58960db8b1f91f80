// The G-buffer's texels as both primary-visibility passes write them: the raster pass (frame/gbuffer.wgsl)
// and the ray-cast pass (frame/gbuffer_trace.wgsl). Techniques read them through common/frame.wgsl,
// whose bindings document the layout.

#import common/scene.wgsl
#import common/frame_uniforms.wgsl

struct GBufferTexels {
    albedo: vec4f,
    normal: vec4f,
    material: vec2u,
    emission: vec4f,
    distance: f32,
    motion: vec2f,
    instance: u32,
}

// The texels of a visible surface: the sample `s` of material `material_index`, both normals facing the
// camera, the distance along the primary ray, the screen-space motion to where the point was in the
// previous frame (pixels) and the mesh it belongs to.
fn gbuffer_texels(
    material_index: u32,
    s: SurfaceMaterial,
    shading_normal: vec3f,
    geometric_normal: vec3f,
    distance: f32,
    motion: vec2f,
    mesh: u32,
) -> GBufferTexels {
    var t: GBufferTexels;
    t.albedo = vec4f(s.base_color, s.metallic);
    t.normal = vec4f(oct_encode(shading_normal), oct_encode(geometric_normal));
    t.material = vec2u(material_index, pack4x8unorm(vec4f(s.roughness, s.specular, 0.0, 0.0)));
    t.emission = vec4f(s.emission, 1.0);
    t.distance = distance;
    t.motion = motion;
    t.instance = mesh + 1u;
    return t;
}

// Where `world` (on mesh `previous_from_current`'s current pose) was on screen in the previous frame.
fn previous_pixel(previous_from_current: mat4x4f, world: vec3f) -> vec2f {
    return clip_to_pixel(frame.prev_view_proj * (previous_from_current * vec4f(world, 1.0)));
}
