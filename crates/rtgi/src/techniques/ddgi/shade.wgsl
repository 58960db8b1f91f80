// Camera pixels: this frame's direct light (accumulated while nothing moves, by the `direct` pass) plus
// the probes' diffuse light, plus (REFLECTION_RAY) the specular light of surfaces smoother than
// REFLECTION_ROUGHNESS through one ray per pixel and frame, sampled from GGX's visible normals and
// shaded at its hit like a probe ray (direct light + the probes' diffuse light), averaged in
// `reflection` while nothing moves. Rougher surfaces get no indirect specular light (as in the paper).

@group(2) @binding(0) var output: texture_storage_2d<rgba32float, write>;
@group(2) @binding(1) var direct: texture_2d<f32>;
@group(2) @binding(2) var probe_irradiance: texture_2d<f32>;
@group(2) @binding(3) var probe_distance: texture_2d<f32>;
@group(2) @binding(4) var probe_sampler: sampler;
@group(2) @binding(5) var<uniform> probe_frame: ProbeFrame;
@group(2) @binding(6) var<storage, read> probe_states: array<ProbeState>;
// Mean reflected light so far (1×1 and unused without REFLECTION_RAY).
@group(2) @binding(7) var reflection: texture_storage_2d<rgba32float, read_write>;

// Light of one GGX sample reflected towards the viewer: brdf_specular · cos / pdf · L(ray).
fn reflected_light(s: GSurface, rng: ptr<function, Rng>) -> vec3f {
    let m = s.material;
    let u = rng_next2(rng);
    let h = local_to_world(sample_ggx_vndf(world_to_local(s.view, s.normal), ggx_alpha(m.roughness), u), s.normal);
    let l = reflect(-s.view, h);
    let pdf = ggx_vndf_pdf(m, s.normal, s.view, l);
    if pdf <= 0.0 || dot(s.geometric_normal, l) <= 0.0 {
        return vec3f(0.0);
    }
    let weight = brdf_eval_specular(m, s.normal, s.view, l) * dot(s.normal, l) / pdf;
    return weight * ray_radiance(trace_closest(Ray(gsurface_ray_origin(s), l), 0.0, FLT_MAX), l, rng);
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= frame.size.x || id.y >= frame.size.y {
        return;
    }
    var radiance = textureLoad(direct, id.xy, 0).rgb;
    let s = load_gsurface(id.xy);
    if s.valid {
        radiance += probe_diffuse_light(s);
        if REFLECTION_RAY && s.material.roughness < REFLECTION_ROUGHNESS {
            var rng = rng_new(id.xy, frame.frame_counter, hash2(frame.seed, 0x72666c74u));
            // A running mean while nothing moves, but never slower than the probes' own blend: what a
            // reflection ray meets is lit by probes still converging.
            let n = f32(frame.sample_index);
            let weight = max(1.0 / (n + 1.0), 1.0 - probe_frame.hysteresis);
            let previous = select(textureLoad(reflection, id.xy).rgb, vec3f(0.0), frame.sample_index == 0u);
            let mean = mix(previous, reflected_light(s, &rng), weight);
            textureStore(reflection, id.xy, vec4f(mean, 1.0));
            radiance += mean;
        }
    }
    textureStore(output, id.xy, vec4f(radiance, 1.0));
}
