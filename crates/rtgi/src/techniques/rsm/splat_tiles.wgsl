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

fn table_rect(k: u32) -> vec4f {
    return textureLoad(vpl_table, vpl_table_texel(k, VPL_TABLE_RECT), 0);
}

// Whether the texel whose centre is `centre` lies in the atlas rectangle `r`.
fn rect_covers(r: vec4f, centre: vec2f) -> bool {
    return all(centre >= r.xy) && all(centre < r.zw);
}

// Adds VPL v's light at surface s to sum.rgb and 1 to sum.a, where v reaches s.
fn splat_add(s: GSurface, v: Vpl, sum: ptr<function, vec4f>) {
    if splat_reaches(s, v) {
        *sum += vec4f(splat_radiance(s, v), 1.0);
    }
}

// Whether any VPL meets the tile whose set starts at word `first`.
fn tile_has_vpls(first: u32) -> bool {
    var any_vpl = 0u;
    for (var word = 0u; word < BIN_WORDS; word++) {
        any_vpl |= bin_word(first + word);
    }
    return any_vpl != 0u;
}

// Each texel reads its tile's VPLs from the table: cheapest on a CPU driver (lavapipe fetches a texel
// for all lanes of a batch at once, and runs a workgroup barrier by switching between its batches).
@compute @workgroup_size(TILE, TILE, 1)
fn splat_tiles(@builtin(global_invocation_id) id: vec3u, @builtin(workgroup_id) tile: vec3u) {
    let a = id.xy;
    if any(a >= atlas_size()) {
        return;
    }
    let first = (tile.x + tile.y * TILES_X) * BIN_WORDS;
    // A tile no VPL meets (unlit scenes, outside every splat) reads no G-buffer.
    if !tile_has_vpls(first) {
        textureStore(atlas_out, a, vec4f(0.0));
        return;
    }
    let s = atlas_surface(a);
    let centre = vec2f(a) + 0.5;
    var sum = vec4f(0.0);
    for (var word = 0u; word < BIN_WORDS; word++) {
        var bits = bin_word(first + word);
        while bits != 0u {
            let k = word * 32u + firstTrailingBit(bits);
            bits &= bits - 1u;
            if rect_covers(table_rect(k), centre) {
                splat_add(s, table_vpl(k), &sum);
            }
        }
    }
    textureStore(atlas_out, a, sum);
}

// splat_tiles_shared loads each round of a tile's VPLs into workgroup memory once (one VPL per
// invocation, SPLAT_ROUND_WORDS words of the set per round), and every texel of the tile reads them
// there. A GPU's texture units deliver 16-byte texels at a fraction of the rate of its other work, and
// the per-texel loop fetches four per texel and VPL: on an H200 at 1080p that splat took 2.0-2.9x the
// time of the rsm gather (docs/measurements/splat-gpu.md). On lavapipe this one takes 1.5x the time of
// splat_tiles (barriers), hence both.
const SPLAT_ROUND_VPLS: u32 = TILE * TILE;
const SPLAT_ROUND_WORDS: u32 = SPLAT_ROUND_VPLS / 32u;

struct RoundVpl {
    vpl: Vpl,
    rect: vec4f,
}

var<workgroup> round_vpls: array<RoundVpl, SPLAT_ROUND_VPLS>;

// Word w of the tile's set whose first word is `first` (0 past the last word).
fn tile_word(first: u32, w: u32) -> u32 {
    if w >= BIN_WORDS {
        return 0u;
    }
    return bin_word(first + w);
}

// Every invocation of a workgroup takes each branch and loop trip alike (the conditions are the
// tile's, not the texel's) and reaches the barriers; a texel outside the atlas computes with the
// atlas's last texel and stores nothing.
@compute @workgroup_size(TILE, TILE, 1)
fn splat_tiles_shared(
    @builtin(global_invocation_id) id: vec3u,
    @builtin(workgroup_id) tile: vec3u,
    @builtin(local_invocation_index) lane: u32,
) {
    let a = id.xy;
    let inside = all(a < atlas_size());
    let first = (tile.x + tile.y * TILES_X) * BIN_WORDS;
    if !tile_has_vpls(first) {
        if inside {
            textureStore(atlas_out, a, vec4f(0.0));
        }
        return;
    }
    let s = atlas_surface(min(a, atlas_size() - 1u));
    let centre = vec2f(a) + 0.5;
    var sum = vec4f(0.0);
    for (var round = 0u; round < BIN_WORDS; round += SPLAT_ROUND_WORDS) {
        var in_round = 0u;
        for (var w = 0u; w < SPLAT_ROUND_WORDS; w++) {
            in_round |= tile_word(first, round + w);
        }
        if in_round == 0u {
            continue;
        }
        if (tile_word(first, round + lane / 32u) & (1u << (lane % 32u))) != 0u {
            let k = round * 32u + lane;
            round_vpls[lane] = RoundVpl(table_vpl(k), table_rect(k));
        }
        workgroupBarrier();
        // The VPLs in index order, as the raster splat blends them.
        for (var w = 0u; w < SPLAT_ROUND_WORDS; w++) {
            var bits = tile_word(first, round + w);
            while bits != 0u {
                let slot = w * 32u + firstTrailingBit(bits);
                bits &= bits - 1u;
                if rect_covers(round_vpls[slot].rect, centre) {
                    splat_add(s, round_vpls[slot].vpl, &sum);
                }
            }
        }
        workgroupBarrier();
    }
    if inside {
        textureStore(atlas_out, a, sum);
    }
}
