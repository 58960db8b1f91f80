// What a VPL's splat covers and adds, shared by the raster splat (`splat.wgsl`) and the tiled compute
// splat (`splat_tiles.wgsl`), which therefore reach the same texels with the same values.

@group(2) @binding(0) var<storage, read> vpls: array<Vpl>;

// The pixel rectangle [lo, hi) of the VPL's bounding sphere, clamped to the image (empty if hi <= lo).
fn splat_rect(v: Vpl) -> vec4f {
    var lo = vec2f(1e30);
    var hi = vec2f(-1e30);
    var behind = false;
    for (var k = 0u; k < 8u; k++) {
        let corner = v.position + v.radius * vec3f(
            select(-1.0, 1.0, (k & 1u) != 0u),
            select(-1.0, 1.0, (k & 2u) != 0u),
            select(-1.0, 1.0, (k & 4u) != 0u),
        );
        let clip = frame.view_proj * vec4f(corner, 1.0);
        if clip.w <= 1e-6 {
            behind = true;
        } else {
            let ndc = clip.xy / clip.w;
            lo = min(lo, ndc);
            hi = max(hi, ndc);
        }
    }
    if behind {
        lo = vec2f(-1.0);
        hi = vec2f(1.0);
    }
    let size = vec2f(frame.size);
    let p0 = clamp(vec2f(lo.x * 0.5 + 0.5, 0.5 - hi.y * 0.5) * size, vec2f(0.0), size);
    let p1 = clamp(vec2f(hi.x * 0.5 + 0.5, 0.5 - lo.y * 0.5) * size, vec2f(0.0), size);
    return vec4f(floor(p0), ceil(p1));
}

// The atlas texels [lo, hi) (whole numbers) the VPL's splat covers: its pixel rectangle mapped into its
// own sub-buffer (pixels x in [r.x, r.z) with x mod N = i sit at atlas x = i·SUB_W + ceil((x − i) / N)).
// All zero when it covers nothing.
fn splat_atlas_rect(v: Vpl) -> vec4f {
    if v.radius <= 0.0 {
        return vec4f(0.0);
    }
    let r = splat_rect(v);
    let n = vec2f(f32(INTERLEAVE_N), f32(INTERLEAVE_M));
    let sub = vec2f(f32(v.subset % INTERLEAVE_N), f32(v.subset / INTERLEAVE_N));
    let lo = sub * vec2f(f32(SUB_W), f32(SUB_H)) + ceil((r.xy - sub) / n);
    let hi = sub * vec2f(f32(SUB_W), f32(SUB_H)) + ceil((r.zw - sub) / n);
    if any(hi <= lo) {
        return vec4f(0.0);
    }
    return vec4f(lo, hi);
}

// Whether the VPL lights surface `s` (within its splat radius) and what it adds there.
fn splat_reaches(s: GSurface, v: Vpl) -> bool {
    return s.valid && distance(s.position, v.position) <= v.radius;
}

fn splat_radiance(s: GSurface, v: Vpl) -> vec3f {
    var p: PixelLight;
    p.valid = true;
    p.position = v.position;
    p.normal = v.normal;
    p.area = v.area;
    p.intensity = v.intensity;
    return pixel_light_radiance(s, p) * SCALE;
}
