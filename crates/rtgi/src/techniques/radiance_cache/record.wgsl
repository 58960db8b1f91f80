// Record computation: one workgroup per record of this round, at the pixel the placement picked. The
// hemisphere above the surface is sampled by SAMPLES_THETA × SAMPLES_PHI rays, one per cell of Ward &
// Heckbert's (1992) stratification (cos² θ uniform in θ, φ uniform), jittered in the cell, traced
// through the shared BVH (rtgi samples the whole hemisphere with rays, so the thesis's single raster
// plane and its border stretching are not needed). A hit returns the direct light its surface reflects
// towards the record (shadow rays, one area-light and one environment sample): one bounce of indirect
// light, as in the thesis; emitters seen directly and misses add nothing, the `direct` pass has them.
// Thread 0 then sums irradiance, the harmonic mean distance and the two gradients.

#import common/direct_light.wgsl

const RECORD_THREADS: u32 = 64u;
const CELLS: u32 = SAMPLES_THETA * SAMPLES_PHI;

var<workgroup> cell_radiance: array<vec3f, CELLS>;
// 1 / hit distance (0 for rays that leave the scene).
var<workgroup> cell_inverse_distance: array<f32, CELLS>;

fn cell_index(j: u32, k: u32) -> u32 {
    return j * SAMPLES_PHI + k;
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
        let u = rng_next2(&rng);
        let sin2 = (f32(cell / SAMPLES_PHI) + u.x) / f32(SAMPLES_THETA);
        let phi = 2.0 * PI * (f32(cell % SAMPLES_PHI) + u.y) / f32(SAMPLES_PHI);
        let sin_theta = sqrt(sin2);
        let local = vec3f(sin_theta * cos(phi), sin_theta * sin(phi), sqrt(max(0.0, 1.0 - sin2)));
        let dir = local_to_world(local, s.normal);
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
    let radius = clamp(harmonic, MIN_ZONE_PIXELS * footprint / ACCURACY, MAX_ZONE_PIXELS * footprint / ACCURACY);

    var r: Record;
    r.position_radius = vec4f(s.position, radius);
    r.normal = vec4f(s.normal, 0.0);
    r.irradiance = vec4f(irradiance, 0.0);
    for (var ch = 0u; ch < 3u; ch++) {
        let g = select(0.0, 1.0, GRADIENTS);
        r.rotation[ch] = vec4f(g * local_to_world(rotation[ch], s.normal), 0.0);
        r.translation[ch] = vec4f(g * local_to_world(translation[ch], s.normal), 0.0);
    }
    records[k] = r;
}
