//! `igi` and `igi-sh`: energy in closed form (white furnace), agreement of their direct light with
//! `direct`, agreement of the two filters on diffuse scenes, convergence to the path-traced reference as
//! VPLs grow, and the bounded geometry term's reported energy loss.

use std::path::PathBuf;

use rtgi::gpu::{GpuContext, GpuOptions, TimingMode};
use rtgi::image::HdrImage;
use rtgi::metrics;
use rtgi::render::{RenderOutput, RenderSettings, render};
use rtgi::renderer::{Aov, Renderer, RendererSettings};
use rtgi::testing::ImageTest;

fn ctx() -> GpuContext {
    GpuContext::new(&GpuOptions::default()).expect("GPU adapter")
}

fn run(ctx: &GpuContext, scene: &str, technique: &str, settings: &[(&str, &str)], size: u32) -> RenderOutput {
    run_frames(ctx, scene, technique, settings, size, 1)
}

fn run_frames(
    ctx: &GpuContext,
    scene: &str,
    technique: &str,
    settings: &[(&str, &str)],
    size: u32,
    frames: u32,
) -> RenderOutput {
    let (name, scene_settings) = scene.split_once(':').unwrap_or((scene, ""));
    let scene_settings: Vec<(String, String)> = scene_settings
        .split(',')
        .filter(|s| !s.is_empty())
        .map(|kv| {
            let (k, v) = kv.split_once('=').expect("key=value");
            (k.to_string(), v.to_string())
        })
        .collect();
    let scene = rtgi::scene::builtin::build(name, &scene_settings).expect("scene");
    let settings = RenderSettings {
        technique: technique.into(),
        technique_settings: settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
        width: size,
        height: size,
        frames,
    };
    render(ctx, &scene, &settings, &mut |_, _| {}).expect("render")
}

fn mean(img: &HdrImage) -> f64 {
    img.rgb.iter().map(|&v| f64::from(v)).sum::<f64>() / img.rgb.len() as f64
}

