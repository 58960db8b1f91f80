//! The histogram SAT against brute-force binning (exact integers, footprints from one texel to many
//! periods of the tiled map), fractional footprints against area-weighted sums, the shader and its
//! layout, a flat normal map against `direct`, and the memory fit.

use std::mem::offset_of;

use glam::{Vec2, Vec3};

use super::histogram::{NormalHistogram, SUBSAMPLES, bilinear_normal, bin_of, stored_bins};
use super::*;
use crate::params::ParamValues;
use crate::scene::builtin::shapes::{MeshBuilder, hash_unit};
use crate::scene::{Camera, Light, Material, Texture, TextureRef};
use crate::shaders::layout::assert_layout;
use crate::shaders::validate;
use crate::techniques::fixture::{fixture_of, mean_relative_difference};

/// A `size`² normal map of hashed normals tilted up to about 50°.
fn hashed_map(size: u32) -> Vec<u8> {
    let mut rgba8 = Vec::new();
    for y in 0..size {
        for x in 0..size {
            let r = 0.75 * hash_unit(&[x, y, 1]).sqrt();
            let phi = std::f32::consts::TAU * hash_unit(&[x, y, 2]);
            let n = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - r * r).sqrt());
            let e = (n * 0.5 + 0.5) * 255.0;
            rgba8.extend([e.x.round() as u8, e.y.round() as u8, e.z.round() as u8, 255]);
        }
    }
    rgba8
}

/// Per texel of the map, its normals' bins (brute force, as the histogram should count them).
fn texel_bins(h: &NormalHistogram, rgba8: &[u8], scale: f32) -> Vec<Vec<u32>> {
    let s = SUBSAMPLES;
    let mut out = Vec::new();
    for y in 0..h.height {
        for x in 0..h.width {
            let mut bins = Vec::new();
            for j in 0..s {
                for i in 0..s {
                    let p = Vec2::new(
                        x as f32 + (i as f32 + 0.5) / s as f32,
                        y as f32 + (j as f32 + 0.5) / s as f32,
                    );
                    bins.push(bin_of(bilinear_normal(rgba8, h.width, p, scale), h.radius, h.bins));
                }
            }
            out.push(bins);
        }
    }
    out
}

#[test]
fn box_histograms_equal_brute_force_binning() {
    let size = 12;
    let rgba8 = hashed_map(size);
    let h = NormalHistogram::build(&rgba8, size, 0.8, 5);
    let per_texel = texel_bins(&h, &rgba8, 0.8);
    let boxes: Vec<[i64; 4]> = vec![
        [0, 0, 1, 1],
        [3, 4, 4, 5],
        [0, 0, 12, 12],
        [5, 7, 11, 12],
        // Across the map's edge, from negative coordinates, over several periods.
        [10, 9, 15, 14],
        [-7, -3, 2, 5],
        [-30, 4, 17, 6],
        [-25, -26, 40, 39],
    ];
    for [x0, y0, x1, y1] in boxes {
        // The K² bins, then the K rows.
        let mut expected = vec![0u32; stored_bins(h.bins) as usize];
        for y in y0..y1 {
            for x in x0..x1 {
                let t = (y.rem_euclid(12) * 12 + x.rem_euclid(12)) as usize;
                for &b in &per_texel[t] {
                    expected[b as usize] += 1;
                    expected[(h.bin_count() + b / h.bins) as usize] += 1;
                }
            }
        }
        assert_eq!(h.box_counts(x0, y0, x1, y1), expected, "box [{x0}, {x1}) × [{y0}, {y1})");
    }
}

