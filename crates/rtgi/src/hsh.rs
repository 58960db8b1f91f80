//! Hemispherical harmonics (Gautron, Křivánek, Pattanaik & Bouatouch 2004; report
//! `research/002-radiance-caching.md` §2): an orthonormal basis of functions on the upper hemisphere
//! (z ≥ 0), and real spherical harmonics of any order, both evaluated by the associated-Legendre
//! recurrence, with the SH ↔ HSH conversion matrix computed numerically (the thesis's printed matrix is
//! garbled) and the exact rotation about the pole.
//!
//! Conventions are [`crate::sh`]'s, so the two modules agree where they overlap: z is the pole,
//! φ = atan2(y, x), coefficient index `l(l+1)+m`, no Condon–Shortley phase (Y_1^1 ∝ +x). HSH replace
//! P_l^m(cos θ) by the shifted P_l^m(2 cos θ − 1) and 4π by 2π in the normalisation. An "order n"
//! expansion has bands l < n, n² coefficients.

use glam::DVec3;

/// Coefficients of an order-`n` expansion (bands 0..n).
pub fn count(order: usize) -> usize {
    order * order
}

/// Index of (l, m), −l ≤ m ≤ l.
pub fn index(l: usize, m: i64) -> usize {
    ((l * l + l) as i64 + m) as usize
}

/// P_l^m(x) for 0 ≤ m ≤ l < order, without the Condon–Shortley phase, at `l(l+1)/2 + m`: the
/// recurrences of the report's §2.1 (P_m^m, then P_{m+1}^m, then up in l).
fn legendre(order: usize, x: f64) -> Vec<f64> {
    let at = |l: usize, m: usize| l * (l + 1) / 2 + m;
    let mut p = vec![0.0; order * (order + 1) / 2];
    let s = (1.0 - x * x).max(0.0).sqrt();
    let mut pmm = 1.0;
    for m in 0..order {
        if m > 0 {
            pmm *= (2 * m - 1) as f64 * s;
        }
        p[at(m, m)] = pmm;
        if m + 1 < order {
            p[at(m + 1, m)] = x * (2 * m + 1) as f64 * pmm;
        }
        for l in m + 2..order {
            p[at(l, m)] = (x * (2 * l - 1) as f64 * p[at(l - 1, m)] - (l + m - 1) as f64 * p[at(l - 2, m)])
                / (l - m) as f64;
        }
    }
    p
}

fn factorial_ratio(l: usize, m: usize) -> f64 {
    // (l − m)! / (l + m)!
    ((l - m + 1)..=(l + m)).map(|k| 1.0 / k as f64).product()
}

/// Real harmonics of `order` at the unit vector `d`, from Legendre values at `x` (cos θ for SH,
/// 2 cos θ − 1 for HSH) and the measure of the domain (4π sphere, 2π hemisphere).
fn harmonics(order: usize, d: DVec3, x: f64, measure: f64) -> Vec<f64> {
    let p = legendre(order, x);
    let phi = d.y.atan2(d.x);
    let mut out = vec![0.0; count(order)];
    for l in 0..order {
        for m in 0..=l {
            let k = ((2 * l + 1) as f64 * factorial_ratio(l, m) / measure).sqrt();
            let plm = p[l * (l + 1) / 2 + m];
            if m == 0 {
                out[index(l, 0)] = k * plm;
            } else {
                let scale = std::f64::consts::SQRT_2 * k * plm;
                out[index(l, m as i64)] = scale * (m as f64 * phi).cos();
                out[index(l, -(m as i64))] = scale * (m as f64 * phi).sin();
            }
        }
    }
    out
}

/// Real spherical harmonics Y_l^m(d), l < `order`, d a unit vector ([`crate::sh::basis`] for order 5).
pub fn sh(order: usize, d: DVec3) -> Vec<f64> {
    harmonics(order, d, d.z.clamp(-1.0, 1.0), 4.0 * std::f64::consts::PI)
}

/// Hemispherical harmonics H_l^m(d), l < `order`, d a unit vector with d.z ≥ 0 (below the horizon the
/// basis is not defined; d.z is clamped to 0 there).
pub fn hsh(order: usize, d: DVec3) -> Vec<f64> {
    harmonics(order, d, 2.0 * d.z.clamp(0.0, 1.0) - 1.0, 2.0 * std::f64::consts::PI)
}

