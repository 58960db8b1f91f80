// The tiled splat's VPL table, a linear texture (common/linear_texture.wgsl): VPL_TABLE_TEXELS texels per
// VPL, written by `splat_rects` and read by the tile-set and per-texel passes.

#import common/linear_texture.wgsl

const VPL_TABLE_POSITION: u32 = 0u;
const VPL_TABLE_NORMAL: u32 = 1u;
const VPL_TABLE_INTENSITY: u32 = 2u;
const VPL_TABLE_RECT: u32 = 3u;
const VPL_TABLE_TEXELS: u32 = 4u;

fn vpl_table_texel(k: u32, entry: u32) -> vec2u {
    return linear_texel(VPL_TABLE_TEXELS * k + entry);
}
