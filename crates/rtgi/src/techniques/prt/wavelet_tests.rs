//! Wavelet transfer (`transfer=wavelet`): the cube and the Haar transform on the CPU, the GPU passes
//! against their CPU twins, and hard shadows against the ray-traced environment light.

use glam::{DVec3, Vec3};

use super::tests::{
    direct_environment_light, gpu_vertex_normal, oblique_turn, params, sky_radiance, white_spheres,
};
use super::wavelet::{cube_point, cube_texel, cube_texels, haar_face, haar_support_area};
use super::*;
use crate::gpu::readback::read_buffer;
use crate::gpu::scene::GpuVertex;
use crate::techniques::fixture::{Fixture, fixture_of};

/// The cube's texels tile the sphere (their exact solid angles sum to 4π), and the texel-centre
/// quadrature of the clamped cosine, Σ_t max(0, n·ω_t) Ω_t, approaches its integral π.
#[test]
fn cube_texels_tile_the_sphere_and_integrate_the_cosine() {
    for resolution in [8, 32] {
        let texels: Vec<(Vec3, f32)> =
            (0..cube_texels(resolution)).map(|t| cube_texel(resolution, t)).collect();
        let sphere: f64 = texels.iter().map(|(_, w)| f64::from(*w)).sum();
        let mut worst_cosine = 0.0f64;
        for n in [Vec3::Y, Vec3::new(0.3, 0.8, -0.52).normalize(), Vec3::new(-1.0, 1.0, 1.0).normalize()] {
            let cosine: f64 = texels.iter().map(|(d, w)| f64::from(n.dot(*d).max(0.0) * w)).sum();
            worst_cosine = worst_cosine.max((cosine / std::f64::consts::PI - 1.0).abs());
        }
        let sphere_error = (sphere / (4.0 * std::f64::consts::PI) - 1.0).abs();
        eprintln!("{resolution}²: |Σ Ω / 4π − 1| {sphere_error:e}, worst |Σ cos Ω / π − 1| {worst_cosine:e}");
        // Measured 6.9e-8 and 7.2e-8 (f32 rounding of the corner formula).
        assert!(sphere_error < 1e-5, "{sphere_error}");
        // Measured 5.2e-3 at 8² and 3.2e-4 at 32²: the midpoint rule's error over the texels the
        // horizon cuts. A wrong solid angle (e.g. the face area alone) is off by 10 % or more.
        let bound = if resolution == 8 { 1e-2 } else { 6e-4 };
        assert!(worst_cosine < bound, "{resolution}: {worst_cosine}");
    }
    // Every face is a different plane, and its coordinates run along the other two axes.
    for face in 0..6 {
        let centre = cube_point(face, 0.0, 0.0);
        assert_eq!(centre.abs().element_sum(), 1.0);
        assert!(
            cube_point(face, 1.0, 0.0).dot(centre) == 1.0 && cube_point(face, 0.0, 1.0).dot(centre) == 1.0
        );
    }
}

/// The non-standard Haar transform is orthonormal: it keeps the dot product of two faces (so Σ_t T_t L_t
/// = Σ_i T̂_i L̂_i, what the sparse dot product relies on), and a constant face has one non-zero
/// coefficient, its scaling coefficient c · R.
#[test]
fn the_haar_transform_is_orthonormal() {
    let r = 16;
    // Deterministic values in [−0.3, 0.7): a 64-bit LCG's high bits.
    let face = |seed: u64| -> Vec<f64> {
        let mut state = seed;
        (0..r * r)
            .map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64 - 0.3
            })
            .collect()
    };
    let (a, b) = (face(1), face(2));
    let (mut ha, mut hb) = (a.clone(), b.clone());
    haar_face(&mut ha, r);
    haar_face(&mut hb, r);
    let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
    for (texels, coefficients) in [(dot(&a, &b), dot(&ha, &hb)), (dot(&a, &a), dot(&ha, &ha))] {
        assert!((texels - coefficients).abs() < 1e-12 * texels.abs().max(1.0), "{texels} vs {coefficients}");
    }
    let mut constant = vec![2.5; r * r];
    haar_face(&mut constant, r);
    assert!((constant[0] - 2.5 * r as f64).abs() < 1e-12);
    assert!(constant[1..].iter().all(|c| c.abs() < 1e-12));
}