fn median_deviation(img: &HdrImage, expected: f64) -> f64 {
    let mut d: Vec<f64> = img.rgb.iter().map(|&v| (f64::from(v) - expected).abs()).collect();
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// Furnace with albedo ρ = 0.5 and emission E = 0.5: VPLs after at most `depth` reflections plus the
/// final gather give exactly E · Σ_{k=0}^{depth+1} ρ^k (the truncated Neumann series).
#[test]
fn furnace_energy_is_the_truncated_neumann_series() {
    let ctx = ctx();
    for technique in ["igi", "igi-sh"] {
        for (depth, expected) in [("0", 0.75), ("1", 0.875), ("8", 0.5 * (1.0 - 0.5f64.powi(10)) / 0.5)] {
            let out = run(
                &ctx,
                "furnace:albedo=0.5,emission=0.5",
                technique,
                // All light from VPLs (igi-sh defaults to rasterised direct light), as the series has it.
                &[("vpls", "4096"), ("depth", depth), ("direct", "vpl")],
                32,
            );
            let m = mean(&out.image);
            let dev = median_deviation(&out.image, expected);
            eprintln!(
                "{technique} depth {depth}: mean {m:.5} (exact {expected:.5}), median pixel deviation {dev:.4}"
            );
            // Measured: means 0.2–0.6 % (igi) and 0.6–1.1 % (igi-sh) low — the 1/d² of VPLs near the
            // box's corners is heavy-tailed, so finite VPL sets fall short of its mean more often than
            // not; median pixel deviation 0.006–0.022 (VPL noise, 256 VPLs per set; 99th percentile
            // 0.09–0.18).
            assert!(
                (m - expected).abs() < 0.02 * expected,
                "{technique} depth {depth}: mean {m} != {expected}"
            );
            assert!(dev < MAX_MEDIAN_DEVIATION, "{technique} depth {depth}: median deviation {dev}");
        }
    }
}

const MAX_MEDIAN_DEVIATION: f64 = 0.045;

/// Without interleaving, 1024 VPLs are gathered in four dispatches of 256 (chunks add up in the
/// half-float accumulation buffer): the furnace's energy must survive that.
#[test]
fn chunked_gather_keeps_the_energy() {
    let ctx = ctx();
    let expected = 0.5 * (1.0 - 0.5f64.powi(10)) / 0.5;
    for technique in ["igi", "igi-sh"] {
        let settings = [("vpls", "1024"), ("interleave", "1x1")];
        let out = run(&ctx, "furnace:albedo=0.5,emission=0.5", technique, &settings, 32);
        let m = mean(&out.image);
        eprintln!("{technique} 1x1, 1024 VPLs: mean {m:.5} (exact {expected:.5})");
        assert!((m - expected).abs() < 0.02 * expected, "{technique}: mean {m} != {expected}");
    }
}

/// With `depth=0` and direct light from VPLs, the only VPL is the spot light itself, with ray-traced
/// visibility: unfiltered, `igi` is `direct`'s image (shadow-mapped) up to shadow-map edges. (`igi-sh`
/// is not: order-2 SH of a single point light overestimates grazing light — the clamped cosine's
/// band-limited approximation is 0.14 instead of 0.09 at 85° — which is the method's, not a bug.)
#[test]
fn vpls_on_the_lights_give_the_direct_light() {
    let ctx = ctx();
    let direct = run(&ctx, "cornell-spot", "direct", &[], 64).image;
    let vpl = run(
        &ctx,
        "cornell-spot",
        "igi",
        &[("depth", "0"), ("vpls", "16"), ("filter", "false"), ("direct", "vpl")],
        64,
    )
    .image;
    let m = metrics::compare(&direct, &vpl).expect("compare");
    eprintln!("igi depth 0 vs direct: {m:?}, means {} {}", mean(&direct), mean(&vpl));
    // Measured: means equal to 0.06 %, FLIP 0.0007 (shadow-map edges).
    assert!((mean(&vpl) / mean(&direct) - 1.0).abs() < 0.003);
    assert!(m.flip < 0.003, "{m:?}");
}

/// Paper §4.2: on diffuse scenes without normal maps, filtering SH and filtering irradiance agree. Both
/// techniques here gather the same VPLs (same seed), filter over the same neighbours (`igi` with
/// `filter_normals=false`: the SH filter crosses normal changes too) and take direct light from
/// rasterisation (order-2 SH band-limits the near-point light of VPLs on the lamp, which is the method's
/// approximation of direct light, not of filtering). What differs is what is filtered: irradiance or
/// SH coefficients of incident light. Their images must agree far more closely than two VPL sets do.
#[test]
fn igi_and_igi_sh_agree_on_the_diffuse_cornell_box() {
    let ctx = ctx();
    let common = [("vpls", "1024"), ("direct", "raster")];
    let irradiance = [common[0], common[1], ("filter_normals", "false")];
    let a = run(&ctx, "cornell", "igi", &irradiance, 64).image;
    let b = run(&ctx, "cornell", "igi-sh", &common, 64).image;
    let other_vpls = [irradiance[0], irradiance[1], irradiance[2], ("seed", "5")];
    let noise = metrics::compare(&a, &run(&ctx, "cornell", "igi", &other_vpls, 64).image).expect("compare");
    let m = metrics::compare(&a, &b).expect("compare");
    let (ma, mb) = (mean(&a), mean(&b));
    eprintln!(
        "igi vs igi-sh on cornell: {m:?}, means {ma:.5} {mb:.5}; igi vs igi with other VPLs: {noise:?}"
    );
    // Measured: FLIP 0.028, relMSE 0.00042, means 0.11397 and 0.11369 (0.24 % apart); two VPL sets of
    // `igi` differ by FLIP 0.175, relMSE 0.051 (ratios 0.16 and 0.008). (With both defaults — direct light from VPLs, `igi`
    // stopping at normal changes — FLIP 0.078, relMSE 0.0020.)
    assert!(m.flip < 0.05 && m.rel_mse < 0.0008, "{m:?}");
    assert!((ma / mb - 1.0).abs() < 0.005, "means {ma} {mb}");
    assert!(m.flip < 0.3 * noise.flip && m.rel_mse < 0.015 * noise.rel_mse, "{m:?} vs VPL noise {noise:?}");
}

fn out_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("image-tests")
}

/// Error against the full-GI reference falls as VPLs grow, and at 4096 VPLs stays within measured
/// bounds.
#[test]
fn error_falls_as_vpls_grow() {
    let ctx = ctx();
    for technique in ["igi", "igi-sh"] {
        let test = |vpls: &'static str| ImageTest {
            name: "igi-cornell",
            scene: "cornell",
            scene_settings: &[],
            technique,
            settings: Box::leak(Box::new([("vpls", vpls)])),
            width: 64,
            height: 64,
            frames: 1,
            reference_spp: 256,
            reference_settings: &[],
            max_flip: 1.0,
            max_rel_mse: 1.0,
        };
        let coarse = test("256").run(&ctx, &out_dir()).expect("render").metrics;
        let fine = test("4096").run(&ctx, &out_dir()).expect("render").metrics;
        eprintln!("{technique}: 256 VPLs {coarse:?}; 4096 VPLs {fine:?}");
        assert!(fine.rel_mse < 0.5 * coarse.rel_mse, "{technique}: {coarse:?} -> {fine:?}");
        assert!(fine.flip < 0.75 * coarse.flip, "{technique}: {coarse:?} -> {fine:?}");
        assert!(fine.flip < MAX_FLIP_4096 && fine.rel_mse < MAX_REL_MSE_4096, "{technique}: {fine:?}");
    }
}

// Measured at 256 → 4096 VPLs with the default direct=raster: igi FLIP 0.220 → 0.108, relMSE 0.0199 →
// 0.0059; igi-sh FLIP 0.218 → 0.114, relMSE 0.0195 → 0.0063 (against a 256-spp reference). Bounds 1.5×
// the larger.
const MAX_FLIP_4096: f64 = 0.17;
const MAX_REL_MSE_4096: f64 = 0.0095;

