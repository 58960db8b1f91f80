// Recombination: each pixel's (filtered) data times its own BRDF, plus emission or the `direct` pass.
// Classic IGI multiplies the demodulated radiance back by the BRDF factor; IGI-SH takes the dot product
// of the incident-light SH coefficients with the projected BRDF, Lambert (clamped cosine about the
// shading normal, Â_l = π, 2π/3, π/4) plus a normalised Phong lobe about the mirror direction with the
// exponent equivalent to the roughness, both rotated zonal harmonics: B_i = Â_l · Y_i(axis).

#import common/frame.wgsl
#import common/sh.wgsl
#import common/environment.wgsl

@group(2) @binding(0) var<storage, read> filtered: array<vec2u>;
@group(2) @binding(1) var direct_light: texture_2d<f32>;
@group(2) @binding(2) var output: texture_storage_2d<rgba32float, read_write>;

fn sh_reflected(s: GSurface, base: u32) -> vec3f {
    var data: array<vec4f, VEC4S>;
    for (var k = 0u; k < VEC4S; k++) {
        data[k] = unpack_half4(filtered[base + k]);
    }
    let n_dot_v = dot(s.normal, s.view);
    if n_dot_v <= 0.0 {
        // A shading normal facing away from the viewer reflects nothing (as brdf_eval has it).
        return vec3f(0.0);
    }
    let weights = brdf_lobe_weights(s.material, n_dot_v);
    let exponent = phong_exponent(s.material.roughness);
    let mirror = reflect(-s.view, s.normal);
    let yn = sh9_basis(s.normal);
    let yr = sh9_basis(mirror);
    var lambert: array<f32, 3>;
    var phong: array<f32, 3>;
    for (var l = 0u; l < 3u; l++) {
        lambert[l] = sh_lambert(l) * INV_PI;
        phong[l] = sh_phong(exponent, l);
    }
    var sum = vec3f(0.0);
    for (var i = 0u; i < 9u; i++) {
        var c: vec3f;
        for (var ch = 0u; ch < 3u; ch++) {
            let f = 3u * i + ch;
            c[ch] = data[f / 4u][f % 4u];
        }
        let l = sh_band(i);
        sum += c * (weights.diffuse * (lambert[l] * yn[i]) + weights.specular * (phong[l] * yr[i]));
    }
    return max(sum, vec3f(0.0));
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
            radiance += sh_reflected(s, base);
        } else {
            let weights = brdf_lobe_weights(s.material, dot(s.normal, s.view));
            radiance += unpack_half4(filtered[base]).rgb * (weights.diffuse + weights.specular);
        }
    }
    let mean = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index);
    textureStore(output, id.xy, vec4f(mean, 1.0));
}
