// The tiled splat's VPL table: per VPL one texel in each layer, VPL_TABLE_WIDTH (set by Rust) to a row,
// written by `splat_rects` and read by the per-texel pass.

const VPL_TABLE_POSITION: u32 = 0u;
const VPL_TABLE_NORMAL: u32 = 1u;
const VPL_TABLE_INTENSITY: u32 = 2u;
const VPL_TABLE_RECT: u32 = 3u;

fn vpl_table_texel(k: u32) -> vec2u {
    return vec2u(k % VPL_TABLE_WIDTH, k / VPL_TABLE_WIDTH);
}
