// The per-frame uniforms (`FrameUniforms` in frame/mod.rs): camera, previous camera, counters, time,
// shadow settings. A module of its own so that passes which cannot bind the G-buffer (the G-buffer pass
// itself) read the same uniforms.

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