#[test]
fn fractional_boxes_count_texels_by_covered_area() {
    let size = 8;
    let rgba8 = hashed_map(size);
    let h = NormalHistogram::build(&rgba8, size, 1.0, 5);
    let per_texel = texel_bins(&h, &rgba8, 1.0);
    for (lo, hi) in [
        (Vec2::new(0.25, 0.5), Vec2::new(0.75, 0.9)),
        (Vec2::new(1.3, 2.6), Vec2::new(4.1, 3.2)),
        (Vec2::new(6.5, 7.25), Vec2::new(9.75, 12.5)),
        (Vec2::new(3.7, 0.1), Vec2::new(30.2, 17.9)),
    ] {
        let mut expected = vec![0.0f64; h.bin_count() as usize];
        for y in lo.y.floor() as i64..hi.y.ceil() as i64 {
            for x in lo.x.floor() as i64..hi.x.ceil() as i64 {
                let cover_x = (hi.x as f64).min(x as f64 + 1.0) - (lo.x as f64).max(x as f64);
                let cover_y = (hi.y as f64).min(y as f64 + 1.0) - (lo.y as f64).max(y as f64);
                let t = (y.rem_euclid(8) * 8 + x.rem_euclid(8)) as usize;
                for &b in &per_texel[t] {
                    expected[b as usize] += cover_x * cover_y;
                }
            }
        }
        let mut sum = 0.0f64;
        for b in 0..h.bin_count() {
            let got = f64::from(h.box_count(lo, hi, b));
            sum += got;
            // f32 arithmetic on counts below a few thousand: measured errors ≤ 2e-4.
            assert!(
                (got - expected[b as usize]).abs() < 1e-3,
                "bin {b} of {lo}..{hi}: {got} vs {}",
                expected[b as usize]
            );
        }
        let area = f64::from((hi.x - lo.x) * (hi.y - lo.y)) * f64::from(h.weight_per_texel());
        assert!((sum - area).abs() < 1e-3 * area, "{lo}..{hi}: {sum} normals, area holds {area}");
    }
}

#[test]
fn a_flat_map_puts_every_normal_in_one_bin_that_holds_it() {
    let rgba8: Vec<u8> = (0..16 * 16).flat_map(|_| [128, 128, 255, 255]).collect();
    let h = NormalHistogram::build(&rgba8, 16, 1.0, 17);
    let counts = h.box_counts(0, 0, 16, 16);
    let full: Vec<usize> = (0..h.bin_count() as usize).filter(|&b| counts[b] > 0).collect();
    assert_eq!(full.len(), 1, "normals in bins {full:?}");
    assert_eq!(counts[full[0]], 16 * 16 * h.weight_per_texel());
    assert_eq!(counts.iter().sum::<u32>(), 2 * counts[full[0]], "one bin and its row");
    // 128/255 decodes to a tilt of 0.0039 in x and y.
    let decoded = Vec3::new(1.0 / 255.0, 1.0 / 255.0, 1.0).normalize();
    assert!((h.bin_normals[full[0]] - decoded).length() < 1e-6, "{}", h.bin_normals[full[0]]);
}

#[test]
fn bins_shrink_to_fit_the_binding_limit() {
    let limit = 128u64 << 20;
    assert_eq!(fitting_bins(17, 1, 256, limit), Some(17));
    // 512² texels × (17² + 17) counts × 4 bytes = 306 MiB; with 11 bins 132 MiB, with 9 90 MiB.
    assert_eq!(fitting_bins(17, 1, 512, limit), Some(9));
    assert_eq!(fitting_bins(16, 1, 512, limit), Some(9));
    assert_eq!(fitting_bins(17, 1, 8192, limit), None);
}

#[test]
fn shader_validates_and_layout_matches() {
    let defines = Defines::new().u32("TILE", 8).u32("AREA_SAMPLES", 4).u32("ENV_SAMPLES", 4);
    let tables = environment::TableShape::new(6, 8);
    validate(
        "glints",
        include_str!("glints.wgsl"),
        &tables.defines(defines.clone().bool("GLINT_ENV_SH", true)),
    );
    validate("glints environment", include_str!("environment.wgsl"), &tables.defines(Defines::new()));
    let m = validate("glints", include_str!("glints.wgsl"), &defines.bool("GLINT_ENV_SH", false));
    assert_layout(
        &m,
        "GlintMaterial",
        size_of::<GpuGlintMaterial>(),
        &[
            ("offset", offset_of!(GpuGlintMaterial, offset)),
            ("size", offset_of!(GpuGlintMaterial, size)),
            ("bins", offset_of!(GpuGlintMaterial, bins)),
            ("weight_per_texel", offset_of!(GpuGlintMaterial, weight_per_texel)),
            ("normal_offset", offset_of!(GpuGlintMaterial, normal_offset)),
        ],
    );
}

