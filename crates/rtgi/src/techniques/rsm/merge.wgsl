// Merge (re-interleave): atlas layout -> image layout (see atlas.wgsl), written as one packed half-float
// vec4 per pixel, row-major: the input format of the shared discontinuity filter.

#import common/frame.wgsl

@group(2) @binding(0) var atlas: texture_2d<f32>;
@group(2) @binding(1) var<storage, read_write> image: array<vec2u>;

@compute @workgroup_size(TILE, TILE)
fn merge(@builtin(global_invocation_id) id: vec3u) {
    let p = id.xy;
    if any(p >= frame.size) {
        return;
    }
    image[p.y * frame.size.x + p.x] = pack_half4(textureLoad(atlas, vec2i(atlas_of_pixel(p)), 0));
}
