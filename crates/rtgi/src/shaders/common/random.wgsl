// Deterministic random numbers: every sample is a pure function of (pixel, frame, seed, dimension), so
// a render is reproducible bit for bit and independent of thread scheduling.

// PCG hash (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering").
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn hash2(a: u32, b: u32) -> u32 {
    return pcg_hash(a ^ pcg_hash(b));
}

fn hash3(a: u32, b: u32, c: u32) -> u32 {
    return pcg_hash(a ^ pcg_hash(b ^ pcg_hash(c)));
}

// Maps 32 random bits to a float in [0, 1) with 24 bits of precision.
fn u32_to_unit(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// A small sequential generator, seeded per pixel and frame.
struct Rng {
    state: u32,
}

fn rng_new(pixel: vec2u, frame: u32, seed: u32) -> Rng {
    return Rng(hash3(pixel.x | (pixel.y << 16u), frame, seed));
}

fn rng_next(rng: ptr<function, Rng>) -> f32 {
    (*rng).state = (*rng).state * 747796405u + 2891336453u;
    let s = (*rng).state;
    let word = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return u32_to_unit((word >> 22u) ^ word);
}

fn rng_next2(rng: ptr<function, Rng>) -> vec2f {
    let a = rng_next(rng);
    return vec2f(a, rng_next(rng));
}

// Radical inverse in base 2 (van der Corput), the first Halton/Hammersley dimension.
fn radical_inverse_2(i: u32) -> f32 {
    return u32_to_unit(reverseBits(i));
}

// Radical inverse in base 3, the second Halton dimension.
fn radical_inverse_3(index: u32) -> f32 {
    var i = index;
    var inv_base = 1.0 / 3.0;
    var f = inv_base;
    var r = 0.0;
    while i > 0u {
        r += f * f32(i % 3u);
        i /= 3u;
        f *= inv_base;
    }
    return r;
}

// Cranley-Patterson rotation of a low-discrepancy point by a random offset.
fn cp_rotate(p: vec2f, offset: vec2f) -> vec2f {
    return fract(p + offset);
}

// The first 32 primes: the bases of the Halton sequence's dimensions.
const HALTON_PRIMES = array<u32, 32>(
    2u, 3u, 5u, 7u, 11u, 13u, 17u, 19u, 23u, 29u, 31u, 37u, 41u, 43u, 47u, 53u,
    59u, 61u, 67u, 71u, 73u, 79u, 83u, 89u, 97u, 101u, 103u, 107u, 109u, 113u, 127u, 131u,
);

fn radical_inverse(base: u32, index: u32) -> f32 {
    let inv_base = 1.0 / f32(base);
    var i = index;
    var f = inv_base;
    var r = 0.0;
    while i > 0u {
        r += f * f32(i % base);
        i /= base;
        f *= inv_base;
    }
    return min(r, 0.99999994);
}

// Dimension `dim` (< 32) of Halton point `index`, Cranley-Patterson rotated by `offset`: with offsets
// drawn per point set, sets are independent of each other yet each stays low-discrepancy.
fn halton(index: u32, dim: u32, offset: f32) -> f32 {
    var primes = HALTON_PRIMES;
    return fract(radical_inverse(primes[dim % 32u], index) + offset);
}
