// Deferred G-buffer: one draw per mesh (instance_index = the mesh's index). Layout of the targets: see
// common/frame.wgsl.

#import common/raster.wgsl
#import common/frame_uniforms.wgsl

// The frame's uniforms, bound alone: the rest of the frame bind group is the G-buffer being drawn.
@group(1) @binding(0) var<uniform> frame: FrameUniforms;
// Per mesh: current world position -> the previous frame's (object motion; identity when static).
@group(1) @binding(1) var<storage, read> mesh_motion: array<mat4x4f>;

// SceneVertexOut's fields plus the motion inputs: entry-point IO cannot nest structs, so the shared
// fields are listed again and reassembled into a SceneVertexOut in the fragment stage.
struct GBufferVertexOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) tangent: vec4f,
    @location(3) uv: vec2f,
    @location(4) @interpolate(flat) material: u32,
    // The vertex's clip position in the previous frame.
    @location(5) prev_clip: vec4f,
    @location(6) @interpolate(flat) mesh: u32,
}

@vertex
fn vs_main(
    @location(0) position: vec3f,
    @location(1) material_flags: u32,
    @location(2) normal_oct: u32,
    @location(3) tangent_oct: u32,
    @location(4) uv: vec2f,
    @builtin(instance_index) mesh: u32,
) -> GBufferVertexOut {
    var v = scene_vertex(frame.view_proj, Vertex(position, material_flags, normal_oct, tangent_oct, uv));
    // Shift the image by -jitter so that pixel centres sample centre + jitter, like primary rays. Motion
    // stays unjittered: prev_clip below uses the previous view-projection as it is.
    v.clip = vec4f(v.clip.xy - vec2f(2.0, -2.0) * frame.jitter / vec2f(frame.size) * v.clip.w, v.clip.zw);
    var out = GBufferVertexOut(v.clip, v.world, v.normal, v.tangent, v.uv, v.material, vec4f(0.0), 0u);
    out.prev_clip = frame.prev_view_proj * (mesh_motion[mesh] * vec4f(position, 1.0));
    out.mesh = mesh;
    return out;
}

struct GBufferOut {
    @location(0) albedo: vec4f,
    @location(1) normal: vec4f,
    @location(2) material: vec2u,
    @location(3) emission: vec4f,
    @location(4) distance: f32,
    @location(5) motion: vec2f,
    @location(6) instance: u32,
}

// Mip level from screen-space UV derivatives, for the explicit-level lookups of the shared library.
fn texture_lod(uv: vec2f) -> f32 {
    let size = vec2f(textureDimensions(textures_srgb));
    let dx = dpdx(uv) * size;
    let dy = dpdy(uv) * size;
    return max(0.0, 0.5 * log2(max(dot(dx, dx), dot(dy, dy))));
}

// Framebuffer coordinates (pixels, y down) of a clip-space position.
fn clip_to_pixel(clip: vec4f) -> vec2f {
    let ndc = clip.xy / clip.w;
    return vec2f(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * vec2f(frame.size);
}

@fragment
fn fs_main(vertex: GBufferVertexOut) -> GBufferOut {
    let in = SceneVertexOut(vertex.clip, vertex.world, vertex.normal, vertex.tangent, vertex.uv, vertex.material);
    let m = materials[in.material];
    let lod = texture_lod(in.uv);
    let s = material_at(m, in.uv, lod);
    if m.alpha_cutoff >= 0.0 && s.alpha < m.alpha_cutoff {
        discard;
    }
    let to_camera = frame.camera_position - in.world;
    let normals = fragment_normals(in, m, to_camera, lod);
    var out: GBufferOut;
    out.albedo = vec4f(s.base_color, s.metallic);
    out.normal = vec4f(oct_encode(normals.shading), oct_encode(normals.geometric));
    out.material = vec2u(in.material, pack4x8unorm(vec4f(s.roughness, s.specular, 0.0, 0.0)));
    out.emission = vec4f(s.emission, 1.0);
    out.distance = length(to_camera);
    // The previous position is interpolated in clip space (perspective-correct), then projected.
    out.motion = clip_to_pixel(vertex.prev_clip) - in.clip.xy;
    out.instance = vertex.mesh + 1u;
    return out;
}
