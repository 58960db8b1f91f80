// One level of the non-standard 2D Haar transform of every cube face of every row (a vertex's
// transfer, or the lighting), orthonormal so that the dot product of two functions' coefficients is
// that of their texels (Parseval): Σ_t T_t L_t = Σ_i T̂_i L̂_i. Level `size` reads the size × size
// scaling coefficients of each face (the texels themselves at size = CUBE_SIZE) from `haar_in` and
// writes each 2 × 2 block's three details into `haar_out` at their final places (the Mallat layout:
// horizontal at (x + half, y), vertical at (x, y + half), diagonal at (x + half, y + half)) and its
// scaling coefficient into `haar_scaling` at (x, y), except the last level (size 2), which writes the
// face's one scaling coefficient to `haar_out` at (0, 0). The composing shader declares
// `alias Coefficient` (f32 or vec4f). The CPU twin is `wavelet::haar_face`.

struct HaarStep {
    // The first vertex of the rows (transfer) and the row count.
    first_row: u32,
    rows: u32,
    // The scaling coefficients' size per face that this level reads.
    size: u32,
    // Terms kept per row by the selection.
    kept: u32,
}

@group(2) @binding(0) var<uniform> haar_step: HaarStep;
@group(2) @binding(1) var<storage, read> haar_in: array<Coefficient>;
@group(2) @binding(2) var<storage, read_write> haar_scaling: array<Coefficient>;
@group(2) @binding(3) var<storage, read_write> haar_out: array<Coefficient>;

// The area of the support of coefficient `index` (in the Mallat layout), relative to its face's: 1 for
// the scaling coefficient and the coarsest details, 1/4 for the next level, ..., 4 / CUBE_SIZE² for
// the finest. The CPU twin is `wavelet::haar_support_area`.
fn haar_support_area(index: u32) -> f32 {
    let xy = cube_texel_xy(index);
    let level = f32(1u << firstLeadingBit(max(max(xy.x, xy.y), 1u)));
    return 1.0 / (level * level);
}

@compute @workgroup_size(64)
fn haar_level(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = id.x + id.y * groups.x * 64u;
    let half = haar_step.size / 2u;
    let blocks = half * half;
    if i >= haar_step.rows * 6u * blocks {
        return;
    }
    let row = i / (6u * blocks);
    let face = (i / blocks) % 6u;
    let x = (i % blocks) % half;
    let y = (i % blocks) / half;
    let base = row * CUBE_TEXELS + face * CUBE_AREA;
    let p00 = haar_in[base + 2u * y * CUBE_SIZE + 2u * x];
    let p10 = haar_in[base + 2u * y * CUBE_SIZE + 2u * x + 1u];
    let p01 = haar_in[base + (2u * y + 1u) * CUBE_SIZE + 2u * x];
    let p11 = haar_in[base + (2u * y + 1u) * CUBE_SIZE + 2u * x + 1u];
    haar_out[base + y * CUBE_SIZE + x + half] = 0.5 * (p00 - p10 + p01 - p11);
    haar_out[base + (y + half) * CUBE_SIZE + x] = 0.5 * (p00 + p10 - p01 - p11);
    haar_out[base + (y + half) * CUBE_SIZE + x + half] = 0.5 * (p00 - p10 - p01 + p11);
    let scaling = 0.5 * (p00 + p10 + p01 + p11);
    if half == 1u {
        haar_out[base] = scaling;
    } else {
        haar_scaling[base + y * CUBE_SIZE + x] = scaling;
    }
}
