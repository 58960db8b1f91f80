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

/// `n` well-spread unit vectors with z from near 1 down to near `z_min` (−1: the sphere, 0: the upper
/// hemisphere): a Fibonacci spiral, z uniform in steps of (1 − z_min)/n, φ advancing by the golden angle.
pub fn fibonacci_directions(n: usize, z_min: f64) -> Vec<glam::DVec3> {
    const GOLDEN_ANGLE: f64 = 2.399_963_229_728_653;
    (0..n)
        .map(|i| {
            let z = 1.0 - (1.0 - z_min) * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = i as f64 * GOLDEN_ANGLE;
            glam::DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
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
