// Colour helpers.

fn luminance(c: vec3f) -> f32 {
    return dot(c, vec3f(0.2126, 0.7152, 0.0722));
}

// The display tone map of `image.rs` (its module documentation), steps 1–3: exposure `scale` = 2^ev,
// the ACES filmic fit of Narkowicz (2015), clamped, then the exact sRGB OETF. The CPU twin is
// `image::tone_map_pixel`; the input is the renderer's output, which is finite by contract.
fn aces_filmic(x: vec3f) -> vec3f {
    let v = clamp(x, vec3f(0.0), vec3f(1.0e4));
    return (v * (2.51 * v + 0.03)) / (v * (2.43 * v + 0.59) + 0.14);
}

fn srgb_encode(linear: vec3f) -> vec3f {
    let curve = 1.055 * pow(linear, vec3f(1.0 / 2.4)) - 0.055;
    return select(curve, 12.92 * linear, linear <= vec3f(0.0031308));
}

fn tone_map(radiance: vec3f, scale: f32) -> vec3f {
    let mapped = clamp(aces_filmic(radiance * scale), vec3f(0.0), vec3f(1.0));
    return srgb_encode(mapped);
}
