// Arrays held in 2-D textures (gpu/linear_texture.rs, which says why): element i at texel
// (i mod LINEAR_TEXELS_PER_ROW, i / LINEAR_TEXELS_PER_ROW).

const LINEAR_TEXELS_PER_ROW: u32 = 4096u;

fn linear_texel(i: u32) -> vec2u {
    return vec2u(i & (LINEAR_TEXELS_PER_ROW - 1u), i / LINEAR_TEXELS_PER_ROW);
}
