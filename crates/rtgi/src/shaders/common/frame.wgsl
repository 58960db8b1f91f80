// Frame inputs shared by every technique (bind group 1): camera, G-buffer, shadow maps.
// Layouts mirror `ShadowView` in frame/mod.rs; `FrameUniforms` is in common/frame_uniforms.wgsl.

#import common/scene.wgsl
#import common/lights.wgsl
#import common/frame_uniforms.wgsl

struct ShadowView {
    view_proj: mat4x4f,
    // x: world size of a texel at unit distance (perspective) or absolute (orthographic);
    // y: 1 for orthographic projections.
    params: vec4f,
}

// Binding 0 is `frame` (common/frame_uniforms.wgsl).
// base colour (rgb), metallic (a)
@group(1) @binding(1) var gb_albedo: texture_2d<f32>;
// shading normal (xy, octahedral), geometric normal (zw, octahedral)
@group(1) @binding(2) var gb_normal: texture_2d<f32>;
// x: material index, y: pack4x8unorm(roughness, specular, 0, 0)
@group(1) @binding(3) var gb_material: texture_2d<u32>;
// emitted radiance
@group(1) @binding(4) var gb_emission: texture_2d<f32>;
// distance along the primary ray; 0 where the ray left the scene
@group(1) @binding(5) var gb_distance: texture_2d<f32>;
@group(1) @binding(6) var shadow_maps: texture_depth_2d_array;
@group(1) @binding(7) var shadow_sampler: sampler_comparison;
@group(1) @binding(8) var<storage, read> shadow_views: array<ShadowView>;
// screen-space motion in pixels: from the pixel to where its surface point was in the previous frame
@group(1) @binding(9) var gb_motion: texture_2d<f32>;
// mesh (instance) index + 1 of the visible surface; 0 where the primary ray left the scene
@group(1) @binding(10) var gb_instance: texture_2d<u32>;

// Progressive accumulation: the mean of `n + 1` samples from the mean of the first `n` and one more
// (the first sample replaces whatever the output held).
fn accumulate_mean(previous_mean: vec3f, sample: vec3f, n: u32) -> vec3f {
    return select(mix(previous_mean, sample, 1.0 / (f32(n) + 1.0)), sample, n == 0u);
}

// A G-buffer texel decoded.
struct GSurface {
    valid: bool,
    position: vec3f,
    normal: vec3f,
    geometric_normal: vec3f,
    // Unit vector towards the camera.
    view: vec3f,
    distance: f32,
    material_index: u32,
    material: SurfaceMaterial,
}

fn load_gsurface(pixel: vec2u) -> GSurface {
    let p = vec2i(pixel);
    let distance = textureLoad(gb_distance, p, 0).r;
    if distance <= 0.0 {
        return decode_gsurface(pixel, distance, vec4f(0.0), vec4f(0.0), vec2u(0u));
    }
    var s = decode_gsurface(
        pixel,
        distance,
        textureLoad(gb_normal, p, 0),
        textureLoad(gb_albedo, p, 0),
        textureLoad(gb_material, p, 0).xy,
    );
    s.material.emission = textureLoad(gb_emission, p, 0).rgb;
    return s;
}

// Decodes the G-buffer texels of `pixel` (distance, normal, albedo and material targets; emission is
// left at zero). Techniques that keep G-buffer copies in another layout (e.g. interleaved sub-buffers)
// decode them with this too.
fn decode_gsurface(pixel: vec2u, distance: f32, nrm: vec4f, alb: vec4f, mat: vec2u) -> GSurface {
    var s: GSurface;
    s.distance = distance;
    let dir = primary_ray_direction(pixel);
    s.view = -dir;
    s.valid = s.distance > 0.0;
    if !s.valid {
        return s;
    }
    s.position = frame.camera_position + dir * s.distance;
    s.normal = oct_decode(nrm.xy);
    s.geometric_normal = oct_decode(nrm.zw);
    let params = unpack4x8unorm(mat.y);
    s.material_index = mat.x;
    s.material.base_color = alb.rgb;
    s.material.metallic = alb.a;
    s.material.alpha = 1.0;
    s.material.roughness = params.x;
    s.material.specular = params.y;
    return s;
}

// Origin of secondary rays leaving a G-buffer surface, offset along its geometric normal relative to the
// camera distance (the precision of the reconstructed position).
fn gsurface_ray_origin(s: GSurface) -> vec3f {
    return s.position + s.geometric_normal * (1e-4 * max(1.0, s.distance));
}

// Cube face of a direction, in the order +X, −X, +Y, −Y, +Z, −Z (matches frame/shadows.rs).
fn cube_face(d: vec3f) -> i32 {
    let a = abs(d);
    if a.x >= a.y && a.x >= a.z {
        return select(1, 0, d.x > 0.0);
    }
    if a.y >= a.z {
        return select(3, 2, d.y > 0.0);
    }
    return select(5, 4, d.z > 0.0);
}

// Fraction of the light that reaches `p` according to the light's shadow map, with a PCF kernel of
// (2r+1)² bilinear comparison taps.
fn shadow_visibility(light: Light, p: vec3f, ng: vec3f) -> f32 {
    if light.shadow_layer < 0 {
        return 1.0;
    }
    var layer = light.shadow_layer;
    if light.kind == LIGHT_POINT {
        layer += cube_face(p - light.position);
    }
    let view = shadow_views[layer];
    var texel = view.params.x;
    if view.params.y < 0.5 {
        texel *= length(p - light.position);
    }
    let offset_p = p + ng * (frame.shadow_normal_offset * texel);
    let clip = view.view_proj * vec4f(offset_p, 1.0);
    if clip.w <= 0.0 {
        return 1.0;
    }
    let ndc = clip.xyz / clip.w;
    let uv = vec2f(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    if any(uv < vec2f(0.0)) || any(uv > vec2f(1.0)) || ndc.z > 1.0 {
        // Outside the shadow frustum: spot cones and fitted directional maps cover everything lit.
        return 1.0;
    }
    let depth = ndc.z - frame.shadow_depth_bias;
    let r = i32(frame.shadow_filter_radius);
    let step = 1.0 / frame.shadow_map_size;
    var sum = 0.0;
    for (var y = -r; y <= r; y++) {
        for (var x = -r; x <= r; x++) {
            sum += textureSampleCompareLevel(shadow_maps, shadow_sampler, uv + vec2f(f32(x), f32(y)) * step, layer, depth);
        }
    }
    let taps = f32((2 * r + 1) * (2 * r + 1));
    return sum / taps;
}
