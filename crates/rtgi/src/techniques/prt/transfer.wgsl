// Diffuse transfer vectors per point (a vertex, or a texel of a triangle's patch: points.wgsl; Sloan,
// Kautz & Snyder 2002), precomputed through the shared BVH:
// T_k = ∫ V(ω) max(0, n·ω) Y_k(ω) dω, so that a vertex lit by an environment with SH coefficients L_k
// receives the irradiance Σ_k L_k T_k (shadowed: V is the vertex's visibility of the environment;
// unshadowed: V = 1, the clamped cosine alone). The integral is estimated with TRANSFER_SAMPLES
// cosine-distributed directions about the vertex normal (lattice.wgsl):
// T_k ≈ (π / N) Σ_s V(ω_s) Y_k(ω_s). Each dispatch adds BATCH of the samples (long loops in one invocation are unsafe on lavapipe); an invocation traces
// its vertex's BATCH rays, keeps their visibility as bits, then adds one coefficient at a time.
//
// Interreflected transfer (Sloan et al. §5) adds bounces: bounce b's transfer at v gathers bounce
// b − 1's at the points its occluded directions hit, ΔT_b(v) = ∫ (ρ_q / π) ΔT_{b−1}(q) max(0, n·ω) dω
// ≈ (1 / N) Σ_s ρ_q ΔT_{b−1}(q_s), with ΔT_{b−1}(q) interpolated from the hit triangle's vertices and
// ρ_q the hit's diffuse reflectance (RGB: interreflected transfer has CHANNELS = 3 per coefficient,
// the others 1). Back faces (hit against their normals) pass nothing on: transfer is for the side the
// normals point to. Layout: transfer[(vertex · order² + k) · CHANNELS + channel].
//
// SELF_TRANSFER: transfer per rigid part (parts.wgsl), interreflected between the part's own surfaces;
// shade_diffuse.wgsl lights it with the environment turned into the part's space.

#import common/scene.wgsl
#import common/hsh.wgsl

struct Batch {
    first_sample: u32,
    // A run-time value so that LLVM (lavapipe) does not unroll the per-coefficient loop.
    order: u32,
}

@group(2) @binding(0) var<storage, read_write> transfer: array<f32>;
@group(2) @binding(1) var<uniform> batch: Batch;
// Interreflection: the previous bounce's transfer increment and this bounce's (CHANNELS = 3 each).
@group(2) @binding(2) var<storage, read> previous_bounce: array<f32>;
@group(2) @binding(3) var<storage, read_write> this_bounce: array<f32>;

const BATCH: u32 = 32u;
// Sample s of a point's cosine-distributed directions (world space; `seed`: PointSurface::seed).
fn transfer_direction(seed: u32, s: u32, n: vec3f) -> vec3f {
    return local_to_world(sample_cosine_hemisphere(transfer_lattice(seed, s)), n);
}

// Invocation per point, over the (x, y) spread of gpu::dispatch::workgroups_for.
@compute @workgroup_size(64)
fn accumulate(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let point = id.x + id.y * groups.x * 64u;
    if point >= POINT_COUNT {
        return;
    }
    let f = transfer_frame(point);
    let n = f.normal;
    var visible = 0u;
    for (var s = 0u; s < BATCH; s++) {
        let sample = batch.first_sample + s;
        if sample >= TRANSFER_SAMPLES {
            break;
        }
        let d = transfer_direction(f.seed, sample, n);
        if !SHADOWED || !transfer_occluded(f, d) {
            visible |= 1u << s;
        }
    }
    let count = batch.order * batch.order;
    let weight = PI / f32(TRANSFER_SAMPLES);
    for (var k = 0u; k < count; k++) {
        var sum = 0.0;
        for (var s = 0u; s < BATCH; s++) {
            if (visible & (1u << s)) != 0u {
                sum += sh_one(k, transfer_direction(f.seed, batch.first_sample + s, n));
            }
        }
        for (var c = 0u; c < CHANNELS; c++) {
            transfer[(point * count + k) * CHANNELS + c] += sum * weight;
        }
    }
}

fn previous_transfer(point: u32, k: u32, count: u32) -> vec3f {
    let i = (point * count + k) * 3u;
    return vec3f(previous_bounce[i], previous_bounce[i + 1u], previous_bounce[i + 2u]);
}

// One batch of directions of one bounce of interreflection into this_bounce.
@compute @workgroup_size(64)
fn interreflect(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let point = id.x + id.y * groups.x * 64u;
    if point >= POINT_COUNT {
        return;
    }
    // The point's part alone with SELF_TRANSFER (parts.wgsl).
    let f = transfer_frame(point);
    let count = batch.order * batch.order;
    for (var s = 0u; s < BATCH; s++) {
        let sample = batch.first_sample + s;
        if sample >= TRANSFER_SAMPLES {
            break;
        }
        let source = bounce_source(f, transfer_direction(f.seed, sample, f.normal));
        if !source.found {
            continue;
        }
        let w = source.at.weights;
        let v = source.at.vertices;
        let scale = source.reflectance / f32(TRANSFER_SAMPLES);
        for (var k = 0u; k < count; k++) {
            let t = w.x * previous_transfer(v.x, k, count) + w.y * previous_transfer(v.y, k, count)
                + w.z * previous_transfer(v.z, k, count);
            let i = (point * count + k) * 3u;
            this_bounce[i] += scale.r * t.r;
            this_bounce[i + 1u] += scale.g * t.g;
            this_bounce[i + 2u] += scale.b * t.b;
        }
    }
}

// Adds a finished bounce to the transfer, one float per invocation.
@compute @workgroup_size(64)
fn add_bounce(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = id.x + id.y * groups.x * 64u;
    if i < POINT_COUNT * batch.order * batch.order * 3u {
        transfer[i] += this_bounce[i];
    }
}
