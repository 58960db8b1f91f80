// The BRDF tables of techniques/brdf_tables (the thesis's §3.5.2, after Kautz et al. 2002): for every outgoing
// direction at a texel centre of a TABLE_SIZE² paraboloid map, the harmonic coefficients (HSH, or SH
// for the baseline) over incoming directions of four cosine-weighted scalar lobes that rtgi's BRDF
// (common/brdf.wgsl) is a linear combination of, at ROUGHNESS_LEVELS roughnesses:
//   table 0:        cos θi / π                       (Lambert)
//   table 1:        S(v·h) cos θi / π                (the Fresnel loss of the dielectric's diffuse layer)
//   table 2 + 2r:   D V cos θi                       (GGX at roughness r / (ROUGHNESS_LEVELS − 1))
//   table 3 + 2r:   S(v·h) D V cos θi
// with S the Schlick weight. The shading pass recombines them with the material's base colour,
// metallic and specular factors exactly as brdf_terms does (lookup.wgsl). Each invocation owns one coefficient of
// one (table, texel), the buffer element at its linear index, and adds SAMPLES_PER_DISPATCH quasi-random samples
// per dispatch (long loops in one invocation are unsafe on lavapipe): cosine-distributed for tables
// 0–1, GGX visible normals for the others, whose weights f cos / pdf are then smooth (G2/G1) even at
// the smoothest roughness.

#import common/brdf.wgsl
#import common/hsh.wgsl
#import common/random.wgsl

struct Slot {
    first_sample: u32,
    // The order as a run-time value (index arithmetic only; compile-time orders have cost lavapipe
    // minutes of compilation elsewhere, see env_harmonics/shade.wgsl).
    order: u32,
}

@group(2) @binding(0) var<storage, read_write> tables: array<f32>;
@group(2) @binding(1) var<uniform> slot: Slot;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let count = slot.order * slot.order;
    let texels = TABLE_SIZE * TABLE_SIZE;
    // Linear over the (x, y) spread of gpu::dispatch::workgroups_for.
    let element = id.x + id.y * groups.x * 64u;
    let k = element % count;
    let table = element / (count * texels);
    if table >= 2u + 2u * ROUGHNESS_LEVELS {
        return;
    }
    let texel = (element / count) % texels;
    let uv = (vec2f(f32(texel % TABLE_SIZE), f32(texel / TABLE_SIZE)) + 0.5) / f32(TABLE_SIZE);
    let v = paraboloid_direction(uv);
    let n_dot_v = max(v.z, 1e-4);
    let level = (table - 2u) / 2u;
    let alpha = ggx_alpha(f32(level) / f32(max(ROUGHNESS_LEVELS - 1u, 1u)));
    var sum = 0.0;
    for (var s = 0u; s < SAMPLES_PER_DISPATCH; s++) {
        let i = slot.first_sample + s;
        if i >= TABLE_SAMPLES {
            break;
        }
        let u = vec2f((f32(i) + 0.5) / f32(TABLE_SAMPLES), radical_inverse_2(i));
        var l: vec3f;
        var weight = 0.0;
        if table < 2u {
            l = sample_cosine_hemisphere(u);
            // (cos θi / π) / pdf = 1.
            weight = 1.0;
            if table == 1u {
                weight = schlick_weight(saturate(dot(v, normalize(v + l))));
            }
        } else {
            let h = sample_ggx_vndf(vec3f(v.xy, n_dot_v), alpha, u);
            l = reflect(-v, h);
            if l.z <= 0.0 {
                continue;
            }
            // D V cos θi / (G1(v) D / (4 n·v)).
            weight = smith_visibility(alpha, l.z, n_dot_v) * l.z * 4.0 * n_dot_v / smith_g1(alpha, n_dot_v);
            if (table & 1u) == 1u {
                weight *= schlick_weight(saturate(dot(v, h)));
            }
        }
        if HSH_BASIS {
            sum += weight * hsh_one(k, l);
        } else {
            sum += weight * sh_one(k, l);
        }
    }
    tables[element] += sum / f32(TABLE_SAMPLES);
}
