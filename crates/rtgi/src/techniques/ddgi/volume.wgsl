// The probe volume of DDGI: lattice, probe states, ray pattern and octahedral atlas tiles, shared by
// every probe pass. The including shader declares `probe_frame` (and, where it reads them,
// `probe_states`); the volume's shape arrives as constants from the host (ddgi/mod.rs): PROBE_COUNTS,
// FIRST_PROBE, PROBE_SPACING, ATLAS_COLUMNS, IRRADIANCE_TEXELS and DISTANCE_TEXELS (interior texels per
// tile edge; tiles add a one-texel gutter), RAYS, MAX_DISTANCE.
//
// Probes stand on an infinite lattice, cell c at FIRST_PROBE + c·PROBE_SPACING (plus the probe's
// relocation offset); the volume holds the PROBE_COUNTS cells from `probe_frame.scroll` on. A probe's
// storage slot is its cell modulo PROBE_COUNTS, so when the volume scrolls with the camera only the
// probes of the cells that leave it are reused (and reset) for the cells that enter; the rest keep
// their history and their slots.

#import common/sampling.wgsl

// Mirrors `ProbeFrame` in ddgi/mod.rs: what changes every frame.
struct ProbeFrame {
    // Rotation of this frame's spherical Fibonacci ray pattern.
    rotation: mat3x3f,
    // First lattice cell of the volume this frame.
    scroll: vec3i,
    // Weight of the previous value in the blend, for probes that have been updated before.
    hysteresis: f32,
    // First lattice cell of the volume last frame.
    previous_scroll: vec3i,
    // The probes traced and updated this frame: `update_count` slots from `update_start`, wrapping.
    update_start: u32,
    update_count: u32,
    // 1: the probe state pass relocates and classifies this frame; 0: the probes keep their states.
    classify: u32,
}

// Mirrors `ProbeState` in ddgi/mod.rs.
struct ProbeState {
    // Relocation: from the lattice point to where the probe stands (world units).
    offset: vec3f,
    // PROBE_ACTIVE, PROBE_VALID, PROBE_BLEND and PROBE_INSIDE bits (constants from the host, where each
    // is explained).
    flags: u32,
}

fn probe_count() -> u32 {
    return PROBE_COUNTS.x * PROBE_COUNTS.y * PROBE_COUNTS.z;
}

fn probe_grid(probe: u32) -> vec3u {
    let xy = PROBE_COUNTS.x * PROBE_COUNTS.y;
    return vec3u(probe % PROBE_COUNTS.x, (probe % xy) / PROBE_COUNTS.x, probe / xy);
}

fn probe_index(g: vec3u) -> u32 {
    return g.x + PROBE_COUNTS.x * (g.y + PROBE_COUNTS.y * g.z);
}

// The storage slot of lattice cell `c`.
fn cell_slot(c: vec3i) -> u32 {
    let n = vec3i(PROBE_COUNTS);
    return probe_index(vec3u(((c % n) + n) % n));
}

// The lattice cell that storage slot `slot` stands for when the volume starts at cell `scroll`.
fn slot_cell(slot: u32, scroll: vec3i) -> vec3i {
    let n = vec3i(PROBE_COUNTS);
    return scroll + (((vec3i(probe_grid(slot)) - scroll) % n) + n) % n;
}

// The lattice point of cell `c` (where a probe stands before relocation).
fn cell_position(c: vec3i) -> vec3f {
    return FIRST_PROBE + vec3f(c) * PROBE_SPACING;
}

// Whether `slot` lies in the `count` slots from `start` (wrapping around the volume).
fn slot_in_range(slot: u32, start: u32, count: u32) -> bool {
    let n = probe_count();
    return (slot + n - start) % n < count;
}

// Whether `slot` is traced and updated this frame.
fn probe_in_update(slot: u32) -> bool {
    return slot_in_range(slot, probe_frame.update_start, probe_frame.update_count);
}

// Direction of ray `ray` of every probe this frame.
fn probe_ray_direction(ray: u32) -> vec3f {
    return normalize(probe_frame.rotation * spherical_fibonacci(ray, RAYS));
}

// Top-left texel of a probe's tile (edge `interior + 2`) in an atlas of ATLAS_COLUMNS tiles per row.
fn probe_tile_origin(probe: u32, interior: u32) -> vec2u {
    return vec2u(probe % ATLAS_COLUMNS, probe / ATLAS_COLUMNS) * (interior + 2u);
}

// The interior texel (0..interior per axis) whose value tile texel `t` (0..interior+2) holds: itself
// inside, the octahedral neighbour across the edge in the gutter (edges mirror, corners swap
// diagonally), so bilinear lookups near an edge blend the right directions.
fn gutter_source(t: vec2u, interior: u32) -> vec2u {
    let last = interior + 1u;
    var s = vec2i(t) - 1;
    let n = i32(interior);
    let on_x = t.x == 0u || t.x == last;
    let on_y = t.y == 0u || t.y == last;
    if on_x && on_y {
        // Corner: the diagonally opposite interior corner.
        return vec2u(select(0u, interior - 1u, t.x == 0u), select(0u, interior - 1u, t.y == 0u));
    }
    if on_y {
        s = vec2i(n - 1 - s.x, select(n - 1, 0, t.y == 0u));
    } else if on_x {
        s = vec2i(select(n - 1, 0, t.x == 0u), n - 1 - s.y);
    }
    return vec2u(s);
}

// The direction an interior texel stands for.
fn texel_direction(texel: vec2u, interior: u32) -> vec3f {
    return oct_decode((vec2f(texel) + 0.5) / f32(interior) * 2.0 - 1.0);
}

// Atlas coordinates (0..1) of direction `dir` in a probe's tile, for bilinear lookups.
fn probe_atlas_uv(probe: u32, dir: vec3f, interior: u32, atlas_size: vec2u) -> vec2f {
    let inside = (oct_encode(dir) * 0.5 + 0.5) * f32(interior);
    return (vec2f(probe_tile_origin(probe, interior)) + 1.0 + inside) / vec2f(atlas_size);
}

