// Radiance cache splatting (Gautron et al. 2005) in compute: instead of blending one quad per record,
// (1) each record of the range [splat_begin, count) gets the framebuffer rectangle of its zone of
// influence, (2) each BIN_TILE² tile a bit set of the records whose rectangle meets it (one thread per
// 32-record word: no atomics, so the sets do not depend on thread order), (3) each pixel adds, in record
// order, w_k · E_k(p) and w_k of every record of its tile's set whose weight reaches 1/a. The sums equal
// the classical interpolation's over all records (no record outside its rectangle reaches 1/a), in a
// fixed order, so the image does not depend on scheduling.

@compute @workgroup_size(64, 1, 1)
fn splat_rects(@builtin(global_invocation_id) id: vec3u) {
    let k = state.splat_begin + id.x;
    if k < state.count {
        rects[id.x] = record_screen_rect(records[k]);
    }
}

// Invocation (word, tile x, tile y).
@compute @workgroup_size(64, 1, 1)
fn splat_bins(@builtin(global_invocation_id) id: vec3u) {
    let word = id.x;
    let range = state.count - state.splat_begin;
    if word >= BIN_WORDS || word * 32u >= range {
        return;
    }
    let tile_lo = vec2f(vec2u(id.y, id.z) * BIN_TILE);
    let tile_hi = tile_lo + f32(BIN_TILE);
    var bits = 0u;
    for (var b = 0u; b < 32u; b++) {
        let i = word * 32u + b;
        if i < range {
            let r = rects[i];
            if all(r.xy < tile_hi) && all(r.zw > tile_lo) {
                bits |= 1u << b;
            }
        }
    }
    bins[(id.y + id.z * BIN_TILES_X) * BIN_WORDS + word] = bits;
}

@compute @workgroup_size(TILE, TILE, 1)
fn splat(@builtin(global_invocation_id) id: vec3u) {
    if any(id.xy >= frame.size) {
        return;
    }
    let begin = state.splat_begin;
    let range = state.count - begin;
    // Nothing to add (the rounds that find no miss): the buffer already holds the sums.
    if range == 0u && begin > 0u {
        return;
    }
    var sum = vec4f(0.0);
    if begin > 0u {
        sum = textureLoad(splat_buffer, id.xy);
    }
    let s = load_gsurface(id.xy);
    if s.valid && range > 0u {
        let tile = id.xy / BIN_TILE;
        let first = (tile.x + tile.y * BIN_TILES_X) * BIN_WORDS;
        let words = (range + 31u) / 32u;
        for (var word = 0u; word < words; word++) {
            var bits = bins[first + word];
            while bits != 0u {
                let k = begin + word * 32u + firstTrailingBit(bits);
                bits &= bits - 1u;
                let r = records[k];
                let e = record_error(r, s.position, s.normal);
                if e <= ACCURACY {
                    let w = record_weight_of_error(e);
                    sum += vec4f(w * record_irradiance(r, s.position, s.normal), w);
                }
            }
        }
    }
    textureStore(splat_buffer, id.xy, sum);
}
