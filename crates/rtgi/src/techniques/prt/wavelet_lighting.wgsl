// Wavelet lighting per frame (Ng, Ramamoorthi & Hanrahan 2003), composed after cube.wgsl, haar.wgsl
// and select.wgsl with `alias Coefficient = vec4f` (radiance in rgb): the environment, as the world
// sees it now (turned), resampled onto the cube (each texel the solid-angle-weighted mean of
// LIGHT_SUBSAMPLES² points), turned into Haar wavelets, and its `kept` largest coefficients (by the
// luminance of their absolute values, area-weighted) kept in a dense, otherwise zero array: the per-frame non-linear
// approximation. Every vertex's irradiance is then the sparse dot product of its kept transfer terms
// (wavelet_transfer.wgsl) with that array.

#import common/environment.wgsl
#import common/color.wgsl

@group(2) @binding(4) var<storage, read_write> kept_lighting: array<vec4f>;
@group(2) @binding(5) var<storage, read> transfer_terms: array<u32>;
@group(2) @binding(6) var<storage, read_write> vertex_irradiance: array<vec4f>;

const LIGHT_SUBSAMPLES: u32 = 4u;

// Area-weighted selection (Ng et al. 2003, §5): the luminance of the coefficient's absolute value
// times its support's area. By magnitude alone a small bright source (whose fine coefficients carry
// most of the L2 energy) takes every term and the rest of the sky goes dark: on pillars:sky=patch at
// 6 × 32², 6 and 18 terms gave FLIP 0.706 and 0.436 against the full-GI reference.
fn magnitude(c: vec4f, index: u32) -> f32 {
    return luminance(abs(c.rgb)) * haar_support_area(index);
}

fn keep_term(row: u32, slot: u32, index: u32) {
    kept_lighting[index] = haar_out[index];
}

// The environment on the cube, into the scaling buffer that the first Haar level reads.
@compute @workgroup_size(64)
fn light_cube(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let texel = id.x + id.y * groups.x * 64u;
    if texel >= CUBE_TEXELS {
        return;
    }
    let face = cube_texel_face(texel);
    let xy = cube_texel_xy(texel);
    var sum = vec3f(0.0);
    var weights = 0.0;
    for (var s = 0u; s < LIGHT_SUBSAMPLES * LIGHT_SUBSAMPLES; s++) {
        let offset = (vec2f(f32(s % LIGHT_SUBSAMPLES), f32(s / LIGHT_SUBSAMPLES)) + 0.5) / f32(LIGHT_SUBSAMPLES);
        let p = cube_point(face, cube_coordinates(xy, offset));
        // The solid angle per unit of face area at p.
        let w = pow(dot(p, p), -1.5);
        sum += w * environment_radiance(normalize(p));
        weights += w;
    }
    haar_scaling[texel] = vec4f(sum / weights, 0.0);
}

@compute @workgroup_size(64)
fn select_lighting(@builtin(local_invocation_index) lane: u32) {
    select_terms(0u, haar_step.kept, lane);
}

// Invocation per vertex: Σ over its kept terms of transfer × kept lighting; `haar_step.kept` is the
// transfer's terms per vertex here.
@compute @workgroup_size(64)
fn light_vertices(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let vertex = id.x + id.y * groups.x * 64u;
    if vertex >= VERTEX_COUNT {
        return;
    }
    var sum = vec3f(0.0);
    let first = vertex * haar_step.kept;
    for (var k = 0u; k < haar_step.kept; k++) {
        let term = transfer_terms[first + k];
        sum += unpack2x16float(term & 0xffffu).x * kept_lighting[term >> 16u].rgb;
    }
    // A truncated approximation can ring below zero.
    vertex_irradiance[vertex] = vec4f(max(sum, vec3f(0.0)), 1.0);
}
