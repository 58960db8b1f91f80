// Jensen et al. 2001's single-scattering term (SINGLE_SCATTERING > 0), a pass of its own before
// shading (so that its cost shows in the per-pass timings): every translucent pixel's estimate of this
// frame goes to `single_light`, which shade.wgsl adds.

#import common/direct_light.wgsl

// The fluence at x, inside the medium of `material` (index eta, extinction sigma_t), of a light seen
// along l at `distance` with irradiance `irradiance` across l: its path approximated as Jensen et al.
// 2001 do, by the straight line from x towards the light up to where it leaves the medium (x_i), its
// length inside corrected for refraction (s' = s_i cos θ_i / cos θ_t), and the refracted beam's
// fluence T₁₂(θ_i) E⊥ cos θ_i / cos θ_t · e^{−σ_t s'}, zero where anything but the medium's own
// boundary is in the way or the light is shadowed from x_i.
fn refracted_fluence(x: vec3f, l: vec3f, distance: f32, irradiance: vec3f, material: u32, eta: f32, sigma_t: vec3f) -> vec3f {
    if max3(irradiance) <= 0.0 {
        return vec3f(0.0);
    }
    let hit = trace_closest(Ray(x, l), 0.0, distance);
    if hit.t == FLT_MAX || !hits_back_face(hit.triangle, hit.u, hit.v, l) {
        return vec3f(0.0);
    }
    let boundary = surface_at(hit.triangle, hit.u, hit.v, l);
    // surface_at turns the normals towards x: the boundary's outward normal is their opposite.
    let cos_i = -dot(boundary.normal, l);
    if boundary.material_index != material || cos_i <= 0.0 {
        return vec3f(0.0);
    }
    let remaining = select(distance - hit.t, FLT_MAX, distance == FLT_MAX);
    if trace_any(Ray(offset_origin(boundary.position, -boundary.geometric_normal), l), 0.0, remaining) {
        return vec3f(0.0);
    }
    let cos_t = sqrt(1.0 - (1.0 - cos_i * cos_i) / (eta * eta));
    let inside = hit.t * cos_i / cos_t;
    return (1.0 - fresnel_dielectric(eta, cos_i)) * irradiance * (cos_i / cos_t) * exp(-sigma_t * inside);
}

// One sample of the environment from inside a medium, over the whole sphere (light may enter from
// any side): importance-sampled for maps, uniform otherwise.
fn environment_incident_sphere(u: vec2f) -> IncidentSample {
    if environment_is_tabulated() {
        return environment_incident(vec3f(0.0, 1.0, 0.0), u);
    }
    let d = sample_uniform_sphere(u);
    return IncidentSample(d, FLT_MAX, environment_radiance(d) * 4.0 * PI);
}

// Jensen et al. 2001's single-scattering term by Monte Carlo: light scattered once inside the medium
// towards the viewer, at points along the refracted view ray at distances sampled ∝ e^{−σ_t s} of one
// channel picked uniformly (one-sample MIS over the channels, as the path tracer's walk), each lit by
// `refracted_fluence` of every light, isotropically scattered with the reduced coefficients (the
// walk's medium) and leaving through the boundary with T₂₁(θ_o)/η² (radiance leaving a denser
// medium). On a half-space this converges to `scene::subsurface::Subsurface::single_scattering`.
fn single_scattering(s: GSurface, pixel: vec2u) -> vec3f {
    let m = materials[s.material_index];
    let cos_o = dot(s.normal, s.view);
    if cos_o <= 0.0 {
        return vec3f(0.0);
    }
    let eta = m.medium_eta;
    let sigma_s = m.medium_scattering;
    let sigma_t = m.medium_absorption + sigma_s;
    let into = refract(-s.view, s.normal, 1.0 / eta);
    // Beyond where the refracted view ray leaves the medium again there is nothing to scatter. The
    // scattering points themselves start at the surface, not at the ray's offset origin: light
    // crossing an extra offset of medium would be dimmed by e^{−σ_t offset}, about 1 % here.
    let far = trace_closest(Ray(offset_origin(s.position, -s.geometric_normal), into), 0.0, FLT_MAX).t;
    var rng = rng_new(pixel, frame.frame_counter, hash2(frame.seed, 0x73737331u));
    var sum = vec3f(0.0);
    for (var k = 0u; k < SINGLE_SCATTERING; k++) {
        let channel = min(u32(rng_next(&rng) * 3.0), 2u);
        let depth = -log(1.0 - rng_next(&rng)) / sigma_t[channel];
        if depth >= far {
            continue;
        }
        let x = s.position + into * depth;
        var fluence = vec3f(0.0);
        for (var l = 0u; l < scene_info.light_count; l++) {
            let inc = light_incidence(lights[l], x);
            fluence += refracted_fluence(x, inc.direction, inc.distance * (1.0 - 1e-4), inc.irradiance, s.material_index, eta, sigma_t);
        }
        if scene_info.emissive_count > 0u && AREA_SAMPLES > 0u {
            for (var a = 0u; a < AREA_SAMPLES; a++) {
                let i = emissive_incident(x, vec3f(rng_next(&rng), rng_next2(&rng)));
                fluence += refracted_fluence(x, i.direction, i.distance, i.weight, s.material_index, eta, sigma_t) / f32(AREA_SAMPLES);
            }
        }
        if scene_info.env_kind != ENV_NONE && ENV_SAMPLES > 0u {
            for (var e = 0u; e < ENV_SAMPLES; e++) {
                let i = environment_incident_sphere(rng_next2(&rng));
                fluence += refracted_fluence(x, i.direction, i.distance, i.weight, s.material_index, eta, sigma_t) / f32(ENV_SAMPLES);
            }
        }
        let falloff = exp(-sigma_t * depth);
        sum += sigma_s * falloff / dot(sigma_t * falloff, vec3f(1.0 / 3.0)) * fluence;
    }
    let exit = (1.0 - fresnel_dielectric(eta, cos_o)) / (eta * eta);
    return exit / (4.0 * PI) * sum / f32(max(SINGLE_SCATTERING, 1u));
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    let s = load_gsurface(id.xy);
    var light = vec3f(0.0);
    if s.valid && is_translucent(s.material_index) {
        light = single_scattering(s, id.xy);
    }
    single_light[id.y * frame.size.x + id.x] = vec4f(light, 0.0);
}
