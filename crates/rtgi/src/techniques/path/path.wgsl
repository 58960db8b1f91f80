// The reference: a unidirectional path tracer over the shared BVH, BRDF, light and environment code.
//
// At every vertex: emission (MIS-weighted against area-light sampling), next-event estimation of every
// analytic light (shadow rays), one area-light sample and one environment sample (MIS against BRDF
// sampling), then a BRDF-sampled continuation with Russian roulette (see below).
// MAX_BOUNCES < 0 means unlimited; k counts indirect bounces (0 = direct light only).
// NEE_MODE 0 = MIS, 1 = light sampling only, 2 = BRDF sampling only (delta lights always use NEE).
//
// Translucent materials (a medium under the surface, SUBSURFACE_WALK) are a rough dielectric boundary
// (brdf.wgsl `dielectric_*`, the material's roughness and the medium's η) over a homogeneous medium
// that the path crosses by a random walk: free flights with the extinction σ_a + σ_s' of a colour
// channel chosen in proportion to the path's throughput (one-sample MIS over the channels), isotropic
// scattering with the reduced coefficients (similarity theory: the diffusion the dipole models, in far
// fewer steps than the measured media's forward-peaked phase functions need). Lights are estimated
// where the walk meets the boundary (refraction towards the light: the exit vertices); the walk's
// inner scattering points cannot see a light through a refracting boundary. The walk is not a bounce:
// max_bounces counts vertices the path leaves on the outside, so max_bounces=0 is direct light with
// subsurface transport, what the `subsurface` technique computes.

#import common/frame.wgsl
#import common/environment.wgsl
#import common/light_sampling.wgsl
#import common/random.wgsl

@group(2) @binding(0) var output: texture_storage_2d<rgba32float, read_write>;
// Rays traced this frame (closest-hit and shadow), for the throughput statistics.
// Rays traced since the technique was created, as a 64-bit count (low word, carries into the high
// word): read once for the stats, never per frame, so frames need no readback.
// Slot 2 counts random walks cut short after MAX_WALK_STEPS scattering events (their light is lost).
@group(2) @binding(1) var<storage, read_write> ray_count: array<atomic<u32>, 3>;
// Index of this dispatch's sample within the frame (one dispatch per sample, see `main`).
@group(2) @binding(2) var<uniform> sample_index: u32;

const ROULETTE_DEPTH: u32 = 3u;
const ROULETTE_THRESHOLD: f32 = 0.1;

fn visible(origin: vec3f, dir: vec3f, dist: f32, rays: ptr<function, u32>) -> bool {
    *rays += 1u;
    return !trace_any(Ray(origin, dir), 0.0, dist);
}

fn mis_weight(pdf_this: f32, pdf_other: f32) -> f32 {
    if NEE_MODE == 0u {
        return mis_power(pdf_this, pdf_other);
    }
    return 1.0;
}

struct WalkEnd {
    hit: Hit,
    // False when the walk was absorbed (Russian roulette) or cut short; hit is then meaningless.
    reached_boundary: bool,
}

// Carries the path through the medium of material `m` from `ray` (inside) to the boundary: updates
// `ray` to the last flight and `throughput` by every flight's transmittance and scattering albedo over
// the channel-mixture density.
fn medium_walk(ray: ptr<function, Ray>, throughput: ptr<function, vec3f>, m: Material, rng: ptr<function, Rng>, rays: ptr<function, u32>) -> WalkEnd {
    var end: WalkEnd;
    let sigma_t = m.medium_absorption + m.medium_scattering;
    for (var step = 0u; step < MAX_WALK_STEPS; step++) {
        let weights = *throughput;
        let total = weights.x + weights.y + weights.z;
        if !(total > 0.0) {
            return end;
        }
        let p = weights / total;
        let pick = rng_next(rng);
        let sigma = select(select(sigma_t.z, sigma_t.y, pick < p.x + p.y), sigma_t.x, pick < p.x);
        let t = -log(1.0 - rng_next(rng)) / sigma;
        *rays += 1u;
        let hit = trace_closest(*ray, 0.0, t);
        if hit.t < t {
            let tr = exp(-sigma_t * hit.t);
            let pdf = dot(p, tr);
            if !(pdf > 0.0) {
                return end;
            }
            *throughput *= tr / pdf;
            end.hit = hit;
            end.reached_boundary = true;
            return end;
        }
        let tr = exp(-sigma_t * t);
        let pdf = dot(p, sigma_t * tr);
        if !(pdf > 0.0) {
            return end;
        }
        *throughput *= m.medium_scattering * tr / pdf;
        let q = max3(*throughput);
        if q < ROULETTE_THRESHOLD {
            if rng_next(rng) >= q / ROULETTE_THRESHOLD {
                return end;
            }
            *throughput *= ROULETTE_THRESHOLD / q;
        }
        *ray = Ray((*ray).origin + (*ray).dir * t, sample_uniform_sphere(rng_next2(rng)));
    }
    atomicAdd(&ray_count[2], 1u);
    return end;
}

