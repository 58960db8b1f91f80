// VPL generation (instant radiosity, Keller 1997), one thread per light path: each of the `sets`
// interleaving sets traces `paths` light paths from the lights, chosen in proportion to their power,
// with its own Cranley-Patterson rotation of a Halton sequence, so sets are uncorrelated and every set
// alone is an unbiased estimate of the light. Path i stores a VPL at vertex j while i < N_j (the
// quasi-random Russian roulette of instant radiosity: N_j = round(N_0 ρ̄^j)), the VPL's flux scaled by
// N_0 / N_j; the slot of vertex j of path i in its set is offset_j + i, so every
// slot is written by exactly one thread.

#import common/frame.wgsl
#import common/environment.wgsl
#import common/random.wgsl
#import common/sampling.wgsl
#import common/light_sampling.wgsl

@group(2) @binding(0) var<storage, read_write> vpls: array<Vpl>;
// [0, D]: N_j, the paths alive at vertex j; [D + 1, 2D + 1]: offset_j of vertex j's slots in a set
// (NO_SLOT where that vertex is not stored).
@group(2) @binding(1) var<storage, read> vpl_layout: array<u32>;
@group(2) @binding(2) var<storage, read> light_entries: array<LightEntry>;
@group(2) @binding(3) var<uniform> gen: VplGeneration;

const NO_SLOT: u32 = 0xffffffffu;
const ENTRY_LIGHT: u32 = 0u;
const ENTRY_EMISSIVE: u32 = 1u;
const ENTRY_ENVIRONMENT: u32 = 2u;

// A light source to start paths from; `cdf` runs over entries in proportion to power.
struct LightEntry {
    cdf: f32,
    probability: f32,
    kind: u32,
    index: u32,
}

struct VplGeneration {
    sets: u32,
    paths: u32,
    slots_per_set: u32,
    max_depth: u32,
    entry_count: u32,
    // Analytic lights with a VPL of their own in the first slots of every set (0 when direct light is
    // not carried by VPLs).
    fixed_lights: u32,
    _pad1: u32,
    _pad2: u32,
    // Bounding sphere of the scene (centre, radius): directional sources emit from a disc covering it.
    sphere: vec4f,
}

fn alive(j: u32) -> u32 {
    return vpl_layout[j];
}

fn slot_of(set_index: u32, j: u32, i: u32) -> u32 {
    let offset = vpl_layout[gen.max_depth + 1u + j];
    if offset == NO_SLOT {
        return NO_SLOT;
    }
    return set_index * gen.slots_per_set + offset + i;
}

fn store(slot: u32, v: Vpl) {
    if slot != NO_SLOT {
        vpls[slot] = v;
    }
}

// Marks the slots of vertices j0.. of path i empty (the path was absorbed or left the scene).
fn end_path(set_index: u32, j0: u32, i: u32) {
    var empty: Vpl;
    empty.kind = VPL_EMPTY;
    for (var j = j0; j <= gen.max_depth; j++) {
        if i < alive(j) {
            store(slot_of(set_index, j, i), empty);
        }
    }
}

fn qmc(set_index: u32, i: u32, dim: u32) -> f32 {
    let offset = u32_to_unit(hash3(set_index, frame.frame_counter * 0x9e3779b9u ^ frame.seed, dim));
    return halton(i, dim, offset);
}

