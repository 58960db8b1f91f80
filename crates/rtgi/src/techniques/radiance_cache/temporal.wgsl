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

// Deleted records leave holes that splatting still walks and new records cannot fill (a round's new
// records are splatted as one range [splat_begin, count)). When the holes reach a quarter of the
// cache, or the cache could no longer take a full frame's budget of new records, the live records are
// moved down over them in order (splatting sums records in index order; the order stays), at the start
// of a frame, before aging writes the refresh list of record indices. One workgroup walks the cache in
// chunks: every record of a chunk is read before any is written, and records only move down, to slots
// already read, so none is overwritten before it is read.

const COMPACTION_THREADS: u32 = 256u;
var<workgroup> compaction_prefix: array<u32, COMPACTION_THREADS>;
var<workgroup> compaction_count: u32;

fn compaction_needed() -> bool {
    let holes = state.deleted_total - state.compacted_total;
    return holes > 0u && (holes * 4u >= state.count || state.count + RECORDS_PER_FRAME > CAPACITY);
}

// Moves one coefficient (9 floats from `src_index`) of a record to `dst_index`, after every thread of the chunk
// has read its own.
fn move_coefficient(src_index: u32, dst_index: u32, moves: bool) {
    var a = vec3f(0.0);
    var b = vec3f(0.0);
    var c = vec3f(0.0);
    if moves {
        a = vec3f(radiance[src_index], radiance[src_index + 1u], radiance[src_index + 2u]);
        b = vec3f(radiance[src_index + 3u], radiance[src_index + 4u], radiance[src_index + 5u]);
        c = vec3f(radiance[src_index + 6u], radiance[src_index + 7u], radiance[src_index + 8u]);
    }
    storageBarrier();
    if moves {
        radiance[dst_index] = a.x;
        radiance[dst_index + 1u] = a.y;
        radiance[dst_index + 2u] = a.z;
        radiance[dst_index + 3u] = b.x;
        radiance[dst_index + 4u] = b.y;
        radiance[dst_index + 5u] = b.z;
        radiance[dst_index + 6u] = c.x;
        radiance[dst_index + 7u] = c.y;
        radiance[dst_index + 8u] = c.z;
    }
}

@compute @workgroup_size(COMPACTION_THREADS, 1, 1)
fn compact_records(@builtin(local_invocation_index) thread: u32) {
    if thread == 0u {
        compaction_count = select(0u, state.count, compaction_needed());
    }
    let count = workgroupUniformLoad(&compaction_count);
    if count == 0u {
        return;
    }
    let coefficients = radiance_coefficients();
    var written = 0u;
    for (var base = 0u; base < count; base += COMPACTION_THREADS) {
        let k = base + thread;
        var r: Record;
        var next: Record;
        var used = 0u;
        var live = false;
        if k < count {
            r = records[k];
            next = records[CAPACITY + k];
            used = atomicLoad(&record_used[k]);
            live = !record_is_deleted(r);
        }
        compaction_prefix[thread] = select(0u, 1u, live);
        // Every read above comes before any write below.
        storageBarrier();
        workgroupBarrier();
        // Inclusive scan (Hillis-Steele) of the chunk's live flags.
        for (var offset = 1u; offset < COMPACTION_THREADS; offset <<= 1u) {
            let add = select(0u, compaction_prefix[select(0u, thread - offset, thread >= offset)], thread >= offset);
            workgroupBarrier();
            compaction_prefix[thread] += add;
            workgroupBarrier();
        }
        let chunk_live = compaction_prefix[COMPACTION_THREADS - 1u];
        let j = written + compaction_prefix[thread] - select(0u, 1u, live);
        let moves = live && j != k;
        if moves {
            records[j] = r;
            records[CAPACITY + j] = next;
            atomicStore(&record_used[j], used);
        }
        let radiance_moves = moves && record_is_radiance(r);
        for (var i = 0u; i < coefficients; i++) {
            for (var plane = 0u; plane < 2u; plane++) {
                move_coefficient(radiance_index(k, i, plane), radiance_index(j, i, plane), radiance_moves);
            }
        }
        written += chunk_live;
        // The next chunk's flags overwrite the prefix sums only after every thread has read them.
        workgroupBarrier();
    }
    if thread == 0u {
        state.compacted_total += count - written;
        state.count = written;
    }
}
