// The tables of the basis-space environment integration (seed 003, article 2, part b: Gamboa, Guertin
// & Nowrouzezahrai 2018, §3.5), computed on the GPU once per environment:
//
// `lobe`: the zonal-harmonic coefficients of the GGX distribution of each microfacet,
//   k_l(α) = 2π ∫₀¹ D_α(μ) P_l(μ) dμ = √(4π / (2l+1)) f_l, for ENV_ROUGHNESS_STEPS roughness values
//   spread evenly over [0, 1] (α from `ggx_alpha`, D from `ggx_d`: the BRDF library's own lobe), so a
//   bin of normal n contributes Σ_lm k_l L̂_lm y_lm(n) to ∫ L̂(h) D(h·n) dh (Funk–Hecke).
// `basis`: the real SH (common/hsh.wgsl's, order ENV_ORDER) at the half-vector quadrature's directions,
//   ENV_H_BANDS bands of equal area in z × 2 ENV_H_BANDS steps in φ.
// `project`: for every view direction v of a latitude–longitude grid (ENV_VIEW_ROWS rows from the
//   pole +z to −z, poles included, × ENV_VIEW_COLUMNS columns), the SH coefficients over the half
//   vector h of the half-vector-space lighting L̂(v, h) = L(2(v·h)h − v) · 4 (v·h)⁺ (the Jacobian of
//   reflection in L̂, as the paper's Eq. 47), in the environment's own frame, so a turning environment
//   only turns the lookups. One workgroup per (view, block of 64 coefficients): each step lights 64
//   half vectors into workgroup memory, then every invocation adds them against its coefficient's
//   basis values.

#import common/environment.wgsl
#import common/hsh.wgsl
#import common/brdf.wgsl

@group(2) @binding(0) var<storage, read_write> lobe_zh: array<f32>;
@group(2) @binding(1) var<storage, read_write> basis: array<f32>;
@group(2) @binding(2) var<storage, read_write> table: array<vec4f>;

const ENV_COEFFICIENTS: u32 = ENV_ORDER * ENV_ORDER;
const ENV_H_DIRECTIONS: u32 = 2u * ENV_H_BANDS * ENV_H_BANDS;
// Midpoint steps of the lobe integral, in s with θ = (π/2) s², dense where the lobe is narrow (2048
// agree with 65536 to 1e-7 down to the smallest α). lavapipe ends a loop after 65535 iterations counted
// over the whole invocation, an inner loop's included: steps × (order + 1) must stay below that.
const LOBE_STEPS: u32 = 2048u;

fn half_vector_direction(k: u32) -> vec3f {
    let band = k / (2u * ENV_H_BANDS);
    let step = k % (2u * ENV_H_BANDS);
    let z = 1.0 - 2.0 * (f32(band) + 0.5) / f32(ENV_H_BANDS);
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = PI * (f32(step) + 0.5) / f32(ENV_H_BANDS);
    return vec3f(r * cos(phi), r * sin(phi), z);
}

// One invocation per (roughness step, band l).
@compute @workgroup_size(64)
fn lobe(@builtin(global_invocation_id) id: vec3u) {
    let index = id.x;
    if index >= ENV_ROUGHNESS_STEPS * ENV_ORDER {
        return;
    }
    let roughness = f32(index / ENV_ORDER) / f32(ENV_ROUGHNESS_STEPS - 1u);
    let l = index % ENV_ORDER;
    let alpha = ggx_alpha(roughness);
    var sum = 0.0;
    for (var i = 0u; i < LOBE_STEPS; i++) {
        let s = (f32(i) + 0.5) / f32(LOBE_STEPS);
        let theta = 0.5 * PI * s * s;
        let mu = cos(theta);
        // P_l(μ) by Bonnet's recurrence.
        var p_prev = 1.0;
        var p = mu;
        if l == 0u {
            p = 1.0;
        }
        for (var j = 2u; j <= l; j++) {
            let next = (f32(2u * j - 1u) * mu * p - f32(j - 1u) * p_prev) / f32(j);
            p_prev = p;
            p = next;
        }
        // dμ = sin θ dθ, dθ = π s ds.
        sum += ggx_d(alpha, mu) * p * sin(theta) * PI * s;
    }
    lobe_zh[index] = TWO_PI * sum / f32(LOBE_STEPS);
}

// One invocation per (half-vector direction, coefficient).
@compute @workgroup_size(64)
fn basis_values(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let index = id.x + id.y * groups.x * 64u;
    if index >= ENV_H_DIRECTIONS * ENV_COEFFICIENTS {
        return;
    }
    basis[index] = sh_one(index % ENV_COEFFICIENTS, half_vector_direction(index / ENV_COEFFICIENTS));
}

fn view_direction(view: u32) -> vec3f {
    let row = view / ENV_VIEW_COLUMNS;
    let column = view % ENV_VIEW_COLUMNS;
    let theta = PI * f32(row) / f32(ENV_VIEW_ROWS - 1u);
    let phi = TWO_PI * f32(column) / f32(ENV_VIEW_COLUMNS);
    return vec3f(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

var<workgroup> lit: array<vec3f, 64>;

// Workgroup (x, y): coefficients 64x .. 64x + 63 of view y.
@compute @workgroup_size(64)
fn project(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) local: u32) {
    let view = group.y;
    let k = group.x * 64u + local;
    let v = view_direction(view);
    var sum = vec3f(0.0);
    let chunks = (ENV_H_DIRECTIONS + 63u) / 64u;
    for (var chunk = 0u; chunk < chunks; chunk++) {
        let own = chunk * 64u + local;
        var light = vec3f(0.0);
        if own < ENV_H_DIRECTIONS {
            let h = half_vector_direction(own);
            let c = dot(v, h);
            if c > 0.0 {
                light = environment_radiance_unrotated(2.0 * c * h - v) * (4.0 * c);
            }
        }
        lit[local] = light;
        workgroupBarrier();
        if k < ENV_COEFFICIENTS {
            let last = min(64u, ENV_H_DIRECTIONS - chunk * 64u);
            for (var j = 0u; j < last; j++) {
                sum += lit[j] * basis[(chunk * 64u + j) * ENV_COEFFICIENTS + k];
            }
        }
        workgroupBarrier();
    }
    if k < ENV_COEFFICIENTS {
        table[view * ENV_COEFFICIENTS + k] = vec4f(sum * (4.0 * PI / f32(ENV_H_DIRECTIONS)), 0.0);
    }
}
