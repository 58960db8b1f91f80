// The radiance cache's own resources (bind group 2), one layout for all its passes.

@group(2) @binding(0) var<storage, read_write> records: array<Record>;
@group(2) @binding(1) var<storage, read_write> state: CacheState;
// Per record of the range being splatted: its framebuffer rectangle (x0, y0, x1, y1).
@group(2) @binding(2) var<storage, read_write> rects: array<vec4f>;
// Per BIN_TILE² tile: a bit set (BIN_WORDS words) of the records of the range whose rectangle meets it.
@group(2) @binding(3) var<storage, read_write> bins: array<u32>;
// Per candidate tile of this round: the complement of the best miss's key (0 = no miss).
@group(2) @binding(4) var<storage, read_write> candidates: array<atomic<u32>>;
// The pixels (x | y << 16) of this round's new records, in the order of their slots.
@group(2) @binding(5) var<storage, read_write> new_pixels: array<u32>;
// Per pixel: Σ w_k E_k(p) (rgb) and Σ w_k (a) over the records splatted so far.
@group(2) @binding(6) var splat_buffer: texture_storage_2d<rgba32float, read_write>;
@group(2) @binding(7) var direct_light_texture: texture_2d<f32>;
@group(2) @binding(8) var output: texture_storage_2d<rgba32float, write>;