/// A metal floor with a normal map under a point light and a spot light, seen obliquely.
fn lit_floor(rgba8: Vec<u8>, size: u32) -> crate::scene::Scene {
    let mut floor = MeshBuilder::new();
    floor.grid(Vec3::new(-2.0, 0.0, 2.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -4.0), 2, 2, 2.0);
    crate::scene::Scene {
        name: "lit-floor".into(),
        meshes: vec![floor.build("floor", 0)],
        materials: vec![Material {
            name: "metal".into(),
            base_color: Vec3::new(0.9, 0.8, 0.7).extend(1.0),
            metallic: 1.0,
            roughness: 0.4,
            normal_texture: Some(TextureRef::new(0)),
            normal_scale: 1.0,
            ..Default::default()
        }],
        textures: vec![Texture { name: "map".into(), width: size, height: size, rgba8, srgb: false }],
        lights: vec![
            Light::Point { position: Vec3::new(0.0, 1.0, -1.5), intensity: Vec3::splat(2.0) },
            Light::Spot {
                position: Vec3::new(-1.0, 1.5, 0.5),
                direction: Vec3::new(0.5, -1.0, -0.6).normalize(),
                intensity: Vec3::new(3.0, 2.0, 1.0),
                inner_angle: 0.4,
                outer_angle: 0.6,
            },
        ],
        camera: Camera {
            position: Vec3::new(0.0, 1.0, 2.0),
            target: Vec3::new(0.0, 0.0, -0.5),
            up: Vec3::Y,
            yfov: 50f32.to_radians(),
            znear: 0.05,
            zfar: 20.0,
        },
        ..Default::default()
    }
}

/// With every micronormal equal to the macro normal, the footprint's histogram is one bin holding that
/// normal, so glints must shade exactly as `direct` does (same BRDF, lights and shadow maps).
#[test]
fn a_flat_normal_map_shades_as_direct() {
    let rgba8: Vec<u8> = (0..32 * 32).flat_map(|_| [128, 128, 255, 255]).collect();
    let mut f = fixture_of(lit_floor(rgba8, 32), 48, 32);
    let params = ParamValues::defaults("glints", &PARAMS).expect("defaults");
    let mut glints = Glints::new(&f.setup(&params)).expect("glints");
    let image = f.render_rgb(&mut glints, 1);
    let counters = glints.read_counters(&f.ctx).expect("counters");
    let direct_params =
        ParamValues::defaults("direct", &crate::techniques::direct::DIRECT_PARAMS).expect("defaults");
    let mut direct = crate::techniques::direct::DirectLighting::new(
        &f.setup(&direct_params),
        &f.output,
        crate::techniques::direct::DirectOutput::Accumulate,
    )
    .expect("direct");
    let mut direct = DirectOnly(&mut direct);
    let expected = f.render_rgb(&mut direct, 1);
    let lit = expected.iter().filter(|p| p.max_element() > 1e-3).count();
    assert!(lit > 48 * 32 / 4, "only {lit} lit pixels: the test lost its light");
    assert!(counters[0] as usize > 48 * 32 / 2, "{} pixels see the floor", counters[0]);
    assert_eq!(counters[1], counters[0], "one bin per pixel");
    let difference = mean_relative_difference(&image, &expected);
    // Measured: 1.7e-4 on lavapipe. `direct` reads the normal from the G-buffer, which keeps it as
    // half-float octahedral coordinates; glints use the exact one (a wrong weight or total would be
    // off by percents).
    assert!(difference < 3.5e-4, "glints differ from direct by {difference}");
}

/// `DirectLighting` as a technique, for comparisons.
struct DirectOnly<'a>(&'a mut crate::techniques::direct::DirectLighting);

impl Technique for DirectOnly<'_> {
    fn render_frame(&mut self, fc: &FrameContext, profiler: &mut Profiler) -> Result<(), RenderError> {
        self.0.render(fc, profiler)
    }
}

