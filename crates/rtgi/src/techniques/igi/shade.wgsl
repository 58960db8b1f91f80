// Recombination: each pixel's (filtered) data times its own BRDF, plus emission or the `direct` pass.
// Classic IGI multiplies the demodulated radiance back by the BRDF factor; IGI-SH takes the dot product
// of the incident-light SH coefficients with the projected BRDF, Lambert plus a normalised Phong lobe
// (common/sh_lobes.wgsl).

#import common/frame.wgsl
#import common/sh_lobes.wgsl
#import common/environment.wgsl

@group(2) @binding(0) var<storage, read> filtered: array<vec2u>;
@group(2) @binding(1) var direct_light: texture_2d<f32>;
@group(2) @binding(2) var output: texture_storage_2d<rgba32float, read_write>;

// The pixel whose filtered SH incident_sh reads: its first packed vec4.
var<private> sh_base: u32;

// Coefficient k of the pixel's incident radiance: floats 3k, 3k + 1, 3k + 2 of its packed halves.
fn incident_sh(k: u32) -> vec3f {
    var c: vec3f;
    for (var ch = 0u; ch < 3u; ch++) {
        let f = 3u * k + ch;
        c[ch] = unpack2x16float(filtered[sh_base + f / 4u][(f / 2u) % 2u])[f % 2u];
    }
    return c;
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let base = (id.y * frame.size.x + id.x) * VEC4S;
    let s = load_gsurface(id.xy);
    var radiance: vec3f;
    if DIRECT_RASTER {
        radiance = textureLoad(direct_light, id.xy, 0).rgb;
    } else if !s.valid {
        radiance = environment_radiance(-s.view);
    } else {
        radiance = s.material.emission;
    }
    if s.valid {
        if SH {
            sh_base = base;
            radiance += phong_lobes_reflected(s.material, s.normal, s.view, 3u);
        } else {
            let weights = brdf_lobe_weights(s.material, dot(s.normal, s.view));
            radiance += unpack_half4(filtered[base]).rgb * (weights.diffuse + weights.specular);
        }
    }
    let mean = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(mean, 1.0));
}
