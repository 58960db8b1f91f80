//! The frequency analysis of the dual hierarchy (Belcour et al., GI 2019; thesis §3.2): per material,
//! the spatial bandwidth B_s of the multiply-scattered light (from the 1-D spectrum of the dipole's
//! profile R_d) and the angular bandwidth B_θ(θ_o) of the outgoing Fresnel transmittance (a windowed
//! Fourier transform around each θ_o). A bandwidth is the frequency below which 95 % of the power
//! spectrum's energy lies, which overestimates the true bound (conservative, as the paper says).

use std::f64::consts::PI;

use glam::Vec3;

use crate::scene::subsurface::{Dipole, DirectionalDipole, fresnel_dielectric, refract_into};

/// Fraction of the spectrum's energy a bandwidth keeps.
pub const ENERGY_FRACTION: f64 = 0.95;
/// Entries of the B_θ table over θ_o in [0, π/2) (`ANGULAR_BINS` in bindings.wgsl).
pub const ANGULAR_BINS: usize = 32;
/// Standard deviation of the Gaussian window of the angular transform, radians.
pub const ANGULAR_WINDOW: f64 = 0.1;

/// In-place radix-2 FFT of `re`/`im` (length a power of two).
fn fft(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    debug_assert!(n.is_power_of_two() && im.len() == n);
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let angle = -2.0 * PI / len as f64;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let (s, c) = (angle * k as f64).sin_cos();
                let (a, b) = (start + k, start + k + len / 2);
                let (tr, ti) = (re[b] * c - im[b] * s, re[b] * s + im[b] * c);
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
            }
        }
        len <<= 1;
    }
}

/// The frequency (cycles per unit of `step`) below which `ENERGY_FRACTION` of the power spectrum of
/// `values`, sampled every `step`, lies.
pub fn energy_bandwidth(values: &[f64], step: f64) -> f64 {
    let n = values.len().next_power_of_two();
    let mut re = values.to_vec();
    re.resize(n, 0.0);
    let mut im = vec![0.0; n];
    fft(&mut re, &mut im);
    let power: Vec<f64> = re.iter().zip(&im).map(|(r, i)| r * r + i * i).collect();
    let total: f64 = power.iter().sum();
    if total <= 0.0 {
        return 0.0;
    }
    // Frequencies ±k together, from 0 up.
    let mut acc = power[0];
    for k in 1..=n / 2 {
        acc += power[k] + if k < n - k { power[n - k] } else { 0.0 };
        if acc >= ENERGY_FRACTION * total {
            return k as f64 / (n as f64 * step);
        }
    }
    0.5 / step
}

/// B_s (cycles per metre): the largest over the channels of the bandwidth of R_d along a line through
/// the entry point, sampled out to where the profile has fallen by e^{−12} with 4096 samples (or
/// `samples`, for the resolution test).
pub fn spatial_bandwidth_with(dipole: &Dipole, samples: usize) -> f64 {
    let (tr, z_v) = (dipole.transport, dipole.z_v);
    let mut best: f64 = 0.0;
    for c in 0..3 {
        let extent = f64::from(12.0 / tr[c] + 4.0 * z_v[c]);
        let step = 2.0 * extent / samples as f64;
        let values: Vec<f64> = (0..samples)
            .map(|i| f64::from(dipole.profile((-extent + (i as f64 + 0.5) * step).abs() as f32)[c]))
            .collect();
        best = best.max(energy_bandwidth(&values, step));
    }
    best
}

pub fn spatial_bandwidth(dipole: &Dipole) -> f64 {
    spatial_bandwidth_with(dipole, 4096)
}

/// Angles of incidence (degrees) over which the directional dipole's bandwidth is maximised.
pub const DIRECTIONAL_INCIDENCE: [f32; 4] = [0.0, 30.0, 60.0, 85.0];

/// B_s of the directional dipole (the paper's rule for it): the largest over the channels and the
/// angles of incidence in [`DIRECTIONAL_INCIDENCE`] of the bandwidth of the profile along the plane of
/// incidence of a flat boundary, 4096 samples out to where it has fallen by e^{−12}.
pub fn directional_spatial_bandwidth(dipole: &DirectionalDipole, eta: f32) -> f64 {
    let samples = 4096;
    let n = Vec3::Z;
    let mut best: f64 = 0.0;
    for degrees in DIRECTIONAL_INCIDENCE {
        let (sin, cos) = degrees.to_radians().sin_cos();
        let w12 = refract_into(Vec3::new(sin, 0.0, cos), n, eta);
        for c in 0..3 {
            let extent = f64::from(
                12.0 / dipole.transport[c] + 4.0 * (dipole.virtual_offset[c] + dipole.extrapolation[c]),
            );
            let step = 2.0 * extent / samples as f64;
            let values: Vec<f64> = (0..samples)
                .map(|i| {
                    let x = (-extent + (i as f64 + 0.5) * step) as f32;
                    f64::from(dipole.eval(Vec3::ZERO, n, w12, Vec3::new(x, 0.0, 0.0), n)[c])
                })
                .collect();
            best = best.max(energy_bandwidth(&values, step));
        }
    }
    best
}