/// Mean linear luminance of the pixels in the rectangle (x, y, w, h) of a `width`-wide image.
fn patch_luminance(image: &[Vec3], width: usize, (x, y, w, h): (usize, usize, usize, usize)) -> f64 {
    let mut sum = 0.0;
    for row in y..y + h {
        for p in &image[row * width + x..row * width + x + w] {
            sum += f64::from(p.dot(Vec3::new(0.2126, 0.7152, 0.0722)));
        }
    }
    sum / (w * h) as f64
}

/// Basis-space integration of the environment (part b) against the sampled estimator it replaces, on
/// the glints scene under the sky (floor and sphere, the sphere's shadow): after 4 frames the SH
/// image must match a 128-frame sampled render of the same model, in the mean of the floor and of the
/// sphere and per pixel, and be far closer to it than 4 frames of sampling.
#[test]
fn environment_by_sh_matches_sampled_environment() {
    let (width, height) = (48usize, 32usize);
    let mut f =
        crate::techniques::fixture::fixture_with("glints", &[("sky", "sky")], width as u32, height as u32);
    let mut render = |settings: &[(&str, &str)], frames: u32| {
        let set: Vec<(String, String)> =
            settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
        let params = ParamValues::from_settings("glints", &PARAMS, &set).expect("settings");
        let mut glints = Glints::new(&f.setup(&params)).expect("glints");
        f.render_rgb(&mut glints, frames)
    };
    let reference = render(&[("env_samples", "8"), ("seed", "7")], 128);
    let sampled = render(&[], 4);
    let sh = render(&[("env_order", "8"), ("env_views", "8")], 4);
    let sh_error = mean_relative_difference(&sh, &reference);
    let sampled_error = mean_relative_difference(&sampled, &reference);
    let floor = (0, 20, 48, 12);
    let sphere = (16, 4, 16, 14);
    let floor_ratio = patch_luminance(&sh, width, floor) / patch_luminance(&reference, width, floor);
    let sphere_ratio = patch_luminance(&sh, width, sphere) / patch_luminance(&reference, width, sphere);
    eprintln!(
        "sh {sh_error:.4}, sampled {sampled_error:.4}, floor {floor_ratio:.4}, sphere {sphere_ratio:.4}"
    );
    assert!(sh_error < 0.1, "SH environment differs from the sampled one by {sh_error}");
    assert!(
        sh_error < 0.5 * sampled_error,
        "SH {sh_error} not below half of 4 sampled frames' {sampled_error}"
    );
    assert!((floor_ratio - 1.0).abs() < 0.03, "floor: SH / sampled = {floor_ratio}");
    assert!((sphere_ratio - 1.0).abs() < 0.03, "sphere: SH / sampled = {sphere_ratio}");
}

