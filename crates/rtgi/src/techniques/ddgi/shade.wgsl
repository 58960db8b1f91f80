// Camera pixels: this frame's direct light (accumulated while nothing moves, by the `direct` pass) plus
// the probes' diffuse light.

#import common/frame.wgsl

@group(2) @binding(0) var output: texture_storage_2d<rgba32float, write>;
@group(2) @binding(1) var direct: texture_2d<f32>;
@group(2) @binding(2) var probe_irradiance: texture_2d<f32>;
@group(2) @binding(3) var probe_distance: texture_2d<f32>;
@group(2) @binding(4) var probe_sampler: sampler;
@group(2) @binding(5) var<uniform> probe_frame: ProbeFrame;

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    var radiance = textureLoad(direct, id.xy, 0).rgb;
    let s = load_gsurface(id.xy);
    if s.valid {
        radiance += probe_diffuse_light(s);
    }
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
