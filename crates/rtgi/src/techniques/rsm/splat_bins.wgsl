// The tiled compute splat's set-up (see `splat_tiles.wgsl`): (1) each VPL's atlas rectangle; (2) per
// TILE×TILE tile of the atlas, a bit set of the VPLs whose rectangle meets it (one thread per 32-VPL word:
// no atomics, so the sets do not depend on thread order); and the VPL table the per-texel pass reads.

// splat_rects writes the table; splat_bins reads it (two bind groups: a texture is not written and read
// in one dispatch). Storage buffers are loaded lane by lane inside loops on lavapipe, textures are not.
@group(2) @binding(1) var<storage, read_write> bins: array<u32>;
@group(2) @binding(2) var vpl_table_out: texture_storage_2d<rgba32float, write>;
@group(2) @binding(3) var vpl_table: texture_2d<f32>;

@compute @workgroup_size(64, 1, 1)
fn splat_rects(@builtin(global_invocation_id) id: vec3u) {
    if id.x < VPL_COUNT {
        let v = vpls[id.x];
        let rect = splat_atlas_rect(v);
        let k = id.x;
        textureStore(vpl_table_out, vpl_table_texel(k, VPL_TABLE_POSITION), vec4f(v.position, v.radius));
        textureStore(vpl_table_out, vpl_table_texel(k, VPL_TABLE_NORMAL), vec4f(v.normal, v.area));
        textureStore(vpl_table_out, vpl_table_texel(k, VPL_TABLE_INTENSITY), vec4f(v.intensity, 0.0));
        textureStore(vpl_table_out, vpl_table_texel(k, VPL_TABLE_RECT), rect);
    }
}

// Invocation (word, tile x, tile y).
@compute @workgroup_size(64, 1, 1)
fn splat_bins(@builtin(global_invocation_id) id: vec3u) {
    let word = id.x;
    if word >= BIN_WORDS {
        return;
    }
    let tile_lo = vec2f(vec2u(id.y, id.z) * TILE);
    let tile_hi = tile_lo + f32(TILE);
    var bits = 0u;
    for (var b = 0u; b < 32u; b++) {
        let k = word * 32u + b;
        if k >= VPL_COUNT {
            break;
        }
        let r = textureLoad(vpl_table, vpl_table_texel(k, VPL_TABLE_RECT), 0);
        if all(r.xy < tile_hi) && all(r.zw > tile_lo) {
            bits |= 1u << b;
        }
    }
    bins[(id.y + id.z * TILES_X) * BIN_WORDS + word] = bits;
}
