// Geometry-aware upsampling of the reduced-resolution gather (Dachsbacher & Stamminger 2005): each pixel
// interpolates bilinearly between the four nearest low-resolution samples when all four lie on a surface
// similar to its own (shading normals' cosine above NORMAL_COS, distance from its tangent plane below
// DEPTH_THRESHOLD × the view distance: the same tests as the interleaved blur, from Rust); otherwise it is
// flagged (alpha 0) for a full-resolution gather.

#import common/frame.wgsl

@group(2) @binding(0) var low: texture_2d<f32>;
@group(2) @binding(1) var full: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let p = id.xy;
    if any(p >= frame.size) {
        return;
    }
    let s = load_gsurface(p);
    if !s.valid {
        textureStore(full, p, vec4f(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let low_size = vec2i(textureDimensions(low));
    let q = (vec2f(p) + 0.5) / f32(DOWNSAMPLE) - 0.5;
    let base = vec2i(floor(q));
    let fr = q - floor(q);
    var sum = vec3f(0.0);
    var weight = 0.0;
    var ok = true;
    for (var k = 0; k < 4; k++) {
        let d = vec2i(k & 1, k >> 1);
        let c = clamp(base + d, vec2i(0), low_size - 1);
        let src = min(vec2u(c) * DOWNSAMPLE + DOWNSAMPLE / 2u, frame.size - 1u);
        let t = load_gsurface(src);
        let w = select(1.0 - fr.x, fr.x, d.x == 1) * select(1.0 - fr.y, fr.y, d.y == 1);
        let similar = t.valid && dot(t.normal, s.normal) > NORMAL_COS
            && abs(dot(t.position - s.position, s.geometric_normal)) < DEPTH_THRESHOLD * s.distance;
        if !similar && w > 0.0 {
            ok = false;
        }
        sum += textureLoad(low, c, 0).rgb * w;
        weight += w;
    }
    if ok {
        textureStore(full, p, vec4f(sum / max(weight, 1e-6), 1.0));
    } else {
        textureStore(full, p, vec4f(0.0));
    }
}
