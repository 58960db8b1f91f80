// Direct + indirect light into the technique's output, averaged progressively over frames. The indirect
// light is a texture (`main`) or a packed half-float buffer from the discontinuity filter (`main_packed`).

#import common/frame.wgsl

@group(2) @binding(0) var direct: texture_2d<f32>;
@group(2) @binding(1) var output: texture_storage_2d<rgba32float, read_write>;
@group(2) @binding(2) var indirect: texture_2d<f32>;
@group(2) @binding(3) var<storage, read> indirect_packed: array<vec2u>;

fn composite(p: vec2u, indirect: vec3f) {
    let c = textureLoad(direct, p, 0).rgb + indirect;
    textureStore(output, p, vec4f(accumulate_mean(textureLoad(output, p).rgb, c, frame.sample_index), 1.0));
}

@compute @workgroup_size(TILE, TILE)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if all(id.xy < frame.size) {
        composite(id.xy, textureLoad(indirect, id.xy, 0).rgb);
    }
}

@compute @workgroup_size(TILE, TILE)
fn main_packed(@builtin(global_invocation_id) id: vec3u) {
    if all(id.xy < frame.size) {
        composite(id.xy, unpack_half4(indirect_packed[id.y * frame.size.x + id.x]).rgb);
    }
}
