// Deferred G-buffer by rasterisation: one draw per mesh (instance_index = the mesh's index). The texels
// are common/gbuffer.wgsl's, as the ray-cast pass (gbuffer_trace.wgsl) writes them.

#import common/raster.wgsl
#import common/gbuffer.wgsl

// Per mesh: current world position -> the previous frame's (object motion; identity when static).
@group(1) @binding(1) var<storage, read> mesh_motion: array<mat4x4f>;

// SceneVertexOut's fields plus the mesh: entry-point IO cannot nest structs, so the shared fields are
// listed again and reassembled into a SceneVertexOut in the fragment stage.
struct GBufferVertexOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
    @location(1) normal: vec3f,
    @location(2) tangent: vec4f,
    @location(3) uv: vec2f,
    @location(4) @interpolate(flat) material: u32,
    @location(5) @interpolate(flat) mesh: u32,
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
    // stays unjittered: previous_pixel uses the previous view-projection as it is.
    v.clip = vec4f(v.clip.xy - vec2f(2.0, -2.0) * frame.jitter / vec2f(frame.size) * v.clip.w, v.clip.zw);
    return GBufferVertexOut(v.clip, v.world, v.normal, v.tangent, v.uv, v.material, mesh);
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
    let motion = previous_pixel(mesh_motion[vertex.mesh], in.world) - in.clip.xy;
    let t = gbuffer_texels(in.material, s, normals.shading, normals.geometric, length(to_camera), motion, vertex.mesh);
    return GBufferOut(t.albedo, t.normal, t.material, t.emission, t.distance, t.motion, t.instance);
}
