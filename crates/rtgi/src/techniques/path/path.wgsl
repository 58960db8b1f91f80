// The reference: a unidirectional path tracer over the shared BVH, BRDF, light and environment code.
//
// At every vertex: emission (MIS-weighted against area-light sampling), next-event estimation of every
// analytic light (shadow rays), one area-light sample and one environment sample (MIS against BRDF
// sampling), then a BRDF-sampled continuation with Russian roulette (see below).
// MAX_BOUNCES < 0 means unlimited; k counts indirect bounces (0 = direct light only).
// NEE_MODE 0 = MIS, 1 = light sampling only, 2 = BRDF sampling only (delta lights always use NEE).

#import common/frame.wgsl
#import common/environment.wgsl
#import common/light_sampling.wgsl
#import common/random.wgsl

@group(2) @binding(0) var output: texture_storage_2d<rgba32float, read_write>;
// Rays traced this frame (closest-hit and shadow), for the throughput statistics.
// Rays traced since the technique was created, as a 64-bit count (low word, carries into the high
// word): read once for the stats, never per frame, so frames need no readback.
@group(2) @binding(1) var<storage, read_write> ray_count: array<atomic<u32>, 2>;
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
    for (var depth = 0u; ; depth++) {
        *rays += 1u;
        let hit = trace_closest(ray, 0.0, FLT_MAX);
        if hit.t == FLT_MAX {
            let le = environment_radiance(ray.dir);
            if depth == 0u {
                radiance += throughput * le;
            } else if NEE_MODE != 1u {
                radiance += throughput * le * mis_weight(prev_brdf_pdf, prev_env_pdf);
            }
            break;
        }
        let s = surface_at(hit.triangle, hit.u, hit.v, ray.dir);
        if max3(s.material.emission) > 0.0 {
            if depth == 0u {
                radiance += throughput * s.material.emission;
            } else if NEE_MODE != 1u {
                let light_pdf = area_light_pdf(prev_position, s.position, s.geometric_normal, s.material_index);
                radiance += throughput * s.material.emission * mis_weight(prev_brdf_pdf, light_pdf);
            }
        }
        if MAX_BOUNCES >= 0 && i32(depth) > MAX_BOUNCES {
            break;
        }
        let v = -ray.dir;
        let n = s.normal;
        let ng = s.geometric_normal;
        let origin = offset_origin(s.position, ng);

        // Next-event estimation.
        for (var i = 0u; i < scene_info.light_count; i++) {
            let inc = light_incidence(lights[i], s.position);
            let cos_theta = dot(n, inc.direction);
            if cos_theta > 0.0 && dot(ng, inc.direction) > 0.0 && max3(inc.irradiance) > 0.0 {
                if visible(origin, inc.direction, inc.distance * (1.0 - 1e-4), rays) {
                    radiance += throughput * brdf_eval(s.material, n, v, inc.direction) * inc.irradiance * cos_theta;
                }
            }
        }
        if NEE_MODE != 2u && scene_info.emissive_count > 0u {
            let ls = sample_area_light(origin, vec3f(rng_next(rng), rng_next2(rng)));
            let cos_theta = dot(n, ls.direction);
            if ls.pdf > 0.0 && cos_theta > 0.0 && dot(ng, ls.direction) > 0.0 {
                if visible(origin, ls.direction, ls.distance * (1.0 - 1e-4), rays) {
                    let f = brdf_eval(s.material, n, v, ls.direction);
                    let w = mis_weight(ls.pdf, brdf_pdf(s.material, n, v, ls.direction));
                    radiance += throughput * f * ls.radiance * cos_theta * w / ls.pdf;
                }
            }
        }
        if NEE_MODE != 2u && scene_info.env_kind != ENV_NONE {
            let es = sample_environment_light(n, rng_next2(rng));
            let cos_theta = dot(n, es.direction);
            if es.pdf > 0.0 && cos_theta > 0.0 && dot(ng, es.direction) > 0.0 {
                if visible(origin, es.direction, FLT_MAX, rays) {
                    let f = brdf_eval(s.material, n, v, es.direction);
                    let w = mis_weight(es.pdf, brdf_pdf(s.material, n, v, es.direction));
                    radiance += throughput * f * es.radiance * cos_theta * w / es.pdf;
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
        let bs = brdf_sample(s.material, n, v, vec3f(rng_next(rng), rng_next2(rng)));
        if bs.pdf <= 0.0 || dot(ng, bs.direction) <= 0.0 || max3(bs.weight) <= 0.0 {
            break;
        }
        throughput *= bs.weight;
        prev_position = s.position;
        prev_brdf_pdf = bs.pdf;
        prev_env_pdf = environment_light_pdf(n, bs.direction);
        ray = Ray(origin, bs.direction);
    }
    return radiance;
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