fn find_entry(u: f32) -> u32 {
    var lo = 0u;
    var hi = gen.entry_count - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if light_entries[mid].cdf < u {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// A point on the disc of the scene's bounding-sphere radius, perpendicular to `d`, behind the scene.
fn disc_origin(d: vec3f, u: vec2f) -> vec3f {
    let r = gen.sphere.w * sqrt(u.x);
    let phi = TWO_PI * u.y;
    return gen.sphere.xyz - d * (2.0 * gen.sphere.w)
        + (basis_tangent(d) * cos(phi) + basis_bitangent(d) * sin(phi)) * r;
}

fn surface_vpl(s: SurfaceHit, incoming: vec3f, flux: vec3f) -> Vpl {
    var v: Vpl;
    v.kind = VPL_SURFACE;
    v.position = offset_origin(s.position, s.geometric_normal);
    v.normal = s.normal;
    v.flux = flux;
    v.incoming = incoming;
    v.base_color = s.material.base_color;
    v.metallic = s.material.metallic;
    v.roughness = s.material.roughness;
    v.specular = s.material.specular;
    return v;
}

// The exact VPL of analytic light k: the light itself.
fn light_vpl(k: u32) -> Vpl {
    let light = lights[k];
    var v: Vpl;
    if light.kind == LIGHT_DIRECTIONAL {
        v.kind = VPL_DIRECTIONAL;
        v.normal = -light.direction;
        v.flux = light.intensity;
    } else {
        v.kind = VPL_LIGHT;
        v.light = k;
        v.flux = vec3f(1.0, 0.0, 0.0);
    }
    return v;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let per_set = max(gen.paths, gen.fixed_lights);
    if id.x >= gen.sets * per_set {
        return;
    }
    let set_index = id.x / per_set;
    let i = id.x % per_set;
    if i < gen.fixed_lights {
        vpls[set_index * gen.slots_per_set + i] = light_vpl(i);
    }
    if i >= gen.paths {
        return;
    }
    let entry = light_entries[find_entry(qmc(set_index, i, 0u))];
    let scale = 1.0 / (entry.probability * f32(gen.paths));
    let u1 = vec2f(qmc(set_index, i, 1u), qmc(set_index, i, 2u));
    let u2 = vec2f(qmc(set_index, i, 3u), qmc(set_index, i, 4u));
    let u3 = vec2f(qmc(set_index, i, 5u), qmc(set_index, i, 6u));

    var first: Vpl;
    var origin: vec3f;
    var dir: vec3f;
    var flux = vec3f(0.0);
    switch entry.kind {
        case ENTRY_LIGHT: {
            let light = lights[entry.index];
            // Vertex 0 stays empty: the light has its own exact VPL among the fixed slots.
            first.kind = VPL_EMPTY;
            if light.kind == LIGHT_DIRECTIONAL {
                origin = disc_origin(light.direction, u1);
                dir = light.direction;
                flux = light.intensity * (PI * gen.sphere.w * gen.sphere.w) * scale;
            } else {
                origin = light.position;
                if light.kind == LIGHT_SPOT {
                    dir = local_to_world(sample_cone(u1, light.cos_outer), light.direction);
                    let pdf = 1.0 / (TWO_PI * (1.0 - light.cos_outer));
                    flux = light.intensity * spot_attenuation(light, dir) / pdf * scale;
                } else {
                    dir = sample_uniform_sphere(u1);
                    flux = light.intensity * (4.0 * PI) * scale;
                }
            }
        }
        case ENTRY_EMISSIVE: {
            let e = sample_emitter_point(vec3f(u1, u2.x));
            let ng = select(-1.0, 1.0, u2.y < 0.5) * e.normal;
            // Two-sided emitter: one side per path, chosen with probability 1/2.
            let area_pdf = e.area_pdf * 0.5;
            if area_pdf > 0.0 {
                flux = e.emission * PI / area_pdf * scale;
            }
            first.kind = VPL_EMITTER;
            first.position = offset_origin(e.position, ng);
            first.normal = ng;
            first.flux = flux;
            origin = first.position;
            dir = local_to_world(sample_cosine_hemisphere(u3), ng);
        }
        default: {
            var to_light: vec3f;
            var pdf = 1.0 / (4.0 * PI);
            var radiance: vec3f;
            if environment_is_tabulated() {
                let es = sample_environment_map(u1);
                to_light = es.direction;
                pdf = es.pdf;
                radiance = es.radiance;
            } else {
                to_light = sample_uniform_sphere(u1);
                radiance = environment_radiance(to_light);
            }
            if pdf > 0.0 {
                first.flux = radiance / pdf * scale;
            }
            first.kind = VPL_DIRECTIONAL;
            first.normal = to_light;
            origin = disc_origin(-to_light, u2);
            dir = -to_light;
            flux = first.flux * (PI * gen.sphere.w * gen.sphere.w);
        }
    }
    if max3(flux) <= 0.0 && (first.kind == VPL_EMPTY || max3(first.flux) <= 0.0) {
        end_path(set_index, 0u, i);
        return;
    }
    store(slot_of(set_index, 0u, i), first);

    for (var j = 1u; j <= gen.max_depth; j++) {
        if i >= alive(j) {
            return;
        }
        let hit = trace_closest(Ray(origin, dir), 0.0, FLT_MAX);
        if !hit_found(hit) || max3(flux) <= 0.0 {
            end_path(set_index, j, i);
            return;
        }
        let s = surface_at(hit.triangle, hit.u, hit.v, dir);
        // Only the first N_j paths store vertex j: each stands for 1/N_j of the light, not 1/N_0.
        let roulette = f32(alive(0u)) / f32(alive(j));
        store(slot_of(set_index, j, i), surface_vpl(s, -dir, flux * roulette));
        if j == gen.max_depth || i >= alive(j + 1u) {
            return;
        }
        let d0 = 7u + 3u * (j - 1u);
        let bs = brdf_sample(s.material, s.normal, -dir, vec3f(qmc(set_index, i, d0), qmc(set_index, i, d0 + 1u), qmc(set_index, i, d0 + 2u)));
        if bs.pdf <= 0.0 || dot(s.geometric_normal, bs.direction) <= 0.0 {
            end_path(set_index, j + 1u, i);
            return;
        }
        flux *= bs.weight;
        origin = offset_origin(s.position, s.geometric_normal);
        dir = bs.direction;
    }
}
