// Camera pixels: the direct light (the shared `direct` pass, averaged while nothing changes) plus the
// diffuse lobe times the cache's irradiance, Σ w_k E_k(p) / Σ w_k (no indirect light where no record
// reaches yet, in progressive mode); on glossy surfaces the radiance records' Σ w_k L_k / Σ w_k, which
// already carries the whole BRDF.

#import common/brdf.wgsl

@compute @workgroup_size(TILE, TILE, 1)
fn shade(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    var radiance = textureLoad(direct_light_texture, id.xy, 0).rgb;
    let s = load_gsurface(id.xy);
    let sum = textureLoad(splat_buffer, id.xy);
    if s.valid && sum.a > 0.0 && is_glossy(s.material) {
        radiance += max(sum.rgb / sum.a, vec3f(0.0));
    } else if s.valid && sum.a > 0.0 {
        let diffuse = brdf_lobe_weights(s.material, dot(s.normal, s.view)).diffuse;
        radiance += diffuse * INV_PI * sum.rgb / sum.a;
    }
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
