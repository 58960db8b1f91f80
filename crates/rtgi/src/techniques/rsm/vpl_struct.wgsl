// A VPL taken from the RSM (layout: `GpuVpl` in splat.rs).
struct Vpl {
    position: vec3f,
    // Splat radius: beyond it the VPL's bound lum(I)/(π d²) is below the threshold.
    radius: f32,
    normal: vec3f,
    area: f32,
    intensity: vec3f,
    // Sub-buffer (sample subset) the VPL is splatted into when interleaved.
    subset: u32,
}
