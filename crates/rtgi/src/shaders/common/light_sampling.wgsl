// Sampling of emissive triangles (area lights) and its density, shared by `direct` and the path tracer.
// Triangles are chosen in proportion to their power (the CDF in `emissive_triangles`), points uniformly
// on the chosen triangle; emission is two-sided.

#import common/scene.wgsl
#import common/sampling.wgsl

struct AreaLightSample {
    // Unit direction from the origin to the sampled point.
    direction: vec3f,
    distance: f32,
    // Emitted radiance towards the origin.
    radiance: vec3f,
    // Solid-angle density at the origin; 0 for an unusable sample.
    pdf: f32,
}

// A point on the emissive triangles, chosen by power (u.x) and uniformly on its triangle (u.yz).
struct EmitterPoint {
    position: vec3f,
    // Unit geometric normal of the triangle (either side emits).
    normal: vec3f,
    emission: vec3f,
    // Area density of the choice over all emissive surface.
    area_pdf: f32,
}

// Requires scene_info.emissive_count > 0.
fn sample_emitter_point(u: vec3f) -> EmitterPoint {
    var lo = 0u;
    var hi = scene_info.emissive_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if emissive_triangles[mid].cdf < u.x {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let t = triangle_vertices(emissive_triangles[lo].triangle);
    let b = sample_triangle(u.yz);
    let w = 1.0 - b.x - b.y;
    var r: EmitterPoint;
    r.position = t[0].position * w + t[1].position * b.x + t[2].position * b.y;
    r.normal = normalize(cross(t[1].position - t[0].position, t[2].position - t[0].position));
    let material_index = vertex_material(t[0]);
    let uv = t[0].uv * w + t[1].uv * b.x + t[2].uv * b.y;
    r.emission = material_at(materials[material_index], uv, 0.0).emission;
    r.area_pdf = emission_pdf[material_index];
    return r;
}

fn sample_area_light(origin: vec3f, u: vec3f) -> AreaLightSample {
    var r: AreaLightSample;
    r.pdf = 0.0;
    if scene_info.emissive_count == 0u {
        return r;
    }
    let e = sample_emitter_point(u);
    let ln = e.normal;
    let d = e.position - origin;
    let dist2 = dot(d, d);
    r.distance = sqrt(dist2);
    r.direction = d / r.distance;
    let cos_light = abs(dot(ln, r.direction));
    if cos_light <= 1e-7 {
        return r;
    }
    r.radiance = e.emission;
    r.pdf = e.area_pdf * dist2 / cos_light;
    return r;
}

// Solid-angle density with which `sample_area_light` from `origin` would pick the point `p` with
// geometric normal `ng` on a triangle of material `material_index` (for MIS of BRDF-sampled hits).
fn area_light_pdf(origin: vec3f, p: vec3f, ng: vec3f, material_index: u32) -> f32 {
    let d = p - origin;
    let dist2 = dot(d, d);
    let cos_light = abs(dot(ng, d)) / sqrt(dist2);
    if cos_light <= 1e-7 {
        return 0.0;
    }
    return emission_pdf[material_index] * dist2 / cos_light;
}
