// Depth-only rendering of the scene into one shadow-map layer; alpha-masked surfaces cut holes.

#import common/scene.wgsl

struct ShadowView {
    view_proj: mat4x4f,
    params: vec4f,
}

@group(1) @binding(0) var<uniform> shadow_view: ShadowView;

struct VertexOut {
    @builtin(position) clip: vec4f,
    @location(0) uv: vec2f,
    @location(1) @interpolate(flat) material: u32,
}

@vertex
fn vs_main(@location(0) position: vec3f, @location(1) material_flags: u32, @location(4) uv: vec2f) -> VertexOut {
    var out: VertexOut;
    out.clip = shadow_view.view_proj * vec4f(position, 1.0);
    out.uv = uv;
    out.material = material_flags & MATERIAL_MASK;
    return out;
}

@fragment
fn fs_main(in: VertexOut) {
    let m = materials[in.material];
    if m.alpha_cutoff >= 0.0 && base_color_alpha(m, in.uv, 0.0).a < m.alpha_cutoff {
        discard;
    }
}