/// Quadrature over the upper hemisphere: (direction, weight) pairs, Gauss–Legendre in cos θ (`n` nodes)
/// × `2n` uniform steps in φ, exact for the products of two HSH or HSH × SH of bands below n.
pub fn hemisphere_quadrature(n: usize) -> Vec<(DVec3, f64)> {
    let (nodes, weights) = crate::sh::gauss_legendre(n);
    let steps = 2 * n;
    let mut out = Vec::with_capacity(n * steps);
    for (x, w) in nodes.iter().zip(&weights) {
        // cos θ on [0, 1]: half the [−1, 1] rule.
        let z = 0.5 * (x + 1.0);
        let r = (1.0 - z * z).max(0.0).sqrt();
        for k in 0..steps {
            let phi = 2.0 * std::f64::consts::PI * (k as f64 + 0.5) / steps as f64;
            let weight = 0.5 * w * 2.0 * std::f64::consts::PI / steps as f64;
            out.push((DVec3::new(r * phi.cos(), r * phi.sin(), z), weight));
        }
    }
    out
}

/// The HSH coefficients of `f` over the upper hemisphere, order `order`, by [`hemisphere_quadrature`]
/// with `nodes` nodes in cos θ.
pub fn project(order: usize, nodes: usize, f: impl Fn(DVec3) -> f64) -> Vec<f64> {
    let mut c = vec![0.0; count(order)];
    for (d, w) in hemisphere_quadrature(nodes) {
        let v = f(d) * w;
        for (ci, h) in c.iter_mut().zip(hsh(order, d)) {
            *ci += v * h;
        }
    }
    c
}

/// f(d) = Σ c_i H_i(d) on the upper hemisphere.
pub fn eval(c: &[f64], order: usize, d: DVec3) -> f64 {
    c.iter().zip(hsh(order, d)).map(|(a, b)| a * b).sum()
}

/// The conversion matrix C (report Eq. 3.20): C[i][j] = ∫ H_i Y_j over the upper hemisphere, rows the
/// HSH of `hsh_order`, columns the SH of `sh_order`. An HSH vector h is the SH vector Cᵀh on the
/// hemisphere; an SH vector s restricted to the hemisphere is the HSH vector C s. Zero unless the two m
/// agree (the φ factors are the same functions).
pub fn conversion(hsh_order: usize, sh_order: usize) -> Vec<Vec<f64>> {
    let mut c = vec![vec![0.0; count(sh_order)]; count(hsh_order)];
    // Polynomials in cos θ of degree < hsh_order + sh_order, but the SH carry √(1−z²) factors in
    // odd m: not polynomial, so more nodes than the degree alone asks for.
    for (d, w) in hemisphere_quadrature(4 * (hsh_order + sh_order) + 16) {
        let (h, y) = (hsh(hsh_order, d), sh(sh_order, d));
        for (row, hi) in c.iter_mut().zip(&h) {
            for (cij, yj) in row.iter_mut().zip(&y) {
                *cij += w * hi * yj;
            }
        }
    }
    c
}

