// Glossy transfer matrices per vertex (Sloan, Kautz & Snyder 2002 §6), precomputed through the shared
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

const GLOSSY_BATCH: u32 = 64u;

// The batch's harmonics, direction after direction (COEFFICIENTS = order²).
var<workgroup> harmonics: array<f32, GLOSSY_BATCH * COEFFICIENTS>;

// Sample s of the vertex's uniformly distributed directions (world space).
fn glossy_direction(vertex: u32, s: u32, n: vec3f) -> vec3f {
    return local_to_world(sample_cone(transfer_lattice(vertex, s), 0.0), n);
}

// harmonics[first + k] = weight · Y_k(d) for the batch's order² coefficients: hsh.wgsl's
// associated-Legendre recurrence (its conventions: index l(l+1)+m, no Condon–Shortley phase), run once
// for every coefficient rather than once per coefficient as sh_one does, which costs 10–20 times more.
fn store_harmonics(first: u32, d: vec3f, weight: f32) {
    let z = clamp(d.z, -1.0, 1.0);
    let s = sqrt(max(0.0, 1.0 - z * z));
    let r = length(d.xy);
    let e = select(vec2f(1.0, 0.0), d.xy / r, r > 1e-20);
    var pmm = 1.0;
    // e^{imφ}
    var turn = vec2f(1.0, 0.0);
    for (var m = 0u; m < batch.order; m++) {
        if m > 0u {
            pmm *= f32(2u * m - 1u) * s;
            turn = vec2f(turn.x * e.x - turn.y * e.y, turn.x * e.y + turn.y * e.x);
        }
        var p_prev = 0.0;
        var p = pmm;
        // (l − m)! / (l + m)!, from l = m on.
        var ratio = 1.0;
        for (var k = 2u; k <= 2u * m; k++) {
            ratio /= f32(k);
        }
        for (var l = m; l < batch.order; l++) {
            if l == m + 1u {
                p_prev = p;
                p = z * f32(2u * m + 1u) * pmm;
            } else if l > m + 1u {
                let next = (z * f32(2u * l - 1u) * p - f32(l + m - 1u) * p_prev) / f32(l - m);
                p_prev = p;
                p = next;
            }
            if l > m {
                ratio *= f32(l - m) / f32(l + m);
            }
            let scale = weight * sqrt(f32(2u * l + 1u) * ratio / (4.0 * PI)) * p;
            let centre = first + l * l + l;
            if m == 0u {
                harmonics[centre] = scale;
            } else {
                harmonics[centre + m] = HSH_SQRT_2 * scale * turn.x;
                harmonics[centre - m] = HSH_SQRT_2 * scale * turn.y;
            }
        }
    }
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
    if vertex < VERTEX_COUNT && sample < TRANSFER_SAMPLES {
        let v = vertices[vertex];
        let n = vertex_normal(v);
        d = glossy_direction(vertex, sample, n);
        visible = !SHADOWED || !trace_any(Ray(offset_origin(v.position, n), d), 0.0, FLT_MAX);
    }
    store_harmonics(lane * count, d, select(0.0, 1.0, visible));
    workgroupBarrier();
    if vertex >= VERTEX_COUNT {
        return;
    }
    let pairs = count * (count + 1u) / 2u;
    let weight = 2.0 * PI / f32(TRANSFER_SAMPLES);
    var entry = 0u;
    for (var i = 0u; i < count; i++) {
        for (var j = i; j < count; j++) {
            if entry % GLOSSY_BATCH == lane {
                var sum = 0.0;
                for (var s = 0u; s < GLOSSY_BATCH; s++) {
                    sum += harmonics[s * count + i] * harmonics[s * count + j];
                }
                transfer[vertex * pairs + entry] += sum * weight;
            }
            entry++;
        }
    }
}

// L'_i = Σ_j M_ij L_j, one coefficient of one vertex per invocation, whenever the environment's SH or
// the matrices change.
@compute @workgroup_size(64)
fn transfer_lighting(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = batch.order * batch.order;
    let element = id.x + id.y * groups.x * 64u;
    if element >= VERTEX_COUNT * count {
        return;
    }
    let vertex = element / count;
    let i = element % count;
    let matrix = vertex * (count * (count + 1u) / 2u);
    var sum = vec3f(0.0);
    for (var j = 0u; j < count; j++) {
        let a = min(i, j);
        let b = max(i, j);
        sum += transfer[matrix + a * (2u * count - a + 1u) / 2u + b - a] * environment_sh[j].rgb;
    }
    transferred[element] = vec4f(sum, 0.0);
}