/// The environment on the cube as light_cube computes it: each texel the solid-angle-weighted mean of
/// 4 × 4 points, in the world after `turn`.
fn cpu_light_cube(environment: &crate::scene::Environment, resolution: u32, turn: glam::DMat3) -> Vec<DVec3> {
    let n = 4;
    (0..cube_texels(resolution))
        .map(|t| {
            let (face, i) = (t / (resolution * resolution), t % (resolution * resolution));
            let (x, y) = (i % resolution, i / resolution);
            let (mut sum, mut weights) = (DVec3::ZERO, 0.0);
            for s in 0..n * n {
                let at = |t: u32, o: u32| {
                    (f64::from(t) + (f64::from(o) + 0.5) / f64::from(n)) * 2.0 / f64::from(resolution) - 1.0
                };
                let p = cube_point(face, at(x, s % n) as f32, at(y, s / n) as f32).as_dvec3();
                let w = p.length_squared().powf(-1.5);
                sum += w * sky_radiance(environment, turn.transpose() * p.normalize());
                weights += w;
            }
            sum / weights
        })
        .collect()
}

/// Every face of `texels` (RGB) in Haar wavelets.
fn cpu_haar(texels: &[DVec3], resolution: u32) -> Vec<DVec3> {
    let area = (resolution * resolution) as usize;
    let mut out = vec![DVec3::ZERO; texels.len()];
    for face in 0..6 {
        for c in 0..3 {
            let mut channel: Vec<f64> = texels[face * area..(face + 1) * area].iter().map(|t| t[c]).collect();
            haar_face(&mut channel, resolution as usize);
            for (o, v) in out[face * area..(face + 1) * area].iter_mut().zip(channel) {
                o[c] = v;
            }
        }
    }
    out
}

fn read_vec4(f: &Fixture, buffer: &wgpu::Buffer) -> Vec<DVec3> {
    let bytes = read_buffer(&f.ctx, buffer, 0, buffer.size()).expect("read back");
    bytemuck::cast_slice::<u8, [f32; 4]>(&bytes)
        .iter()
        .map(|v| Vec3::new(v[0], v[1], v[2]).as_dvec3())
        .collect()
}

/// A vertex's transfer terms: (index, value).
fn read_terms(f: &Fixture, prt: &Prt) -> Vec<Vec<(usize, f64)>> {
    let bytes = read_buffer(&f.ctx, &prt.transfer.buffer, 0, prt.transfer.buffer.size()).expect("transfer");
    let words: &[u32] = bytemuck::cast_slice(&bytes);
    words
        .chunks(prt.transfer.floats_per_vertex as usize)
        .take(prt.transfer.vertices as usize)
        .map(|terms| {
            terms
                .iter()
                .map(|w| ((w >> 16) as usize, f64::from(half::f16::from_bits(*w as u16).to_f32())))
                .collect()
        })
        .collect()
}

/// The ground of `spheres-env` alone, under its sky: every vertex sees the whole upper hemisphere.
fn open_ground() -> Fixture {
    let mut f = white_spheres(None);
    f.scene.meshes.truncate(1);
    f.gpu_scene = crate::gpu::GpuScene::new(&f.ctx, &f.scene).expect("ground alone");
    f
}

fn wavelets(prt: &Prt) -> &WaveletPasses {
    let TransferPasses::Wavelets(w) = &prt.transfer.passes else { panic!("wavelet transfer") };
    w
}