fn trace_path(pixel: vec2u, rng: ptr<function, Rng>, rays: ptr<function, u32>) -> vec3f {
    var dir = primary_ray_direction(pixel);
    if PIXEL_JITTER {
        dir = primary_ray_through(vec2f(pixel) + rng_next2(rng));
    }
    var ray = Ray(frame.camera_position, dir);
    var throughput = vec3f(1.0);
    var radiance = vec3f(0.0);
    var prev_position = ray.origin;
    var prev_brdf_pdf = 0.0;
    var prev_env_pdf = 0.0;
    // Whether the last direction was one no light sample could have chosen (the camera's, a walk's
    // flight, a crossing of an index-matched boundary): lights it meets count in full.
    var prev_unsampled = true;
    // Bounces that left a surface on the outside (the walk inside a medium is not one).
    var bounces = 0u;
    var in_medium = false;
    var medium_material = 0u;
    for (var depth = 0u; ; depth++) {
        var hit: Hit;
        if SUBSURFACE_WALK && in_medium {
            let walk = medium_walk(&ray, &throughput, materials[medium_material], rng, rays);
            if !walk.reached_boundary {
                break;
            }
            hit = walk.hit;
        } else {
            *rays += 1u;
            hit = trace_closest(ray, 0.0, FLT_MAX);
        }
        if hit.t == FLT_MAX {
            let le = environment_radiance(ray.dir);
            if prev_unsampled {
                radiance += throughput * le;
            } else if NEE_MODE != 1u {
                radiance += throughput * le * mis_weight(prev_brdf_pdf, prev_env_pdf);
            }
            break;
        }
        let s = surface_at(hit.triangle, hit.u, hit.v, ray.dir);
        if max3(s.material.emission) > 0.0 {
            if prev_unsampled || in_medium {
                radiance += throughput * s.material.emission;
            } else if NEE_MODE != 1u {
                let light_pdf = area_light_pdf(prev_position, s.position, s.geometric_normal, s.material_index);
                radiance += throughput * s.material.emission * mis_weight(prev_brdf_pdf, light_pdf);
            }
        }
        if MAX_BOUNCES >= 0 && i32(bounces) > MAX_BOUNCES {
            break;
        }
        let v = -ray.dir;
        let n = s.normal;
        let ng = s.geometric_normal;
        // A medium's boundary: the walk's own (whatever material a coplanar surface there has) or a
        // translucent surface met from outside.
        let boundary_material = select(s.material_index, medium_material, in_medium);
        let eta_medium = select(0.0, materials[boundary_material].medium_eta, SUBSURFACE_WALK);
        let dielectric = eta_medium > 0.0;
        // Every light is outside: on v's side of an outer vertex, beyond the boundary of an exit vertex.
        let outside = select(1.0, -1.0, in_medium);
        let n_out = n * outside;
        let ng_out = ng * outside;
        let eta = select(eta_medium, 1.0 / eta_medium, in_medium);
        let index_matched = dielectric && eta == 1.0;
        let origin = offset_origin(s.position, ng_out);

        // Next-event estimation (none through an index-matched boundary: it is a delta).
        if !index_matched {
            for (var i = 0u; i < scene_info.light_count; i++) {
                let inc = light_incidence(lights[i], s.position);
                let cos_theta = dot(n_out, inc.direction);
                if cos_theta > 0.0 && dot(ng_out, inc.direction) > 0.0 && max3(inc.irradiance) > 0.0 {
                    let f = bsdf_eval(s.material, dielectric, eta, n, v, inc.direction);
                    if max3(f) > 0.0 && visible(origin, inc.direction, inc.distance * (1.0 - 1e-4), rays) {
                        radiance += throughput * f * inc.irradiance * cos_theta;
                    }
                }
            }
            if NEE_MODE != 2u && scene_info.emissive_count > 0u {
                let ls = sample_area_light(origin, vec3f(rng_next(rng), rng_next2(rng)));
                let cos_theta = dot(n_out, ls.direction);
                if ls.pdf > 0.0 && cos_theta > 0.0 && dot(ng_out, ls.direction) > 0.0 {
                    let f = bsdf_eval(s.material, dielectric, eta, n, v, ls.direction);
                    if max3(f) > 0.0 && visible(origin, ls.direction, ls.distance * (1.0 - 1e-4), rays) {
                        let w = mis_weight(ls.pdf, bsdf_pdf(s.material, dielectric, eta, n, v, ls.direction));
                        radiance += throughput * f * ls.radiance * cos_theta * w / ls.pdf;
                    }
                }
            }
            if NEE_MODE != 2u && scene_info.env_kind != ENV_NONE {
                let es = sample_environment_light(n_out, rng_next2(rng));
                let cos_theta = dot(n_out, es.direction);
                if es.pdf > 0.0 && cos_theta > 0.0 && dot(ng_out, es.direction) > 0.0 {
                    let f = bsdf_eval(s.material, dielectric, eta, n, v, es.direction);
                    if max3(f) > 0.0 && visible(origin, es.direction, FLT_MAX, rays) {
                        let w = mis_weight(es.pdf, bsdf_pdf(s.material, dielectric, eta, n, v, es.direction));
                        radiance += throughput * f * es.radiance * cos_theta * w / es.pdf;
                    }
                }
            }
        }

        // Russian roulette, unbiased since survivors are reweighted by 1/p. It only starts once the
        // path's throughput has fallen below ROULETTE_THRESHOLD and lifts survivors back to that
        // threshold (not to 1), so in bright closed scenes (the furnace) long paths do not turn into a
        // few heavy samples: this keeps every furnace pixel within 5 % at 1024 spp.
        if depth + 1u >= ROULETTE_DEPTH {
            let t = max3(throughput);
            if t < ROULETTE_THRESHOLD {
                let p = t / ROULETTE_THRESHOLD;
                if rng_next(rng) >= p {
                    break;
                }
                throughput /= p;
            }
        }
        var next_dir: vec3f;
        var pdf = 0.0;
        var crossed = false;
        if index_matched {
            next_dir = ray.dir;
            crossed = true;
        } else if dielectric {
            let ds = dielectric_sample(s.material.roughness, eta, n, v, vec3f(rng_next(rng), rng_next2(rng)));
            // The microfacet sample must agree with the geometry about which side it leaves on.
            if ds.pdf <= 0.0 || ds.weight <= 0.0 || (dot(ng, ds.direction) < 0.0) != ds.refracted {
                break;
            }
            throughput *= ds.weight;
            next_dir = ds.direction;
            pdf = ds.pdf;
            crossed = ds.refracted;
        } else {
            let bs = brdf_sample(s.material, n, v, vec3f(rng_next(rng), rng_next2(rng)));
            if bs.pdf <= 0.0 || dot(ng, bs.direction) <= 0.0 || max3(bs.weight) <= 0.0 {
                break;
            }
            throughput *= bs.weight;
            next_dir = bs.direction;
            pdf = bs.pdf;
        }
        if crossed {
            in_medium = !in_medium;
            medium_material = s.material_index;
        }
        if !in_medium {
            bounces += 1u;
        }
        prev_unsampled = index_matched;
        prev_position = s.position;
        prev_brdf_pdf = pdf;
        prev_env_pdf = environment_light_pdf(n_out, next_dir);
        ray = Ray(offset_origin(s.position, select(-ng, ng, dot(ng, next_dir) > 0.0)), next_dir);
    }
    return radiance;
}

