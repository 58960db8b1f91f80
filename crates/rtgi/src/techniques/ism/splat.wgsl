// Splats the point pool into every VPL's paraboloid map, one workgroup per VPL (its frame is set up
// once, then the threads stride through its ISM_POINTS_PER_VPL points): each point is drawn as a
// square of texels sized by the disc it stands for (radius ISM_POINT_RADIUS, seen from the VPL; at
// most 5×5 texels), keeping the nearest distance per texel. The atlas holds !bits(distance) so that
// atomicMax keeps the nearest and the cleared value 0 reads as empty.

#import common/math.wgsl

@group(2) @binding(0) var<storage, read> vpls: array<Vpl>;
@group(2) @binding(1) var<storage, read> positions: array<vec4f>;
@group(2) @binding(2) var<storage, read_write> atlas: array<atomic<u32>>;

const THREADS: u32 = 64u;

@compute @workgroup_size(THREADS)
fn main(@builtin(workgroup_id) group: vec3u, @builtin(local_invocation_index) thread: u32) {
    let k = group.x;
    let v = vpls[k];
    if !ism_covers(v.kind) {
        return;
    }
    let tangent = basis_tangent(v.normal);
    let bitangent = basis_bitangent(v.normal);
    let start = ism_pool_start(k);
    let base = k * ISM_SIZE * ISM_SIZE;
    for (var j = thread; j < ISM_POINTS_PER_VPL; j += THREADS) {
        let p = positions[(start + j) % ISM_POOL];
        let d = p.xyz - v.position;
        let distance = length(d);
        let local = vec3f(dot(d, tangent), dot(d, bitangent), dot(d, v.normal)) / distance;
        if p.w == 0.0 || distance <= 1e-6 || local.z <= 0.0 {
            continue;
        }
        let centre = ism_texel_coords(local);
        let radius = i32(min(ISM_POINT_RADIUS / distance / ism_texel_angle(local.z), 2.0));
        let texel = vec2i(floor(centre));
        let value = ~bitcast<u32>(distance);
        for (var y = max(texel.y - radius, 0); y <= min(texel.y + radius, i32(ISM_SIZE) - 1); y++) {
            for (var x = max(texel.x - radius, 0); x <= min(texel.x + radius, i32(ISM_SIZE) - 1); x++) {
                atomicMax(&atlas[base + u32(y) * ISM_SIZE + u32(x)], value);
            }
        }
    }
}
