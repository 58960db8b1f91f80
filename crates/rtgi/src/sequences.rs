//! Low-discrepancy sequences on the CPU, twins of `shaders/common/random.wgsl` (its `halton` is checked
//! against [`radical_inverse`]).

/// The radical inverse of `i` in `base`: its digits mirrored about the radix point, in [0, 1).
pub fn radical_inverse(base: u32, mut i: u32) -> f64 {
    let (mut f, mut r) = (1.0 / f64::from(base), 0.0);
    while i > 0 {
        r += f * f64::from(i % base);
        i /= base;
        f /= f64::from(base);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::radical_inverse;

    #[test]
    fn radical_inverse_mirrors_the_digits() {
        assert_eq!(radical_inverse(2, 1), 0.5);
        assert_eq!(radical_inverse(2, 6), 0.375); // 110₂ → 0.011₂
        assert!((radical_inverse(3, 5) - 7.0 / 9.0).abs() < 1e-15); // 12₃ → 0.21₃
        assert_eq!(radical_inverse(5, 0), 0.0);
    }
}
