// Photons and their hashed grid (the photon map, Jensen 2001), shared by the build passes (grid.wgsl)
// and the lookups (lookup.wgsl). Layout mirrors `GpuPhoton` in photon_map/mod.rs.

#import common/math.wgsl
#import common/random.wgsl

struct Photon {
    position: vec3f,
    // The VPL slot the photon came from: the order of photons within a bucket (deterministic sums).
    source: u32,
    // The flux that arrived (W), from `incoming` (unit, towards where it came from).
    flux: vec3f,
    // The length of the light path's last segment: how far the surface that sent it lies (the
    // thesis's d, whose harmonic mean is a photon-density record's R).
    travelled: f32,
    incoming: vec3f,
    _pad1: u32,
    // Shading normal of the surface it landed on.
    normal: vec3f,
    _pad2: u32,
}

// The grid cell (edge PHOTON_CELL = twice the lookup radius) holding p.
fn photon_cell(p: vec3f) -> vec3i {
    return vec3i(floor(p / PHOTON_CELL));
}

// The bucket (of PHOTON_BUCKETS, a power of two) a cell hashes to.
fn photon_bucket(cell: vec3i) -> u32 {
    let c = bitcast<vec3u>(cell);
    return hash3(c.x, c.y, c.z) & (PHOTON_BUCKETS - 1u);
}
