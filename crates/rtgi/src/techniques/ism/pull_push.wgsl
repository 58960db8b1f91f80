// Fills the holes of each VPL's map (one workgroup per VPL) by pull-push over two coarser levels
// (Grossman & Dally 1998, as Ritschel et al. 2008 use it). Pull: a coarse texel averages those of its
// 2×2 finer texels that lie within a depth threshold of their nearest, so a far point seen through a
// gap in a near surface does not drag the average back; the threshold is ISM_PULL_THRESHOLD at the
// finest level, doubled per level. Push: an empty finer texel takes its coarse texel's depth.
// Ritschel et al.'s push also replaces a finer texel that lies farther than its coarse one by more
// than the threshold; here that darkened every surface seen at a grazing angle from the VPLs (a slanted
// wall's farther texels took its nearer depth and shadowed the wall itself: cornell's side walls 7–10 %
// too dark, FLIP against the reference 0.202 instead of 0.154 at 128×128), so it is left out.
// The result is written in place as plain distances; texels that stay empty read as FLT_MAX.

#import common/math.wgsl

@group(2) @binding(0) var<storage, read_write> atlas: array<u32>;

const HALF: u32 = ISM_SIZE / 2u;
const QUARTER: u32 = ISM_SIZE / 4u;
const EMPTY: f32 = FLT_MAX;

var<workgroup> level1: array<f32, HALF * HALF>;
var<workgroup> level2: array<f32, QUARTER * QUARTER>;

fn splatted_distance(bits: u32) -> f32 {
    return select(bitcast<f32>(~bits), EMPTY, bits == 0u);
}

fn pulled(d: vec4f, threshold: f32) -> f32 {
    let nearest = min(min(d.x, d.y), min(d.z, d.w));
    if nearest == EMPTY {
        return EMPTY;
    }
    let near = d <= vec4f(nearest + threshold);
    let count = dot(select(vec4f(0.0), vec4f(1.0), near), vec4f(1.0));
    return dot(select(vec4f(0.0), d, near), vec4f(1.0)) / count;
}

fn pushed(fine: f32, coarse: f32) -> f32 {
    return select(fine, coarse, fine == EMPTY);
}

@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) thread: u32) {
    let base = group.x * ISM_SIZE * ISM_SIZE;
    for (var i = thread; i < HALF * HALF; i += 256u) {
        let fine = 2u * vec2u(i % HALF, i / HALF);
        let at = base + fine.y * ISM_SIZE + fine.x;
        let d = vec4f(
            splatted_distance(atlas[at]),
            splatted_distance(atlas[at + 1u]),
            splatted_distance(atlas[at + ISM_SIZE]),
            splatted_distance(atlas[at + ISM_SIZE + 1u]),
        );
        level1[i] = pulled(d, ISM_PULL_THRESHOLD);
    }
    workgroupBarrier();
    for (var i = thread; i < QUARTER * QUARTER; i += 256u) {
        let fine = 2u * vec2u(i % QUARTER, i / QUARTER);
        let at = fine.y * HALF + fine.x;
        let d = vec4f(level1[at], level1[at + 1u], level1[at + HALF], level1[at + HALF + 1u]);
        level2[i] = pulled(d, 2.0 * ISM_PULL_THRESHOLD);
    }
    workgroupBarrier();
    for (var i = thread; i < HALF * HALF; i += 256u) {
        let coarse = level2[(i / HALF / 2u) * QUARTER + (i % HALF) / 2u];
        level1[i] = pushed(level1[i], coarse);
    }
    workgroupBarrier();
    for (var i = thread; i < ISM_SIZE * ISM_SIZE; i += 256u) {
        let coarse = level1[(i / ISM_SIZE / 2u) * HALF + (i % ISM_SIZE) / 2u];
        let fine = splatted_distance(atlas[base + i]);
        atlas[base + i] = bitcast<u32>(pushed(fine, coarse));
    }
}