/// Report 003 §2.7 experiment 2 under a uniform environment of radiance 1, whose half-vector lighting
/// is L̂(v, h) = 4 (v·h)⁺: the GPU's lobe coefficients against a CPU quadrature of k_l = 2π ∫ D P_l,
/// and the double product Σ_lm k_l L̂_lm(v) y_lm(n) of the GPU's tables against a direct quadrature of
/// ∫ 4 (v·h)⁺ D(h·n) dh, for bins turned 0°, 30° and 60° from a view of the table.
#[test]
fn lobe_and_lighting_tables_match_quadrature() {
    let mut scene = lit_floor(hashed_map(16), 16);
    scene.lights.clear();
    scene.environment = crate::scene::Environment::Uniform(Vec3::ONE);
    let mut f = fixture_of(scene, 16, 16);
    let (order, views) = (12usize, 8u32);
    let set = [("env_order".to_string(), order.to_string()), ("env_views".to_string(), views.to_string())];
    let params = ParamValues::from_settings("glints", &PARAMS, &set).expect("settings");
    let mut glints = Glints::new(&f.setup(&params)).expect("glints");
    f.render_rgb(&mut glints, 1);
    let tables = glints.environment.as_ref().expect("tables");
    let read = |buffer: &wgpu::Buffer, floats: usize| -> Vec<f32> {
        let bytes =
            crate::gpu::readback::read_buffer(&f.ctx, buffer, 0, 4 * floats as u64).expect("readback");
        bytemuck::cast_slice(&bytes).to_vec()
    };
    let steps = environment::ROUGHNESS_STEPS as usize;
    let lobe = read(&tables.lobe_zh, steps * order);
    let shape = tables.shape;
    let count = order * order;
    let table = read(&tables.table, 4 * shape.views() as usize * count);

    // Roughness 0.5 is a step of the table: α = 0.25.
    let step = (steps - 1) / 2;
    let alpha: f64 = 0.25;
    let d = |mu: f64| {
        let a2 = alpha * alpha;
        let x = mu * mu * (a2 - 1.0) + 1.0;
        if mu > 0.0 { a2 / (std::f64::consts::PI * x * x) } else { 0.0 }
    };
    let legendre = |l: usize, mu: f64| {
        let (mut p_prev, mut p) = (1.0, mu);
        if l == 0 {
            return 1.0;
        }
        for j in 2..=l {
            let next = ((2 * j - 1) as f64 * mu * p - (j - 1) as f64 * p_prev) / j as f64;
            p_prev = p;
            p = next;
        }
        p
    };
    let (nodes, weights) = crate::sh::gauss_legendre(400);
    let k: Vec<f64> = (0..order)
        .map(|l| {
            nodes
                .iter()
                .zip(&weights)
                .map(|(x, w)| {
                    let mu = 0.5 * (x + 1.0);
                    std::f64::consts::TAU * 0.5 * w * d(mu) * legendre(l, mu)
                })
                .sum()
        })
        .collect();
    let lobe_error = (0..order).map(|l| (f64::from(lobe[step * order + l]) - k[l]).abs()).fold(0.0, f64::max);
    eprintln!(
        "k_l: {k:.4?}, GPU {:.4?}, largest GPU error {lobe_error:.2e}",
        &lobe[step * order..(step + 1) * order]
    );

    // View (row 3, column 5) of the table.
    let (row, column) = (3u32, 5u32);
    let theta = std::f64::consts::PI * f64::from(row) / f64::from(shape.view_rows - 1);
    let phi = std::f64::consts::TAU * f64::from(column) / f64::from(shape.view_columns);
    let v = glam::DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
    let first = ((row * shape.view_columns + column) as usize) * count;
    let axis = v.cross(glam::DVec3::X).normalize();
    let quadrature = crate::hsh::sphere_quadrature(300);
    let mut worst: f64 = 0.0;
    for degrees in [0.0f64, 30.0, 60.0] {
        let n = glam::DQuat::from_axis_angle(axis, degrees.to_radians()) * v;
        let y = crate::hsh::sh(order, n);
        let mut sh = 0.0;
        for (l, k_l) in k.iter().enumerate() {
            for i in l * l..(l + 1) * (l + 1) {
                sh += k_l * f64::from(table[4 * (first + i)]) * y[i];
            }
        }
        let direct: f64 = quadrature.iter().map(|(h, w)| w * 4.0 * v.dot(*h).max(0.0) * d(h.dot(n))).sum();
        let error = (sh - direct).abs() / direct;
        eprintln!(
            "bin {degrees}° from the view: SH {sh:.5}, quadrature {direct:.5}, relative error {error:.2e}"
        );
        worst = worst.max(error);
    }
    // Measured on lavapipe: lobe coefficients within 7.8e-7 of the CPU's (an f32 sum of 2048 steps, so
    // the bound leaves room for another driver's sin and cos; when the integral's loop was cut short by
    // lavapipe's iteration limit, bands 8 and up were off by 1.4e-2), the double product within 6.3e-4 of
    // the quadrature (the table's own quadrature of a lighting with a kink at the view's horizon).
    assert!(lobe_error < 2e-5, "GPU lobe coefficients off by {lobe_error}");
    assert!(worst < 1.5e-3, "double product off the quadrature by {worst}");
}
