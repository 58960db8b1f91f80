// Building the photon map's hashed grid on the GPU: a counting sort of the photons by bucket. The
// photons are the surface VPLs of light-path vertices 2 and deeper (light that has bounced at least
// once: indirect light; rtgi computes direct light exactly), VPL slots [first, end).
//   count_photons: photons per bucket (atomic adds into grid[0, B));
//   scan_buckets: one workgroup turns the counts into bucket starts grid[0, B] (grid[B]: the total)
//                 and copies them into the scatter cursors grid[B + 1, 2B + 1);
//   scatter_photons: every photon's VPL slot to its bucket's next key (in the atomics' order);
//   place_photons: every photon to its rank among its bucket's keys: each bucket holds its photons in
//                  VPL order, so that sums over a bucket do not depend on the atomics' order
//                  (deterministic output). A rank is a loop over the bucket, not a sort of it: one
//                  invocation sorting a bucket runs O(n²) iterations, and lavapipe (llvmpipe) ends every
//                  invocation's loops after 65535 iterations in all, leaving large buckets half sorted.

@group(2) @binding(0) var<storage, read> vpls: array<Vpl>;
@group(2) @binding(1) var<storage, read_write> photons: array<Photon>;
@group(2) @binding(2) var<storage, read_write> grid: array<atomic<u32>>;
struct PhotonBuild {
    first: u32,
    end: u32,
    // Path vertices stored per path at most (vertex 0, on the lights, is not).
    depth: u32,
    _pad: u32,
    // Slot of vertex j of path 0 (offset_j of light_paths), four per element.
    offsets: array<vec4u, 3>,
}
@group(2) @binding(3) var<uniform> build: PhotonBuild;
// The photons' VPL slots, bucket by bucket, in scatter order.
@group(2) @binding(4) var<storage, read_write> keys: array<u32>;

const SCAN_THREADS: u32 = 256u;

fn photon_slot(id: u32) -> u32 {
    return build.first + id;
}

fn is_photon(v: Vpl) -> bool {
    return v.kind == VPL_SURFACE && max3(v.flux) > 0.0;
}

@compute @workgroup_size(64)
fn count_photons(@builtin(global_invocation_id) id: vec3u) {
    let slot = photon_slot(id.x);
    if slot >= build.end || !is_photon(vpls[slot]) {
        return;
    }
    atomicAdd(&grid[photon_bucket(photon_cell(vpls[slot].position))], 1u);
}

var<workgroup> partial: array<u32, SCAN_THREADS>;

@compute @workgroup_size(256)
fn scan_buckets(@builtin(local_invocation_index) t: u32) {
    let chunk = (PHOTON_BUCKETS + SCAN_THREADS - 1u) / SCAN_THREADS;
    let begin = min(t * chunk, PHOTON_BUCKETS);
    let finish = min(begin + chunk, PHOTON_BUCKETS);
    var sum = 0u;
    for (var b = begin; b < finish; b++) {
        sum += atomicLoad(&grid[b]);
    }
    partial[t] = sum;
    workgroupBarrier();
    // Inclusive scan of the chunk sums (Hillis & Steele).
    for (var step = 1u; step < SCAN_THREADS; step *= 2u) {
        var add = 0u;
        if t >= step {
            add = partial[t - step];
        }
        workgroupBarrier();
        partial[t] += add;
        workgroupBarrier();
    }
    var running = partial[t] - sum;
    for (var b = begin; b < finish; b++) {
        let count = atomicLoad(&grid[b]);
        atomicStore(&grid[b], running);
        atomicStore(&grid[PHOTON_BUCKETS + 1u + b], running);
        running += count;
    }
    if t == SCAN_THREADS - 1u {
        atomicStore(&grid[PHOTON_BUCKETS], partial[t]);
    }
}

fn vertex_offset(j: u32) -> u32 {
    return build.offsets[j / 4u][j % 4u];
}

// The distance from the photon in `slot` back to the vertex its path left before (vertex j - 1 of
// the same path: photons are vertices 2 and deeper, so that one is on a surface and stored).
fn travelled(slot: u32, position: vec3f) -> f32 {
    var j = 2u;
    while j < build.depth && vertex_offset(j + 1u) <= slot {
        j += 1u;
    }
    let previous = vertex_offset(j - 1u) + (slot - vertex_offset(j));
    return distance(position, vpls[previous].position);
}

@compute @workgroup_size(64)
fn scatter_photons(@builtin(global_invocation_id) id: vec3u) {
    let slot = photon_slot(id.x);
    if slot >= build.end || !is_photon(vpls[slot]) {
        return;
    }
    let bucket = photon_bucket(photon_cell(vpls[slot].position));
    keys[atomicAdd(&grid[PHOTON_BUCKETS + 1u + bucket], 1u)] = slot;
}

@compute @workgroup_size(64)
fn place_photons(@builtin(global_invocation_id) id: vec3u) {
    let slot = photon_slot(id.x);
    if slot >= build.end {
        return;
    }
    let v = vpls[slot];
    if !is_photon(v) {
        return;
    }
    let bucket = photon_bucket(photon_cell(v.position));
    let begin = atomicLoad(&grid[bucket]);
    let end = atomicLoad(&grid[bucket + 1u]);
    var rank = 0u;
    for (var i = begin; i < end; i++) {
        rank += select(0u, 1u, keys[i] < slot);
    }
    var p: Photon;
    p.position = v.position;
    p.source = slot;
    p.flux = v.flux;
    p.travelled = travelled(slot, v.position);
    p.incoming = v.incoming;
    p.normal = v.normal;
    photons[begin + rank] = p;
}
