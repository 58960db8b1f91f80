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
//
// In temporal mode (`radiance-cache-temporal`) the pass also predicts the record one time step
// ahead, as Gautron et al. (2006) do on the GPU: every hit is moved with its mesh to the next frame's
// pose and shaded there (direct_light_pair: the next frame's lights, this frame's visibility), then
// reprojected onto the record's hemisphere, which stays where it is; the nearest point wins a cell (a
// z-buffer of atomic minima), cells no point reaches take the farthest of their neighbours (the
// thesis's hole filling with the background). The same sums then give the predicted record (plane 1),
// the change between the two its lifespan: a_t / change frames, at most MAX_LIFESPAN.

#import common/direct_light_prediction.wgsl
#import common/mesh_of_triangle.wgsl

const RECORD_THREADS: u32 = 64u;
const CELLS: u32 = SAMPLES_THETA * SAMPLES_PHI;

var<workgroup> cell_radiance: array<vec3f, CELLS>;
// 1 / hit distance (0 for rays that leave the scene).
var<workgroup> cell_inverse_distance: array<f32, CELLS>;
// Temporal mode (NEXT_CELLS = CELLS, else 1): per cell, the predicted radiance of its hit (indexed by
// the cell the ray left through), and the z-buffer of the reprojection (indexed by the cell a moved
// hit lands in): the landing hit's distance bits above its source cell, NO_LANDING or BACKGROUND.
var<workgroup> next_radiance: array<vec3f, NEXT_CELLS>;
var<workgroup> next_key: array<atomic<u32>, NEXT_CELLS>;
// The largest relative change of a radiance record's coefficients (f32 bits).
var<workgroup> coefficient_change: atomic<u32>;

