// The irradiance query of DDGI, for camera pixels and probe-ray hits alike. The including shader
// declares `probe_irradiance`, `probe_distance`, `probe_sampler` (the atlases it reads) and
// `probe_states` after volume.wgsl; the weighting switches and biases are constants from the host.

#import common/direct_light.wgsl

// Irradiance at a surface point p with shading normal n, seen from direction v (unit, towards the
// viewer), interpolated over the 8 probes of the cage around the biased point with the weights of the
// DDGI paper (each switchable): trilinear, soft backface, Chebyshev visibility from the distance
// moments, and the crush of small weights that hides low-level leaks.
fn probe_irradiance_at(p: vec3f, n: vec3f, v: vec3f) -> vec3f {
    let biased = p + n * NORMAL_BIAS + v * VIEW_BIAS;
    // Outside the volume the nearest cage's probes extrapolate.
    let first = probe_frame.scroll;
    let last = first + vec3i(PROBE_COUNTS) - 1;
    let cell = (biased - FIRST_PROBE) / PROBE_SPACING;
    let base = clamp(vec3i(floor(cell)), first, max(last - 1, first));
    let alpha = clamp(cell - vec3f(base), vec3f(0.0), vec3f(1.0));
    let irradiance_size = textureDimensions(probe_irradiance);
    let distance_size = textureDimensions(probe_distance);
    var sum = vec3f(0.0);
    var weight_sum = 0.0;
    for (var corner = 0u; corner < 8u; corner++) {
        let offset = vec3u(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        let c = min(base + vec3i(offset), last);
        let probe = cell_slot(c);
        let state = probe_states[probe];
        // Classification turned it off (it stands inside geometry or sees nothing near it), or it holds
        // no light yet.
        if (state.flags & (PROBE_ACTIVE | PROBE_VALID)) != (PROBE_ACTIVE | PROBE_VALID) {
            continue;
        }
        let position = cell_position(c) + state.offset;
        let tri = select(1.0 - alpha, alpha, offset == vec3u(1u));
        let trilinear = max(tri.x, 0.001) * max(tri.y, 0.001) * max(tri.z, 0.001);
        var w = 1.0;
        if BACKFACE_WEIGHT {
            // A wrapped cosine, not a cut: probes just behind the surface still count a little, so small
            // details inside a room are not left without probes.
            let to_probe = normalize(position - p);
            w *= sqr((dot(to_probe, n) + 1.0) * 0.5) + 0.2;
        }
        if CHEBYSHEV {
            let from_probe = biased - position;
            let d = length(from_probe);
            let dir = select(vec3f(0.0, 0.0, 1.0), from_probe / d, d > 0.0);
            let moments = textureSampleLevel(
                probe_distance, probe_sampler, probe_atlas_uv(probe, dir, DISTANCE_TEXELS, distance_size), 0.0
            ).xy;
            if d > moments.x {
                let variance = abs(moments.x * moments.x - moments.y);
                let cheb = variance / (variance + sqr(d - moments.x));
                // Cubed for contrast, and never zero so a point no probe sees still gets light.
                w *= max(cheb * cheb * cheb, 0.05);
            }
        }
        w = max(w, 1e-6);
        if LOW_WEIGHT_CRUSH {
            let threshold = 0.2;
            if w < threshold {
                w *= w * w / (threshold * threshold);
            }
        }
        w *= trilinear;
        let e = textureSampleLevel(
            probe_irradiance, probe_sampler, probe_atlas_uv(probe, n, IRRADIANCE_TEXELS, irradiance_size), 0.0
        ).rgb;
        sum += w * e;
        weight_sum += w;
    }
    return select(vec3f(0.0), sum / weight_sum, weight_sum > 0.0);
}

// Light arriving along `dir` from what a ray of a probe or a pixel met (`hit`): at a surface, the light it
// sends back (direct light through shadow rays, the previous probes' diffuse light, and its emission with
// EMITTERS_IN_PROBES); on a miss, the environment with EMITTERS_IN_PROBES, else nothing (pixels and
// probe hits sample emitters and the environment themselves then).
fn ray_radiance(hit: Hit, dir: vec3f, rng: ptr<function, Rng>) -> vec3f {
    if hit.t == FLT_MAX {
        return select(vec3f(0.0), environment_radiance(dir), EMITTERS_IN_PROBES);
    }
    let s = hit_gsurface(surface_at(hit.triangle, hit.u, hit.v, dir), -dir, hit.t);
    var radiance = direct_light(
        s, offset_origin(s.position, s.geometric_normal), rng, SURFEL_AREA_SAMPLES, SURFEL_ENV_SAMPLES, true
    );
    if EMITTERS_IN_PROBES {
        radiance += s.material.emission;
    }
    return radiance + probe_diffuse_light(s);
}

// Light the probes carry reflected by a surface's diffuse lobe towards v.
fn probe_diffuse_light(s: GSurface) -> vec3f {
    let diffuse = brdf_lobe_weights(s.material, dot(s.normal, s.view)).diffuse;
    return diffuse * INV_PI * probe_irradiance_at(s.position, s.normal, s.view);
}
