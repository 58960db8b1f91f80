// Cache-miss detection and record placement on the GPU, without readback. The thesis walks the splat
// buffer on the CPU and creates a record at every pixel whose summed weight is below a, splatting it
// at once so later pixels see it; here each round picks at most one missing pixel per candidate tile
// (the one with the least weight, ties broken by a per-tile hash), compacts the picks in tile order with
// a prefix sum in one workgroup, and the record pass computes them all in parallel. The candidate tile
// starts at FIRST_CANDIDATE_TILE pixels and halves each round down to MIN_CANDIDATE_TILE, so the first records are
// spread out and later rounds fill what they left; a round's records are splatted before the next round
// looks for misses.

#import common/random.wgsl

const NO_PIXEL: u32 = 0xffffffffu;

fn candidate_tile() -> u32 {
    return max(MIN_CANDIDATE_TILE, FIRST_CANDIDATE_TILE >> min(state.iteration, 31u));
}

fn candidate_tiles_x() -> u32 {
    return (frame.size.x + candidate_tile() - 1u) / candidate_tile();
}

fn candidate_tile_count() -> u32 {
    return candidate_tiles_x() * ((frame.size.y + candidate_tile() - 1u) / candidate_tile());
}

// Per pixel: a visible surface whose summed weight is below a (of its kind) is a miss; its key (20 bits of weight,
// then its hashed index in the tile) competes for the tile, stored complemented so that 0 means none.
@compute @workgroup_size(TILE, TILE, 1)
fn detect_misses(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    let s = load_gsurface(id.xy);
    let accuracy = kind_accuracy(is_glossy(s.material));
    let weight = textureLoad(splat_buffer, id.xy).a;
    if weight >= accuracy || !s.valid {
        return;
    }
    let size = candidate_tile();
    let tile = id.xy / size;
    let t = tile.x + tile.y * candidate_tiles_x();
    let local = (id.x % size) + (id.y % size) * size;
    let scramble = hash3(t, state.rounds_total, SEED) & 0xfffu;
    let level = u32(clamp(weight / accuracy, 0.0, 1.0) * 1048575.0);
    atomicMax(&candidates[t], ~((level << 12u) | (local ^ scramble)));
}

@group(3) @binding(0) var<storage, read_write> record_dispatch: vec3u;

const COMPACT_THREADS: u32 = 256u;
var<workgroup> partial: array<u32, COMPACT_THREADS>;

// The pixel a candidate tile picked, or NO_PIXEL.
fn picked_pixel(t: u32) -> u32 {
    let key = atomicLoad(&candidates[t]);
    if key == 0u {
        return NO_PIXEL;
    }
    let size = candidate_tile();
    let scramble = hash3(t, state.rounds_total, SEED) & 0xfffu;
    let local = ((~key) & 0xfffu) ^ scramble;
    let tile = vec2u(t % candidate_tiles_x(), t / candidate_tiles_x());
    let pixel = tile * size + vec2u(local % size, local / size);
    return pixel.x | (pixel.y << 16u);
}

// One workgroup: every thread counts the picks of a contiguous run of tiles (starting at a per-round
// rotation, so that a budget cut does not always favour the top of the frame), a prefix sum over the
// threads gives each run its first slot, and the runs write their pixels in order. Then thread 0
// reserves the slots against the frame's budget and the capacity, and writes the record pass's
// workgroup counts.
@compute @workgroup_size(COMPACT_THREADS, 1, 1)
fn compact(@builtin(local_invocation_index) thread: u32) {
    let tiles = candidate_tile_count();
    let run = (tiles + COMPACT_THREADS - 1u) / COMPACT_THREADS;
    let rotation = hash2(state.rounds_total, SEED) % tiles;
    let first = thread * run;
    let last = min(first + run, tiles);
    var picks = 0u;
    for (var i = first; i < last; i++) {
        picks += select(0u, 1u, picked_pixel((i + rotation) % tiles) != NO_PIXEL);
    }
    partial[thread] = picks;
    workgroupBarrier();
    // Inclusive scan (Hillis-Steele) over the threads' counts.
    for (var offset = 1u; offset < COMPACT_THREADS; offset <<= 1u) {
        let add = select(0u, partial[select(0u, thread - offset, thread >= offset)], thread >= offset);
        workgroupBarrier();
        partial[thread] += add;
        workgroupBarrier();
    }
    let missing = partial[COMPACT_THREADS - 1u];
    let slots = min(
        missing,
        min(RECORDS_PER_FRAME - min(state.created_this_frame, RECORDS_PER_FRAME), CAPACITY - state.count),
    );
    var slot = partial[thread] - picks;
    for (var i = first; i < last && slot < slots; i++) {
        let pixel = picked_pixel((i + rotation) % tiles);
        if pixel != NO_PIXEL {
            new_pixels[slot] = pixel;
            slot++;
        }
    }
    // Every thread has read the state; only now may thread 0 change it.
    storageBarrier();
    workgroupBarrier();
    if thread == 0u {
        state.missing_tiles = missing;
        state.unserved_tiles = missing - slots;
        state.splat_begin = state.count;
        state.count += slots;
        state.created_this_frame += slots;
        state.created_total += slots;
        state.iteration += 1u;
        state.rounds_total += 1u;
        record_dispatch = vec3u(slots, 1u, 1u);
    }
}
