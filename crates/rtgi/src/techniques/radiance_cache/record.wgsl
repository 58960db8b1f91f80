// Record computation: one workgroup per record of this round, at the pixel the placement picked. The
// hemisphere above the surface is sampled by SAMPLES_THETA × SAMPLES_PHI rays, one per cell of Ward &
// Heckbert's (1992) stratification (cos² θ uniform in θ, φ uniform), jittered in the cell, traced
// through the shared BVH (rtgi samples the whole hemisphere with rays, so the thesis's single raster
// plane and its border stretching are not needed). A hit returns the direct light its surface reflects
// towards the record (shadow rays, one area-light and one environment sample): one bounce of indirect
// light, as in the thesis; emitters seen directly and misses add nothing, the `direct` pass has them.
// Thread 0 then sums irradiance, the harmonic mean distance and the two gradients. A record placed on a
// glossy surface is a radiance record: the threads also project the cells onto the HSH of the
// record's frame, each thread its coefficients, with per-coefficient translational gradients by
// Ward & Heckbert's boundary terms with the basis function in place of cos θ (see project_radiance).

#import common/direct_light.wgsl

const RECORD_THREADS: u32 = 64u;
const CELLS: u32 = SAMPLES_THETA * SAMPLES_PHI;

var<workgroup> cell_radiance: array<vec3f, CELLS>;
// 1 / hit distance (0 for rays that leave the scene).
var<workgroup> cell_inverse_distance: array<f32, CELLS>;

fn cell_index(j: u32, k: u32) -> u32 {
    return j * SAMPLES_PHI + k;
}

// The direction (record frame) of a ray in cell `cell`, jittered by the next two numbers of `rng`.
fn cell_direction(cell: u32, rng: ptr<function, Rng>) -> vec3f {
    let u = rng_next2(rng);
    let sin2 = (f32(cell / SAMPLES_PHI) + u.x) / f32(SAMPLES_THETA);
    let phi = 2.0 * PI * (f32(cell % SAMPLES_PHI) + u.y) / f32(SAMPLES_PHI);
    let sin_theta = sqrt(sin2);
    return vec3f(sin_theta * cos(phi), sin_theta * sin(phi), sqrt(max(0.0, 1.0 - sin2)));
}

// HSH coefficient i of the incoming radiance of record k and its translational gradient, written to
// `radiance`. The cells' radiance is taken as constant over each cell, as Ward & Heckbert's gradients
// take it: λ_i = Σ L_cell ∫_cell H_i, and the boundary terms weigh the radiance steps with the basis
// integrated along the boundary (cell_harmonics, from the host) where Ward's irradiance weighs them
// with cos θ. With cos θ in the HSH span, Σ_i (∫ H_i cos) λ_i is the irradiance record's E exactly.
fn project_radiance(k: u32, i: u32) {
    var lambda = vec3f(0.0);
    var gradient_x = vec3f(0.0);
    var gradient_y = vec3f(0.0);
    for (var c = 0u; c < SAMPLES_PHI; c++) {
        let phi_centre = 2.0 * PI * (f32(c) + 0.5) / f32(SAMPLES_PHI);
        let phi_minus = 2.0 * PI * f32(c) / f32(SAMPLES_PHI);
        let previous_c = (c + SAMPLES_PHI - 1u) % SAMPLES_PHI;
        for (var j = 0u; j < SAMPLES_THETA; j++) {
            let here = cell_index(j, c);
            let h = 3u * (here * radiance_coefficients() + i);
            let l = cell_radiance[here];
            lambda += l * cell_harmonics[h];
            // Across the boundary with the previous θ cell (at θ_j−), along u at the cell's φ.
            if j > 0u {
                let below = cell_index(j - 1u, c);
                let across_theta = cell_harmonics[h + 1u]
                    * max(cell_inverse_distance[here], cell_inverse_distance[below]) * (l - cell_radiance[below]);
                gradient_x += cos(phi_centre) * across_theta;
                gradient_y += sin(phi_centre) * across_theta;
            }
            // Across the boundary with the previous φ cell (at φ_c−), along v there.
            let side = cell_index(j, previous_c);
            let across_phi = cell_harmonics[h + 2u]
                * max(cell_inverse_distance[here], cell_inverse_distance[side]) * (l - cell_radiance[side]);
            gradient_x -= sin(phi_minus) * across_phi;
            gradient_y += cos(phi_minus) * across_phi;
        }
    }
    let g = select(0.0, 1.0, GRADIENTS);
    let e = radiance_index(k, i);
    radiance[e] = lambda.x;
    radiance[e + 1u] = lambda.y;
    radiance[e + 2u] = lambda.z;
    radiance[e + 3u] = g * gradient_x.x;
    radiance[e + 4u] = g * gradient_x.y;
    radiance[e + 5u] = g * gradient_x.z;
    radiance[e + 6u] = g * gradient_y.x;
    radiance[e + 7u] = g * gradient_y.y;
    radiance[e + 8u] = g * gradient_y.z;
}

