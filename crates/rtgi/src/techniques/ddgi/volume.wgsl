// The probe volume of DDGI: grid, ray pattern and octahedral atlas tiles, shared by every probe pass.
// The including shader declares `probe_frame`; the volume's shape arrives as constants from the host
// (ddgi/mod.rs): PROBE_COUNTS, FIRST_PROBE, PROBE_SPACING, ATLAS_COLUMNS, IRRADIANCE_TEXELS and
// DISTANCE_TEXELS (interior texels per tile edge; tiles add a one-texel gutter), RAYS, MAX_DISTANCE.

#import common/sampling.wgsl

// Mirrors `ProbeFrame` in ddgi/mod.rs: what changes every frame.
struct ProbeFrame {
    // Rotation of this frame's spherical Fibonacci ray pattern.
    rotation: mat3x3f,
    // Weight of the previous value in the blend (0 on the first update: nothing to keep).
    hysteresis: f32,
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

fn probe_position(g: vec3u) -> vec3f {
    return FIRST_PROBE + vec3f(g) * PROBE_SPACING;
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

