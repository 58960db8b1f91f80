// Temporal mode's bookkeeping at the start of a frame (Gautron et al. 2006, §5.3): every record past
// its lifespan is either recomputed where it is, when it served a pixel in the frame before (the
// thesis asks an occlusion query of the record's splat; here the splat notes the last frame a record
// served, record_used), or deleted, when it did not (out of view or hidden: a record left behind by a
// moving object). Refreshes share the frame's record budget with new records; an expired record left
// over by the budget keeps its (clamped) prediction and asks again next frame.

// One invocation per record.
@compute @workgroup_size(64, 1, 1)
fn age_records(@builtin(global_invocation_id) id: vec3u) {
    let k = id.x;
    if k >= state.count {
        return;
    }
    let r = records[k];
    if record_is_deleted(r) || record_age(r) < record_lifespan(r) {
        return;
    }
    // Served a pixel in the frame before this one (computing it counts as serving its pixel).
    if frame.frame_counter - atomicLoad(&record_used[k]) <= 1u {
        let slot = atomicAdd(&temporal_counters[0], 1u);
        if slot < RECORDS_PER_FRAME {
            new_pixels[slot] = k;
        }
    } else {
        records[k].normal.w = -1.0;
        atomicAdd(&temporal_counters[1], 1u);
    }
}

// One invocation: the refreshes this frame's budget admits, as the record pass's workgroup count.
@group(3) @binding(0) var<storage, read_write> record_dispatch: vec3u;

@compute @workgroup_size(1, 1, 1)
fn refresh_dispatch() {
    let refreshes = min(atomicLoad(&temporal_counters[0]), RECORDS_PER_FRAME);
    state.refreshed_this_frame = refreshes;
    state.refreshed_total += refreshes;
    state.created_this_frame = refreshes;
    state.deleted_total += atomicLoad(&temporal_counters[1]);
    record_dispatch = vec3u(refreshes, 1u, 1u);
}
