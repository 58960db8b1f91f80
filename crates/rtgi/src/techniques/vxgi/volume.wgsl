// Voxel cone tracing (Crassin et al. 2011): the voxel grid every VXGI pass shares. Layouts mirror
// `vxgi/mod.rs`.
//
// The volume is CLIPS nested cubes of GRID³ voxels (clipmap levels, finest first; one cube over the
// scene when CLIPS = 1): level k's minimum corner is `volume.clips[k].xyz` and its voxel edge
// `volume.clips[k].w`, each level twice the voxel of the one before, the coarsest over the scene.
// Positions inside a level are in its voxel units ("grid units": voxel c spans [c, c+1) on each axis).
// Each level's voxels also lie on a lattice anchored at `volume.origin` (the coarsest level's corner):
// voxel c of level k is lattice voxel corners[k] + c. Voxelisation and injection compute from lattice
// indices alone, so that a voxel gets the same words and light wherever its level lies (scrolling).
// The levels are stacked along z in every volume texture: voxel c of level k is texel c + (0, 0, k·GRID).
// Voxelisation leaves two r32uint words per voxel: the running mean of the diffuse albedo of the surfaces
// in it (rgb, unorm8) with their count (the top byte; 0 = empty), and the running mean of their authored
// normals (snorm8 xyz).

// A box of voxels [lo, hi) of a level (xyz).
struct VoxelBox {
    lo: vec4i,
    hi: vec4i,
}

struct VxgiVolume {
    clips: array<vec4f, MAX_CLIPMAPS>,
    corners: array<vec4i, MAX_CLIPMAPS>,
    // This frame's scroll per level: voxel c holds what voxel c + shift held.
    shifts: array<vec4i, MAX_CLIPMAPS>,
    // REGIONS boxes per level for this frame's volume passes: the slabs a scroll enters, the whole level.
    boxes: array<VoxelBox, REGIONS * MAX_CLIPMAPS>,
    origin: vec4f,
}

// Per dispatch of the volume passes: the axis voxelisation's rays follow, the level and the region of
// it a pass works on.
struct DispatchSlot {
    axis: u32,
    clip: u32,
    region: u32,
    _pad: u32,
}

@group(2) @binding(0) var<uniform> volume: VxgiVolume;
@group(2) @binding(9) var<uniform> dispatch_slot: DispatchSlot;
@group(2) @binding(1) var voxel_albedo: texture_storage_3d<r32uint, read_write>;
// Atomic under conservative voxelisation, whose claims are atomic maxima into empty voxels' words.
#if CONSERVATIVE
@group(2) @binding(2) var voxel_normal: texture_storage_3d<r32uint, atomic>;
#else
@group(2) @binding(2) var voxel_normal: texture_storage_3d<r32uint, read_write>;
#endif
@group(2) @binding(3) var radiance_out: texture_storage_3d<rgba16float, write>;

fn voxel_size(k: u32) -> f32 {
    return volume.clips[k].w;
}

fn grid_position(k: u32, p: vec3f) -> vec3f {
    return (p - volume.clips[k].xyz) / voxel_size(k);
}

fn world_position(k: u32, g: vec3f) -> vec3f {
    return volume.clips[k].xyz + g * voxel_size(k);
}

// The box of voxels this dispatch works on.
fn dispatch_box() -> VoxelBox {
    return volume.boxes[REGIONS * dispatch_slot.clip + dispatch_slot.region];
}

// Voxel `id` of the dispatch's box (xyz, in the level) and whether the box holds it (w = 1) or not (0).
fn box_voxel(id: vec3u) -> vec4i {
    let b = dispatch_box();
    let c = b.lo.xyz + vec3i(id);
    return vec4i(c, select(0, 1, all(c < b.hi.xyz)));
}

// Voxel c of level k on the lattice, and p in lattice units of level k: the same numbers wherever the
// level lies.
fn lattice_voxel(k: u32, c: vec3i) -> vec3i {
    return volume.corners[k].xyz + c;
}

fn lattice_position(k: u32, p: vec3f) -> vec3f {
    return (p - volume.origin.xyz) / voxel_size(k);
}

// The centre of voxel c of level k, from its lattice index.
fn voxel_centre(k: u32, c: vec3i) -> vec3f {
    return volume.origin.xyz + (vec3f(lattice_voxel(k, c)) + 0.5) * voxel_size(k);
}

fn inside_grid(g: vec3f) -> bool {
    return all(g >= vec3f(0.0)) && all(g < vec3f(f32(GRID)));
}

// The texel of voxel c of level k in the stacked textures.
fn clip_texel(k: u32, c: vec3u) -> vec3u {
    return c + vec3u(0u, 0u, k * GRID);
}

// The finest level holding p at least `margin` of its voxels inside its border; CLIPS when p lies
// outside even the coarsest.
fn clip_at(p: vec3f, margin: f32) -> u32 {
    for (var k = 0u; k + 1u < CLIPS; k++) {
        let g = grid_position(k, p);
        if all(g >= vec3f(margin)) && all(g <= vec3f(f32(GRID) - margin)) {
            return k;
        }
    }
    let g = grid_position(CLIPS - 1u, p);
    return select(CLIPS, CLIPS - 1u, all(g >= vec3f(0.0)) && all(g <= vec3f(f32(GRID))));
}

struct Voxel {
    occupied: bool,
    albedo: vec3f,
    // The mean authored normal (unnormalised; short where opposite faces share the voxel).
    normal: vec3f,
    count: u32,
}

fn load_voxel(c: vec3u) -> Voxel {
    let a = textureLoad(voxel_albedo, c).x;
    var v: Voxel;
    v.count = a >> 24u;
    v.occupied = v.count > 0u;
    v.albedo = unpack4x8unorm(a).rgb;
    v.normal = unpack4x8snorm(textureLoad(voxel_normal, c).x).xyz;
    return v;
}

// Whether surfaces were added to voxel c (its count, in the albedo word's top byte).
fn voxel_occupied(c: vec3u) -> bool {
    return (textureLoad(voxel_albedo, c).x >> 24u) > 0u;
}

fn store_voxel(c: vec3u, v: Voxel) {
    let count = f32(min(v.count, 255u)) / 255.0;
    textureStore(voxel_albedo, c, vec4u(pack4x8unorm(vec4f(v.albedo, count)), 0u, 0u, 0u));
    textureStore(voxel_normal, c, vec4u(pack4x8snorm(vec4f(v.normal, 0.0)), 0u, 0u, 0u));
}

// The direction a voxel's light leaves in: its mean normal, or up where its faces cancel.
fn voxel_direction(v: Voxel) -> vec3f {
    return select(vec3f(0.0, 1.0, 0.0), normalize(v.normal), length(v.normal) > 1e-3);
}
