// Splatting indirect illumination in compute, at the cost of a gather over the VPLs that reach each
// tile, without blending traffic: (1) each VPL's atlas rectangle; (2) per TILE×TILE tile of the atlas, a
// bit set of the VPLs whose rectangle meets it (one thread per 32-VPL word: no atomics, so the sets do
// not depend on thread order); (3) per atlas texel, the sum over its tile's VPLs in index order of what
// each adds where its rectangle covers the texel and its sphere holds the surface — the texels, values
// and order of the raster splat's additive blending, so the images agree.

// The tile sets, copied into a linear texture after `splat_bins` (read in loops: see gpu/linear_texture.rs).
@group(2) @binding(1) var bin_table: texture_2d<u32>;
@group(2) @binding(2) var atlas_out: texture_storage_2d<rgba32float, write>;
// The VPLs and their rectangles, copied by `splat_rects` (`splat_bins.wgsl`): read inside the VPL loop,
// where lavapipe loads a storage buffer lane by lane (about 3x the cost of the whole VPL's shading)
// but fetches a texture for all lanes at once.
@group(2) @binding(3) var vpl_table: texture_2d<f32>;

fn bin_word(i: u32) -> u32 {
    return textureLoad(bin_table, linear_texel(i), 0).x;
}

fn table_vpl(k: u32) -> Vpl {
    let position = textureLoad(vpl_table, vpl_table_texel(k, VPL_TABLE_POSITION), 0);
    let normal = textureLoad(vpl_table, vpl_table_texel(k, VPL_TABLE_NORMAL), 0);
    let intensity = textureLoad(vpl_table, vpl_table_texel(k, VPL_TABLE_INTENSITY), 0);
    // The subset is not needed here: the rectangle already lies in the VPL's sub-buffer.
    return Vpl(position.xyz, position.w, normal.xyz, normal.w, intensity.rgb, 0u);
}

@compute @workgroup_size(TILE, TILE, 1)
fn splat_tiles(@builtin(global_invocation_id) id: vec3u, @builtin(workgroup_id) tile: vec3u) {
    let a = id.xy;
    if any(a >= atlas_size()) {
        return;
    }
    let first = (tile.x + tile.y * TILES_X) * BIN_WORDS;
    // A tile no VPL meets (unlit scenes, outside every splat) reads no G-buffer.
    var any_vpl = 0u;
    for (var word = 0u; word < BIN_WORDS; word++) {
        any_vpl |= bin_word(first + word);
    }
    if any_vpl == 0u {
        textureStore(atlas_out, a, vec4f(0.0));
        return;
    }
    let s = atlas_surface(a);
    let centre = vec2f(a) + 0.5;
    var sum = vec3f(0.0);
    var count = 0.0;
    for (var word = 0u; word < BIN_WORDS; word++) {
        var bits = bin_word(first + word);
        while bits != 0u {
            let k = word * 32u + firstTrailingBit(bits);
            bits &= bits - 1u;
            let r = textureLoad(vpl_table, vpl_table_texel(k, VPL_TABLE_RECT), 0);
            if all(centre >= r.xy) && all(centre < r.zw) {
                let v = table_vpl(k);
                if splat_reaches(s, v) {
                    sum += splat_radiance(s, v);
                    count += 1.0;
                }
            }
        }
    }
    textureStore(atlas_out, a, vec4f(sum, count));
}
