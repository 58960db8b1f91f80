// Shading: direct light as the `direct` pass computes it, except that a translucent material's
// Lambertian part is replaced by its multiply-scattered light L = F_t(η, θ_o)/π · Σ R_d(r) E A (the
// dipole BSSRDF of Jensen et al. 2001 with the irradiance of the samples, as Jensen & Buhler 2002),
// or F_t(η, θ_o)/(4C_φ(1/η)) · Σ S_d E A for the directional dipole (`exit_scale`), plus, with
// SINGLE_SCATTERING > 0, Jensen et al.'s single-scattering term (single.wgsl); its specular layer stays.
// Progressive: the stochastic light samples average over frames.

#import common/direct_light.wgsl

@group(2) @binding(12) var output: texture_storage_2d<rgba32float, read_write>;

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    var s = load_gsurface(id.xy);
    let translucent = s.valid && is_translucent(s.material_index);
    if translucent {
        s.material.base_color = vec3f(0.0);
    }
    var radiance = direct_pixel_radiance(s, id.xy, AREA_SAMPLES, ENV_SAMPLES);
    let job = pixel_job[id.y * frame.size.x + id.x];
    if translucent && job != NO_JOB {
        let eta = materials[s.material_index].medium_eta;
        let transmitted = 1.0 - fresnel_dielectric(eta, dot(s.normal, s.view));
        radiance += transmitted * media[s.material_index].exit_scale * job_light[job].rgb;
    }
    if translucent && SINGLE_SCATTERING > 0u {
        radiance += single_light[id.y * frame.size.x + id.x].rgb;
    }
    radiance = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
