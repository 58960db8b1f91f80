//! Hemispherical harmonics (Gautron, Křivánek, Pattanaik & Bouatouch 2004; report
//! `research/002-radiance-caching.md` §2): an orthonormal basis of functions on the upper hemisphere
//! (z ≥ 0), and real spherical harmonics of any order, both evaluated by the associated-Legendre
//! recurrence, with the SH ↔ HSH conversion matrix computed numerically (the thesis's printed matrix is
//! garbled), the exact rotation about the pole, the two lossy rotations about a horizontal axis of the
//! thesis (§3.4: through the conversion matrix, and digon deletion with the remapped SH rotation), and
//! the energy fraction a truncated expansion captures (Eq. 3.32), which `examples/hsh_accuracy.rs`
//! tabulates for the thesis's test lobes ([`phong_lobe`], [`ward_slice`]).
//!
//! Conventions are [`crate::sh`]'s, so the two modules agree where they overlap: z is the pole,
//! φ = atan2(y, x), coefficient index `l(l+1)+m`, no Condon–Shortley phase (Y_1^1 ∝ +x). HSH replace
//! P_l^m(cos θ) by the shifted P_l^m(2 cos θ − 1) and 4π by 2π in the normalisation. An "order n"
//! expansion has bands l < n, n² coefficients.

use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// The highest order common/hsh.wgsl evaluates (its HSH_MAX_ORDER; a test keeps the two equal).
pub const MAX_GPU_ORDER: usize = 10;

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

/// Quadrature over the whole sphere: Gauss–Legendre in cos θ (`n` nodes) × `2n` uniform steps in φ,
/// exact for products of two SH of bands below n.
pub fn sphere_quadrature(n: usize) -> Vec<(DVec3, f64)> {
    let (nodes, weights) = crate::sh::gauss_legendre(n);
    let steps = 2 * n;
    let mut out = Vec::with_capacity(n * steps);
    for (z, w) in nodes.iter().zip(&weights) {
        let r = (1.0 - z * z).max(0.0).sqrt();
        for k in 0..steps {
            let phi = 2.0 * PI * (k as f64 + 0.5) / steps as f64;
            out.push((DVec3::new(r * phi.cos(), r * phi.sin(), *z), w * 2.0 * PI / steps as f64));
        }
    }
    out
}

/// The SH rotation of `r` at any order, band by band: [`ShRotationN::apply`] turns the SH coefficients
/// of f into those of g(d) = f(R⁻¹ d). Band l's matrix is A[i][j] = ∫ Y_i(d) Y_j(R⁻¹ d) over the sphere,
/// by [`sphere_quadrature`], which is exact here (both factors are polynomials of degree l), so no
/// recurrence tied to a sign convention is needed ([`crate::sh::rotation`] is the order-5, f32 form).
#[derive(Clone, Debug)]
pub struct ShRotationN {
    order: usize,
    /// Band l's (2l+1)² matrix, row-major.
    bands: Vec<Vec<f64>>,
}

pub fn sh_rotation(order: usize, r: DMat3) -> ShRotationN {
    let inverse = r.transpose();
    let mut bands: Vec<Vec<f64>> = (0..order).map(|l| vec![0.0; (2 * l + 1) * (2 * l + 1)]).collect();
    for (d, w) in sphere_quadrature(order + 2) {
        let (y, turned) = (sh(order, d), sh(order, inverse * d));
        for (l, band) in bands.iter_mut().enumerate() {
            let (first, n) = (l * l, 2 * l + 1);
            for i in 0..n {
                for j in 0..n {
                    band[i * n + j] += w * y[first + i] * turned[first + j];
                }
            }
        }
    }
    ShRotationN { order, bands }
}

impl ShRotationN {
    /// Band l's (2l+1)² matrix, row-major.
    pub fn band(&self, l: usize) -> &[f64] {
        &self.bands[l]
    }

    /// Every band's matrix, band after band, in f32: the layout the GPU passes read (band l's block at
    /// l(4l² − 1)/3).
    pub fn bands_f32(&self) -> Vec<f32> {
        self.bands.iter().flatten().map(|&x| x as f32).collect()
    }

