// Splatting indirect illumination (Dachsbacher & Stamminger 2006): one instanced quad per VPL, covering
// the screen rectangle of the VPL's bounding sphere (radius: where its contribution falls below the
// threshold), additively blended into the indirect buffer. Interleaved, VPL k covers only the pixels
// of sub-buffer k mod N·M in the atlas layout, scaled by SCALE (N·M with rescaling, else 1).

@group(2) @binding(0) var<storage, read> vpls: array<Vpl>;

struct SplatOut {
    @builtin(position) clip: vec4f,
    @location(0) @interpolate(flat) vpl: u32,
}

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

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> SplatOut {
    var out: SplatOut;
    out.vpl = instance;
    out.clip = vec4f(2.0, 2.0, 0.0, 1.0);
    let v = vpls[instance];
    if v.radius <= 0.0 {
        return out;
    }
    let r = splat_rect(v);
    // Pixels x in [r.x, r.z) with x mod N = i sit at atlas x = i·SUB_W + ceil((x − i) / N).
    let n = vec2f(f32(INTERLEAVE_N), f32(INTERLEAVE_M));
    let sub = vec2f(f32(v.subset % INTERLEAVE_N), f32(v.subset / INTERLEAVE_N));
    let lo = sub * vec2f(f32(SUB_W), f32(SUB_H)) + ceil((r.xy - sub) / n);
    let hi = sub * vec2f(f32(SUB_W), f32(SUB_H)) + ceil((r.zw - sub) / n);
    if any(hi <= lo) {
        return out;
    }
    // Two triangles: corners 0,1,2 and 2,1,3 of the rectangle.
    var corners = array<vec2f, 6>(
        vec2f(0.0, 0.0),
        vec2f(1.0, 0.0),
        vec2f(0.0, 1.0),
        vec2f(0.0, 1.0),
        vec2f(1.0, 0.0),
        vec2f(1.0, 1.0),
    );
    let a = mix(lo, hi, corners[vertex]) / vec2f(atlas_size());
    out.clip = vec4f(a.x * 2.0 - 1.0, 1.0 - a.y * 2.0, 0.0, 1.0);
    return out;
}

@fragment
fn fs_main(in: SplatOut) -> @location(0) vec4f {
    let s = atlas_surface(vec2u(in.clip.xy));
    let v = vpls[in.vpl];
    if !s.valid || distance(s.position, v.position) > v.radius {
        discard;
    }
    var p: PixelLight;
    p.valid = true;
    p.position = v.position;
    p.normal = v.normal;
    p.area = v.area;
    p.intensity = v.intensity;
    // Alpha counts the VPLs splatted here: 1 each, 65536 for one of another sub-buffer (never, see tests).
    let foreign = v.subset != atlas_subset(vec2u(in.clip.xy));
    return vec4f(pixel_light_radiance(s, p) * SCALE, select(1.0, 65536.0, foreign));
}