// The surface's scattering towards l (without the cosine): a translucent boundary's dielectric BSDF
// or the opaque BRDF.
fn bsdf_eval(m: SurfaceMaterial, dielectric: bool, eta: f32, n: vec3f, v: vec3f, l: vec3f) -> vec3f {
    if dielectric {
        return vec3f(dielectric_eval(m.roughness, eta, n, v, l));
    }
    return brdf_eval(m, n, v, l);
}

fn bsdf_pdf(m: SurfaceMaterial, dielectric: bool, eta: f32, n: vec3f, v: vec3f, l: vec3f) -> f32 {
    if dielectric {
        return dielectric_pdf(m.roughness, eta, n, v, l);
    }
    return brdf_pdf(m, n, v, l);
}

// One path per pixel and dispatch; the host dispatches SPP times per frame. Looping over samples inside
// the shader is what one would write, but Mesa 22.3's lavapipe (LLVM 15) miscompiles a long sample loop
// around the path loop: at 64 samples per invocation the furnace test lost 16 % of its energy.
@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    var rays = 0u;
    var rng = rng_new(id.xy, frame.frame_counter * SPP + sample_index, frame.seed);
    let radiance = trace_path(id.xy, &rng, &rays);
    let mean = accumulate_mean(textureLoad(output, id.xy).rgb, radiance, frame.sample_index * SPP + sample_index);
    textureStore(output, id.xy, vec4f(mean, 1.0));
    let before = atomicAdd(&ray_count[0], rays);
    if before + rays < before {
        atomicAdd(&ray_count[1], 1u);
    }
}
