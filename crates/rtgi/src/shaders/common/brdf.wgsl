// The one BRDF of rtgi: glTF metallic-roughness (Lambert + GGX with height-correlated Smith masking and
// Schlick Fresnel), with KHR_materials_specular's scale of the dielectric specular layer.
//
// f = mix(dielectric, metal, metallic)
//   dielectric = base/π · (1 − s·F(0.04)) + s·F(0.04) · D·V,   metal = F(base) · D·V
// where s is the specular weight (0 gives an exactly Lambertian, energy-conserving surface) and
// α = roughness², clamped so that perfectly smooth surfaces stay finite.

#import common/math.wgsl
#import common/sampling.wgsl

// Material inputs at a surface point after texture lookups.
struct SurfaceMaterial {
    base_color: vec3f,
    alpha: f32,
    metallic: f32,
    roughness: f32,
    specular: f32,
    emission: vec3f,
}

const MIN_ALPHA: f32 = 0.0025;

fn ggx_alpha(roughness: f32) -> f32 {
    return max(roughness * roughness, MIN_ALPHA);
}

fn ggx_d(alpha: f32, n_dot_h: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = n_dot_h * n_dot_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

// Height-correlated Smith visibility V = G2 / (4 n·l n·v) (Heitz 2014).
fn smith_visibility(alpha: f32, n_dot_l: f32, n_dot_v: f32) -> f32 {
    let a2 = alpha * alpha;
    let gv = n_dot_l * sqrt(n_dot_v * n_dot_v * (1.0 - a2) + a2);
    let gl = n_dot_v * sqrt(n_dot_l * n_dot_l * (1.0 - a2) + a2);
    return 0.5 / max(gv + gl, 1e-12);
}

// Smith G1 for the visible-normal pdf.
fn smith_g1(alpha: f32, n_dot_v: f32) -> f32 {
    let a2 = alpha * alpha;
    return 2.0 * n_dot_v / (n_dot_v + sqrt(a2 + (1.0 - a2) * n_dot_v * n_dot_v));
}

fn schlick_weight(cos_theta: f32) -> f32 {
    let m = saturate(1.0 - cos_theta);
    let m2 = m * m;
    return m2 * m2 * m;
}

fn fresnel_schlick(f0: vec3f, cos_theta: f32) -> vec3f {
    return f0 + (1.0 - f0) * schlick_weight(cos_theta);
}

const DIELECTRIC_F0: f32 = 0.04;

// Unpolarised Fresnel reflectance of a smooth dielectric boundary of relative index `eta`, seen from
// outside at `cos_theta` to the normal: the exact form, not Schlick's (CPU twin:
// `scene::subsurface::fresnel_dielectric`).
fn fresnel_dielectric(eta: f32, cos_theta: f32) -> f32 {
    let c = saturate(cos_theta);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let ct = sqrt(1.0 - sin2_t);
    let rs = (c - eta * ct) / (c + eta * ct);
    let rp = (eta * c - ct) / (eta * c + ct);
    return 0.5 * (rs * rs + rp * rp);
}

// The BRDF's parts for unit vectors n, v (towards the viewer), l (towards the light), zero below the
// surface: the dielectric's diffuse and specular layers and the metal's lobe, before the metallic mix.
struct BrdfTerms {
    dielectric_diffuse: vec3f,
    dielectric_specular: f32,
    metal: vec3f,
}

fn brdf_terms(m: SurfaceMaterial, n: vec3f, v: vec3f, l: vec3f) -> BrdfTerms {
    var t: BrdfTerms;
    let n_dot_l = dot(n, l);
    let n_dot_v = dot(n, v);
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 {
        return t;
    }
    let h = normalize(v + l);
    let n_dot_h = saturate(dot(n, h));
    let v_dot_h = saturate(dot(v, h));
    let alpha = ggx_alpha(m.roughness);
    let spec = ggx_d(alpha, n_dot_h) * smith_visibility(alpha, n_dot_l, n_dot_v);
    let fw = m.specular * (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * schlick_weight(v_dot_h));
    t.dielectric_diffuse = m.base_color * INV_PI * (1.0 - fw);
    t.dielectric_specular = spec * fw;
    t.metal = fresnel_schlick(m.base_color, v_dot_h) * spec;
    return t;
}

// BRDF value (without the cosine).
fn brdf_eval(m: SurfaceMaterial, n: vec3f, v: vec3f, l: vec3f) -> vec3f {
    let t = brdf_terms(m, n, v, l);
    return mix(t.dielectric_diffuse + vec3f(t.dielectric_specular), t.metal, m.metallic);
}

// The BRDF's specular (GGX) part alone, without the cosine.
fn brdf_eval_specular(m: SurfaceMaterial, n: vec3f, v: vec3f, l: vec3f) -> vec3f {
    let t = brdf_terms(m, n, v, l);
    return mix(vec3f(t.dielectric_specular), t.metal, m.metallic);
}

// Density of sampling l by GGX's visible normals from v (what `brdf_sample` does for its specular
// lobe): D_v(h) / (4 v·h) = G1(v) D(h) / (4 n·v).
fn ggx_vndf_pdf(m: SurfaceMaterial, n: vec3f, v: vec3f, l: vec3f) -> f32 {
    let n_dot_v = dot(n, v);
    if dot(n, l) <= 0.0 || n_dot_v <= 0.0 {
        return 0.0;
    }
    let alpha = ggx_alpha(m.roughness);
    let h = normalize(v + l);
    return smith_g1(alpha, n_dot_v) * ggx_d(alpha, saturate(dot(n, h))) / (4.0 * n_dot_v);
}

// Probability of choosing the specular lobe when sampling: the lobe's Fresnel-weighted share at
// normal incidence, bounded away from 0 and 1 so neither lobe is starved.
fn specular_probability(m: SurfaceMaterial, n_dot_v: f32) -> f32 {
    let f = schlick_weight(n_dot_v);
    let spec = mix(m.specular * (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * f), 1.0, m.metallic);
    let diff = (1.0 - m.metallic) * max3(m.base_color) * (1.0 - m.specular * DIELECTRIC_F0);
    if spec <= 0.0 {
        return 0.0;
    }
    if diff <= 0.0 {
        return 1.0;
    }
    return clamp(spec / (spec + diff), 0.1, 0.9);
}

// Density of `brdf_sample` choosing l (solid angle measure).
fn brdf_pdf(m: SurfaceMaterial, n: vec3f, v: vec3f, l: vec3f) -> f32 {
    let n_dot_l = dot(n, l);
    let n_dot_v = dot(n, v);
    if n_dot_l <= 0.0 || n_dot_v <= 0.0 {
        return 0.0;
    }
    let p_spec = specular_probability(m, n_dot_v);
    return p_spec * ggx_vndf_pdf(m, n, v, l) + (1.0 - p_spec) * n_dot_l * INV_PI;
}

struct BrdfSample {
    direction: vec3f,
    pdf: f32,
    // brdf · cos / pdf, or zero when the sample is invalid.
    weight: vec3f,
}

// Samples a direction proportional (roughly) to the BRDF. `u.x` picks the lobe, `u.yz` the direction.
fn brdf_sample(m: SurfaceMaterial, n: vec3f, v: vec3f, u: vec3f) -> BrdfSample {
    var s: BrdfSample;
    let n_dot_v = dot(n, v);
    s.pdf = 0.0;
    s.weight = vec3f(0.0);
    if n_dot_v <= 0.0 {
        return s;
    }
    let p_spec = specular_probability(m, n_dot_v);
    var l: vec3f;
    if u.x < p_spec {
        let alpha = ggx_alpha(m.roughness);
        let h = local_to_world(sample_ggx_vndf(world_to_local(v, n), alpha, u.yz), n);
        l = reflect(-v, h);
    } else {
        l = local_to_world(sample_cosine_hemisphere(u.yz), n);
    }
    s.direction = l;
    s.pdf = brdf_pdf(m, n, v, l);
    if s.pdf > 0.0 {
        s.weight = brdf_eval(m, n, v, l) * dot(n, l) / s.pdf;
    }
    return s;
}

// Approximate directional albedo of the BRDF's two lobes seen from n·v (Schlick Fresnel at n·v; GGX's
// multiple-scattering loss ignored): the BRDF factor that IGI demodulates by, and the lobe weights of
// its SH shading.
struct LobeWeights {
    diffuse: vec3f,
    specular: vec3f,
}

fn brdf_lobe_weights(m: SurfaceMaterial, n_dot_v: f32) -> LobeWeights {
    var w: LobeWeights;
    let f = schlick_weight(saturate(n_dot_v));
    let dielectric_spec = m.specular * (DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * f);
    w.diffuse = m.base_color * (1.0 - dielectric_spec) * (1.0 - m.metallic);
    w.specular = mix(vec3f(dielectric_spec), m.base_color + (1.0 - m.base_color) * f, m.metallic);
    return w;
}

// Exponent of the normalised Phong lobe about the mirror direction equivalent to GGX roughness
// (Walter et al. 2007's α_p = 2/α² − 2, the Beckmann/Phong correspondence, applied to GGX's α).
fn phong_exponent(roughness: f32) -> f32 {
    let a = ggx_alpha(roughness);
    return max(2.0 / (a * a) - 2.0, 0.0);
}

// A rough dielectric boundary between two media (Walter, Marschner, Li and Torrance 2007: GGX
// microfacets, reflection and refraction split by the exact Fresnel term, height-correlated Smith
// masking), for the path tracer's translucent materials. `n` faces `v`; `eta` is the index of the far
// side over the index of v's side (η entering a medium of index η, 1/η leaving it); l on v's side is a
// reflection, on the far side a refraction. The refraction keeps Walter's η² (radiance is η² denser in
// the denser medium); a path that enters a medium and leaves it again carries η² · η⁻² = 1.
// An index-matched boundary (eta = 1) is no boundary at all: callers pass straight through it.

// G2 / (4 |n·l| |n·v|) for either side.
fn smith_g2(alpha: f32, n_dot_l: f32, n_dot_v: f32) -> f32 {
    return 4.0 * n_dot_l * n_dot_v * smith_visibility(alpha, n_dot_l, n_dot_v);
}

// The half vector of v and l across (or on the same side of) the boundary, on n's side, or zero when
// the pair cannot be joined by a microfacet.
fn dielectric_half_vector(n: vec3f, v: vec3f, l: vec3f, eta: f32) -> vec3f {
    let reflect_side = dot(n, l) > 0.0;
    var h = select(v + eta * l, v + l, reflect_side);
    if dot(h, h) < 1e-12 {
        return vec3f(0.0);
    }
    h = normalize(h);
    if !reflect_side {
        // Refraction: v and l must lie on opposite sides of the microfacet.
        h = -h;
        if dot(h, n) < 0.0 {
            h = -h;
        }
        if dot(v, h) <= 0.0 || dot(l, h) >= 0.0 {
            return vec3f(0.0);
        }
    }
    return h;
}

// BSDF value (without the cosine) for v on n's side and l on either side.
fn dielectric_eval(roughness: f32, eta: f32, n: vec3f, v: vec3f, l: vec3f) -> f32 {
    let n_dot_v = dot(n, v);
    let n_dot_l = dot(n, l);
    let h = dielectric_half_vector(n, v, l, eta);
    if n_dot_v <= 0.0 || n_dot_l == 0.0 || dot(h, h) == 0.0 {
        return 0.0;
    }
    let alpha = ggx_alpha(roughness);
    let v_dot_h = dot(v, h);
    let f = fresnel_dielectric(eta, v_dot_h);
    let d = ggx_d(alpha, saturate(dot(n, h)));
    if n_dot_l > 0.0 {
        return f * d * smith_visibility(alpha, n_dot_l, n_dot_v);
    }
    let l_dot_h = dot(l, h);
    let denom = v_dot_h + eta * l_dot_h;
    let g2 = smith_g2(alpha, -n_dot_l, n_dot_v);
    return v_dot_h * abs(l_dot_h) / (n_dot_v * -n_dot_l) * (1.0 - f) * d * g2 * eta * eta / (denom * denom);
}

// Density of `dielectric_sample` choosing l (solid angle measure).
fn dielectric_pdf(roughness: f32, eta: f32, n: vec3f, v: vec3f, l: vec3f) -> f32 {
    let n_dot_v = dot(n, v);
    let h = dielectric_half_vector(n, v, l, eta);
    if n_dot_v <= 0.0 || dot(h, h) == 0.0 {
        return 0.0;
    }
    let alpha = ggx_alpha(roughness);
    let v_dot_h = dot(v, h);
    let f = fresnel_dielectric(eta, v_dot_h);
    // Visible normals: D_v(h) = G1(v) (v·h) D(h) / (n·v).
    let d_v = smith_g1(alpha, n_dot_v) * v_dot_h * ggx_d(alpha, saturate(dot(n, h))) / n_dot_v;
    if dot(n, l) > 0.0 {
        return f * d_v / (4.0 * v_dot_h);
    }
    let l_dot_h = dot(l, h);
    let denom = v_dot_h + eta * l_dot_h;
    return (1.0 - f) * d_v * eta * eta * abs(l_dot_h) / (denom * denom);
}

struct DielectricSample {
    direction: vec3f,
    pdf: f32,
    // bsdf · |cos| / pdf: G2 / G1(v) for either branch, zero when the sample is invalid.
    weight: f32,
    refracted: bool,
}

// Samples a visible microfacet normal, then reflects with the Fresnel probability or refracts.
fn dielectric_sample(roughness: f32, eta: f32, n: vec3f, v: vec3f, u: vec3f) -> DielectricSample {
    var s: DielectricSample;
    let n_dot_v = dot(n, v);
    if n_dot_v <= 0.0 {
        return s;
    }
    let alpha = ggx_alpha(roughness);
    let h = local_to_world(sample_ggx_vndf(world_to_local(v, n), alpha, u.yz), n);
    let v_dot_h = dot(v, h);
    let f = fresnel_dielectric(eta, v_dot_h);
    if u.x < f {
        s.direction = reflect(-v, h);
    } else {
        s.direction = refract(-v, h, 1.0 / eta);
        s.refracted = true;
    }
    let n_dot_l = dot(n, s.direction);
    if (n_dot_l > 0.0) == s.refracted || n_dot_l == 0.0 {
        return s;
    }
    s.pdf = dielectric_pdf(roughness, eta, n, v, s.direction);
    if s.pdf > 0.0 {
        s.weight = smith_g2(alpha, abs(n_dot_l), n_dot_v) / smith_g1(alpha, n_dot_v);
    }
    return s;
}
