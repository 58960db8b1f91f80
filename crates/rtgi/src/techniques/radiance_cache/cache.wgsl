// The records of the radiance cache, their weight (Ward et al. 1988) and extrapolation by gradients
// (Ward & Heckbert 1992), shared by splatting, miss detection and the record pass. Mirrors `Record`
// and `CacheState` in radiance_cache/mod.rs; the CPU twins of `record_weight` and
// `record_irradiance` are `Record::weight` and `Record::irradiance_at` there. Two kinds of records
// (Křivánek et al. 2005; the thesis's §4.3): irradiance records serve diffuse surfaces, radiance
// records (HSH incoming radiance, in `radiance`) serve glossy ones; each kind is placed, splatted and
// summed only for pixels of its kind, with its own accuracy.
//
// Constants from the host: ACCURACY (a), GLOSSY_ACCURACY, GLOSSY_ROUGHNESS, GLOSSY_MIN_ROUGHNESS, CAPACITY (records),
// BIN_TILE (pixels per bin tile edge), BIN_WORDS (CAPACITY / 32), BIN_TILES_X.

#import common/frame.wgsl
#import common/math.wgsl

struct Record {
    // Position (xyz) and harmonic mean distance R to what the hemisphere sees, clamped (w).
    position_radius: vec4f,
    // Normal of the surface at the record (xyz); 1 for a radiance record, 0 for irradiance, −1 for a
    // deleted record (w).
    normal: vec4f,
    // Irradiance (rgb) of the indirect light; the world size of a pixel at the record in the view
    // that placed it, which bounds its zone (w).
    irradiance: vec4f,
    // Per colour channel: the rotational gradient (xyz), E(n) ≈ E + (n_k × n) · ∇r. The w's: the
    // scene time the record was computed at; the time step its prediction looked ahead (0: none);
    // the predicted change per step relative to the record's light (what set its lifespan).
    rotation: array<vec4f, 3>,
    // Per colour channel: the translational gradient (xyz), E(p) ≈ E + (p − p_k) · ∇t. The w's: the
    // frame it was computed in; the first frame it is expired in; its geometric normal, the side its
    // rays leave from (octahedral, 12 bits a coordinate). All three are integers below 2^24, exact as
    // f32 values (integer bits in a float could be NaN or denormal patterns, which drivers may not
    // keep); frame numbers wrap at 2^24 (6 days at 30 fps).
    translation: array<vec4f, 3>,
}

// In temporal mode (TEMPORAL) the cache holds two planes of records and of radiance coefficients:
// plane 0 the record as computed, plane 1 (at CAPACITY + k) its prediction one time step ahead.
// Between the two the record's light is interpolated linearly in time (the temporal gradients of
// Gautron et al. 2006, extrapolated).

fn record_is_deleted(r: Record) -> bool {
    return r.normal.w < -0.5;
}

fn record_time(r: Record) -> f32 {
    return r.rotation[0].w;
}

fn record_step(r: Record) -> f32 {
    return r.rotation[1].w;
}

const FRAME_WRAP: u32 = 0xffffffu;

fn record_frame_number(frame_counter: u32) -> f32 {
    return f32(frame_counter & FRAME_WRAP);
}

fn record_created_frame(r: Record) -> u32 {
    return u32(r.translation[0].w);
}

fn record_expiry_frame(r: Record) -> u32 {
    return u32(r.translation[1].w);
}

// Frames since the record was computed, and its lifespan (both modulo 2^24).
fn record_age(r: Record) -> u32 {
    return ((frame.frame_counter & FRAME_WRAP) - record_created_frame(r)) & FRAME_WRAP;
}

fn record_lifespan(r: Record) -> u32 {
    return (record_expiry_frame(r) - record_created_frame(r)) & FRAME_WRAP;
}

fn encode_record_normal(n: vec3f) -> f32 {
    let e = vec2u(round((oct_encode(n) * 0.5 + 0.5) * 4095.0));
    return f32(e.x | (e.y << 12u));
}

fn record_geometric_normal(r: Record) -> vec3f {
    let packed = u32(r.translation[2].w);
    return oct_decode(vec2f(f32(packed & 0xfffu), f32(packed >> 12u)) / 4095.0 * 2.0 - 1.0);
}

// How far along the record's prediction the current frame is, in time steps (0: the record's own
// light): from its time to at most its lifespan (records past it are refreshed or deleted).
fn record_progress(r: Record) -> f32 {
    if !TEMPORAL || !TEMPORAL_GRADIENTS || record_step(r) <= 0.0 {
        return 0.0;
    }
    return clamp((frame.time - record_time(r)) / record_step(r), 0.0, f32(record_lifespan(r)));
}