    pub fn apply(&self, c: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; count(self.order)];
        for (l, m) in self.bands.iter().enumerate() {
            let (first, n) = (l * l, 2 * l + 1);
            for i in 0..n {
                out[first + i] = (0..n).map(|j| m[i * n + j] * c[first + j]).sum();
            }
        }
        out
    }
}

/// The rotation by `angle` radians about the y axis (the thesis's Y of its ZYZ Euler angles).
pub fn rotation_y(angle: f64) -> DMat3 {
    DMat3::from_rotation_y(angle)
}

/// Rotation method 1 of the thesis (§3.4.1): the HSH vector `h` (order `hsh_order`) to SH of
/// `sh_order` (Cᵀh: the SH projection of f extended by zero below the horizon), the SH rotation by
/// `r`, and back (C s: the rotated function restricted to the upper hemisphere). What turns below the
/// horizon is dropped; what turns up from below is the SH expansion's ringing of the cut, which falls
/// as `sh_order` grows.
pub fn rotate_through_sh(h: &[f64], hsh_order: usize, sh_order: usize, r: DMat3) -> Vec<f64> {
    let c = conversion(hsh_order, sh_order);
    let s: Vec<f64> = (0..count(sh_order)).map(|j| (0..h.len()).map(|i| c[i][j] * h[i]).sum()).collect();
    let turned = sh_rotation(sh_order, r).apply(&s);
    c.iter().map(|row| row.iter().zip(&turned).map(|(a, b)| a * b).sum()).collect()
}

/// The thesis's angle map (Eq. 3.30): a turn by β of the hemisphere is a turn by arccos(2 cos β − 1)
/// of the sphere that the shift x = 2 cos θ − 1 maps it onto (β = π/2 → π).
pub fn sh_angle_of_hsh_angle(beta: f64) -> f64 {
    (2.0 * beta.cos() - 1.0).clamp(-1.0, 1.0).acos()
}

/// The digon matrix M(β) (Eq. 3.27): M[i][j] = ∫ H_i H_j over the part of the upper hemisphere that
/// stays above the horizon after turning by `beta` about y. M h zeroes (in the least-squares sense)
/// the digon that would go under. The integrand is cut along a great circle, so the quadrature
/// (`nodes` in cos θ) converges only as 1/nodes; 96 nodes give about 1e-3.
pub fn digon_deletion(order: usize, beta: f64, nodes: usize) -> Vec<Vec<f64>> {
    let r = rotation_y(beta);
    let mut m = vec![vec![0.0; count(order)]; count(order)];
    for (d, w) in hemisphere_quadrature(nodes) {
        if (r * d).z < 0.0 {
            continue;
        }
        let h = hsh(order, d);
        for (row, hi) in m.iter_mut().zip(&h) {
            for (mij, hj) in row.iter_mut().zip(&h) {
                *mij += w * hi * hj;
            }
        }
    }
    m
}

/// Rotation method 2 of the thesis (§3.4.2–3): digon deletion, then the SH rotation of the remapped
/// angle [`sh_angle_of_hsh_angle`] applied to the HSH coefficients themselves (H_l^m(θ, φ) is √2 Y_l^m
/// at the shifted angle, so the shift moves f onto the whole sphere, the SH rotation turns it there and
/// the coefficients read back as HSH). Approximate: the shift is not an isometry, so a turned lobe
/// changes shape; the digon deletion keeps it from flattening against the equator.
pub fn rotate_by_digon_deletion(h: &[f64], order: usize, beta: f64, delete_digon: bool) -> Vec<f64> {
    let kept = if delete_digon {
        digon_deletion(order, beta, 96)
            .iter()
            .map(|row| row.iter().zip(h).map(|(a, b)| a * b).sum())
            .collect()
    } else {
        h.to_vec()
    };
    sh_rotation(order, rotation_y(sh_angle_of_hsh_angle(beta))).apply(&kept)
}

