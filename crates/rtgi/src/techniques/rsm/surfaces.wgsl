// G-buffer surfaces in the atlas layout (bind group 2, bindings 8–11): the split copy of the G-buffer
// when SPLIT_GBUFFER, otherwise the frame's own G-buffer textures read at the atlas texel's pixel.

@group(2) @binding(8) var sp_albedo: texture_2d<f32>;
@group(2) @binding(9) var sp_normal: texture_2d<f32>;
@group(2) @binding(10) var sp_material: texture_2d<u32>;
@group(2) @binding(11) var sp_distance: texture_2d<f32>;

fn atlas_surface(a: vec2u) -> GSurface {
    let src = atlas_source(a);
    let c = vec2i(select(src.pixel, a, SPLIT_GBUFFER));
    var distance = textureLoad(sp_distance, c, 0).r;
    if !src.valid {
        distance = 0.0;
    }
    return decode_gsurface(
        src.pixel,
        distance,
        textureLoad(sp_normal, c, 0),
        textureLoad(sp_albedo, c, 0),
        textureLoad(sp_material, c, 0).xy,
    );
}
