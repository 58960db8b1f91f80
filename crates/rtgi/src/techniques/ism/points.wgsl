// The point pool of the imperfect shadow maps in world space: each point is a triangle and
// barycentrics, placed once by area on the CPU, and moves with its triangle (this pass runs again when
// meshes move). Points on alpha-masked texels are marked invalid (w = 0): they occlude nothing.

#import common/scene.wgsl

@group(2) @binding(0) var<storage, read> pool: array<vec4f>;
@group(2) @binding(1) var<storage, read_write> positions: array<vec4f>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= ISM_POOL {
        return;
    }
    let p = pool[id.x];
    let triangle = bitcast<u32>(p.x);
    let t = triangle_vertices(triangle);
    let position = t[0].position * (1.0 - p.y - p.z) + t[1].position * p.y + t[2].position * p.z;
    let visible = bvh_alpha_test(triangle, p.y, p.z);
    positions[id.x] = vec4f(position, select(0.0, 1.0, visible));
}
