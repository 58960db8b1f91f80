// Voxel cone tracing (Crassin et al. 2011): the voxel grid every VXGI pass shares. Layouts mirror
// `vxgi/mod.rs`.
//
// The volume is a cube of GRID³ voxels of edge `volume.corner_voxel.w` whose minimum corner is
// `volume.corner_voxel.xyz`. Positions inside it are in voxel units ("grid units": voxel k spans
// [k, k+1) on each axis). Voxelisation leaves two r32uint words per voxel: the running mean of the
// diffuse albedo of the surfaces in it (rgb, unorm8) with their count (the top byte; 0 = empty), and
// the running mean of their authored normals (snorm8 xyz).

struct VxgiVolume {
    corner_voxel: vec4f,
}

@group(2) @binding(0) var<uniform> volume: VxgiVolume;
@group(2) @binding(1) var voxel_albedo: texture_storage_3d<r32uint, read_write>;
@group(2) @binding(2) var voxel_normal: texture_storage_3d<r32uint, read_write>;

fn voxel_size() -> f32 {
    return volume.corner_voxel.w;
}

fn grid_position(p: vec3f) -> vec3f {
    return (p - volume.corner_voxel.xyz) / voxel_size();
}

fn world_position(g: vec3f) -> vec3f {
    return volume.corner_voxel.xyz + g * voxel_size();
}

fn inside_grid(g: vec3f) -> bool {
    return all(g >= vec3f(0.0)) && all(g < vec3f(f32(GRID)));
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

fn store_voxel(c: vec3u, v: Voxel) {
    let count = f32(min(v.count, 255u)) / 255.0;
    textureStore(voxel_albedo, c, vec4u(pack4x8unorm(vec4f(v.albedo, count)), 0u, 0u, 0u));
    textureStore(voxel_normal, c, vec4u(pack4x8snorm(vec4f(v.normal, 0.0)), 0u, 0u, 0u));
}

// The direction a voxel's light leaves in: its mean normal, or up where its faces cancel.
fn voxel_direction(v: Voxel) -> vec3f {
    return select(vec3f(0.0, 1.0, 0.0), normalize(v.normal), length(v.normal) > 1e-3);
}
