// Glossy transfer matrices per point ("vertex" below: a vertex, or a texel of a triangle's patch,
// points.wgsl; Sloan, Kautz & Snyder 2002 §6), precomputed through the shared
// BVH: M_ij = ∫_H V(ω) Y_i(ω) Y_j(ω) dω over the hemisphere about the vertex normal, so that the
// vertex's incident radiance with its self-shadowing, V·L, has the SH coefficients L'_i = Σ_j M_ij L_j
// for an environment with coefficients L_j (projected to the order: the transferred radiance). Shading
// then integrates L' against the whole BRDF in the view direction (shade_glossy.wgsl). V = 1 without
// SHADOWED: the hemisphere's mask alone. M is symmetric: only i ≤ j is kept, row after row,
// transfer[vertex · FLOATS_PER_POINT + i(2n − i + 1)/2 + j − i] with n = order² and P = n(n + 1)/2
// (FLOATS_PER_POINT = P without GLOSSY_BOUNCE).
//
// The integral is estimated with TRANSFER_SAMPLES uniformly distributed directions (lattice.wgsl):
// M_ij ≈ (2π / N) Σ_s V(ω_s) Y_i(ω_s) Y_j(ω_s). A workgroup is one vertex and one batch of GLOSSY_BATCH
// directions: each invocation traces one direction and writes its harmonics (zero when occluded) to
// workgroup memory, then the invocations share out the matrix's P entries, each summing over the batch.
//
// GLOSSY_BOUNCE (transfer=glossy-interreflected) adds the light the other surfaces reflect towards the
// point: a bounce matrix beside M, B_ijc = ∫_H (1 − V(ω)) Y_i(ω) (ρ_c(q) / π) T_jc(q) dω, where q is the
// surface direction ω meets (a front face) and T(q) its interreflected diffuse transfer of bounces − 1
// bounces (transfer.wgsl, RGB, interpolated at q), so that q sends the point (ρ(q) / π) Σ_j T_j(q) L_j:
// the surfaces light bounces off reflect it diffusely, and the point receives light of up to `bounces`
// bounces, as interreflected diffuse transfer does. It is estimated over M's directions and kept after
// M's pairs, entry (i · order² + j) · 3 + c of the point's FLOATS_PER_POINT floats.
//
// SELF_TRANSFER: each point's matrices are of its rigid part alone, in the part's space (parts.wgsl), and
// maps the environment turned into that space (self_transfer.wgsl) to transferred radiance in that
// space; shade_glossy.wgsl turns the pixel's normal and view into it.

#import common/scene.wgsl
#import common/hsh.wgsl

struct Batch {
    first_sample: u32,
    // A run-time value so that LLVM (lavapipe) does not unroll the per-coefficient loops.
    order: u32,
}

@group(2) @binding(0) var<storage, read_write> transfer: array<f32>;
@group(2) @binding(1) var<uniform> batch: Batch;
// The environment's SH (rgb) and each vertex's transferred radiance, order² vec4f per vertex.
@group(2) @binding(2) var<storage, read> environment_sh: array<vec4f>;
@group(2) @binding(3) var<storage, read_write> transferred: array<vec4f>;
// SELF_TRANSFER: per instance the environment's SH in the instance's own space (self_transfer.wgsl).
@group(2) @binding(5) var<storage, read> instance_sh: array<vec4f>;
// GLOSSY_BOUNCE: every point's interreflected diffuse transfer (transfer.wgsl's layout, CHANNELS = 3).
@group(2) @binding(6) var<storage, read> reflected_transfer: array<f32>;

const GLOSSY_BATCH: u32 = 64u;

// The batch's harmonics, direction after direction (COEFFICIENTS = order²).
var<workgroup> harmonics: array<f32, GLOSSY_BATCH * COEFFICIENTS>;
// GLOSSY_BOUNCE: the light BOUNCE_ROUND of the batch's directions meet, (ρ(q) / π) T(q) per coefficient
// and channel: as many as fit beside `harmonics` in 16 KiB (mod.rs, bounce_round).
var<workgroup> gathered: array<f32, BOUNCE_ROUND * COEFFICIENTS * 3u>;

// Sample s of a point's uniformly distributed directions (world space; `seed`: PointSurface::seed).
fn glossy_direction(seed: u32, s: u32, n: vec3f) -> vec3f {
    return local_to_world(sample_cone(transfer_lattice(seed, s), 0.0), n);
}

// Direction `lane` of the batch of `vertex`, from the vertex's transfer frame; none past the last
// point or sample.
struct BatchDirection {
    frame: TransferFrame,
    direction: vec3f,
    valid: bool,
}

fn batch_direction(vertex: u32, lane: u32) -> BatchDirection {
    let sample = batch.first_sample + lane;
    if vertex >= POINT_COUNT || sample >= TRANSFER_SAMPLES {
        return BatchDirection(TransferFrame(), vec3f(0.0, 0.0, 1.0), false);
    }
    let f = transfer_frame(vertex);
    return BatchDirection(f, glossy_direction(f.seed, sample, f.normal), true);
}

