// Lookups in the BRDF tables of build.wgsl. The composing shader declares
// `brdf_tables: array<f32>` (read-only storage) and the defines TABLE_SIZE and ROUGHNESS_LEVELS
// (BrdfTableShape::defines). Coefficient k of a lobe at an outgoing direction is bilinear between the
// four nearest texels of the paraboloid map and, for the GGX lobes, linear between the two nearest
// roughness rungs; brdf_table_combine then weighs the four lobes with a material exactly as
// brdf_terms weighs its terms, so a table dot product integrates rtgi's BRDF.

#import common/brdf.wgsl
#import common/hsh.wgsl

// Where a table's four texels around an outgoing direction start, their bilinear weights, and the
// roughness rungs around the material's roughness.
struct BrdfTableLookup {
    texels: vec4u,
    weights: vec4f,
    rung: u32,
    rung_weight: f32,
}

// `local_view`: the outgoing direction in the frame of the normal (+z).
fn brdf_table_lookup(local_view: vec3f, roughness: f32) -> BrdfTableLookup {
    let last = f32(TABLE_SIZE - 1u);
    let x = clamp(paraboloid_uv(local_view) * f32(TABLE_SIZE) - 0.5, vec2f(0.0), vec2f(last));
    let i0 = vec2u(floor(x));
    let i1 = min(i0 + 1u, vec2u(TABLE_SIZE - 1u));
    let f = x - vec2f(i0);
    var t: BrdfTableLookup;
    t.weights = vec4f((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
    t.texels = vec4u(i0.y * TABLE_SIZE + i0.x, i0.y * TABLE_SIZE + i1.x, i1.y * TABLE_SIZE + i0.x, i1.y * TABLE_SIZE + i1.x);
    let level = saturate(roughness) * f32(ROUGHNESS_LEVELS - 1u);
    t.rung = min(u32(level), ROUGHNESS_LEVELS - 2u);
    t.rung_weight = level - f32(t.rung);
    return t;
}

// Coefficient k of table `table`, whose texels hold `count` coefficients each.
fn brdf_table_value(t: BrdfTableLookup, table: u32, k: u32, count: u32) -> f32 {
    let e = (vec4u(table * TABLE_SIZE * TABLE_SIZE) + t.texels) * count + k;
    return dot(t.weights, vec4f(brdf_tables[e.x], brdf_tables[e.y], brdf_tables[e.z], brdf_tables[e.w]));
}

// Coefficient k of the four lobes: Lambert, its Fresnel loss, D·V and S·D·V at the looked-up roughness.
fn brdf_table_lobes(t: BrdfTableLookup, k: u32, count: u32) -> vec4f {
    let r = 2u + 2u * t.rung;
    return vec4f(
        brdf_table_value(t, 0u, k, count),
        brdf_table_value(t, 1u, k, count),
        mix(brdf_table_value(t, r, k, count), brdf_table_value(t, r + 2u, k, count), t.rung_weight),
        mix(brdf_table_value(t, r + 1u, k, count), brdf_table_value(t, r + 3u, k, count), t.rung_weight),
    );
}

// brdf_terms, integrated: the dielectric's diffuse layer base/π (1 − s F), its specular layer s F D V
// with F = 0.04 + 0.96 S, and the metal's (base + (1 − base) S) D V, from the four lobes' integrals
// against the same light (each an RGB sum).
fn brdf_table_combine(m: SurfaceMaterial, lambert: vec3f, lambert_fresnel: vec3f, ggx: vec3f, ggx_fresnel: vec3f) -> vec3f {
    let sw = m.specular;
    let dielectric = m.base_color * (lambert * (1.0 - sw * DIELECTRIC_F0) - sw * (1.0 - DIELECTRIC_F0) * lambert_fresnel)
        + sw * (DIELECTRIC_F0 * ggx + (1.0 - DIELECTRIC_F0) * ggx_fresnel);
    let metal = m.base_color * (ggx - ggx_fresnel) + ggx_fresnel;
    return mix(dielectric, metal, m.metallic);
}
