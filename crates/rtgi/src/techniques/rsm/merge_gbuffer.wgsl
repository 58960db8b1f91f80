// Merge of the split G-buffer copies (surfaces.wgsl, bindings 8–11) back into the image layout: with
// split.wgsl, the round trip the tests check bit for bit.

#import common/frame.wgsl

@group(2) @binding(0) var out_albedo: texture_storage_2d<rgba16float, write>;
@group(2) @binding(1) var out_normal: texture_storage_2d<rgba16float, write>;
@group(2) @binding(2) var out_material: texture_storage_2d<rg32uint, write>;
@group(2) @binding(3) var out_distance: texture_storage_2d<r32float, write>;

@compute @workgroup_size(TILE, TILE)
fn merge_gbuffer(@builtin(global_invocation_id) id: vec3u) {
    let p = id.xy;
    if any(p >= frame.size) {
        return;
    }
    let a = vec2i(atlas_of_pixel(p));
    textureStore(out_albedo, p, textureLoad(sp_albedo, a, 0));
    textureStore(out_normal, p, textureLoad(sp_normal, a, 0));
    textureStore(out_material, p, textureLoad(sp_material, a, 0));
    textureStore(out_distance, p, textureLoad(sp_distance, a, 0));
}
