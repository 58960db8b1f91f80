// A stable hash for cache keys (references, precomputed data). Compiled as `rtgi::stable_hash` and,
// through `include!`, inside `crates/rtgi/build.rs`: `std` only, no inner doc comments.

/// 64-bit FNV-1a: a stable hash (unlike `DefaultHasher`, which may change between Rust releases).
#[derive(Clone, Copy, Debug)]
pub struct StableHasher(u64);

impl Default for StableHasher {
    fn default() -> Self {
        StableHasher(0xcbf2_9ce4_8422_2325)
    }
}

impl StableHasher {
    pub fn bytes(&mut self, data: &[u8]) -> &mut Self {
        for b in data {
            self.0 ^= u64::from(*b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
        self
    }

    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.bytes(&v.to_le_bytes())
    }

    pub fn f32s(&mut self, v: &[f32]) -> &mut Self {
        for x in v {
            self.u32(x.to_bits());
        }
        self
    }

    pub fn str(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32).bytes(s.as_bytes())
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}
