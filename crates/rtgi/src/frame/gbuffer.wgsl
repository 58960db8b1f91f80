// Deferred G-buffer: one draw of the whole scene. Layout of the targets: see common/frame.wgsl.

#import common/raster.wgsl

struct Camera {
    view_proj: mat4x4f,
    position: vec3f,
    _pad: f32,
}

@group(1) @binding(0) var<uniform> camera: Camera;

@vertex
fn vs_main(
    @location(0) position: vec3f,
    @location(1) material_flags: u32,
    @location(2) normal_oct: u32,
    @location(3) tangent_oct: u32,
    @location(4) uv: vec2f,
) -> SceneVertexOut {
    return scene_vertex(camera.view_proj, Vertex(position, material_flags, normal_oct, tangent_oct, uv));
}

struct GBufferOut {
    @location(0) albedo: vec4f,
    @location(1) normal: vec4f,
    @location(2) material: vec2u,
    @location(3) emission: vec4f,
    @location(4) distance: f32,
}

// Mip level from screen-space UV derivatives, for the explicit-level lookups of the shared library.
fn texture_lod(uv: vec2f) -> f32 {
    let size = vec2f(textureDimensions(textures_srgb));
    let dx = dpdx(uv) * size;
    let dy = dpdy(uv) * size;
    return max(0.0, 0.5 * log2(max(dot(dx, dx), dot(dy, dy))));
}

@fragment
fn fs_main(in: SceneVertexOut) -> GBufferOut {
    let m = materials[in.material];
    let lod = texture_lod(in.uv);
    let s = material_at(m, in.uv, lod);
    if m.alpha_cutoff >= 0.0 && s.alpha < m.alpha_cutoff {
        discard;
    }
    let to_camera = camera.position - in.world;
    let normals = fragment_normals(in, m, to_camera, lod);
    var out: GBufferOut;
    out.albedo = vec4f(s.base_color, s.metallic);
    out.normal = vec4f(oct_encode(normals.shading), oct_encode(normals.geometric));
    out.material = vec2u(in.material, pack4x8unorm(vec4f(s.roughness, s.specular, 0.0, 0.0)));
    out.emission = vec4f(s.emission, 1.0);
    out.distance = length(to_camera);
    return out;
}