const NO_LANDING: u32 = 0xffffffffu;
// A cell whose ray left the scene and where no moved hit lands: it still sees the background.
const BACKGROUND: u32 = 0xfffffffeu;
const SOURCE_BITS: u32 = 0x3ffu;

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
fn project_radiance(k: u32, i: u32, plane: u32) {
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
    let e = radiance_index(k, i, plane);
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

// Where a record sits and what it serves.
struct RecordSurface {
    position: vec3f,
    normal: vec3f,
    geometric_normal: vec3f,
    // Where its rays leave from (off the surface).
    origin: vec3f,
    glossy: bool,
    // World size of a pixel at the record in the view that placed it (bounds its zone).
    footprint: f32,
}

// The random numbers of a record's rays follow its position, not its slot: a record recomputed where
// it is draws the same rays (no change where nothing changed), wherever compaction moved it.
fn record_seed(rs: RecordSurface) -> u32 {
    let p = bitcast<vec3u>(rs.position);
    return hash3(p.x, p.y, p.z);
}

// The cell of a direction in the record's frame (z > 0).
fn cell_of(local: vec3f) -> u32 {
    let sin2 = max(0.0, 1.0 - local.z * local.z);
    let j = min(u32(sin2 * f32(SAMPLES_THETA)), SAMPLES_THETA - 1u);
    var phi = atan2(local.y, local.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let c = min(u32(phi / (2.0 * PI) * f32(SAMPLES_PHI)), SAMPLES_PHI - 1u);
    return cell_index(j, c);
}

// A cell's ray: where it hits (`hit.t` FLT_MAX where it leaves the scene), the surface there seen from
// the record, whether the ray met its front and where that surface's rays leave from. `rng` continues
// with the hit's shading.
struct CellRay {
    hit: Hit,
    surface: GSurface,
    front: bool,
    origin: vec3f,
}

fn trace_cell_ray(rs: RecordSurface, cell: u32, rng: ptr<function, Rng>) -> CellRay {
    let dir = local_to_world(cell_direction(cell, rng), rs.normal);
    var ray: CellRay;
    ray.hit = trace_closest(Ray(rs.origin, dir), 0.0, FLT_MAX);
    if ray.hit.t < FLT_MAX {
        ray.surface = hit_gsurface(surface_at(ray.hit.triangle, ray.hit.u, ray.hit.v, dir), -dir, ray.hit.t);
        ray.front = !hits_back_face(ray.hit.triangle, ray.hit.u, ray.hit.v, dir);
        ray.origin = offset_origin(ray.surface.position, ray.surface.geometric_normal);
    }
    return ray;
}

fn cell_rng(rs: RecordSurface, cell: u32) -> Rng {
    return rng_new(vec2u(record_seed(rs), cell), 0u, hash2(SEED, 0x72637264u));
}

// Outside temporal mode: the radiance arriving through a cell (rgb) and 1 / its ray's hit distance
// (a; 0 for a ray that leaves the scene). The hit returns the direct light it reflects towards the
// record, and in `photon-irradiance-cache` also the light that reached it after bounces, from the
// photon map (a final gather: the photons' noise is averaged over the record's rays).
fn traced_cell(rs: RecordSurface, cell: u32) -> vec4f {
    var rng = cell_rng(rs, cell);
    let ray = trace_cell_ray(rs, cell, &rng);
    if ray.hit.t == FLT_MAX {
        return vec4f(0.0);
    }
    var radiance = vec3f(0.0);
    if ray.front {
        let h = ray.surface;
        radiance = direct_light(h, ray.origin, &rng, 1u, 1u, true);
        if PHOTONS {
            radiance += photon_radiance(h.position, h.normal, h.view, h.material);
        }
    }
    return vec4f(radiance, 1.0 / max(ray.hit.t, 1e-6));
}

// Traces the cells of the record (this thread's share) into cell_radiance / cell_inverse_distance;
// in temporal mode also predicts each hit and lands it in the z-buffer. With PHOTON_RECORDS the cells
// come from the photon map instead (photon_record.wgsl; every thread must call it); with PHOTONS
// alone (the final gather) the record-ray pass traced them, one invocation per ray: a lookup reads
// the photons of eight grid cells, a few thousand on a lit wall, and a thread with several rays would
// run past the 65535 loop iterations lavapipe allows an invocation.
fn trace_cells(k: u32, rs: RecordSurface, thread: u32) {
    if PHOTON_RECORDS {
        gather_photon_cells(rs, thread);
        return;
    }
    if PHOTONS {
        let first = (k - state.splat_begin) * CELLS;
        for (var cell = thread; cell < CELLS; cell += RECORD_THREADS) {
            let traced = gathered_cells[first + cell];
            cell_radiance[cell] = traced.rgb;
            cell_inverse_distance[cell] = traced.a;
        }
        return;
    }
    for (var cell = thread; cell < CELLS; cell += RECORD_THREADS) {
        if !TEMPORAL {
            let traced = traced_cell(rs, cell);
            cell_radiance[cell] = traced.rgb;
            cell_inverse_distance[cell] = traced.a;
            continue;
        }
        var rng = cell_rng(rs, cell);
        let ray = trace_cell_ray(rs, cell, &rng);
        var radiance = vec3f(0.0);
        var inverse_distance = 0.0;
        if ray.hit.t < FLT_MAX {
            inverse_distance = 1.0 / max(ray.hit.t, 1e-6);
            let h = ray.surface;
            let motion = next_motion[mesh_of_triangle(ray.hit.triangle)];
            var moved = h;
            moved.position = (motion * vec4f(h.position, 1.0)).xyz;
            moved.normal = normalize((motion * vec4f(h.normal, 0.0)).xyz);
            moved.geometric_normal = normalize((motion * vec4f(h.geometric_normal, 0.0)).xyz);
            // Seen from where the rays leave, so that a hit that does not move lands in its own cell.
            let to_record = rs.origin - moved.position;
            moved.view = normalize(to_record);
            // A hit that stays put under lights that stay put is lit the same next frame: shade it once.
            let still = all(motion[0] == vec4f(1.0, 0.0, 0.0, 0.0)) && all(motion[1] == vec4f(0.0, 1.0, 0.0, 0.0))
                && all(motion[2] == vec4f(0.0, 0.0, 1.0, 0.0)) && all(motion[3] == vec4f(0.0, 0.0, 0.0, 1.0));
            var predicted = vec3f(0.0);
            if ray.front && still && cache_uniforms.lights_move == 0u {
                radiance = direct_light(h, ray.origin, &rng, 1u, 1u, true);
                predicted = radiance;
            } else if ray.front {
                let pair = direct_light_pair(
                    h, moved, ray.origin, offset_origin(moved.position, moved.geometric_normal), &rng, 1u, 1u,
                );
                radiance = pair.now;
                predicted = pair.next;
            }
            next_radiance[cell] = predicted;
            let local = world_to_local(-to_record, rs.normal);
            let distance = length(to_record);
            if local.z > 0.0 && distance > 0.0 {
                let key = (bitcast<u32>(distance) & ~SOURCE_BITS) | cell;
                atomicMin(&next_key[cell_of(local / distance)], key);
            }
        } else {
            atomicMin(&next_key[cell], BACKGROUND);
        }
        cell_radiance[cell] = radiance;
        cell_inverse_distance[cell] = inverse_distance;
    }
}

// Temporal mode: replaces this thread's cells by the prediction: the landing hit's radiance and
// distance; the background where nothing lands on a cell that saw it; in a hole, the farthest landed
// neighbour (θ ± 1, φ ± 1; the background is the farthest); the cell as it is where no neighbour landed.
fn resolve_prediction(rs: RecordSurface, thread: u32) {
    for (var cell = thread; cell < CELLS; cell += RECORD_THREADS) {
        var key = atomicLoad(&next_key[cell]);
        if key == NO_LANDING {
            let j = cell / SAMPLES_PHI;
            let c = cell % SAMPLES_PHI;
            var neighbours = array<u32, 4>(
                cell_index(j, (c + 1u) % SAMPLES_PHI),
                cell_index(j, (c + SAMPLES_PHI - 1u) % SAMPLES_PHI),
                cell_index(min(j + 1u, SAMPLES_THETA - 1u), c),
                cell_index(select(j - 1u, 0u, j == 0u), c),
            );
            for (var n = 0u; n < 4u; n++) {
                let other = atomicLoad(&next_key[neighbours[n]]);
                // Keys order by distance, so the farthest landed neighbour has the largest key
                // short of NO_LANDING (BACKGROUND beats every landed hit).
                if other != NO_LANDING && (key == NO_LANDING || other > key) {
                    key = other;
                }
            }
        }
        if key == BACKGROUND {
            cell_radiance[cell] = vec3f(0.0);
            cell_inverse_distance[cell] = 0.0;
        } else if key != NO_LANDING {
            cell_radiance[cell] = next_radiance[key & SOURCE_BITS];
            cell_inverse_distance[cell] = 1.0 / max(bitcast<f32>(key & ~SOURCE_BITS), 1e-6);
        }
    }
}

// The irradiance record of the traced cells (thread 0): irradiance, gradients and R.
fn irradiance_record(rs: RecordSurface) -> Record {
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
    // of the placing view (the thesis does not clamp; without a floor, corners fill with tiny records).
    var harmonic = select(3.0e38, f32(CELLS) / inverse_sum, inverse_sum > 0.0);
    if PHOTON_RECORDS {
        // From the photons' own distances: their cells' means would count empty cells as far.
        harmonic = photon_gather.x;
    }
    let accuracy = kind_accuracy(rs.glossy);
    let radius =
        clamp(harmonic, MIN_ZONE_PIXELS * rs.footprint / accuracy, MAX_ZONE_PIXELS * rs.footprint / accuracy);

    var r: Record;
    r.position_radius = vec4f(rs.position, radius);
    r.normal = vec4f(rs.normal, select(0.0, 1.0, rs.glossy));
    r.irradiance = vec4f(irradiance, rs.footprint);
    for (var ch = 0u; ch < 3u; ch++) {
        let g = select(0.0, 1.0, GRADIENTS);
        r.rotation[ch] = vec4f(g * local_to_world(rotation[ch], rs.normal), 0.0);
        r.translation[ch] = vec4f(g * local_to_world(translation[ch], rs.normal), 0.0);
    }
    return r;
}

// The largest change of coefficient i (of this thread's) between the record and its prediction,
// relative to the record's mean radiance (λ_0): the thesis's max_i λ_1^i / λ_0^i, which is unbounded
// where a coefficient is near 0.
fn note_coefficient_change(k: u32, i: u32) {
    let e0 = radiance_index(k, i, 0u);
    let e1 = radiance_index(k, i, 1u);
    let base = radiance_index(k, 0u, 0u);
    let mean = max(max3(abs(vec3f(radiance[base], radiance[base + 1u], radiance[base + 2u]))), 1e-20);
    let change = abs(vec3f(radiance[e1], radiance[e1 + 1u], radiance[e1 + 2u]) - vec3f(radiance[e0], radiance[e0 + 1u], radiance[e0 + 2u]));
    atomicMax(&coefficient_change, bitcast<u32>(max3(change) / mean));
}

// Computes record k at rs (every thread of the workgroup calls it): plane 0, and in temporal mode
// plane 1 and the lifespan.
fn build_record(k: u32, rs: RecordSurface, thread: u32) {
    if TEMPORAL {
        for (var cell = thread; cell < CELLS; cell += RECORD_THREADS) {
            atomicStore(&next_key[cell], NO_LANDING);
        }
        if thread == 0u {
            atomicStore(&coefficient_change, 0u);
        }
        workgroupBarrier();
    }
    trace_cells(k, rs, thread);
    workgroupBarrier();
    if rs.glossy {
        for (var i = thread; i < radiance_coefficients(); i += RECORD_THREADS) {
            project_radiance(k, i, 0u);
        }
    }
    var r: Record;
    if thread == 0u {
        r = irradiance_record(rs);
        r.rotation[0].w = frame.time;
        r.rotation[1].w = select(0.0, cache_uniforms.step, TEMPORAL);
        r.translation[0].w = record_frame_number(frame.frame_counter);
        r.translation[1].w = record_frame_number(frame.frame_counter + MAX_LIFESPAN);
        r.translation[2].w = encode_record_normal(rs.geometric_normal);
    }
    if !TEMPORAL {
        if thread == 0u {
            records[k] = r;
        }
        return;
    }
    workgroupBarrier();
    resolve_prediction(rs, thread);
    workgroupBarrier();
    if rs.glossy {
        for (var i = thread; i < radiance_coefficients(); i += RECORD_THREADS) {
            project_radiance(k, i, 1u);
            note_coefficient_change(k, i);
        }
    }
    workgroupBarrier();
    if thread == 0u {
        var next = irradiance_record(rs);
        next.position_radius.w = r.position_radius.w;
        var change = max3(abs(next.irradiance.rgb - r.irradiance.rgb)) / max(max3(r.irradiance.rgb), 1e-20);
        if rs.glossy {
            change = bitcast<f32>(atomicLoad(&coefficient_change));
        }
        // a_t / change steps, at least one frame (Gautron et al.'s w_t ≥ 1/a_t with |τ − 1| for τ).
        var lifespan = MAX_LIFESPAN;
        if change * f32(MAX_LIFESPAN) > TEMPORAL_ACCURACY {
            lifespan = max(1u, u32(TEMPORAL_ACCURACY / change));
        }
        r.rotation[2].w = change;
        r.translation[1].w = record_frame_number(frame.frame_counter + lifespan);
        records[k] = r;
        records[CAPACITY + k] = next;
        atomicStore(&record_used[k], frame.frame_counter);
    }
}

// The surface of the record the pixel placement picked for `slot`.
fn pixel_record_surface(slot: u32) -> RecordSurface {
    let packed = new_pixels[slot];
    let pixel = vec2u(packed & 0xffffu, packed >> 16u);
    let s = load_gsurface(pixel);
    let footprint = s.distance
        * length(primary_ray_through(vec2f(pixel) + vec2f(1.5, 0.5)) - primary_ray_through(vec2f(pixel) + 0.5));
    return RecordSurface(
        s.position, s.normal, s.geometric_normal, gsurface_ray_origin(s), is_glossy(s.material), footprint,
    );
}

// The surface of the record the photon placement picked for `slot` (diffuse; its zone no smaller
// than the photon radius: there is no view to size it by, so its footprint is the photon radius over
// MIN_ZONE_PIXELS).
fn photon_record_surface(slot: u32) -> RecordSurface {
    let p = photons[new_pixels[slot]];
    return RecordSurface(
        p.position, p.normal, p.normal, offset_origin(p.position, p.normal), false,
        PHOTON_RADIUS / max(MIN_ZONE_PIXELS, 1.0),
    );
}

// A new record at the pixel the placement picked for slot `group.x`.
@compute @workgroup_size(RECORD_THREADS, 1, 1)
fn compute_record(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) thread: u32) {
    build_record(state.splat_begin + group.x, pixel_record_surface(group.x), thread);
}

// Temporal mode: an expired record recomputed where it is (the thesis's replacement at a fixed
// location), its index in slot `group.x` of the refresh list.
@compute @workgroup_size(RECORD_THREADS, 1, 1)
fn refresh_record(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) thread: u32) {
    let k = new_pixels[group.x];
    let old = records[k];
    let ng = record_geometric_normal(old);
    let rs = RecordSurface(
        old.position_radius.xyz,
        old.normal.xyz,
        ng,
        offset_origin(old.position_radius.xyz, ng),
        record_is_radiance(old),
        old.irradiance.w,
    );
    build_record(k, rs, thread);
}

// A record at the photon the photon placement picked for slot `group.x`.
@compute @workgroup_size(RECORD_THREADS, 1, 1)
fn compute_photon_record(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) thread: u32) {
    build_record(state.splat_begin + group.x, photon_record_surface(group.x), thread);
}

// The final gather's record rays (PHOTONS without PHOTON_RECORDS), before the record pass: one
// invocation per ray, the record's slot `group.x`, its cell group.y × RAY_THREADS + thread.

fn trace_record_ray(slot: u32, cell: u32, rs: RecordSurface) {
    gathered_cells[slot * CELLS + cell] = traced_cell(rs, cell);
}

@compute @workgroup_size(RAY_THREADS, 1, 1)
fn trace_record_rays(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) thread: u32) {
    let cell = group.y * RAY_THREADS + thread;
    if cell < CELLS {
        trace_record_ray(group.x, cell, pixel_record_surface(group.x));
    }
}

@compute @workgroup_size(RAY_THREADS, 1, 1)
fn trace_photon_record_rays(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) thread: u32) {
    let cell = group.y * RAY_THREADS + thread;
    if cell < CELLS {
        trace_record_ray(group.x, cell, photon_record_surface(group.x));
    }
}
