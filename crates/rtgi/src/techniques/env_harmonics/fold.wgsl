// T'_j = Σ_i C[i][j] T_i over the HSH i with the m of j: an HSH BRDF table's coefficients against the SH
// environment (j over its environment_order² coefficients, i over the table's order²), once, so that
// shading costs the same in both bases (see shade.wgsl).

#import common/hsh.wgsl

struct FoldShape {
    // Run-time values (see shade.wgsl).
    order: u32,
    environment_order: u32,
}

@group(2) @binding(0) var<storage, read> tables: array<f32>;
// C, order² rows × environment_order² columns.
@group(2) @binding(1) var<storage, read> conversion: array<f32>;
@group(2) @binding(2) var<storage, read_write> folded: array<f32>;
@group(2) @binding(3) var<uniform> shape: FoldShape;

@compute @workgroup_size(64)
fn fold(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = shape.order * shape.order;
    let environment_count = shape.environment_order * shape.environment_order;
    // Linear over the (x, y) spread of gpu::dispatch::workgroups_for.
    let element = id.x + id.y * groups.x * 64u;
    if element >= (2u + 2u * ROUGHNESS_LEVELS) * TABLE_SIZE * TABLE_SIZE * environment_count {
        return;
    }
    let j = element % environment_count;
    let first = (element / environment_count) * count;
    let m = harmonic_lm(j).y;
    var sum = 0.0;
    for (var l = u32(abs(m)); l < shape.order; l++) {
        let i = u32(i32(l * l + l) + m);
        sum += conversion[i * environment_count + j] * tables[first + i];
    }
    folded[element] = sum;
}
