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

// The workgroups of the record pass (one per record) and of the final gather's record-ray pass (one
// invocation per ray).
struct RecordDispatch {
    records: vec3u,
    _pad0: u32,
    rays: vec3u,
    _pad1: u32,
}
@group(3) @binding(0) var<storage, read_write> record_dispatch: RecordDispatch;

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

// What candidate t of this round picked (a pixel, x | y << 16, or a photon index), or NO_PIXEL.
fn picked(t: u32, photon_round: bool) -> u32 {
    if photon_round {
        return picked_photon(t);
    }
    return picked_pixel(t);
}

// One workgroup: every thread counts the picks of a contiguous run of candidates (starting at a
// per-round rotation, so that a budget cut does not always favour the top of the frame), a prefix sum
// over the threads gives each run its first slot, and the runs write their picks in order. Then
// thread 0 reserves the slots against the frame's budget and the capacity, and writes the record
// pass's workgroup counts.
fn compact_picks(thread: u32, tiles: u32, photon_round: bool) {
    let run = (tiles + COMPACT_THREADS - 1u) / COMPACT_THREADS;
    let rotation = hash2(state.rounds_total, SEED) % tiles;
    let first = thread * run;
    let last = min(first + run, tiles);
    var picks = 0u;
    for (var i = first; i < last; i++) {
        picks += select(0u, 1u, picked((i + rotation) % tiles, photon_round) != NO_PIXEL);
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
        let pick = picked((i + rotation) % tiles, photon_round);
        if pick != NO_PIXEL {
            new_pixels[slot] = pick;
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
        state.rounds_total += 1u;
        if photon_round {
            state.photon_round += 1u;
            state.photon_placed += slots;
        } else {
            state.iteration += 1u;
        }
        record_dispatch.records = vec3u(slots, 1u, 1u);
        record_dispatch.rays = vec3u(slots, (SAMPLES_THETA * SAMPLES_PHI + RAY_THREADS - 1u) / RAY_THREADS, 1u);
    }
}

@compute @workgroup_size(COMPACT_THREADS, 1, 1)
fn compact(@builtin(local_invocation_index) thread: u32) {
    compact_picks(thread, candidate_tile_count(), false);
}

// Records placed at photons (`record_placement=photons`, the thesis's Algorithm 6: a record at every
// photon the cache does not yet cover, Σ_k w_k < a, so that the lit parts of the scene, where photons
// land, are covered whatever the view). The thesis walks the photons in order and adds each record at
// once; here each round tests PHOTON_CANDIDATES photons (every stride-th of the map, the buckets'
// order scattering them over the scene) against every record, picks the first missing one in each
// cell of a world grid (PLACEMENT_CELL wide, halving each round, hashed into PHOTON_PICKS slots), and
// the record pass computes the picks in parallel before the next round tests again. Photon records
// are diffuse (photons do not carry their surface's material).

fn photon_stride() -> u32 {
    return max(1u, photon_grid[PHOTON_BUCKETS] / PHOTON_CANDIDATES);
}

fn picked_photon(t: u32) -> u32 {
    let key = atomicLoad(&candidates[t]);
    if key == 0u {
        return NO_PIXEL;
    }
    return (~key) * photon_stride();
}

@compute @workgroup_size(64, 1, 1)
fn detect_photon_misses(@builtin(global_invocation_id) id: vec3u) {
    let c = id.x;
    let i = c * photon_stride();
    if c >= PHOTON_CANDIDATES || i >= photon_grid[PHOTON_BUCKETS] {
        return;
    }
    let p = photons[i];
    var weight = 0.0;
    for (var k = 0u; k < state.count; k++) {
        let r = records[k];
        let e = record_error(r, p.position, p.normal);
        if !record_is_radiance(r) && !record_is_deleted(r) && e <= ACCURACY {
            weight += record_weight_of_error(e);
        }
    }
    if weight >= ACCURACY {
        return;
    }
    let size = PLACEMENT_CELL / f32(1u << min(state.photon_round, 24u));
    let cell = bitcast<vec3u>(vec3i(floor(p.position / size)));
    atomicMax(&candidates[hash3(cell.x, cell.y, cell.z) & (PHOTON_PICKS - 1u)], ~c);
}

@compute @workgroup_size(COMPACT_THREADS, 1, 1)
fn compact_photons(@builtin(local_invocation_index) thread: u32) {
    compact_picks(thread, PHOTON_PICKS, true);
}

// After the photon rounds: the frame's first splat starts from the first record again.
@compute @workgroup_size(1, 1, 1)
fn end_photon_placement() {
    state.splat_begin = 0u;
}
