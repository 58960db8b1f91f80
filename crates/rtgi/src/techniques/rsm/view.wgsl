// One RSM layer's view (layout: `RsmView` in map.rs).
struct RsmView {
    view_proj: mat4x4f,
    // Index of the light in the scene's `lights`.
    light: u32,
    orthographic: u32,
    // World size of a texel at unit distance (perspective) or absolute (orthographic).
    texel: f32,
    // Edge of the map in texels.
    size: f32,
}
