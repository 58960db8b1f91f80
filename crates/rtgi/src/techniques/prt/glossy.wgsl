// Glossy transfer matrices per point ("vertex" below: a vertex, or a texel of a triangle's patch,
// points.wgsl; Sloan, Kautz & Snyder 2002 §6), precomputed through the shared
// BVH: M_ij = ∫_H V(ω) Y_i(ω) Y_j(ω) dω over the hemisphere about the vertex normal, so that the
// vertex's incident radiance with its self-shadowing, V·L, has the SH coefficients L'_i = Σ_j M_ij L_j
// for an environment with coefficients L_j (projected to the order: the transferred radiance). Shading
// then integrates L' against the whole BRDF in the view direction (shade_glossy.wgsl). V = 1 without
// SHADOWED: the hemisphere's mask alone. M is symmetric: only i ≤ j is kept, row after row,
// transfer[vertex · P + i(2n − i + 1)/2 + j − i] with n = order² and P = n(n + 1)/2.
//
// The integral is estimated with TRANSFER_SAMPLES uniformly distributed directions (lattice.wgsl):
// M_ij ≈ (2π / N) Σ_s V(ω_s) Y_i(ω_s) Y_j(ω_s). A workgroup is one vertex and one batch of GLOSSY_BATCH
// directions: each invocation traces one direction and writes its harmonics (zero when occluded) to
// workgroup memory, then the invocations share out the matrix's P entries, each summing over the batch.
//
// SELF_TRANSFER: each point's matrix is of its rigid part alone, in the part's space (parts.wgsl), and
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

const GLOSSY_BATCH: u32 = 64u;

// The batch's harmonics, direction after direction (COEFFICIENTS = order²).
var<workgroup> harmonics: array<f32, GLOSSY_BATCH * COEFFICIENTS>;

// Sample s of a point's uniformly distributed directions (world space; `seed`: PointSurface::seed).
fn glossy_direction(seed: u32, s: u32, n: vec3f) -> vec3f {
    return local_to_world(sample_cone(transfer_lattice(seed, s), 0.0), n);
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
    let sample = batch.first_sample + lane;
    var d = vec3f(0.0, 0.0, 1.0);
    var visible = false;
    if vertex < POINT_COUNT && sample < TRANSFER_SAMPLES {
        let f = transfer_frame(vertex);
        d = glossy_direction(f.seed, sample, f.normal);
        visible = !SHADOWED || !transfer_occluded(f, d);
    }
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
        transfer[vertex * pairs + entry] += sum * weight;
    }
}

// L'_i = Σ_j M_ij L_j, one coefficient of one vertex per invocation, whenever the environment's SH,
// the matrices or (SELF_TRANSFER) the parts' placement change; L is the environment as the point's
// part sees it.
@compute @workgroup_size(64)
fn transfer_lighting(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = batch.order * batch.order;
    let element = id.x + id.y * groups.x * 64u;
    if element >= POINT_COUNT * count {
        return;
    }
    let vertex = element / count;
    let i = element % count;
    let matrix = vertex * (count * (count + 1u) / 2u);
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
    }
    transferred[element] = vec4f(sum, 0.0);
}
