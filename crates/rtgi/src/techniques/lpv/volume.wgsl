// Light propagation volumes (Kaplanyan & Dachsbacher 2010): the grids, their cells and order-1 SH per
// colour channel, shared by every LPV pass. Layouts mirror `lpv/mod.rs`.
//
// Cascade c is a cube of GRID³ cells of edge `cascades[c].w` whose minimum corner is `cascades[c].xyz`
// (cascade 0 the finest). A cell stores the intensity I(ω) [W/sr] its light leaves with in direction ω,
// as order-1 SH per channel: three vec4f (R, G, B). The geometry volume (GV) of a cascade is offset by
// half a cell: its (GRID+1)³ cells are centred on the LPV cells' corners, and each holds the blocking
// potential B(ω), the fraction of light travelling in direction ω that its surfaces stop, as one
// order-1 SH, followed by the diffuse albedo of those surfaces (MULTIPLE_BOUNCES only) as the sums of
// albedo × covered fraction (rgb) and of the covered fraction (w): GEOMETRY_SLOTS vec4f per cell,
// `geometry[GEOMETRY_SLOTS i]` and `geometry[GEOMETRY_SLOTS i + 1]`.

#import common/sh.wgsl

struct LpvParams {
    cascades: array<vec4f, MAX_CASCADES>,
    cascade_count: u32,
    // Light injection's fixed-point scale is computed on the GPU (`flux_scale`); the geometry volume's is
    // constant.
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Per propagation step.
struct PropagationStep {
    // 0 for the first step, which spreads the injected light without occlusion (the paper's remedy for
    // a surface blocking its own light).
    index: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(2) @binding(0) var<uniform> lpv: LpvParams;

fn cells_per_cascade() -> u32 {
    return GRID * GRID * GRID;
}

fn geometry_cells_per_cascade() -> u32 {
    return (GRID + 1u) * (GRID + 1u) * (GRID + 1u);
}

fn cell_index(cascade: u32, c: vec3u) -> u32 {
    return cascade * cells_per_cascade() + (c.z * GRID + c.y) * GRID + c.x;
}

fn geometry_index(cascade: u32, c: vec3u) -> u32 {
    let n = GRID + 1u;
    return cascade * geometry_cells_per_cascade() + (c.z * n + c.y) * n + c.x;
}

fn cell_of(cascade: u32, i: u32) -> vec3u {
    let local = i - cascade * cells_per_cascade();
    return vec3u(local % GRID, (local / GRID) % GRID, local / (GRID * GRID));
}

fn geometry_cell_of(cascade: u32, i: u32) -> vec3u {
    let n = GRID + 1u;
    let local = i - cascade * geometry_cells_per_cascade();
    return vec3u(local % n, (local / n) % n, local / (n * n));
}

fn cell_size(cascade: u32) -> f32 {
    return lpv.cascades[cascade].w;
}

// Position in cell units of cascade `cascade` (cell k spans [k, k+1)).
fn grid_position(cascade: u32, p: vec3f) -> vec3f {
    return (p - lpv.cascades[cascade].xyz) / cell_size(cascade);
}

fn inside_grid(g: vec3f) -> bool {
    return all(g >= vec3f(0.0)) && all(g < vec3f(f32(GRID)));
}

// The 4 SH coefficients of channel `k` of the light of a cell.
struct CellLight {
    r: vec4f,
    g: vec4f,
    b: vec4f,
}

fn eval_cell(c: CellLight, d: vec3f) -> vec3f {
    let y = sh4_basis(d);
    return vec3f(dot(c.r, y), dot(c.g, y), dot(c.b, y));
}
