// Direct lighting from the G-buffer: emission, analytic lights through shadow maps, and (ray traced
// through the shared BVH) emissive triangles and the environment. Progressive: frame k averages its
// estimate into the output with weight 1/(k+1), so `--frames N` converges the stochastic terms
// (unless ACCUMULATE is false: then a GI technique adds its indirect light and accumulates the sum).

#import common/direct_light.wgsl

@group(2) @binding(0) var output: texture_storage_2d<rgba32float, read_write>;

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    var radiance = direct_pixel_radiance(load_gsurface(id.xy), id.xy, AREA_SAMPLES, ENV_SAMPLES);
    if ACCUMULATE {
        radiance = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    }
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
