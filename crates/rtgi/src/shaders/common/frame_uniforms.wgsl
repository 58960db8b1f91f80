// The per-frame uniforms (`FrameUniforms` in frame/mod.rs): camera, previous camera, counters, time,
// shadow settings, bound at group 1, binding 0 in every pass, and the camera rays derived from them. A
// module of its own so that passes which cannot bind the G-buffer (the G-buffer passes themselves) read
// the same uniforms and trace the same primary rays.

struct FrameUniforms {
    view_proj: mat4x4f,
    inv_view_proj: mat4x4f,
    // The previous frame's view-projection (equal to view_proj on a first frame or after a cut).
    prev_view_proj: mat4x4f,
    camera_position: vec3f,
    // Frames since the renderer started: the dimension of per-frame random numbers.
    frame_counter: u32,
    size: vec2u,
    seed: u32,
    shadow_filter_radius: u32,
    // Constant depth bias and normal offset (in shadow-map texels) against self-shadowing.
    shadow_depth_bias: f32,
    shadow_normal_offset: f32,
    shadow_map_size: f32,
    // Frames accumulated since the view or scene last changed: progressive techniques average over it.
    sample_index: u32,
    // Sub-pixel offset of primary rays in pixels.
    jitter: vec2f,
    time: f32,
    delta_time: f32,
    // 1 when last frame's history may be reused (no cut, parameter change or resize since).
    history_valid: u32,
}

@group(1) @binding(0) var<uniform> frame: FrameUniforms;

// Unit direction of the primary ray through framebuffer position `xy` (pixels, y down, unjittered).
fn primary_ray_through(xy: vec2f) -> vec3f {
    let ndc = vec2f(xy.x / f32(frame.size.x) * 2.0 - 1.0, 1.0 - xy.y / f32(frame.size.y) * 2.0);
    let p = frame.inv_view_proj * vec4f(ndc, 0.5, 1.0);
    return normalize(p.xyz / p.w - frame.camera_position);
}

// Unit direction of the primary ray of `pixel`: through its centre plus this frame's jitter, where
// the G-buffer samples it too.
fn primary_ray_direction(pixel: vec2u) -> vec3f {
    return primary_ray_through(vec2f(pixel) + 0.5 + frame.jitter);
}

// Framebuffer coordinates (pixels, y down) of a clip-space position.
fn clip_to_pixel(clip: vec4f) -> vec2f {
    let ndc = clip.xy / clip.w;
    return vec2f(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * vec2f(frame.size);
}