/// The GPU's wavelet passes against their CPU twins on open vertices (the ground alone) under the
/// sky, turned and not, at 8² per face: the lighting's Haar coefficients; with every term kept, each
/// vertex's transfer terms (T_t = max(0, n·ω_t) Ω_t transformed) and its irradiance, which must be the
/// pixel-basis sum Σ_t T_t L_t; with few terms kept, the largest ones (the transfer's area-weighted).
#[test]
fn wavelet_passes_match_their_cpu_twins() {
    let resolution = 8;
    let all = cube_texels(resolution);
    let mut f = open_ground();
    let bytes = read_buffer(&f.ctx, &f.gpu_scene.vertex_buffer, 0, f.gpu_scene.vertex_buffer.size())
        .expect("vertices");
    let normals: Vec<DVec3> =
        bytemuck::cast_slice::<u8, GpuVertex>(&bytes).iter().map(gpu_vertex_normal).collect();
    let texels: Vec<(DVec3, f64)> =
        (0..all).map(|t| cube_texel(resolution, t)).map(|(d, w)| (d.as_dvec3(), f64::from(w))).collect();
    let transfer_of = |n: DVec3| -> Vec<f64> {
        let mut t: Vec<f64> = texels.iter().map(|(d, w)| n.dot(*d).max(0.0) * w).collect();
        let area = (resolution * resolution) as usize;
        for face in t.chunks_mut(area) {
            haar_face(face, resolution as usize);
        }
        t
    };

    let everything = all.to_string();
    let p = params(&[
        ("transfer", "wavelet"),
        ("wavelet_resolution", "8"),
        ("wavelet_terms", &everything),
        ("wavelet_transfer_terms", &everything),
    ]);
    let mut prt = Prt::new(&f.setup(&p)).expect("prt");
    let (mut worst_lighting, mut worst_term, mut worst_irradiance) = (0.0f64, 0.0f64, 0.0f64);
    for (frame, degrees) in [(0u64, 0.0f32), (1, 70.0)] {
        let turn = oblique_turn(degrees);
        if f.gpu_scene.rotate_environment(&f.ctx, turn) {
            prt.scene_changed(&f.ctx, &f.gpu_scene, crate::techniques::SceneChange::EnvironmentRotation)
                .expect("change");
        }
        f.render_rgb(&mut prt, 1);
        assert_eq!(wavelets(&prt).lightings, frame + 1, "a turn must light the vertices again");
        let cube = cpu_light_cube(&f.scene.environment, resolution, glam::DMat3::from_quat(turn.as_dquat()));
        let expected = cpu_haar(&cube, resolution);
        let got = read_vec4(&f, &wavelets(&prt).lighting_coefficients);
        let kept = read_vec4(&f, &wavelets(&prt).kept_lighting);
        let scale = expected.iter().map(|c| c.abs().max_element()).fold(0.0, f64::max);
        for ((g, k), e) in got.iter().zip(&kept).zip(&expected) {
            worst_lighting = worst_lighting.max((*g - *e).abs().max_element() / scale);
            assert_eq!(g, k, "every term is kept");
        }
        // Irradiance in the pixel basis, on the CPU.
        let irradiance = read_vec4(&f, &wavelets(&prt).irradiance);
        for (v, n) in normals.iter().enumerate().take(prt.transfer.vertices as usize) {
            let sum: DVec3 = texels.iter().zip(&cube).map(|((d, w), l)| n.dot(*d).max(0.0) * w * *l).sum();
            worst_irradiance =
                worst_irradiance.max((irradiance[v] - sum).abs().max_element() / sum.max_element());
        }
    }
    let terms = read_terms(&f, &prt);
    for (v, n) in normals.iter().enumerate().take(terms.len()) {
        let expected = transfer_of(*n);
        let scale = expected.iter().fold(0.0f64, |m, t| m.max(t.abs()));
        // Unused slots are (0, 0); zeros are never kept.
        for &(i, value) in terms[v].iter().filter(|t| t.1 != 0.0) {
            worst_term = worst_term.max((value - expected[i]).abs() / scale);
        }
        let mut indices: Vec<usize> = terms[v].iter().filter(|t| t.1 != 0.0).map(|t| t.0).collect();
        indices.dedup();
        let nonzero = expected.iter().filter(|t| t.abs() > 1e-6 * scale).count();
        assert!(
            indices.len() >= nonzero,
            "vertex {v}: {} terms for {nonzero} non-zero coefficients",
            indices.len()
        );
    }
    eprintln!(
        "worst relative error: lighting {worst_lighting:e}, transfer terms {worst_term:e}, irradiance {worst_irradiance:e}"
    );
    // Measured 7.4e-7 (f32 rounding of the GPU's sums).
    assert!(worst_lighting < 1.5e-6, "lighting {worst_lighting}");
    // Measured 5.3e-5: the terms are f16 (11-bit mantissa, 2.4e-4 relative to the term itself at
    // worst, less relative to the largest).
    assert!(worst_term < 1e-4, "transfer terms {worst_term}");
    // Measured 1.2e-4: the f16 terms again, summed; a missing face, term or normalisation is off by 1 %
    // or more.
    assert!(worst_irradiance < 2.5e-4, "irradiance {worst_irradiance}");

    // Few terms: the kept ones are the largest.
    let p = params(&[
        ("transfer", "wavelet"),
        ("wavelet_resolution", "8"),
        ("wavelet_terms", "8"),
        ("wavelet_transfer_terms", "24"),
    ]);
    let mut prt = Prt::new(&f.setup(&p)).expect("prt");
    f.render_rgb(&mut prt, 1);
    let largest = |values: Vec<f64>, k: usize| -> f64 {
        let mut v = values;
        v.sort_by(|a, b| b.total_cmp(a));
        v[k - 1]
    };
    let kept = read_vec4(&f, &wavelets(&prt).kept_lighting);
    let coefficients = read_vec4(&f, &wavelets(&prt).lighting_coefficients);
    // Area-weighted luminance.
    let weighted: Vec<f64> = coefficients
        .iter()
        .enumerate()
        .map(|(i, c)| {
            c.abs().dot(DVec3::new(0.2126, 0.7152, 0.0722)) * haar_support_area(resolution, i as u32)
        })
        .collect();
    let kept_count = kept.iter().filter(|k| k.max_element() != 0.0 || k.min_element() != 0.0).count();
    let eighth = largest(weighted.clone(), 8);
    assert_eq!(kept_count, 8);
    for ((k, c), w) in kept.iter().zip(&coefficients).zip(&weighted) {
        let is_kept = k.max_element() != 0.0 || k.min_element() != 0.0;
        assert_eq!(is_kept, *w >= eighth, "kept {k} of {c} (the 8th largest {eighth})");
    }
    for (v, terms) in read_terms(&f, &prt).iter().enumerate() {
        // Area-weighted magnitudes.
        let weighted: Vec<f64> = transfer_of(normals[v])
            .iter()
            .enumerate()
            .map(|(i, t)| t.abs() * haar_support_area(resolution, i as u32))
            .collect();
        let threshold = largest(weighted.clone(), 24);
        let scale = weighted.iter().fold(0.0f64, |m, t| m.max(*t));
        // Ties (a flat ground facing up is symmetric) and f32 against f64 can swap terms of equal
        // magnitude: every kept term is among the largest up to the f16 rounding.
        let mut kept = 0;
        for &(i, value) in terms.iter().filter(|t| t.1 != 0.0) {
            assert!(weighted[i] >= threshold - 1e-3 * scale, "vertex {v}: term {i} = {value}");
            kept += 1;
        }
        assert_eq!(kept, 24, "vertex {v}");
    }
}

