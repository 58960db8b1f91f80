// Virtual point lights of instant radiosity (Keller 1997) and the light they deliver to a point.
// Layout mirrors `GpuVpl` in igi/mod.rs.

#import common/lights.wgsl
#import common/brdf.wgsl

const VPL_EMPTY: u32 = 0u;
// On a surface, re-emitting the flux that arrived from `incoming` through the surface's BRDF.
const VPL_SURFACE: u32 = 1u;
// On an emissive triangle: a one-sided Lambertian emitter of flux Φ (direct light from area lights).
const VPL_EMITTER: u32 = 2u;
// One of the scene's analytic point or spot lights (index `light`), its intensity scaled by flux.x.
const VPL_LIGHT: u32 = 3u;
// Light from infinitely far away along `normal` (directional lights, environment): irradiance `flux`.
const VPL_DIRECTIONAL: u32 = 4u;

struct Vpl {
    position: vec3f,
    kind: u32,
    // Shading normal (surface, emitter) or the unit direction towards the light (directional).
    normal: vec3f,
    light: u32,
    flux: vec3f,
    roughness: f32,
    // Unit direction towards where the light came from (surface VPLs).
    incoming: vec3f,
    metallic: f32,
    base_color: vec3f,
    specular: f32,
}

fn vpl_material(v: Vpl) -> SurfaceMaterial {
    var m: SurfaceMaterial;
    m.base_color = v.base_color;
    m.alpha = 1.0;
    m.metallic = v.metallic;
    m.roughness = v.roughness;
    m.specular = v.specular;
    m.emission = vec3f(0.0);
    return m;
}

struct VplIncidence {
    // Unit direction from the receiver towards the VPL, and the distance (FLT_MAX: infinitely far).
    direction: vec3f,
    distance: f32,
    // Radiance times solid angle arriving along `direction`: reflected radiance is
    // brdf · weight · cos θ at the receiver.
    weight: vec3f,
    // The VPL's share cos θ_vpl / d² of the geometry term (0 for lights, which are never clamped).
    geometry: f32,
}

fn vpl_incidence(v: Vpl, x: vec3f) -> VplIncidence {
    var r: VplIncidence;
    r.weight = vec3f(0.0);
    r.geometry = 0.0;
    switch v.kind {
        case VPL_SURFACE, VPL_EMITTER: {
            let d = v.position - x;
            let dist2 = max(dot(d, d), 1e-12);
            r.distance = sqrt(dist2);
            r.direction = d / r.distance;
            let cos_vpl = dot(v.normal, -r.direction);
            if cos_vpl <= 0.0 {
                return r;
            }
            r.geometry = cos_vpl / dist2;
            if v.kind == VPL_SURFACE {
                r.weight = v.flux * brdf_eval(vpl_material(v), v.normal, v.incoming, -r.direction) * r.geometry;
            } else {
                r.weight = v.flux * INV_PI * r.geometry;
            }
        }
        case VPL_LIGHT: {
            let inc = light_incidence(lights[v.light], x);
            r.direction = inc.direction;
            r.distance = inc.distance;
            r.weight = inc.irradiance * v.flux.x;
        }
        case VPL_DIRECTIONAL: {
            r.direction = v.normal;
            r.distance = FLT_MAX;
            r.weight = v.flux;
        }
        default: {}
    }
    return r;
}
