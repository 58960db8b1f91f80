// Wavelet transfer per vertex (Ng, Ramamoorthi & Hanrahan 2003), composed after cube.wgsl, haar.wgsl
// and select.wgsl with `alias Coefficient = f32`. A vertex's transfer in the pixel basis of the cube
// (cube.wgsl) is T_t = V(ω_t) max(0, n·ω_t) Ω_t: its visibility of the environment through the
// texel's centre (one ray through the shared BVH), the clamped cosine
// and the texel's solid angle, so that Σ_t T_t L_t is the vertex's irradiance from an environment of
// texel radiances L_t. haar.wgsl turns every face into Haar wavelets and select.wgsl keeps each
// vertex's `kept` largest coefficients (area-weighted, below): transfer_terms[vertex · kept + slot] holds the coefficient's
// index (high 16 bits) and its value as f16 (low 16 bits); unused slots are 0 (index 0, value 0).
// The host processes the vertices in chunks of `rows` (the scratch buffers hold one chunk).

#import common/scene.wgsl

@group(2) @binding(4) var<storage, read_write> transfer_terms: array<u32>;

// Area-weighted selection: a coefficient's magnitude times the area of its support (relative to the
// face's). The lighting's kept terms are coarse ones and the fine ones of its bright, small sources; a
// fine transfer term matters only where such a source is, and there the coarse terms matter too.
// Measured on pillars:sky=patch at 6 × 32², 256 terms, 128²: relative MSE against the ray-traced
// environment light 0.0066 by magnitude alone, 0.0050 area-weighted (0.0247 weighted the other way).
fn magnitude(c: f32, index: u32) -> f32 {
    return abs(c) * haar_support_area(index);
}

fn keep_term(row: u32, slot: u32, index: u32) {
    let value = pack2x16float(vec2f(haar_out[row * CUBE_TEXELS + index], 0.0)) & 0xffffu;
    transfer_terms[(haar_step.first_row + row) * haar_step.kept + slot] = (index << 16u) | value;
}

// The chunk's transfer in the pixel basis, into the scaling buffer that the first Haar level reads.
@compute @workgroup_size(64)
fn visibility_cube(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = id.x + id.y * groups.x * 64u;
    if i >= haar_step.rows * CUBE_TEXELS {
        return;
    }
    let vertex = haar_step.first_row + i / CUBE_TEXELS;
    let texel = i % CUBE_TEXELS;
    var value = 0.0;
    if vertex < VERTEX_COUNT {
        let v = vertices[vertex];
        let n = vertex_normal(v);
        let d = cube_texel_direction(texel);
        let cosine = dot(n, d);
        if cosine > 0.0 && !trace_any(Ray(offset_origin(v.position, n), d), 0.0, FLT_MAX) {
            value = cosine * cube_texel_solid_angle(texel);
        }
    }
    haar_scaling[i] = value;
}

// A workgroup per vertex of the chunk.
@compute @workgroup_size(64)
fn select_transfer(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) lane: u32) {
    let row = group.x;
    if row >= haar_step.rows || haar_step.first_row + row >= VERTEX_COUNT {
        return;
    }
    select_terms(row, haar_step.kept, lane);
}
