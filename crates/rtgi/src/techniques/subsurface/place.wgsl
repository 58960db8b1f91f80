// Places every illumination sample on its triangle as the scene's vertices are now: once, and again
// whenever meshes move (the tree pass then refits the nodes' bounds), so samples ride on moving
// translucent objects without a new build.

#import common/scene.wgsl
#import common/indirect.wgsl

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let i = indirect_linear_index(id, groups, 64u);
    if i >= arrayLength(&samples) {
        return;
    }
    let s = samples[i];
    let t = triangle_vertices(s.triangle);
    let w = vec3f(1.0 - s.u - s.v, s.u, s.v);
    samples[i].position = t[0].position * w.x + t[1].position * w.y + t[2].position * w.z;
    let n = vertex_normal(t[0]) * w.x + vertex_normal(t[1]) * w.y + vertex_normal(t[2]) * w.z;
    let geometric = cross(t[1].position - t[0].position, t[2].position - t[0].position);
    samples[i].normal = normalize(select(geometric, n, dot(n, n) > 0.0));
}
