// Scrolling a clipmap level (prepended: volume.wgsl): the level has moved by `volume.shifts[k]` of its
// voxels, and its voxel words and radiance were copied, as they were, into the scratch textures below
// (one level's worth, GRID³). Each voxel of the level takes what the voxel it now is held before the
// move, or nothing where the level enters new space (voxelisation and injection fill those slabs next).
// One dispatch over the whole level (`dispatch_slot.clip`); the radiance written is radiance_out's
// texture (the first bounce's, or with scroll_radiance the second's; previous_radiance holds its copy).

@group(3) @binding(0) var previous_albedo: texture_3d<u32>;
@group(3) @binding(1) var previous_normal: texture_3d<u32>;
@group(3) @binding(2) var previous_radiance: texture_3d<f32>;

// Where voxel `id` of level k was before the move (w = 1), or w = 0 if the level did not hold it.
fn previous_voxel(k: u32, id: vec3u) -> vec4i {
    let source = vec3i(id) + volume.shifts[k].xyz;
    let kept = all(source >= vec3i(0)) && all(source < vec3i(i32(GRID)));
    return vec4i(source, select(0, 1, kept));
}

fn scroll_radiance_of(k: u32, id: vec3u, source: vec4i) {
    var radiance = vec4f(0.0);
    if source.w != 0 {
        radiance = textureLoad(previous_radiance, source.xyz, 0);
    }
    textureStore(radiance_out, clip_texel(k, id), radiance);
}

@compute @workgroup_size(4, 4, 4)
fn scroll_voxels(@builtin(global_invocation_id) id: vec3u) {
    if any(id >= vec3u(GRID)) {
        return;
    }
    let k = dispatch_slot.clip;
    let source = previous_voxel(k, id);
    var words = vec2u(0u);
    if source.w != 0 {
        words = vec2u(textureLoad(previous_albedo, source.xyz, 0).x, textureLoad(previous_normal, source.xyz, 0).x);
    }
    let t = clip_texel(k, id);
    textureStore(voxel_albedo, t, vec4u(words.x, 0u, 0u, 0u));
    textureStore(voxel_normal, t, vec4u(words.y, 0u, 0u, 0u));
    scroll_radiance_of(k, id, source);
}

@compute @workgroup_size(4, 4, 4)
fn scroll_radiance(@builtin(global_invocation_id) id: vec3u) {
    if any(id >= vec3u(GRID)) {
        return;
    }
    let k = dispatch_slot.clip;
    scroll_radiance_of(k, id, previous_voxel(k, id));
}
