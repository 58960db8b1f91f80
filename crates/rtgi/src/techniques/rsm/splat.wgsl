// Splatting indirect illumination (Dachsbacher & Stamminger 2006), the raster way: one instanced quad
// per VPL over its atlas rectangle (`splat_common.wgsl`), additively blended into the indirect buffer.
// Interleaved, VPL k covers only the pixels of sub-buffer k mod N·M, scaled by SCALE.

struct SplatOut {
    @builtin(position) clip: vec4f,
    @location(0) @interpolate(flat) vpl: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> SplatOut {
    var out: SplatOut;
    out.vpl = instance;
    out.clip = vec4f(2.0, 2.0, 0.0, 1.0);
    let r = splat_atlas_rect(vpls[instance]);
    if all(r == vec4f(0.0)) {
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
    let a = mix(r.xy, r.zw, corners[vertex]) / vec2f(atlas_size());
    out.clip = vec4f(a.x * 2.0 - 1.0, 1.0 - a.y * 2.0, 0.0, 1.0);
    return out;
}

@fragment
fn fs_main(in: SplatOut) -> @location(0) vec4f {
    let s = atlas_surface(vec2u(in.clip.xy));
    let v = vpls[in.vpl];
    if !splat_reaches(s, v) {
        discard;
    }
    // Alpha counts the VPLs splatted here: 1 each, 65536 for one of another sub-buffer (never, see tests).
    let foreign = v.subset != atlas_subset(vec2u(in.clip.xy));
    return vec4f(splat_radiance(s, v), select(1.0, 65536.0, foreign));
}