@compute @workgroup_size(RECORD_THREADS, 1, 1)
fn compute_record(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) thread: u32) {
    let slot = group.x;
    let k = state.splat_begin + slot;
    let packed = new_pixels[slot];
    let pixel = vec2u(packed & 0xffffu, packed >> 16u);
    let s = load_gsurface(pixel);
    let origin = gsurface_ray_origin(s);
    for (var cell = thread; cell < CELLS; cell += RECORD_THREADS) {
        var rng = rng_new(vec2u(k, cell), 0u, hash2(SEED, 0x72637264u));
        let dir = local_to_world(cell_direction(cell, &rng), s.normal);
        let hit = trace_closest(Ray(origin, dir), 0.0, FLT_MAX);
        var radiance = vec3f(0.0);
        var inverse_distance = 0.0;
        if hit.t < FLT_MAX {
            inverse_distance = 1.0 / max(hit.t, 1e-6);
            if !hits_back_face(hit.triangle, hit.u, hit.v, dir) {
                let h = hit_gsurface(surface_at(hit.triangle, hit.u, hit.v, dir), -dir, hit.t);
                radiance = direct_light(h, offset_origin(h.position, h.geometric_normal), &rng, 1u, 1u, true);
            }
        }
        cell_radiance[cell] = radiance;
        cell_inverse_distance[cell] = inverse_distance;
    }
    workgroupBarrier();
    let glossy = is_glossy(s.material);
    if glossy {
        for (var i = thread; i < radiance_coefficients(); i += RECORD_THREADS) {
            project_radiance(k, i);
        }
    }
    if thread != 0u {
        return;
    }

    let m = f32(SAMPLES_THETA);
    let n = f32(SAMPLES_PHI);
    var irradiance = vec3f(0.0);
    var inverse_sum = 0.0;
    // Columns: the gradient vectors (local frame) of the red, green and blue irradiance.
    var rotation = mat3x3f(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    var translation = mat3x3f(vec3f(0.0), vec3f(0.0), vec3f(0.0));
    for (var c = 0u; c < SAMPLES_PHI; c++) {
        let phi = 2.0 * PI * (f32(c) + 0.5) / n;
        let u_k = vec3f(cos(phi), sin(phi), 0.0);
        let v_k = vec3f(-sin(phi), cos(phi), 0.0);
        let phi_minus = 2.0 * PI * f32(c) / n;
        let v_minus = vec3f(-sin(phi_minus), cos(phi_minus), 0.0);
        let previous_c = (c + SAMPLES_PHI - 1u) % SAMPLES_PHI;
        var tan_sum = vec3f(0.0);
        for (var j = 0u; j < SAMPLES_THETA; j++) {
            let here = cell_index(j, c);
            let l = cell_radiance[here];
            irradiance += l;
            inverse_sum += cell_inverse_distance[here];
            let sin2_centre = (f32(j) + 0.5) / m;
            tan_sum -= sqrt(sin2_centre / (1.0 - sin2_centre)) * l;
            // Across the boundary with the previous φ cell (at φ_k−, over θ_j− ... θ_j+).
            let side = cell_index(j, previous_c);
            let sin_step = sqrt((f32(j) + 1.0) / m) - sqrt(f32(j) / m);
            let across_phi = sin_step * max(cell_inverse_distance[here], cell_inverse_distance[side])
                * (l - cell_radiance[side]);
            translation += mat3x3f(v_minus * across_phi.x, v_minus * across_phi.y, v_minus * across_phi.z);
            // Across the boundary with the previous θ cell (at θ_j−).
            if j > 0u {
                let below = cell_index(j - 1u, c);
                let sin2_minus = f32(j) / m;
                let across_theta = (2.0 * PI / n) * sqrt(sin2_minus) * (1.0 - sin2_minus)
                    * max(cell_inverse_distance[here], cell_inverse_distance[below])
                    * (l - cell_radiance[below]);
                translation += mat3x3f(u_k * across_theta.x, u_k * across_theta.y, u_k * across_theta.z);
            }
        }
        rotation += mat3x3f(v_k * tan_sum.x, v_k * tan_sum.y, v_k * tan_sum.z);
    }
    let scale = PI / (m * n);
    irradiance *= scale;
    rotation = rotation * scale;

    // R: the harmonic mean distance, its zone a·R clamped to [MIN_ZONE_PIXELS, MAX_ZONE_PIXELS] pixels
    // of this view (the thesis does not clamp; without a floor, corners fill with tiny records).
    let footprint = s.distance
        * length(primary_ray_through(vec2f(pixel) + vec2f(1.5, 0.5)) - primary_ray_through(vec2f(pixel) + 0.5));
    let harmonic = select(3.0e38, f32(CELLS) / inverse_sum, inverse_sum > 0.0);
    let accuracy = kind_accuracy(glossy);
    let radius = clamp(harmonic, MIN_ZONE_PIXELS * footprint / accuracy, MAX_ZONE_PIXELS * footprint / accuracy);

    var r: Record;
    r.position_radius = vec4f(s.position, radius);
    r.normal = vec4f(s.normal, select(0.0, 1.0, glossy));
    r.irradiance = vec4f(irradiance, 0.0);
    for (var ch = 0u; ch < 3u; ch++) {
        let g = select(0.0, 1.0, GRADIENTS);
        r.rotation[ch] = vec4f(g * local_to_world(rotation[ch], s.normal), 0.0);
        r.translation[ch] = vec4f(g * local_to_world(translation[ch], s.normal), 0.0);
    }
    records[k] = r;
}