/// The reference for both: the HSH projection of f turned by `r`, g(d) = f(R⁻¹ d) where R⁻¹ d is above
/// the horizon and 0 where it comes from below (f, given by `h`, exists only above).
pub fn rotate_exactly(h: &[f64], order: usize, r: DMat3, nodes: usize) -> Vec<f64> {
    let inverse = r.transpose();
    project(order, nodes, |d| {
        let from = inverse * d;
        if from.z >= 0.0 { eval(h, order, from) } else { 0.0 }
    })
}

/// The fraction of f's energy (∫ f² over the upper hemisphere) that the first `order` bands capture
/// (the thesis's accuracy, Eq. 3.32, after Ramamoorthi & Hanrahan), per order 1..=`order`: `.0` for
/// HSH, `.1` for SH (of f extended by zero below the horizon, as an SH renderer stores a hemispherical
/// function). Both tend to 1; each entry is Σ c² over the bands below that order.
pub fn energy_fractions(order: usize, nodes: usize, f: impl Fn(DVec3) -> f64) -> (Vec<f64>, Vec<f64>) {
    let mut hsh_c = vec![0.0; count(order)];
    let mut sh_c = vec![0.0; count(order)];
    let mut energy = 0.0;
    for (d, w) in hemisphere_quadrature(nodes) {
        let v = f(d);
        energy += w * v * v;
        for (c, b) in hsh_c.iter_mut().zip(hsh(order, d)) {
            *c += w * v * b;
        }
        for (c, b) in sh_c.iter_mut().zip(sh(order, d)) {
            *c += w * v * b;
        }
    }
    let fractions = |c: &[f64]| -> Vec<f64> {
        (1..=order).map(|n| c[..count(n)].iter().map(|x| x * x).sum::<f64>() / energy).collect()
    };
    (fractions(&hsh_c), fractions(&sh_c))
}

/// The outgoing direction at `theta_o` from the normal (z), in the xz plane (φ_o = 0).
pub fn outgoing(theta_o: f64) -> DVec3 {
    DVec3::new(theta_o.sin(), 0.0, theta_o.cos())
}

/// The thesis's Phong test lobe (§3.5, Fig. 3.9): (cos α)⁵, α the angle between the incoming direction
/// and the mirror direction of `wo` about the normal (z); 0 beyond 90°.
pub fn phong_lobe(wo: DVec3, exponent: i32) -> impl Fn(DVec3) -> f64 {
    let mirror = DVec3::new(-wo.x, -wo.y, wo.z);
    move |wi: DVec3| wi.dot(mirror).max(0.0).powi(exponent)
}

/// The thesis's Ward test (Fig. 3.10): the anisotropic Ward BRDF (kd 0, ks 1, αx along x, αy along y)
/// for the outgoing `wo`, times cos θi. The slice alone has infinite energy (it grows as 1/√cos θi at
/// the horizon, and ∫ 1/cos θ dω diverges), so Eq. 3.32 needs the cosine-weighted slice, which is also
/// what a lighting integral projects.
pub fn ward_slice(wo: DVec3, alpha_x: f64, alpha_y: f64) -> impl Fn(DVec3) -> f64 {
    move |wi: DVec3| {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        let tan2 = (h.x * h.x / (alpha_x * alpha_x) + h.y * h.y / (alpha_y * alpha_y)) / (h.z * h.z);
        (-tan2).exp() / (4.0 * PI * alpha_x * alpha_y * (wi.z * wo.z).sqrt()) * wi.z
    }
}

/// The Heidrich–Seidel paraboloid map of the upper hemisphere (the thesis's Eqs. 3.35–3.36, its
/// parameterisation of outgoing directions): u = ½(1 + x/(z + 1)), v = ½(1 + y/(z + 1)); the horizon is
/// the circle of radius ½ about (½, ½).
pub fn paraboloid_uv(d: DVec3) -> (f64, f64) {
    let z1 = d.z.max(0.0) + 1.0;
    (0.5 * (1.0 + d.x / z1), 0.5 * (1.0 + d.y / z1))
}

