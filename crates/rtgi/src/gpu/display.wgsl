// Tone-maps linear radiance into an 8-bit display image (sRGB-encoded values in an rgba8unorm texture,
// which the viewer samples through an rgba8unorm-srgb view).
#import common/color.wgsl

struct DisplayUniforms {
    // 2^exposure_ev.
    scale: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

@group(0) @binding(0) var radiance: texture_2d<f32>;
@group(0) @binding(1) var display: texture_storage_2d<rgba8unorm, write>;
@group(0) @binding(2) var<uniform> uniforms: DisplayUniforms;

@compute @workgroup_size(DISPLAY_WG, DISPLAY_WG, 1)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let size = textureDimensions(display);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let c = textureLoad(radiance, id.xy, 0).rgb;
    textureStore(display, id.xy, vec4f(tone_map(c, uniforms.scale), 1.0));
}