/// One frame of `technique` on the built-in `cornell` box: the image, the emission and albedo AOVs and
/// the technique's counters.
struct Frame {
    image: HdrImage,
    emission: HdrImage,
    albedo: HdrImage,
    counters: std::collections::BTreeMap<String, f64>,
}

fn cornell_frame(ctx: &GpuContext, settings: &[(&str, &str)], size: u32) -> Frame {
    let scene = rtgi::scene::builtin::build("cornell", &[]).expect("scene");
    let mut renderer = Renderer::new(
        ctx,
        scene,
        &RendererSettings {
            technique: "igi".into(),
            technique_settings: settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
            width: size,
            height: size,
            timing: TimingMode::Frame,
        },
    )
    .expect("renderer");
    renderer.step().expect("frame");
    Frame {
        image: renderer.read_image().expect("image"),
        emission: renderer.read_aov(Aov::Emission).expect("emission"),
        albedo: renderer.read_aov(Aov::Albedo).expect("albedo"),
        counters: renderer.stats().expect("stats").counters,
    }
}

/// The light the VPLs deliver, summed over the image as luminance: on the Cornell box's Lambertian
/// surfaces a pixel shows Lₑ + ρ/π·E per channel, so E = π(L − Lₑ)/ρ — the quantity the technique's
/// clamping counters sum (luminance of incident light × cos θ). Channels without albedo (the lamp, misses)
/// carry no VPL light.
fn incident_light(frame: &Frame) -> f64 {
    let weights = [0.2126, 0.7152, 0.0722];
    let mut sum = 0.0;
    for (i, ((l, e), rho)) in
        frame.image.rgb.iter().zip(&frame.emission.rgb).zip(&frame.albedo.rgb).enumerate()
    {
        if *rho > 1e-4 {
            sum += weights[i % 3] * std::f64::consts::PI * f64::from(l - e) / f64::from(*rho);
        }
    }
    sum
}

/// Bounding the geometry term removes energy, and the technique reports how much: the reported share of
/// the incident light removed by the bound (and added back by compensation) is the share the image lost
/// (and regained). Unfiltered, so that each pixel's light is its own.
#[test]
fn clamping_reports_its_energy_loss() {
    let ctx = ctx();
    // All light from VPLs: the image's light is then exactly what the counters account for.
    let base = [("vpls", "1024"), ("filter", "false"), ("direct", "vpl")];
    let free = cornell_frame(&ctx, &base, 32);
    assert_eq!(free.counters["clamped_energy_fraction"], 0.0);
    for g_max in ["0.5", "2"] {
        let clamped = cornell_frame(&ctx, &[base[0], base[1], base[2], ("g_max", g_max)], 32);
        let with = [base[0], base[1], base[2], ("g_max", g_max), ("bias_compensation", "true")];
        let compensated = cornell_frame(&ctx, &with, 32);
        let (f, c, k) = (incident_light(&free), incident_light(&clamped), incident_light(&compensated));
        let lost = clamped.counters["clamped_energy_fraction"];
        let back = compensated.counters["compensated_energy_fraction"];
        let (measured_lost, measured_back) = ((f - c) / f, (k - c) / f);
        eprintln!(
            "g_max {g_max}: lost reported {lost:.5}, in the image {measured_lost:.5}; added back reported \
             {back:.5}, in the image {measured_back:.5}"
        );
        assert!(lost > 0.01, "g_max {g_max}: {lost}");
        assert!(
            (lost - measured_lost).abs() < MAX_FRACTION_MISMATCH,
            "g_max {g_max}: {lost} vs {measured_lost}"
        );
        assert!(back > 0.01, "g_max {g_max}: {back}");
        assert!(
            (back - measured_back).abs() < MAX_FRACTION_MISMATCH,
            "g_max {g_max}: {back} vs {measured_back}"
        );
    }
    // Compensation adds back most of it over frames (measured at g_max = 2 over 8 frames: means 0.1193
    // unbounded, 0.0919 clamped, 0.1121 compensated — one level of compensation only).
    let settings = [("vpls", "1024"), ("direct", "vpl"), ("g_max", "2")];
    let free = run_frames(&ctx, "cornell", "igi", &settings[..2], 32, 8);
    let clamped = run_frames(&ctx, "cornell", "igi", &settings, 32, 8);
    let with = [settings[0], settings[1], settings[2], ("bias_compensation", "true")];
    let compensated = run_frames(&ctx, "cornell", "igi", &with, 32, 8);
    let (f, c, k) = (mean(&free.image), mean(&clamped.image), mean(&compensated.image));
    eprintln!("g_max 2 over 8 frames: means free {f}, clamped {c}, compensated {k}");
    assert!((f - k).abs() < 0.5 * (f - c), "compensation: {f} {c} {k}");
}

// Measured (32², 1024 VPLs, one frame): reported − image share lost 0.00025 (g_max 0.5, 0.854 lost) and
// 0.00078 (g_max 2, 0.472), added back 0.0015 and 0.0003 — half-float accumulation and the albedo AOV's
// half floats. Counting the clamped light of occluded VPLs too (the bug this caught) reported 0.870
// against 0.854 lost and 0.247 against 0.280 added back.
const MAX_FRACTION_MISMATCH: f64 = 0.003;
