// Reading reflective shadow maps (bind group 3) and the RSM pixel-light kernel, shared by the gather
// (`rsm`, `rsm-interleaved`) and the splatting (`sii`) techniques. Layouts mirror `map.rs`.

#import common/frame.wgsl

// Per texel: world position (xyz) and the cross-section of the light beam through it (w; 0 where the
// light reaches nothing).
@group(3) @binding(0) var rsm_position: texture_2d_array<f32>;
// Normal of the reflector (xyz), facing the light.
@group(3) @binding(1) var rsm_normal: texture_2d_array<f32>;
// Reflected radiant intensity along the normal, I_p = Φ_p / π (the paper's Φ_p folds in the 1/π).
@group(3) @binding(2) var rsm_intensity: texture_2d_array<f32>;
@group(3) @binding(3) var<storage, read> rsm_views: array<RsmView>;
// A light's first RSM layer is its `shadow_layer` in the scene's `lights` (group 0): RSMs and shadow maps
// number their per-light views alike.

// One RSM texel as a pixel light.
struct PixelLight {
    valid: bool,
    position: vec3f,
    area: f32,
    normal: vec3f,
    intensity: vec3f,
}

fn load_pixel_light(texel: vec2i, layer: i32) -> PixelLight {
    var p: PixelLight;
    let pos = textureLoad(rsm_position, texel, layer, 0);
    p.valid = pos.w > 0.0;
    p.position = pos.xyz;
    p.area = pos.w;
    p.normal = textureLoad(rsm_normal, texel, layer, 0).xyz;
    p.intensity = textureLoad(rsm_intensity, texel, layer, 0).rgb;
    return p;
}

// Radiance reflected towards the viewer at surface s from pixel light p (no visibility test: RSM methods
// ignore indirect occlusion).
fn pixel_light_radiance(s: GSurface, p: PixelLight) -> vec3f {
    let e = rsm_irradiance(p.intensity, p.position, p.normal, s.position, s.normal, p.area);
    if all(e <= vec3f(0.0)) {
        return vec3f(0.0);
    }
    let l = normalize(p.position - s.position);
    return brdf_eval(s.material, s.normal, s.view, l) * e;
}

// Where x falls in RSM layer `layer`: the centre of its sampling disc (uv in [0,1]²). Points outside the
// view are clamped to the map's edge, and points behind its view plane get the map's centre: the paper's
// projection is only defined inside the frustum, and the light of such points still comes from the map.
fn rsm_project_layer(layer: i32, x: vec3f) -> vec2f {
    let clip = rsm_views[layer].view_proj * vec4f(x, 1.0);
    if clip.w <= 0.0 {
        return vec2f(0.5);
    }
    let ndc = clip.xy / clip.w;
    return clamp(vec2f(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5), vec2f(0.0), vec2f(1.0));
}

// Texels of all RSM layers (0 when there is no light), numbered layer by layer, row by row.
fn rsm_texel_count() -> u32 {
    let size = u32(rsm_views[0].size);
    return size * size * select(0u, arrayLength(&rsm_views), rsm_views[0].size > 0.0);
}

// (x, y, layer) of texel `index` of that numbering.
fn texel_of(index: u32) -> vec3i {
    let size = u32(rsm_views[0].size);
    let i = index % (size * size);
    return vec3i(i32(i % size), i32(i / size), i32(index / (size * size)));
}