/// The coefficients of f rotated by `angle` radians about the pole, g(d) = f(R_z(−angle) d): exact (each
/// band's (m, −m) pair turns like a vector in the plane), for SH and HSH alike.
pub fn rotate_z(c: &[f64], order: usize, angle: f64) -> Vec<f64> {
    let mut out = c.to_vec();
    for l in 0..order {
        for m in 1..=l as i64 {
            let (s, co) = (m as f64 * angle).sin_cos();
            let (cos_part, sin_part) = (c[index(l, m)], c[index(l, -m)]);
            out[index(l, m)] = cos_part * co - sin_part * s;
            out[index(l, -m)] = sin_part * co + cos_part * s;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn directions() -> Vec<DVec3> {
        (0..200)
            .map(|i| {
                // A Fibonacci sphere: well spread, both hemispheres.
                let z = 1.0 - (i as f64 + 0.5) / 100.0;
                let r = (1.0 - z * z).sqrt();
                let phi = i as f64 * 2.399_963_229_728_653;
                DVec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect()
    }

    #[test]
    fn sh_of_order_5_is_the_sh_module() {
        for d in directions() {
            let expected = crate::sh::basis(d.as_vec3());
            for (i, (a, b)) in sh(5, d).iter().zip(expected).enumerate() {
                assert!((a - f64::from(b)).abs() < 1e-6, "Y_{i}({d}): {a} against {b}");
            }
        }
    }

    /// Orthonormal over the upper hemisphere (the report: identity to 1e-15 for l ≤ 2), here to order 8.
    #[test]
    fn hsh_are_orthonormal_on_the_hemisphere() {
        let order = 8;
        let mut gram = vec![vec![0.0; count(order)]; count(order)];
        for (d, w) in hemisphere_quadrature(32) {
            let h = hsh(order, d);
            for i in 0..h.len() {
                for j in 0..h.len() {
                    gram[i][j] += w * h[i] * h[j];
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, g) in row.iter().enumerate() {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((g - expected).abs() < 1e-12, "<H_{i}, H_{j}> = {g}");
            }
        }
    }

    /// The report's recomputation of Eq. 3.20 for l, l' < 3 (rows HSH, columns SH), to its 3 decimals.
    #[test]
    fn the_conversion_matrix_is_the_reports_recomputed_one() {
        #[rustfmt::skip]
        let report = [
            [0.707, 0.0, 0.612, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.674, 0.0, 0.0, 0.0, 0.675, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.354, 0.0, 0.0, 0.0, 0.685, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.674, 0.0, 0.0, 0.0, 0.675, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.619, 0.0, 0.0, 0.0, 0.0],
            [0.0, -0.158, 0.0, 0.0, 0.0, 0.212, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.177, 0.0, 0.0],
            [0.0, 0.0, 0.0, -0.158, 0.0, 0.0, 0.0, 0.212, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.619],
        ];
        let c = conversion(3, 3);
        for (i, row) in report.iter().enumerate() {
            for (j, r) in row.iter().enumerate() {
                assert!((c[i][j] - r).abs() <= 0.0005 + 1e-9, "C[{i}][{j}] = {} against {r}", c[i][j]);
            }
        }
    }

    /// Only equal m couple; and the round trip HSH → SH → HSH, max|C Cᵀ − I| for an order-3 HSH vector,
    /// falls as the report's table says (0.97, 0.34, 0.16 at SH orders 3, 5, 10; its figures to ±0.01).
    #[test]
    fn conversion_couples_equal_m_and_round_trips_as_the_report_measured() {
        let m_of = |i: usize| {
            let l = (i as f64).sqrt() as i64;
            i as i64 - l * l - l
        };
        let c = conversion(4, 6);
        for (i, row) in c.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                if m_of(i) != m_of(j) {
                    assert!(v.abs() < 1e-12, "C[{i}][{j}] = {v}");
                }
            }
        }
        for (sh_order, expected) in [(3, 0.97), (5, 0.34), (10, 0.16)] {
            let c = conversion(3, sh_order);
            let mut worst: f64 = 0.0;
            for i in 0..c.len() {
                for k in 0..c.len() {
                    let v: f64 = (0..c[i].len()).map(|j| c[i][j] * c[k][j]).sum();
                    worst = worst.max((v - if i == k { 1.0 } else { 0.0 }).abs());
                }
            }
            eprintln!("SH order {sh_order}: max|C Cᵀ − I| = {worst:.4}");
            assert!((worst - expected).abs() < 0.01, "SH order {sh_order}: {worst} against {expected}");
        }
    }

    /// A function in the span of the order-n HSH projects onto itself; projection is the least-squares
    /// fit, and rotating about the pole is exact: the projection of the turned function equals the
    /// turned coefficients.
    #[test]
    fn projection_reproduces_and_pole_rotation_is_exact() {
        let order = 5;
        let c: Vec<f64> = (0..count(order)).map(|i| ((i * 7 + 3) % 11) as f64 / 11.0 - 0.4).collect();
        let back = project(order, 24, |d| eval(&c, order, d));
        for (a, b) in c.iter().zip(&back) {
            assert!((a - b).abs() < 1e-10, "{a} against {b}");
        }
        // A lobe off the pole (not in the span), turned by 0.7 rad about z.
        let f = |d: DVec3| (d.dot(DVec3::new(0.6, 0.0, 0.8)).max(0.0)).powi(4);
        let angle: f64 = 0.7;
        let turned = project(order, 48, |d| {
            let (s, co) = (-angle).sin_cos();
            f(DVec3::new(co * d.x - s * d.y, s * d.x + co * d.y, d.z))
        });
        let rotated = rotate_z(&project(order, 48, f), order, angle);
        for (a, b) in turned.iter().zip(&rotated) {
            assert!((a - b).abs() < 1e-9, "{a} against {b}");
        }
    }
}
