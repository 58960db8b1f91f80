// Voxelisation (prepended: volume.wgsl) by rays through the shared BVH: for each axis, one ray per
// column of voxels along it, through the voxel centres of the other two axes, meets the surfaces in
// order; every hit adds its surface to the voxel that holds it. A triangle is found by the rays of its
// dominant axis at least once per voxel it crosses, as a rasteriser projecting it on that axis would
// (the paper's voxelisation without its conservative rasterisation: a surface that crosses a voxel away
// from the column centres can be missed; conservative.wgsl adds those voxels). The axes run in three dispatches and each thread owns its column,
// so the running means are updated without atomics and in the same order on every run. Each clipmap
// level is voxelised by its own dispatches (`dispatch_slot.clip`).

#import common/scene.wgsl
#import common/brdf.wgsl


// A surface on a voxel face belongs to the voxel behind it (against its authored normal): the hit
// point moves this far (in voxels) against the normal before it picks its voxel.
const FACE_TIE: f32 = 1e-3;

fn add_surface(c: vec3u, albedo: vec3f, normal: vec3f) {
    var v = load_voxel(c);
    let k = f32(v.count);
    v.albedo = (v.albedo * k + albedo) / (k + 1.0);
    v.normal = (v.normal * k + normal) / (k + 1.0);
    v.count = min(v.count + 1u, 255u);
    store_voxel(c, v);
}

// Clears the dispatch's box.
@compute @workgroup_size(4, 4, 4)
fn clear_voxels(@builtin(global_invocation_id) id: vec3u) {
    let voxel = box_voxel(id);
    if voxel.w == 0 {
        return;
    }
    let t = clip_texel(dispatch_slot.clip, vec3u(voxel.xyz));
    textureStore(voxel_albedo, t, vec4u(0u));
    textureStore(voxel_normal, t, vec4u(0u));
}

// One thread per column of the dispatch's box along `dispatch_slot.axis`. The column's ray is the same
// for every box and every placement of the level: it starts on the lattice origin's plane, through the
// centres of the column's lattice voxels, and only its interval changes (the box's span, widened by a
// voxel at each end so that surfaces on the box's faces are met; each surface goes to the voxel it
// belongs to, if that lies in the box). A scrolled level's new slabs then get the voxels a level
// voxelised where it stands would get.
@compute @workgroup_size(8, 8)
fn voxelize(@builtin(global_invocation_id) id: vec3u) {
    let a = dispatch_slot.axis;
    let level = dispatch_slot.clip;
    let b = dispatch_box();
    let u = (a + 1u) % 3u;
    let v = (a + 2u) % 3u;
    if i32(id.x) >= b.hi[u] - b.lo[u] || i32(id.y) >= b.hi[v] - b.lo[v] {
        return;
    }
    let corner = volume.corners[level].xyz;
    var w = vec3f(0.0);
    w[u] = f32(corner[u] + b.lo[u] + i32(id.x)) + 0.5;
    w[v] = f32(corner[v] + b.lo[v] + i32(id.y)) + 0.5;
    var dir = vec3f(0.0);
    dir[a] = 1.0;
    let cell = voxel_size(level);
    let ray = Ray(volume.origin.xyz + w * cell, dir);
    var tmin = f32(corner[a] + b.lo[a] - 1) * cell;
    let tmax = f32(corner[a] + b.hi[a] + 1) * cell;
    // Hits closer than this to the previous one are the same surface (a shared edge, a coplanar twin).
    let separation = FACE_TIE * cell;
    // A column holds at most GRID + 2 voxels; more hits than twice that are surfaces sharing voxels.
    for (var k = 0u; k < 2u * GRID + 4u; k++) {
        let hit = trace_closest(ray, tmin, tmax);
        if !hit_found(hit) {
            break;
        }
        tmin = hit.t + separation;
        let s = surface_at(hit.triangle, hit.u, hit.v, dir);
        // surface_at faces the normals towards the ray; the voxel keeps the authored side.
        let authored = select(1.0, -1.0, hits_back_face(hit.triangle, hit.u, hit.v, dir));
        let tie = lattice_position(level, s.position) - s.geometric_normal * (authored * FACE_TIE);
        let c = vec3i(floor(tie)) - corner;
        if all(c >= b.lo.xyz) && all(c < b.hi.xyz) {
            let albedo = brdf_lobe_weights(s.material, 1.0).diffuse;
            add_surface(clip_texel(level, vec3u(c)), albedo, s.normal * authored);
        }
    }
}
