// Reflected radiance from SH coefficients of incident radiance with the BRDF modelled as two radially
// symmetric lobes (Sloan, Kautz & Snyder 2002 §6; Kautz, Sloan & Snyder 2002): Lambert's clamped
// cosine about the shading normal n plus a normalised Phong lobe (n+1)/(2π) cosⁿ about the mirror
// direction r, with the exponent equivalent to the GGX roughness (phong_exponent) and the lobes'
// directional albedos as weights (brdf_lobe_weights). A radially symmetric kernel turned to its axis
// has the coefficients Â_l Y_i(axis), so
//   L_o = Σ_i L_i (w_d Â_l^cos / π · Y_i(n) + w_s Â_l^phong · Y_i(r)),
// no tables and order² terms per point. igi-sh shades its per-pixel SH this way; prt's glossy
// transfer with glossy_lobe = phong shades its transferred radiance this way.
//
// The including shader defines `fn incident_sh(k: u32) -> vec3f`, coefficient k (index l(l+1)+m, as
// sh.wgsl and hsh.wgsl) of the radiance arriving at the point.

#import common/sh.wgsl
#import common/hsh.wgsl
#import common/brdf.wgsl

// The first `order` bands of incident_sh reflected towards `view` by `m` at a point with shading
// normal `normal`.
fn phong_lobes_reflected(m: SurfaceMaterial, normal: vec3f, view: vec3f, order: u32) -> vec3f {
    let n_dot_v = dot(normal, view);
    if n_dot_v <= 0.0 {
        // A shading normal facing away from the viewer reflects nothing (as brdf_eval has it).
        return vec3f(0.0);
    }
    let weights = brdf_lobe_weights(m, n_dot_v);
    let exponent = phong_exponent(m.roughness);
    let mirror = reflect(-view, normal);
    var sum = vec3f(0.0);
    for (var l = 0u; l < order; l++) {
        let diffuse = weights.diffuse * (sh_lambert(l) * INV_PI);
        let specular = weights.specular * sh_phong(exponent, l);
        for (var k = l * l; k < (l + 1u) * (l + 1u); k++) {
            sum += incident_sh(k) * (diffuse * sh_one(k, normal) + specular * sh_one(k, mirror));
        }
    }
    // Truncated SH can ring below zero.
    return max(sum, vec3f(0.0));
}
