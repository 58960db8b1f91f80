// One level of a mip chain: a box filter from the source level (bound as `src`) to the next (`dst`).
//
// The includer (gpu/mips.rs) prepends the bindings and four accessors for its texture dimension:
// src_size(), dst_size(), load_src(p), store_dst(p, v), with p = (x, y, layer) for 2-D arrays and
// (x, y, z) for 3-D textures, and the workgroup size MIP_WG_X/Y/Z.
//
// Destination texel j covers the source interval [j·s, (j+1)·s) on each axis, s = source size /
// destination size. Even sizes give s = 2 (exactly two texels); odd sizes (WebGPU halves rounding down:
// 5 → 2) give 2 < s ≤ 3, and a source texel the interval only partly covers counts with the covered
// fraction, so every source texel contributes its full area to the level below and a constant stays
// constant. Layers of a 2-D array have s = 1 on the layer axis: each keeps to itself.

// Length of source texel i (the interval [i, i + 1)) inside [lo, hi).
fn coverage(i: u32, lo: f32, hi: f32) -> f32 {
    return max(0.0, min(f32(i + 1u), hi) - max(f32(i), lo));
}

@compute @workgroup_size(MIP_WG_X, MIP_WG_Y, MIP_WG_Z)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let dst = dst_size();
    if any(id >= dst) {
        return;
    }
    let src = src_size();
    let scale = vec3f(src) / vec3f(dst);
    let lo = vec3f(id) * scale;
    let hi = lo + scale;
    let first = vec3u(floor(lo));
    let end = min(vec3u(ceil(hi)), src);
    var sum = vec4f(0.0);
    var weight = 0.0;
    for (var z = first.z; z < end.z; z++) {
        let wz = coverage(z, lo.z, hi.z);
        for (var y = first.y; y < end.y; y++) {
            let wzy = wz * coverage(y, lo.y, hi.y);
            for (var x = first.x; x < end.x; x++) {
                let w = wzy * coverage(x, lo.x, hi.x);
                sum += w * load_src(vec3u(x, y, z));
                weight += w;
            }
        }
    }
    // The weights add up to s.x·s.y·s.z; dividing by their float sum keeps rounding out of the mean.
    store_dst(id, sum / weight);
}
