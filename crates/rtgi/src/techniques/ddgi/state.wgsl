// Probe state, once per probe and frame before the probe rays (one workgroup per probe):
// - a probe whose slot now stands for another lattice cell (the volume scrolled) starts afresh;
// - relocation (RELOCATION) and classification (CLASSIFICATION), as RTXGI does them, from
//   CLASSIFY_RAYS rays on a fixed spherical Fibonacci pattern (fixed, so a probe's decision does not
//   jitter with the rotating pattern of the irradiance rays): a probe most of whose rays hit back faces
//   stands inside geometry and moves through the nearest back face; one closer than MIN_SURFACE_DISTANCE
//   to a surface steps away from it; one clear of everything (by twice that distance: a dead band
//   against oscillation) drifts back towards its lattice point.
//   Moves that would leave RELOCATION_LIMIT cell fractions (per axis) are refused. A probe inside
//   geometry, or with no surface in the cells it interpolates (within one spacing of its lattice
//   point), is switched off: not traced, not updated, not interpolated;
//   Both run only on the frames the host asks for (`probe_frame.classify`: while the probes settle after
//   creation, a geometry change or a scroll); otherwise the probes keep their offsets and flags;
// - the VALID and BLEND bits follow from whether this frame's update will write the probe.

#import common/scene.wgsl

@group(2) @binding(0) var<storage, read_write> probe_states: array<ProbeState>;
@group(2) @binding(1) var<uniform> probe_frame: ProbeFrame;

// Hit distance of each classification ray, negative for a back face, FLT_MAX for a miss.
var<workgroup> hit_distance: array<f32, CLASSIFY_RAYS>;

@compute @workgroup_size(CLASSIFY_RAYS)
fn main(
    @builtin(workgroup_id) group: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    let slot = group.x + group.y * groups.x;
    if slot >= probe_count() {
        return;
    }
    let cell = slot_cell(slot, probe_frame.scroll);
    var state = probe_states[slot];
    if any(cell != slot_cell(slot, probe_frame.previous_scroll)) {
        state = ProbeState(vec3f(0.0), PROBE_ACTIVE);
    }
    let lattice_point = cell_position(cell);
    let origin = lattice_point + state.offset;
    let classify = (RELOCATION || CLASSIFICATION) && probe_frame.classify != 0u;
    if classify {
        let dir = spherical_fibonacci(lane, CLASSIFY_RAYS);
        let hit = trace_closest(Ray(origin, dir), 0.0, FLT_MAX);
        var d = hit.t;
        if hit.t < FLT_MAX && hits_back_face(hit.triangle, hit.u, hit.v, dir) {
            d = -hit.t;
        }
        hit_distance[lane] = d;
    }
    workgroupBarrier();
    if lane != 0u {
        return;
    }
    if classify {
        var back_faces = 0u;
        var nearest_back = FLT_MAX;
        var nearest_back_dir = vec3f(0.0);
        var nearest_front = FLT_MAX;
        var nearest_front_dir = vec3f(0.0);
        var farthest_front = -1.0;
        var farthest_front_dir = vec3f(0.0);
        var surface_nearby = false;
        for (var r = 0u; r < CLASSIFY_RAYS; r++) {
            let d = hit_distance[r];
            let dir = spherical_fibonacci(r, CLASSIFY_RAYS);
            if d < 0.0 {
                back_faces += 1u;
                if -d < nearest_back {
                    nearest_back = -d;
                    nearest_back_dir = dir;
                }
                continue;
            }
            if d < nearest_front {
                nearest_front = d;
                nearest_front_dir = dir;
            }
            if d > farthest_front {
                farthest_front = d;
                farthest_front_dir = dir;
            }
            if d < FLT_MAX && all(abs(origin + dir * d - lattice_point) <= PROBE_SPACING) {
                surface_nearby = true;
            }
        }
        let inside = f32(back_faces) > BACKFACE_THRESHOLD * f32(CLASSIFY_RAYS);
        state.flags = select(state.flags & ~PROBE_INSIDE, state.flags | PROBE_INSIDE, inside);
        if RELOCATION {
            var moved = state.offset;
            if inside {
                moved += nearest_back_dir * (nearest_back + MIN_SURFACE_DISTANCE);
            } else if nearest_front < MIN_SURFACE_DISTANCE {
                // Towards the most open direction when it leads away from the nearest surface (out of
                // corners), else straight away from that surface; to 1.5× the minimum distance, inside
                // the dead band below, so the next frame's rays (which pass the nearest point of the
                // surface at other angles) do not pull it straight back.
                let away = select(-nearest_front_dir, farthest_front_dir, dot(nearest_front_dir, farthest_front_dir) <= 0.0);
                moved += away * (1.5 * MIN_SURFACE_DISTANCE - nearest_front);
            } else if nearest_front > 2.0 * MIN_SURFACE_DISTANCE {
                let back = min(length(state.offset), nearest_front - 2.0 * MIN_SURFACE_DISTANCE);
                if back > 0.0 {
                    moved -= normalize(state.offset) * back;
                }
            }
            if all(abs(moved) <= RELOCATION_LIMIT * PROBE_SPACING) {
                state.offset = moved;
            }
        }
        if CLASSIFICATION {
            let on = !inside && surface_nearby;
            state.flags = select(state.flags & ~PROBE_ACTIVE, state.flags | PROBE_ACTIVE, on);
        }
    }
    let valid = (state.flags & PROBE_VALID) != 0u;
    state.flags = select(state.flags & ~PROBE_BLEND, state.flags | PROBE_BLEND, valid);
    if (state.flags & PROBE_ACTIVE) != 0u && probe_in_update(slot) {
        state.flags |= PROBE_VALID;
    }
    probe_states[slot] = state;
}
