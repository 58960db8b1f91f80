// Split (de-interleave) and merge of per-pixel buffers between the image layout and the atlas layout
// of atlas.wgsl. Both are pure copies, so a split followed by a merge reproduces its input bit for bit.

#import common/frame.wgsl

// split_gbuffer: frame G-buffer -> atlas copies.
@group(2) @binding(0) var out_albedo: texture_storage_2d<rgba16float, write>;
@group(2) @binding(1) var out_normal: texture_storage_2d<rgba16float, write>;
@group(2) @binding(2) var out_material: texture_storage_2d<rg32uint, write>;
@group(2) @binding(3) var out_distance: texture_storage_2d<r32float, write>;

@compute @workgroup_size(TILE, TILE)
fn split_gbuffer(@builtin(global_invocation_id) id: vec3u) {
    let a = id.xy;
    if any(a >= atlas_size()) {
        return;
    }
    let src = atlas_source(a);
    if !src.valid {
        textureStore(out_distance, a, vec4f(0.0));
        return;
    }
    let p = vec2i(src.pixel);
    textureStore(out_albedo, a, textureLoad(gb_albedo, p, 0));
    textureStore(out_normal, a, textureLoad(gb_normal, p, 0));
    textureStore(out_material, a, textureLoad(gb_material, p, 0));
    textureStore(out_distance, a, textureLoad(gb_distance, p, 0));
}