// A workgroup per vertex over the (x, y) spread of gpu::dispatch::workgroups_for.
@compute @workgroup_size(64)
fn accumulate_matrix(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
) {
    let vertex = group.x + group.y * groups.x;
    let count = batch.order * batch.order;
    let b = batch_direction(vertex, lane);
    let d = b.direction;
    let visible = b.valid && (!SHADOWED || !transfer_occluded(b.frame, d));
    for (var k = 0u; k < count; k++) {
        harmonics[lane * count + k] = select(0.0, sh_one(k, d), visible);
    }
    workgroupBarrier();
    if vertex >= POINT_COUNT {
        return;
    }
    let pairs = count * (count + 1u) / 2u;
    let weight = 2.0 * PI / f32(TRANSFER_SAMPLES);
    // Entries lane, lane + 64, …: every invocation busy on its own entries (a test per entry of which
    // invocation owns it would leave all but one of a SIMD group's lanes idle).
    var i = 0u;
    var row_start = 0u;
    for (var entry = lane; entry < pairs; entry += GLOSSY_BATCH) {
        while entry >= row_start + count - i {
            row_start += count - i;
            i++;
        }
        let j = i + entry - row_start;
        var sum = 0.0;
        for (var s = 0u; s < GLOSSY_BATCH; s++) {
            sum += harmonics[s * count + i] * harmonics[s * count + j];
        }
        transfer[vertex * FLOATS_PER_POINT + entry] += sum * weight;
    }
}

fn reflected(point: u32, j: u32, count: u32) -> vec3f {
    let i = (point * count + j) * 3u;
    return vec3f(reflected_transfer[i], reflected_transfer[i + 1u], reflected_transfer[i + 2u]);
}

// GLOSSY_BOUNCE: one batch of B's directions, a workgroup per vertex as accumulate_matrix. Every
// invocation traces its direction; then, BOUNCE_ROUND directions at a time, those directions' gathered
// transfer goes to workgroup memory and the invocations share out B's 3 · order⁴ entries.
@compute @workgroup_size(64)
fn accumulate_bounce(
    @builtin(local_invocation_index) lane: u32,
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
) {
    let vertex = group.x + group.y * groups.x;
    let count = batch.order * batch.order;
    let b = batch_direction(vertex, lane);
    let d = b.direction;
    // Where the direction meets a front face, and its reflectance there.
    var source = BounceSource();
    if b.valid {
        source = bounce_source(b.frame, d);
    }
    let lit = source.found;
    let at = source.at;
    let scale = source.reflectance / PI;
    for (var k = 0u; k < count; k++) {
        harmonics[lane * count + k] = select(0.0, sh_one(k, d), lit);
    }
    let pairs = count * (count + 1u) / 2u;
    let entries = count * count * 3u;
    let weight = 2.0 * PI / f32(TRANSFER_SAMPLES);
    for (var first = 0u; first < GLOSSY_BATCH; first += BOUNCE_ROUND) {
        if lane >= first && lane < first + BOUNCE_ROUND {
            let s = lane - first;
            let w = at.weights;
            for (var j = 0u; j < count; j++) {
                var t = vec3f(0.0);
                if lit {
                    t = scale
                        * (w.x * reflected(at.vertices.x, j, count) + w.y * reflected(at.vertices.y, j, count)
                            + w.z * reflected(at.vertices.z, j, count));
                }
                let g = (s * count + j) * 3u;
                gathered[g] = t.r;
                gathered[g + 1u] = t.g;
                gathered[g + 2u] = t.b;
            }
        }
        workgroupBarrier();
        if vertex < POINT_COUNT {
            for (var entry = lane; entry < entries; entry += GLOSSY_BATCH) {
                let c = entry % 3u;
                let i = entry / 3u / count;
                let j = entry / 3u % count;
                var sum = 0.0;
                for (var s = 0u; s < BOUNCE_ROUND; s++) {
                    sum += harmonics[(first + s) * count + i] * gathered[(s * count + j) * 3u + c];
                }
                transfer[vertex * FLOATS_PER_POINT + pairs + entry] += sum * weight;
            }
        }
        workgroupBarrier();
    }
}

// L'_i = Σ_j M_ij L_j (+ B_ij L_j with GLOSSY_BOUNCE, per channel), one coefficient of one vertex per
// invocation, whenever the environment's SH, the matrices or (SELF_TRANSFER) the parts' placement
// change; L is the environment as the point's part sees it.
@compute @workgroup_size(64)
fn transfer_lighting(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = batch.order * batch.order;
    let element = id.x + id.y * groups.x * 64u;
    if element >= POINT_COUNT * count {
        return;
    }
    let vertex = element / count;
    let i = element % count;
    let matrix = vertex * FLOATS_PER_POINT;
    let bounce = matrix + count * (count + 1u) / 2u + i * count * 3u;
    var instance = NO_INSTANCE;
    if SELF_TRANSFER {
        instance = vertex_instances[point_vertex(vertex)];
    }
    var sum = vec3f(0.0);
    for (var j = 0u; j < count; j++) {
        let a = min(i, j);
        let b = max(i, j);
        var light = environment_sh[j].rgb;
        if instance != NO_INSTANCE {
            light = instance_sh[instance * count + j].rgb;
        }
        sum += transfer[matrix + a * (2u * count - a + 1u) / 2u + b - a] * light;
        if GLOSSY_BOUNCE {
            let k = bounce + j * 3u;
            sum += vec3f(transfer[k], transfer[k + 1u], transfer[k + 2u]) * light;
        }
    }
    transferred[element] = vec4f(sum, 0.0);
}