/// The inverse of [`paraboloid_uv`]; (u, v) outside the disc maps to the horizon.
pub fn paraboloid_direction(u: f64, v: f64) -> DVec3 {
    let (mut x, mut y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    let r2 = x * x + y * y;
    if r2 > 1.0 {
        let r = r2.sqrt();
        (x, y) = (x / r, y / r);
    }
    let r2 = r2.min(1.0);
    DVec3::new(2.0 * x, 2.0 * y, 1.0 - r2) / (1.0 + r2)
}

/// A BRDF in HSH per outgoing direction (the thesis's §3.5.2, after Kautz et al. 2002): for each texel
/// of a `size`² paraboloid map of outgoing directions, the HSH coefficients (order `order`) of the
/// cosine-weighted slice f(ωo, ωi) cos θi over incoming directions, so that the reflected radiance of an
/// incoming radiance with HSH coefficients λ is the dot product with [`BrdfTable::at`]. Outgoing
/// directions between texel centres are interpolated bilinearly, as the thesis's texture fetches.
#[derive(Clone, Debug)]
pub struct BrdfTable {
    pub order: usize,
    pub size: usize,
    /// Texel (i, j) (u along i) holds count(order) coefficients at ((j·size + i)·count(order)).
    pub coefficients: Vec<f64>,
}

impl BrdfTable {
    /// Projects `f(ωo, ωi)` (already cosine-weighted) at each texel centre with [`project`] of `nodes`
    /// nodes in cos θ.
    pub fn build(order: usize, size: usize, nodes: usize, f: impl Fn(DVec3, DVec3) -> f64) -> Self {
        let n = count(order);
        let mut coefficients = vec![0.0; size * size * n];
        let quadrature = hemisphere_quadrature(nodes);
        let basis: Vec<Vec<f64>> = quadrature.iter().map(|(d, _)| hsh(order, *d)).collect();
        for j in 0..size {
            for i in 0..size {
                let wo = Self::texel_direction(size, i, j);
                let out = &mut coefficients[(j * size + i) * n..][..n];
                for ((wi, w), h) in quadrature.iter().zip(&basis) {
                    let v = f(wo, *wi) * w;
                    for (c, b) in out.iter_mut().zip(h) {
                        *c += v * b;
                    }
                }
            }
        }
        BrdfTable { order, size, coefficients }
    }

    /// The outgoing direction at the centre of texel (i, j).
    pub fn texel_direction(size: usize, i: usize, j: usize) -> DVec3 {
        paraboloid_direction((i as f64 + 0.5) / size as f64, (j as f64 + 0.5) / size as f64)
    }

    /// The coefficients for the outgoing direction `wo`, bilinear between texel centres (clamped at
    /// the map's edge).
    pub fn at(&self, wo: DVec3) -> Vec<f64> {
        let n = count(self.order);
        let (u, v) = paraboloid_uv(wo);
        let last = (self.size - 1) as f64;
        let (x, y) =
            ((u * self.size as f64 - 0.5).clamp(0.0, last), (v * self.size as f64 - 0.5).clamp(0.0, last));
        let (i0, j0) = (x.floor() as usize, y.floor() as usize);
        let (i1, j1) = ((i0 + 1).min(self.size - 1), (j0 + 1).min(self.size - 1));
        let (fx, fy) = (x - i0 as f64, y - j0 as f64);
        let texel = |i: usize, j: usize| &self.coefficients[(j * self.size + i) * n..][..n];
        (0..n)
            .map(|k| {
                let top = texel(i0, j0)[k] * (1.0 - fx) + texel(i1, j0)[k] * fx;
                let bottom = texel(i0, j1)[k] * (1.0 - fx) + texel(i1, j1)[k] * fx;
                top * (1.0 - fy) + bottom * fy
            })
            .collect()
    }

    /// The reflected radiance towards `wo` of an incoming radiance given by its HSH coefficients.
    pub fn reflect(&self, wo: DVec3, radiance: &[f64]) -> f64 {
        self.at(wo).iter().zip(radiance).map(|(a, b)| a * b).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn directions() -> Vec<DVec3> {
        crate::sequences::fibonacci_directions(200, -1.0)
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

    #[test]
    fn the_paraboloid_map_round_trips() {
        for d in crate::sequences::fibonacci_directions(300, 0.0) {
            let (u, v) = paraboloid_uv(d);
            let back = paraboloid_direction(u, v);
            assert!((back - d).length() < 1e-12, "{d} → ({u}, {v}) → {back}");
        }
        assert!((paraboloid_direction(0.5, 0.5) - DVec3::Z).length() < 1e-15);
        assert!(paraboloid_direction(1.0, 0.5).z.abs() < 1e-15, "the disc's edge is the horizon");
    }

    /// A BRDF table reflects as the integral it stands for: at a texel centre the dot product with an
    /// HSH radiance equals ∫ L f cos θi exactly (orthonormality), and between texels the bilinear
    /// table stays close to the directly projected slice. Phong cos⁵ × cos θi at order 8 on a 16² map.
    #[test]
    fn brdf_tables_reflect_as_the_integral() {
        let order = 8;
        let f = |wo: DVec3, wi: DVec3| phong_lobe(wo, 5)(wi) * wi.z;
        let table = BrdfTable::build(order, 16, 32, f);
        let radiance: Vec<f64> = (0..count(order)).map(|i| ((i * 5 + 1) % 7) as f64 / 7.0 - 0.2).collect();
        let mut worst_dot: f64 = 0.0;
        for (i, j) in [(8, 8), (3, 9), (12, 2)] {
            let wo = BrdfTable::texel_direction(16, i, j);
            let direct: f64 = hemisphere_quadrature(48)
                .iter()
                .map(|(wi, w)| w * eval(&radiance, order, *wi) * f(wo, *wi))
                .sum();
            // Both integrate the band-limited part of the slice; the rest is orthogonal to L.
            worst_dot = worst_dot.max((table.reflect(wo, &radiance) - direct).abs() / direct.abs());
        }
        eprintln!(
            "dot product against the integral at texel centres: worst relative difference {worst_dot:e}"
        );
        // Measured 1.5e-7 (the two quadratures of the kinked lobe, 32 and 48 nodes); bound 2×.
        assert!(worst_dot < 3e-7, "{worst_dot}");
        let mut worst: f64 = 0.0;
        for wo in crate::sequences::fibonacci_directions(64, 0.2) {
            let exact = project(order, 32, |wi| f(wo, wi));
            let norm = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
            let between = table.at(wo);
            worst = worst
                .max(exact.iter().zip(&between).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt() / norm);
        }
        eprintln!("bilinear table against the slice's projection: worst relative error {worst:.4}");
        // Measured 0.056 (the bilinear step between 16² texels); bound 1.6×.
        assert!(worst < 0.09, "{worst}");
    }

    /// The generic-order SH rotation agrees with the order-5 one of `sh` (which solves for its matrices
    /// otherwise), and turning by R then R⁻¹ gives the coefficients back.
    #[test]
    fn sh_rotation_of_any_order_is_the_sh_modules_and_inverts() {
        let r = DMat3::from_euler(glam::EulerRot::ZYZ, 0.3, 1.1, -0.7);
        let c: Vec<f64> = (0..count(5)).map(|i| ((i * 5 + 2) % 9) as f64 / 9.0 - 0.3).collect();
        let ours = sh_rotation(5, r).apply(&c);
        let c32: [f32; 25] = std::array::from_fn(|i| c[i] as f32);
        let theirs = crate::sh::rotation(r.as_mat3()).apply(&c32);
        for (a, b) in ours.iter().zip(theirs) {
            assert!((a - f64::from(b)).abs() < 1e-5, "{a} against {b}");
        }
        let order = 9;
        let c: Vec<f64> = (0..count(order)).map(|i| ((i * 7 + 3) % 11) as f64 / 11.0 - 0.4).collect();
        let back = sh_rotation(order, r.transpose()).apply(&sh_rotation(order, r).apply(&c));
        for (a, b) in c.iter().zip(&back) {
            assert!((a - b).abs() < 1e-12, "{a} against {b}");
        }
    }

    fn distance(a: &[f64], b: &[f64]) -> f64 {
        a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt()
    }

    /// The thesis's rotation experiments (report §2.12, item 7) on an order-5 HSH lobe tilted 30° from
    /// the pole, turned 40° about y towards the horizon (errors: the L² distance over the hemisphere to
    /// the exact turn, relative to its norm). Method 1 converges as its SH order grows (measured 0.028,
    /// 1.4e-3, 8.9e-5, 2.9e-5 at SH orders 5, 10, 20, 40); method 2 is an approximation whose error is
    /// pinned, and digon deletion keeps a steep turn from flattening the lobe; β = π/2 maps to π.
    #[test]
    fn rotations_about_y_behave_as_the_thesis_says() {
        let order = 5;
        let lobe = phong_lobe(outgoing(-30f64.to_radians()), 4);
        let h = project(order, 48, lobe);
        let beta = 40f64.to_radians();
        let exact = rotate_exactly(&h, order, rotation_y(beta), 96);
        let norm = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
        let through =
            |sh_order| distance(&rotate_through_sh(&h, order, sh_order, rotation_y(beta)), &exact) / norm;
        let errors: Vec<f64> = [5, 10, 20, 40].iter().map(|&n| through(n)).collect();
        let deleted = distance(&rotate_by_digon_deletion(&h, order, beta, true), &exact) / norm;
        let kept = distance(&rotate_by_digon_deletion(&h, order, beta, false), &exact) / norm;
        eprintln!(
            "method 1 at SH orders 5/10/20/40: {errors:?}; method 2: {deleted} (without deletion {kept})"
        );
        assert!(errors.windows(2).all(|w| w[1] < w[0]), "method 1 does not converge: {errors:?}");
        assert!(errors[3] < 6e-5, "method 1 at SH order 40: {}", errors[3]);
        // Measured 0.42 with digon deletion and 0.27 without at 40°: in L², deletion does not help a small
        // turn; bounds at 1.5× the measurement. At 80° it does (the thesis's flattening against the
        // equator, Fig. 3.7): measured 0.55 with deletion, 2.31 without.
        assert!(deleted < 0.63 && kept < 0.41, "method 2 at 40°: {deleted} with deletion, {kept} without");
        let steep = 80f64.to_radians();
        let exact = rotate_exactly(&h, order, rotation_y(steep), 96);
        let norm = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
        let deleted = distance(&rotate_by_digon_deletion(&h, order, steep, true), &exact) / norm;
        let kept = distance(&rotate_by_digon_deletion(&h, order, steep, false), &exact) / norm;
        eprintln!("method 2 at 80°: {deleted} (without deletion {kept})");
        assert!(
            deleted < 0.83 && deleted < 0.5 * kept,
            "method 2 at 80°: {deleted} with deletion, {kept} without"
        );
        // acos near −1 amplifies cos(π/2)'s rounding (6e-17) to about 1e-8.
        assert!((sh_angle_of_hsh_angle(PI / 2.0) - PI).abs() < 1e-7);
        assert!(sh_angle_of_hsh_angle(0.0).abs() < 1e-12);
        // No turn at all: method 2 is the identity (the digon is empty).
        let same = rotate_by_digon_deletion(&h, order, 0.0, true);
        assert!(distance(&same, &h) < 1e-9 * norm, "identity off by {}", distance(&same, &h));
    }

    /// Eq. 3.32 for the thesis's test lobes (Figs. 3.9, 3.10): at every coefficient count HSH capture
    /// more of the energy than SH, both grow with the order and stay below 1.
    #[test]
    fn hsh_capture_more_energy_than_sh_at_equal_counts() {
        for theta in [0.0f64, 30.0, 60.0] {
            let wo = outgoing(theta.to_radians());
            for (name, (hsh_f, sh_f)) in [
                ("Phong cos⁵", energy_fractions(8, 64, phong_lobe(wo, 5))),
                ("Ward", energy_fractions(8, 64, ward_slice(wo, 0.2, 0.5))),
            ] {
                eprintln!("{name} θo = {theta}°: HSH {hsh_f:.3?} SH {sh_f:.3?}");
                for n in 0..8 {
                    assert!(
                        hsh_f[n] > sh_f[n],
                        "{name} θo {theta}° order {}: HSH {} SH {}",
                        n + 1,
                        hsh_f[n],
                        sh_f[n]
                    );
                    assert!(hsh_f[n] <= 1.0 + 1e-9 && sh_f[n] <= 1.0 + 1e-9);
                    if n > 0 {
                        assert!(hsh_f[n] >= hsh_f[n - 1] && sh_f[n] >= sh_f[n - 1]);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod gpu_tests {
    use super::*;
    use crate::gpu::kernel::run_kernel;
    use crate::gpu::{GpuContext, GpuOptions};

    const ORDER: usize = MAX_GPU_ORDER;

    #[test]
    fn the_wgsl_maximum_order_is_the_rust_one() {
        let wgsl = include_str!("shaders/common/hsh.wgsl");
        let order = format!("const HSH_MAX_ORDER: u32 = {MAX_GPU_ORDER}u;");
        let coefficients = format!("const HSH_MAX_COEFFICIENTS: u32 = {}u;", count(MAX_GPU_ORDER));
        assert!(
            wgsl.contains(&order) && wgsl.contains(&coefficients),
            "common/hsh.wgsl must say {order} {coefficients}"
        );
    }

    const SHADER: &str = "#import common/hsh.wgsl
@group(0) @binding(0) var<storage, read> input: array<vec4f>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let n = arrayLength(&input);
    if id.x >= n { return; }
    let d = input[id.x].xyz;
    for (var i = 0u; i < HSH_MAX_COEFFICIENTS; i++) {
        output[id.x * 204u + i] = hsh_one(i, d);
        output[id.x * 204u + 100u + i] = sh_one(i, d);
    }
    let uv = paraboloid_uv(d);
    let back = paraboloid_direction(uv);
    output[id.x * 204u + 200u] = uv.x;
    output[id.x * 204u + 201u] = uv.y;
    output[id.x * 204u + 202u] = length(back - d);
}";

    /// hsh.wgsl against hsh.rs at the largest order it supports, on 512 directions of the upper
    /// hemisphere (the pole included). Worst differences measured on lavapipe: see the assertion.
    #[test]
    fn wgsl_matches_cpu() {
        let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
        let mut dirs: Vec<[f32; 4]> = crate::sequences::fibonacci_directions(511, 0.0)
            .iter()
            .map(|d| d.as_vec3().extend(0.0).to_array())
            .collect();
        dirs.push([0.0, 0.0, 1.0, 0.0]);
        let gpu = run_kernel(
            &ctx,
            "hsh test",
            SHADER,
            bytemuck::cast_slice(&dirs),
            dirs.len() as u32,
            dirs.len() * 204,
        )
        .expect("kernel");
        let mut worst: f64 = 0.0;
        for (k, d) in dirs.iter().enumerate() {
            let d64 = DVec3::new(f64::from(d[0]), f64::from(d[1]), f64::from(d[2]));
            let (h, y) = (hsh(ORDER, d64), sh(ORDER, d64));
            for (offset, cpu) in [(0, &h), (100, &y)] {
                for (i, c) in cpu.iter().enumerate() {
                    let g = f64::from(gpu[k * 204 + offset + i]);
                    // Relative to the band's size: Y and H reach a few units at order 10.
                    worst = worst.max((g - c).abs() / (1.0 + c.abs()));
                }
            }
            // The paraboloid map and its inverse.
            let (u, v) = paraboloid_uv(d64);
            let at = |i: usize| f64::from(gpu[k * 204 + 200 + i]);
            worst = worst.max((at(0) - u).abs()).max((at(1) - v).abs()).max(at(2));
        }
        eprintln!("hsh.wgsl against hsh.rs: worst difference {worst:e}");
        assert!(worst < 2e-4, "worst difference {worst}");
    }
}
