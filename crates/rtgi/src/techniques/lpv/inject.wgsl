// Injection (prepended: volume.wgsl and the RSM reader). Every RSM texel of every layer becomes a
// virtual point light of intensity I_p ⟨n_p, ω⟩⁺ in the cell holding its position shifted half a cell
// along its normal (the paper's guard against lighting its own surface), in every cascade that holds
// it; with GEOMETRY_VOLUME it also adds its surface's blocking potential to the geometry volume, and
// `inject_gbuffer` adds the camera's visible surfaces.
//
// Many texels land in one cell, and WGSL has no float atomics: the sums are fixed-point i32 atomics,
// which add exactly in any order, so the volumes are the same whatever order the threads run in.
// Light uses a scale measured on the GPU each frame (`measure_flux`): the largest possible sum of one
// coefficient over all texels maps to 2^30, so no sum can overflow. Blocking potentials (areas in cell
// faces, at most a few per cell) use the constant BLOCKING_SCALE, and so do the area-weighted albedo sums
// of MULTIPLE_BOUNCES (an albedo is at most 1, so they stay below the area's own sum).

#import common/lights.wgsl
#import common/indirect.wgsl

@group(2) @binding(1) var<storage, read_write> light_fixed: array<atomic<i32>>;
@group(2) @binding(2) var<storage, read_write> blocking_fixed: array<atomic<i32>>;
@group(2) @binding(7) var<storage, read_write> flux_scale: array<f32>;

const FLUX_THREADS: u32 = 256u;
const FIXED_RANGE: f32 = 1073741824.0;
var<workgroup> partial: array<f32, FLUX_THREADS>;

// The largest |coefficient| of the cosine lobe of unit intensity (band 1 on its axis).
fn lobe_bound() -> f32 {
    let c = sh4_cosine_lobe(vec3f(0.0, 0.0, 1.0));
    return max(c.x, c.z);
}

// The RSM's summed largest channel in two dispatches of a fixed shape, so the sum is reduced in the
// same order on every run (deterministic): FLUX_GROUPS workgroups each reduce a strided share into
// flux_scale[1 + group], then one workgroup reduces those into the scale at flux_scale[0].
fn reduce_partial(t: u32) {
    for (var stride = FLUX_THREADS / 2u; stride > 0u; stride /= 2u) {
        workgroupBarrier();
        if t < stride {
            partial[t] += partial[t + stride];
        }
    }
}

@compute @workgroup_size(FLUX_THREADS)
fn measure_flux(@builtin(local_invocation_index) t: u32, @builtin(workgroup_id) group: vec3u) {
    let n = rsm_texel_count();
    var sum = 0.0;
    for (var i = group.x * FLUX_THREADS + t; i < n; i += FLUX_THREADS * FLUX_GROUPS) {
        let c = texel_of(i);
        let p = load_pixel_light(c.xy, c.z);
        if p.valid {
            sum += max(max3(p.intensity), 0.0);
        }
    }
    partial[t] = sum;
    reduce_partial(t);
    if t == 0u {
        flux_scale[1u + group.x] = partial[0];
    }
}

@compute @workgroup_size(FLUX_THREADS)
fn flux_scale_from_partials(@builtin(local_invocation_index) t: u32) {
    partial[t] = select(0.0, flux_scale[1u + t], t < FLUX_GROUPS);
    reduce_partial(t);
    if t == 0u {
        let bound = partial[0] * lobe_bound();
        flux_scale[0] = select(0.0, FIXED_RANGE / bound, bound > 0.0);
    }
}

fn add_fixed_light(base: u32, c: vec4f) {
    for (var k = 0u; k < 4u; k++) {
        atomicAdd(&light_fixed[base + k], i32(round(c[k])));
    }
}

