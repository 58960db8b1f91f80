// Splatting indirect illumination in compute, at the cost of a gather over the VPLs that reach each
// tile, without blending traffic: (1) each VPL's atlas rectangle; (2) per TILE×TILE tile of the atlas, a
// bit set of the VPLs whose rectangle meets it (one thread per 32-VPL word: no atomics, so the sets do
// not depend on thread order); (3) per atlas texel, the sum over its tile's VPLs in index order of what
// each adds where its rectangle covers the texel and its sphere holds the surface — the texels, values
// and order of the raster splat's additive blending, so the images agree.

@group(2) @binding(1) var<storage, read_write> rects: array<vec4f>;
@group(2) @binding(2) var<storage, read_write> bins: array<u32>;
@group(2) @binding(3) var atlas_out: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(64, 1, 1)
fn splat_rects(@builtin(global_invocation_id) id: vec3u) {
    if id.x < VPL_COUNT {
        rects[id.x] = splat_atlas_rect(vpls[id.x]);
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
        let r = rects[k];
        if all(r.xy < tile_hi) && all(r.zw > tile_lo) {
            bits |= 1u << b;
        }
    }
    bins[(id.y + id.z * TILES_X) * BIN_WORDS + word] = bits;
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
        any_vpl |= bins[first + word];
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
        var bits = bins[first + word];
        while bits != 0u {
            let k = word * 32u + firstTrailingBit(bits);
            bits &= bits - 1u;
            let r = rects[k];
            if all(centre >= r.xy) && all(centre < r.zw) {
                let v = vpls[k];
                if splat_reaches(s, v) {
                    sum += splat_radiance(s, v);
                    count += 1.0;
                }
            }
        }
    }
    textureStore(atlas_out, a, vec4f(sum, count));
}