/// Σ over pixels and channels of (p − r)² / (r² + 0.01), averaged: the relative MSE of the bench.
fn relative_mse(pixels: &[Vec3], reference: &[Vec3]) -> f64 {
    let sum: f64 = pixels
        .iter()
        .zip(reference)
        .map(|(p, r)| {
            let (d, r) = ((*p - *r).as_dvec3(), r.as_dvec3());
            (d * d / (r * r + DVec3::splat(0.01))).element_sum()
        })
        .sum();
    sum / (3 * pixels.len()) as f64
}

/// All-frequency transfer keeps the hard shadows of a small bright patch (pillars:sky=patch) that SH
/// transfer blurs: against the direct pass's ray-traced environment light (white surfaces, so that the
/// environment's direct light is all either image holds), wavelets at only 8² per face (one visibility
/// ray per 11° texel) and 6 % of the lighting's terms have a far smaller relative MSE than shadowed SH
/// transfer of order 5.
#[test]
fn wavelet_transfer_keeps_the_hard_shadows_sh_transfer_blurs() {
    let mut scene =
        crate::scene::builtin::build("pillars", &[("sky".into(), "patch".into())]).expect("scene");
    scene.materials = scene
        .materials
        .iter()
        .map(|m| crate::scene::Material {
            specular: 0.0,
            ..crate::scene::Material::diffuse(&m.name, Vec3::ONE)
        })
        .collect();
    let mut f = fixture_of(scene, 64, 48);
    let reference = direct_environment_light(&mut f);
    let mut error = |settings: &[(&str, &str)]| {
        let mut prt = Prt::new(&f.setup(&params(settings))).expect("prt");
        relative_mse(&f.render_rgb(&mut prt, 1), &reference)
    };
    let sh = error(&[("transfer", "shadowed"), ("order", "5"), ("transfer_samples", "256")]);
    let wavelet = error(&[
        ("transfer", "wavelet"),
        ("wavelet_resolution", "8"),
        ("wavelet_terms", "24"),
        ("wavelet_transfer_terms", "384"),
    ]);
    eprintln!("relative MSE against the direct pass: wavelets {wavelet:.4}, SH order 5 {sh:.4}");
    // Measured 0.0083 and 0.0467 (at 16² per face the wavelets' falls to 0.0048).
    assert!(wavelet < 0.015, "wavelets {wavelet}");
    assert!(wavelet < 0.35 * sh, "wavelets {wavelet} not clearly below SH {sh}");
}

/// A cube face's side must halve down to one texel.
#[test]
fn a_wavelet_resolution_that_is_not_a_power_of_two_is_refused() {
    let e = (INFO.validate)(&params(&[("transfer", "wavelet"), ("wavelet_resolution", "12")])).unwrap_err();
    assert!(e.contains("wavelet_resolution") && e.contains("12"), "{e}");
    assert!((INFO.validate)(&params(&[("transfer", "wavelet"), ("wavelet_resolution", "16")])).is_ok());
}
