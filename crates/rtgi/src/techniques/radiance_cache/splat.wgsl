// Radiance cache splatting (Gautron et al. 2005) in compute: instead of blending one quad per record,
// (1) each record of the range [splat_begin, count) gets the framebuffer rectangle of its zone of
// influence, (2) each BIN_TILE² tile a bit set of the records whose rectangle meets it (one thread per
// 32-record word: no atomics, so the sets do not depend on thread order), (3) each pixel adds, in record
// order, w_k · E_k(p) and w_k of every record of its tile's set whose weight reaches 1/a. The sums equal
// the classical interpolation's over all records (no record outside its rectangle reaches 1/a), in a
// fixed order, so the image does not depend on scheduling. Diffuse pixels sum irradiance records'
// w_k E_k(p); glossy pixels sum radiance records' w_k L_k(p, ω_o), where L_k is the dot product of the
// record's HSH incoming radiance (extrapolated to p) with the HSH BRDF tables at the pixel's outgoing
// direction: the record's hemisphere is read in the pixel's frame, unrotated (exact between equal
// normals, as on a wall; the thesis rotates it). A glossy pixel walks its records once per coefficient
// (Σ_k w_k λ_ki(p), then times the BRDF's coefficient i), so no invocation holds more than one
// coefficient of the pixel's BRDF.

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

// Where the records of a pixel's tile's set start, and how many words of it the range fills.
struct TileSet {
    first: u32,
    words: u32,
}

fn tile_set(pixel: vec2u, range: u32) -> TileSet {
    let tile = pixel / BIN_TILE;
    return TileSet((tile.x + tile.y * BIN_TILES_X) * BIN_WORDS, (range + 31u) / 32u);
}

// Σ_k w_k E_k(p) (rgb) and Σ_k w_k (a) over the irradiance records of the tile set that reach the
// diffuse surface s.
fn irradiance_sum(tiles: TileSet, begin: u32, s: GSurface) -> vec4f {
    var sum = vec4f(0.0);
    for (var word = 0u; word < tiles.words; word++) {
        var bits = bins[tiles.first + word];
        while bits != 0u {
            let k = begin + word * 32u + firstTrailingBit(bits);
            bits &= bits - 1u;
            let r = records[k];
            let e = record_error(r, s.position, s.normal);
            if !record_is_radiance(r) && !record_is_deleted(r) && e <= ACCURACY {
                let w = record_weight_of_error(e);
                sum += vec4f(w * record_irradiance_now(k, r, s.position, s.normal), w);
                mark_used(k);
            }
        }
    }
    return sum;
}

// Σ_k w_k λ_ki(p) (rgb) and Σ_k w_k (a) over the radiance records of the tile set that reach the
// glossy surface s.
fn radiance_sum(tiles: TileSet, begin: u32, s: GSurface, i: u32) -> vec4f {
    var sum = vec4f(0.0);
    for (var word = 0u; word < tiles.words; word++) {
        var bits = bins[tiles.first + word];
        while bits != 0u {
            let k = begin + word * 32u + firstTrailingBit(bits);
            bits &= bits - 1u;
            let r = records[k];
            let e = record_error(r, s.position, s.normal);
            if record_is_radiance(r) && e <= GLOSSY_ACCURACY {
                let w = record_weight_of_error(e);
                sum += vec4f(w * record_radiance(k, r, i, s.position), w);
                if i == 0u {
                    mark_used(k);
                }
            }
        }
    }
    return sum;
}

// Σ_k w_k L_k(p, ω_o) (rgb) and Σ_k w_k (a) of a glossy surface.
fn glossy_splat(tiles: TileSet, begin: u32, s: GSurface) -> vec4f {
    let count = radiance_coefficients();
    let first = radiance_sum(tiles, begin, s, 0u);
    if first.a <= 0.0 {
        return vec4f(0.0);
    }
    let t = brdf_table_lookup(world_to_local(s.view, s.normal), s.material.roughness);
    // The four lobes' integrals against the records' light, combined with the material once.
    var lambert = vec3f(0.0);
    var lambert_fresnel = vec3f(0.0);
    var ggx = vec3f(0.0);
    var ggx_fresnel = vec3f(0.0);
    for (var i = 0u; i < count; i++) {
        var incoming = first.rgb;
        if i > 0u {
            incoming = radiance_sum(tiles, begin, s, i).rgb;
        }
        let l = brdf_table_lobes(t, i, count);
        lambert += incoming * l.x;
        lambert_fresnel += incoming * l.y;
        ggx += incoming * l.z;
        ggx_fresnel += incoming * l.w;
    }
    return vec4f(brdf_table_combine(s.material, lambert, lambert_fresnel, ggx, ggx_fresnel), first.a);
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
        if is_glossy(s.material) {
            sum += glossy_splat(tile_set(id.xy, range), begin, s);
        } else {
            sum += irradiance_sum(tile_set(id.xy, range), begin, s);
        }
    }
    textureStore(splat_buffer, id.xy, sum);
}