/// B_θ(θ_o) (cycles per radian) at the centres of `ANGULAR_BINS` bins over [0, π/2): the bandwidth of
/// the outgoing transmittance 1 − F(η, cos θ) (zero past grazing, even about normal incidence) under a
/// Gaussian window of `ANGULAR_WINDOW` radians, with zero padding for resolution. The window's own
/// spread (about 2 cycles per radian) is a floor: the estimate is conservative where F barely changes.
pub fn angular_bandwidths(eta: f32) -> [f32; ANGULAR_BINS] {
    let transmittance = |theta: f64| {
        let t = theta.abs();
        if t >= PI / 2.0 { 0.0 } else { 1.0 - f64::from(fresnel_dielectric(eta, t.cos() as f32)) }
    };
    let samples = 256;
    let half = 4.0 * ANGULAR_WINDOW;
    let step = 2.0 * half / samples as f64;
    std::array::from_fn(|bin| {
        let center = (bin as f64 + 0.5) / ANGULAR_BINS as f64 * PI / 2.0;
        let mut values: Vec<f64> = (0..samples)
            .map(|i| {
                let x = -half + (i as f64 + 0.5) * step;
                (-0.5 * (x / ANGULAR_WINDOW).powi(2)).exp() * transmittance(center + x)
            })
            .collect();
        values.resize(4 * samples, 0.0);
        energy_bandwidth(&values, step) as f32
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Subsurface;
    use crate::scene::subsurface::DipoleModel;

    /// The power spectrum of a Gaussian of standard deviation σ is a Gaussian of standard deviation
    /// 1/(2√2 πσ) in frequency, so 95 % of its energy lies below 1.96 times that.
    #[test]
    fn gaussian_bandwidth() {
        let sigma = 0.05;
        let step = 0.001;
        let values: Vec<f64> =
            (0..4096).map(|i| (-0.5 * ((i as f64 - 2048.0) * step / sigma).powi(2)).exp()).collect();
        let expected = 1.959_964 / (2.0 * 2f64.sqrt() * PI * sigma);
        let b = energy_bandwidth(&values, step);
        // One frequency bin is 1/(4096·0.001) = 0.24 cycles.
        assert!((b - expected).abs() < 0.25, "{b} against {expected}");
    }

    /// Experiment 1 of the report: B_s grows with σ_tr (the profile narrows) and is stable under the
    /// transform's resolution. Measured: 4096 against 16384 samples differ by < 1 %.
    #[test]
    fn spatial_bandwidth_grows_with_transport_and_is_stable() {
        let m = |sigma_a: f32| {
            Subsurface {
                absorption: glam::Vec3::splat(sigma_a),
                reduced_scattering: glam::Vec3::splat(20.0),
                eta: 1.3,
            }
            .dipole(DipoleModel::Classical)
        };
        let mut last = 0.0;
        for sigma_a in [0.05, 0.5, 2.0, 8.0, 20.0] {
            let b = spatial_bandwidth(&m(sigma_a));
            assert!(b > last, "σ_a {sigma_a}: B_s {b} not above {last}");
            let fine = spatial_bandwidth_with(&m(sigma_a), 16384);
            assert!((fine / b - 1.0).abs() < 0.02, "σ_a {sigma_a}: {b} at 4096, {fine} at 16384");
            last = b;
        }
    }

    /// The directional dipole's B_s also grows with σ_tr, and exceeds the radial dipole's of the same
    /// medium: its ray source sits nearer the surface, so its profile is sharper (measured 4.5–7.4×
    /// the classical dipole's over these media; bound: above it).
    #[test]
    fn directional_bandwidth_grows_with_transport() {
        let medium = |sigma_a: f32| Subsurface {
            absorption: glam::Vec3::splat(sigma_a),
            reduced_scattering: glam::Vec3::splat(20.0),
            eta: 1.3,
        };
        let mut last = 0.0;
        for sigma_a in [0.05, 0.5, 2.0, 8.0, 20.0] {
            let m = medium(sigma_a);
            let b = directional_spatial_bandwidth(&m.directional_dipole(), m.eta);
            let radial = spatial_bandwidth(&m.dipole(DipoleModel::Classical));
            eprintln!("σ_a {sigma_a}: directional B_s {b}, classical {radial}, {:.2}×", b / radial);
            assert!(b.is_finite() && b > last, "σ_a {sigma_a}: B_s {b} not above {last}");
            assert!(b > radial, "σ_a {sigma_a}: directional {b} against classical {radial}");
            last = b;
        }
    }

    /// B_θ rises towards grazing, where the transmittance falls to zero.
    #[test]
    fn angular_bandwidth_rises_at_grazing() {
        let table = angular_bandwidths(1.3);
        assert!(table.iter().all(|b| b.is_finite() && *b > 0.0));
        assert!(table[ANGULAR_BINS - 1] > 1.5 * table[0], "{table:?}");
    }
}