// Blocking of a surface of area `area` (facing n, diffuse albedo `albedo`) in cascade `cascade`:
// area / cell face × ⟨−n, ω⟩⁺, the fraction of a cell's cross-section it covers for light travelling in
// direction ω towards its front; `source` 0 = the RSMs, 1 = the G-buffer (kept apart and merged by
// `resolve`). With MULTIPLE_BOUNCES the albedo is summed weighted by the covered fraction (both sources
// together: a mean, so a surface seen twice does not count double).
fn add_blocking(cascade: u32, position: vec3f, normal: vec3f, area: f32, albedo: vec3f, source: u32) {
    let g = round(grid_position(cascade, position));
    if any(g < vec3f(0.0)) || any(g > vec3f(f32(GRID))) {
        return;
    }
    let s = cell_size(cascade);
    let covered = area / (s * s) * BLOCKING_SCALE;
    let b = sh4_cosine_lobe(-normal) * covered;
    let base = geometry_index(cascade, vec3u(g)) * GEOMETRY_SUMS;
    for (var k = 0u; k < 4u; k++) {
        atomicAdd(&blocking_fixed[base + source * 4u + k], i32(round(b[k])));
    }
    if MULTIPLE_BOUNCES {
        let rho = clamp(albedo, vec3f(0.0), vec3f(1.0));
        let a = vec4f(rho, 1.0) * covered;
        for (var k = 0u; k < 4u; k++) {
            atomicAdd(&blocking_fixed[base + 8u + k], i32(round(a[k])));
        }
    }
}

@compute @workgroup_size(64)
fn inject_rsm(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = indirect_linear_index(gid, groups, 64u);
    if i >= rsm_texel_count() {
        return;
    }
    let c = texel_of(i);
    let p = load_pixel_light(c.xy, c.z);
    if !p.valid {
        return;
    }
    let lobe = sh4_cosine_lobe(p.normal) * flux_scale[0];
    // The texel's beam cross-section over the cosine of incidence: its area on the surface (the cosine
    // bounded against grazing texels).
    var surface_area = 0.0;
    var albedo = vec3f(0.0);
    if GEOMETRY_VOLUME {
        let incidence = light_incidence(lights[rsm_views[c.z].light], p.position);
        surface_area = p.area / max(dot(p.normal, incidence.direction), 0.25);
        // The RSM stores the reflected intensity I = E·A·ρ/π (map.wgsl): the albedo is recovered from
        // the light's irradiance across the texel's beam.
        let arriving = incidence.irradiance * p.area;
        albedo = select(vec3f(0.0), PI * p.intensity / arriving, arriving > vec3f(0.0));
    }
    for (var k = 0u; k < lpv.cascade_count; k++) {
        let g = grid_position(k, p.position + 0.5 * cell_size(k) * p.normal);
        if inside_grid(g) {
            let base = cell_index(k, vec3u(g)) * 12u;
            add_fixed_light(base, lobe * p.intensity.r);
            add_fixed_light(base + 4u, lobe * p.intensity.g);
            add_fixed_light(base + 8u, lobe * p.intensity.b);
        }
        if GEOMETRY_VOLUME {
            add_blocking(k, p.position, p.normal, surface_area, albedo, 0u);
        }
    }
}

// The camera's surfaces as blockers: a pixel covers distance² × its solid angle / cos on the surface.
@compute @workgroup_size(TILE, TILE)
fn inject_gbuffer(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    let s = load_gsurface(id.xy);
    if !s.valid {
        return;
    }
    let centre = vec2f(id.xy) + 0.5 + frame.jitter;
    let d0 = primary_ray_through(centre);
    let solid_angle = length(cross(primary_ray_through(centre + vec2f(1.0, 0.0)) - d0,
                                   primary_ray_through(centre + vec2f(0.0, 1.0)) - d0));
    // Facing the camera: the side it blocks light towards.
    let n = select(s.geometric_normal, -s.geometric_normal, dot(s.geometric_normal, s.view) < 0.0);
    let cosine = max(abs(dot(n, s.view)), 0.25);
    let area = s.distance * s.distance * solid_angle / cosine;
    let albedo = s.material.base_color * (1.0 - s.material.metallic);
    for (var k = 0u; k < lpv.cascade_count; k++) {
        add_blocking(k, s.position, n, area, albedo, 1u);
    }
}
