// The work layout of an RSM technique's indirect buffer (the "atlas"), from constants set by Rust
// (`AtlasLayout` in interleave.rs):
// - interleaved (INTERLEAVE_N × INTERLEAVE_M > 1): N·M sub-buffers of SUB_W × SUB_H texels side by side;
//   sub-buffer (i, j) holds the pixels (x, y) with x mod N = i and y mod M = j, at (x / N, y / M)
//   (Segovia et al. 2006's de-interleaved layout); it is shaded with sample subset i + N·j.
// - reduced resolution (DOWNSAMPLE = f > 1, no interleaving): texel c stands for the pixel c·f + f/2.

struct AtlasSource {
    pixel: vec2u,
    valid: bool,
}

fn atlas_size() -> vec2u {
    return vec2u(SUB_W * INTERLEAVE_N, SUB_H * INTERLEAVE_M);
}

fn atlas_subset(a: vec2u) -> u32 {
    return a.x / SUB_W + INTERLEAVE_N * (a.y / SUB_H);
}

fn atlas_source(a: vec2u) -> AtlasSource {
    let sub = vec2u(a.x / SUB_W, a.y / SUB_H);
    let local = vec2u(a.x % SUB_W, a.y % SUB_H);
    let p = (local * vec2u(INTERLEAVE_N, INTERLEAVE_M) + sub) * DOWNSAMPLE;
    var r: AtlasSource;
    r.valid = all(p < frame.size);
    r.pixel = min(p + vec2u(DOWNSAMPLE / 2u), frame.size - 1u);
    return r;
}

// The atlas texel of a full-resolution pixel (DOWNSAMPLE = 1).
fn atlas_of_pixel(p: vec2u) -> vec2u {
    let n = vec2u(INTERLEAVE_N, INTERLEAVE_M);
    return (p % n) * vec2u(SUB_W, SUB_H) + p / n;
}