// What the passes of a frame hand each other on the GPU (the host writes only the per-frame fields at
// the frame's start and reads the counters for the stats).
struct CacheState {
    // Records in the cache.
    count: u32,
    // The next splat pass adds records [splat_begin, count); 0 = the splat buffer is rebuilt.
    splat_begin: u32,
    // Miss-detection rounds this frame (the candidate tile halves each round).
    iteration: u32,
    // Records created this frame (against RECORDS_PER_FRAME).
    created_this_frame: u32,
    // Tiles with a missing pixel at the last round, and of them the ones left for lack of budget.
    missing_tiles: u32,
    unserved_tiles: u32,
    // Records created since the cache was last cleared.
    created_total: u32,
    // Temporal mode: expired records recomputed in place this frame, and in all; records deleted
    // (expired without having served a pixel in the frame before) in all.
    refreshed_this_frame: u32,
    refreshed_total: u32,
    deleted_total: u32,
    // Miss-detection rounds since the cache was last cleared: placement draws its tie-breaks and
    // budget rotation from it, so a cache started at any frame places the same records.
    rounds_total: u32,
    // Temporal mode: deleted records removed by compaction, in all.
    compacted_total: u32,
    // Photon placement: its rounds since the cache was cleared, and the records it placed.
    photon_round: u32,
    photon_placed: u32,
}

// Weights above this are clamped (the weight is infinite at the record itself).
const MAX_WEIGHT: f32 = 1e4;

// Surfaces whose indirect light comes from radiance records: a specular lobe with a roughness in
// [GLOSSY_MIN_ROUGHNESS, GLOSSY_ROUGHNESS) (sharper lobes ring in HSH of the orders built here).
fn is_glossy(m: SurfaceMaterial) -> bool {
    return m.roughness >= GLOSSY_MIN_ROUGHNESS && m.roughness < GLOSSY_ROUGHNESS && (m.metallic > 0.0 || m.specular > 0.0);
}

fn kind_accuracy(glossy: bool) -> f32 {
    return select(ACCURACY, GLOSSY_ACCURACY, glossy);
}

fn record_is_radiance(r: Record) -> bool {
    return r.normal.w > 0.5;
}

// Ward's error term ||p − p_k|| / R_k + sqrt(1 − n · n_k); the record contributes where it is ≤ a
// (weight ≥ 1/a).
fn record_error(r: Record, p: vec3f, n: vec3f) -> f32 {
    let d = length(p - r.position_radius.xyz) / r.position_radius.w;
    return d + sqrt(max(0.0, 1.0 - dot(n, r.normal.xyz)));
}

fn record_weight_of_error(e: f32) -> f32 {
    return 1.0 / max(e, 1.0 / MAX_WEIGHT);
}

// Irradiance of record r extrapolated to (p, n) by its gradients (may be negative).
fn record_irradiance_unclamped(r: Record, p: vec3f, n: vec3f) -> vec3f {
    let axis = cross(r.normal.xyz, n);
    let dp = p - r.position_radius.xyz;
    let delta = vec3f(
        dot(axis, r.rotation[0].xyz) + dot(dp, r.translation[0].xyz),
        dot(axis, r.rotation[1].xyz) + dot(dp, r.translation[1].xyz),
        dot(axis, r.rotation[2].xyz) + dot(dp, r.translation[2].xyz),
    );
    return r.irradiance.rgb + delta;
}

// Irradiance of record r extrapolated to (p, n) by its gradients, never negative.
fn record_irradiance(r: Record, p: vec3f, n: vec3f) -> vec3f {
    return max(record_irradiance_unclamped(r, p, n), vec3f(0.0));
}

// The framebuffer rectangle (x0, y0, x1, y1, pixels) holding the projection of the sphere of radius
// a · R_k around the record (a of its kind), outside which the record's weight is below 1/a: the projected corners of
// the sphere's bounding box, widened by a pixel for the sub-pixel jitter of primary rays; the whole
// frame when the box reaches behind the camera.
fn record_screen_rect(r: Record) -> vec4f {
    if record_is_deleted(r) {
        return vec4f(0.0);
    }
    let radius = kind_accuracy(record_is_radiance(r)) * r.position_radius.w;
    var lo = vec2f(3.0e38);
    var hi = vec2f(-3.0e38);
    for (var i = 0u; i < 8u; i++) {
        let corner = vec3f(f32(i & 1u), f32((i >> 1u) & 1u), f32(i >> 2u)) * 2.0 - 1.0;
        let clip = frame.view_proj * vec4f(r.position_radius.xyz + radius * corner, 1.0);
        if clip.w <= 1e-6 {
            return vec4f(0.0, 0.0, vec2f(frame.size));
        }
        let xy = clip_to_pixel(clip);
        lo = min(lo, xy);
        hi = max(hi, xy);
    }
    return vec4f(max(lo - 1.0, vec2f(0.0)), min(hi + 1.0, vec2f(frame.size)));
}
