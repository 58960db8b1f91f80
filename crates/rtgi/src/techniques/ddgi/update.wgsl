#import common/random.wgsl

// Probe update: every texel of every probe tile (gutters included) of the active probes in this frame's
// update blends this frame's rays into the previous atlas, E_t = α·E_{t−1} + (1 − α)·Ê_t, with Ê the
// lobe-weighted mean normalised by the summed weights and α = probe_frame.hysteresis (0 for a probe
// never updated before), rounded as the atlas stores it without stalling (blend_stored); every other texel is copied, since the atlases ping-pong. Irradiance: cosine lobe, Ê = π·Σ w·L / Σ w (exact for
// uniform radiance), back-face rays skipped. Distance: the mean and mean square of the hit distance
// (clamped to MAX_DISTANCE) under a cosine-power lobe; texels whose summed weight is below 0.001 keep
// their value. A gutter texel computes the interior texel it mirrors, so both hold the same value
// without a second pass.

@group(0) @binding(0) var<storage, read> ray_data: array<vec4f>;
@group(0) @binding(1) var previous: texture_2d<f32>;
@group(0) @binding(2) var<uniform> probe_frame: ProbeFrame;
@group(0) @binding(3) var updated: texture_storage_2d<ATLAS_FORMAT, write>;
@group(0) @binding(4) var<storage, read> probe_states: array<ProbeState>;

struct Texel {
    probe: u32,
    // Tile texel (with gutter), the interior texel it holds, and where that lives in the atlas.
    tile: vec2u,
    source: vec2u,
    held: vec2u,
    valid: bool,
    // Whether this frame's rays update it, and the weight of its previous value if so.
    updated: bool,
    hysteresis: f32,
}

fn locate(id: vec2u, interior: u32) -> Texel {
    var t: Texel;
    let edge = interior + 2u;
    let tile = id / edge;
    t.probe = tile.y * ATLAS_COLUMNS + tile.x;
    t.valid = tile.x < ATLAS_COLUMNS && t.probe < probe_count();
    t.tile = id % edge;
    t.source = gutter_source(t.tile, interior);
    t.held = probe_tile_origin(t.probe, interior) + 1u + t.source;
    if t.valid {
        let flags = probe_states[t.probe].flags;
        t.updated = (flags & PROBE_ACTIVE) != 0u && probe_in_update(t.probe);
        t.hysteresis = select(0.0, probe_frame.hysteresis, (flags & PROBE_BLEND) != 0u);
    }
    return t;
}

// The blend E = α·E_prev + (1 − α)·Ê as the atlas stores it. The format rounds every value to a step of
// its own, so an increment below a step rounds back to E_prev and the blend stalls short of its target
// by up to step / (1 − α): 2.5 % at α = 0.98 in rgba16float. Float formats (ATLAS_STOCHASTIC) therefore
// round the blend themselves, to one of its two representable neighbours with the probabilities that
// keep its mean: the stored value is exact whatever the hardware's rounding mode, and unbiased even for
// noisy, skewed Ê (a deterministic fix, one step towards Ê, still left cornell-spot 2.3 % dark: it
// steers towards the median). Unorm atlases (exact steps ATLAS_ABSOLUTE_STEP) take that one step.
fn blend_stored(stored: vec4f, goal: vec4f, alpha: f32, random: vec4f) -> vec4f {
    let blended = mix(goal, stored, alpha);
    if ATLAS_STOCHASTIC {
        let exponent = floor(log2(max(abs(blended), vec4f(ATLAS_MIN_NORMAL))));
        let step = max(exp2(exponent) * ATLAS_RELATIVE_STEP, vec4f(ATLAS_ABSOLUTE_STEP));
        let below = floor(blended / step) * step;
        return select(below, below + step, random < (blended - below) / step);
    }
    let step = max(abs(stored) * ATLAS_RELATIVE_STEP, vec4f(ATLAS_ABSOLUTE_STEP));
    let gap = goal - stored;
    let stalls = (abs(gap) >= step) & (abs(blended - stored) < step);
    return select(blended, stored + sign(gap) * step, stalls);
}

// Four uniform numbers in [0, 1) for texel `id` this frame (the ray pattern's rotation changes every frame).
fn texel_random(id: vec2u) -> vec4f {
    var rng = rng_new(id, bitcast<u32>(probe_frame.rotation[0].x), 0u);
    return vec4f(rng_next2(&rng), rng_next2(&rng));
}

@compute @workgroup_size(8, 8)
fn update_irradiance(@builtin(global_invocation_id) id: vec3u) {
    let t = locate(id.xy, IRRADIANCE_TEXELS);
    if !t.valid {
        return;
    }
    var value = textureLoad(previous, t.held, 0).rgb;
    if t.updated {
        let dir = texel_direction(t.source, IRRADIANCE_TEXELS);
        var sum = vec3f(0.0);
        var weight = 0.0;
        for (var r = 0u; r < RAYS; r++) {
            let ray = ray_data[t.probe * RAYS + r];
            let w = max(0.0, dot(dir, probe_ray_direction(r)));
            if ray.w >= 0.0 && w > 0.0 {
                sum += w * ray.rgb;
                weight += w;
            }
        }
        if weight > 0.0 {
            value = blend_stored(vec4f(value, 0.0), vec4f(PI * sum / weight, 0.0), t.hysteresis, texel_random(id.xy)).rgb;
        }
    }
    textureStore(updated, id.xy, vec4f(value, 1.0));
}

@compute @workgroup_size(8, 8)
fn update_distance(@builtin(global_invocation_id) id: vec3u) {
    let t = locate(id.xy, DISTANCE_TEXELS);
    if !t.valid {
        return;
    }
    var value = textureLoad(previous, t.held, 0).xy;
    if t.updated {
        let dir = texel_direction(t.source, DISTANCE_TEXELS);
        var sum = vec2f(0.0);
        var weight = 0.0;
        for (var r = 0u; r < RAYS; r++) {
            let c = dot(dir, probe_ray_direction(r));
            if c > 0.0 {
                let w = pow(c, DISTANCE_EXPONENT);
                let d = min(abs(ray_data[t.probe * RAYS + r].w), MAX_DISTANCE);
                sum += w * vec2f(d, d * d);
                weight += w;
            }
        }
        if weight >= 0.001 {
            value = blend_stored(vec4f(value, 0.0, 0.0), vec4f(sum / weight, 0.0, 0.0), t.hysteresis, texel_random(id.xy)).xy;
        }
    }
    textureStore(updated, id.xy, vec4f(value, 0.0, 1.0));
}
