// The precomputation's directions at a vertex: sample s of TRANSFER_SAMPLES is a point of a Fibonacci
// lattice in the unit square moved by a per-vertex Cranley–Patterson offset (so neighbouring vertices do
// not share their directions' errors), then warped to the hemisphere about the vertex normal.

#import common/random.wgsl
#import common/sampling.wgsl

const GOLDEN_FRACTION: f32 = 0.6180339887;

fn transfer_lattice(vertex: u32, s: u32) -> vec2f {
    let lattice = vec2f((f32(s) + 0.5) / f32(TRANSFER_SAMPLES), fract(f32(s) * GOLDEN_FRACTION));
    let offset = vec2f(u32_to_unit(hash2(vertex, 0x70727431u)), u32_to_unit(hash2(vertex, 0x70727432u)));
    return cp_rotate(lattice, offset);
}
