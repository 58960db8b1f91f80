//! The reference path tracer against exact answers.

use rtgi::gpu::{GpuContext, GpuOptions};
use rtgi::render::{RenderOutput, RenderSettings, render};

fn mean(v: &[f32]) -> f64 {
    v.iter().map(|x| f64::from(*x)).sum::<f64>() / v.len() as f64
}

/// White furnace: walls of albedo 0.8 emitting 0.2 give radiance 0.2 / (1 − 0.8) = 1 everywhere. 64
/// samples in one frame is the configuration that exposed a lavapipe miscompile (it read 0.84).
#[test]
fn furnace_mean_radiance_is_one() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let scene = rtgi::scene::builtin::build("furnace", &[]).expect("furnace");
    let settings = RenderSettings {
        technique: "path".into(),
        technique_settings: vec![("spp".into(), "64".into())],
        width: 48,
        height: 48,
        frames: 1,
    };
    let out = render(&ctx, &scene, &settings, &mut |_, _| {}).expect("render");
    let m = mean(&out.image.rgb);
    assert!((m - 1.0).abs() < 0.01, "furnace mean radiance {m}, expected 1 ± 1 %");
    let rays = out.stats.counters["rays"];
    let samples = out.stats.counters["samples"];
    assert_eq!(samples, 48.0 * 48.0 * 64.0);
    // Each furnace path has at least three vertices before roulette, each with a closest-hit and a
    // shadow ray: far fewer rays per sample means paths were cut short.
    assert!(rays / samples > 6.0, "{rays} rays for {samples} samples");
}

/// At 1024 samples per pixel every furnace pixel is within 5 % of 1.
#[test]
fn furnace_every_pixel_within_five_percent_at_1024_spp() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let img = render_path(&ctx, "furnace", 24, 1024, &[]);
    let (lo, hi) = img.rgb.iter().fold((f32::MAX, f32::MIN), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    eprintln!("furnace at 1024 spp: mean {:.5}, min {lo:.4}, max {hi:.4}", mean(&img.rgb));
    assert!(lo > 0.95 && hi < 1.05, "pixel range [{lo}, {hi}] not within 1 ± 5 %");
}

fn render_path(
    ctx: &GpuContext,
    scene: &str,
    size: u32,
    spp: u32,
    extra: &[(&str, &str)],
) -> rtgi::image::HdrImage {
    let scene = rtgi::scene::builtin::build(scene, &[]).expect("scene");
    render_scene(ctx, &scene, size, spp, extra).image
}

/// `path` on `scene` at size² with `spp` samples per pixel (frames of up to 64) and the `extra` settings.
fn render_scene(
    ctx: &GpuContext,
    scene: &rtgi::scene::Scene,
    size: u32,
    spp: u32,
    extra: &[(&str, &str)],
) -> RenderOutput {
    let mut technique_settings = vec![("spp".to_string(), spp.min(64).to_string())];
    technique_settings.extend(extra.iter().map(|(k, v)| (k.to_string(), v.to_string())));
    let settings = RenderSettings {
        technique: "path".into(),
        technique_settings,
        width: size,
        height: size,
        frames: spp.div_ceil(64),
    };
    render(ctx, scene, &settings, &mut |_, _| {}).expect("render")
}

/// Light sampling only, BRDF sampling only and their MIS combination are three unbiased estimators of
/// the same image: their means agree within noise. The noise of each estimator's image mean is measured
/// from independent seeds, and the means must agree within four standard errors. (bumpy-glossy has only
/// point lights, which always use next-event estimation, so there the three coincide.)
#[test]
fn nee_brdf_and_mis_estimators_agree() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    const SEEDS: u32 = 6;
    for scene in ["cornell", "spheres-env", "bumpy-glossy"] {
        let stats: Vec<(f64, f64)> = ["mis", "light", "brdf"]
            .iter()
            .map(|nee| {
                let means: Vec<f64> = (0..SEEDS)
                    .map(|seed| {
                        let seed = seed.to_string();
                        mean(
                            &render_path(
                                &ctx,
                                scene,
                                24,
                                64,
                                &[("nee", nee), ("max_bounces", "2"), ("seed", &seed)],
                            )
                            .rgb,
                        )
                    })
                    .collect();
                let m = means.iter().sum::<f64>() / f64::from(SEEDS);
                let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / f64::from(SEEDS - 1);
                (m, (var / f64::from(SEEDS)).sqrt())
            })
            .collect();
        eprintln!(
            "{scene}: mean ± standard error: mis {:?} light {:?} brdf {:?}",
            stats[0], stats[1], stats[2]
        );
        for (name, (m, se)) in ["light", "brdf"].iter().zip(&stats[1..]) {
            let (m0, se0) = stats[0];
            let tolerance = 4.0 * (se * se + se0 * se0).sqrt() + 1e-6 * m0;
            if scene == "spheres-env" && *name == "light" {
                // Cosine-sampling the sky for the near-mirror spheres (roughness 0 → GGX α = 0.0025) has a
                // heavy right tail: the reflection lobe is found about once in 10⁵ samples, so finite runs
                // fall short of the mean and seed-to-seed spread underestimates the error. Measured:
                // 0.5897 ± 0.0022 against MIS 0.5998 ± 0.0008. Only the short side is allowed, and little.
                assert!(*m <= m0 + tolerance && *m >= 0.97 * m0, "{scene}: light-only mean {m} vs MIS {m0}");
                continue;
            }
            assert!(
                (m - m0).abs() <= tolerance,
                "{scene}: {name} mean {m} vs MIS {m0}, beyond 4 standard errors ({tolerance})"
            );
        }
    }
}

/// Least-squares slope of log(rmse) against log(spp).
fn log_log_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (sx, sy) = points.iter().fold((0.0, 0.0), |a, (x, y)| (a.0 + x.ln(), a.1 + y.ln()));
    let (mx, my) = (sx / n, sy / n);
    let num: f64 = points.iter().map(|(x, y)| (x.ln() - mx) * (y.ln() - my)).sum();
    let den: f64 = points.iter().map(|(x, _)| (x.ln() - mx).powi(2)).sum();
    num / den
}

/// An unbiased, consistent estimator's RMSE against a converged reference falls as 1/√spp: the
/// log–log slope over 16…256 spp lies in [−0.55, −0.45]. (A biased estimator flattens out.)
#[test]
fn rmse_falls_as_inverse_square_root_of_samples() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let scene = rtgi::scene::builtin::build("cornell", &[]).expect("cornell");
    let size = 16;
    let request =
        rtgi::reference::ReferenceRequest { width: size, height: size, spp: 4096, settings: vec![] };
    let reference = rtgi::reference::reference(&ctx, &scene, &request, &mut |_, _| {}).expect("reference");
    let mut points = Vec::new();
    for (i, spp) in [16u32, 32, 64, 128, 256].into_iter().enumerate() {
        // A different seed than the reference's (`REFERENCE_SEED`) and than each other, so errors are independent.
        let seed = (1000 + i).to_string();
        let img = render_path(&ctx, "cornell", size, spp, &[("seed", &seed)]);
        let e = rtgi::metrics::rmse(&reference.image, &img).expect("same size");
        eprintln!("spp {spp}: rmse {e:.5}");
        points.push((f64::from(spp), e));
    }
    let slope = log_log_slope(&points);
    eprintln!("log-log slope {slope:.3}");
    assert!((-0.55..=-0.45).contains(&slope), "slope {slope}: {points:?}");
}

/// `translucent`'s sphere, alone in a uniform environment of radiance 1, of a medium that absorbs
/// nothing behind a boundary of index 1.3 at `roughness`, rendered by the path tracer's random walk.
fn white_translucent_sphere(
    ctx: &GpuContext,
    roughness: f32,
    spp: u32,
    nee: &str,
) -> (rtgi::image::HdrImage, f64) {
    use rtgi::scene::{Environment, Material, Subsurface};
    let mut scene = rtgi::scene::builtin::build("translucent", &[]).expect("translucent");
    scene.meshes.retain(|m| m.name == "sphere");
    scene.lights.clear();
    scene.environment = Environment::Uniform(glam::Vec3::ONE);
    let medium = Subsurface {
        absorption: glam::Vec3::ZERO,
        reduced_scattering: glam::Vec3::new(10.0, 30.0, 90.0),
        eta: 1.3,
    };
    scene.materials[2] = Material { roughness, ..Material::translucent("white", medium) };
    let out = render_scene(ctx, &scene, 32, spp, &[("nee", nee)]);
    (out.image, out.stats.counters["truncated_walks"])
}

/// A medium that absorbs nothing returns every path it takes in: lit by a uniform environment, the
/// sphere is as bright as the environment through a smooth boundary (no microfacet loses energy),
/// whatever the colour-dependent scattering. This checks the walk's flight and channel weights and that
/// the η² of entering and the η⁻² of leaving cancel (a lost factor would read 1.69 or 0.59).
#[test]
fn non_absorbing_translucent_sphere_is_a_white_furnace() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let (img, truncated) = white_translucent_sphere(&ctx, 0.0, 256, "mis");
    let m = mean(&img.rgb);
    let (lo, hi) = img.rgb.iter().fold((f32::MAX, f32::MIN), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
    eprintln!(
        "smooth white translucent sphere: mean {m:.5}, pixels in [{lo:.4}, {hi:.4}], {truncated} truncated walks"
    );
    assert_eq!(truncated, 0.0);
    assert!((m - 1.0).abs() < 0.01, "mean radiance {m}, expected 1 ± 1 %");
    // A rough boundary loses what single-scattering microfacets lose at every crossing and internal
    // reflection, and must never gain. Measured: image mean 0.9834 (the sphere covers about a third).
    let (img, _) = white_translucent_sphere(&ctx, 0.4, 256, "mis");
    let rough = mean(&img.rgb);
    eprintln!("rough (0.4) white translucent sphere: mean {rough:.5}");
    assert!(rough > 0.96 && rough < 1.005, "rough boundary: mean radiance {rough}");
    // Sampling the environment alone and the boundary's BSDF alone estimate the same image only if
    // the dielectric's value and density agree (the refraction's half vector, Jacobian and η²).
    let light = mean(&white_translucent_sphere(&ctx, 0.4, 256, "light").0.rgb);
    let bsdf = mean(&white_translucent_sphere(&ctx, 0.4, 256, "brdf").0.rgb);
    eprintln!("rough sphere: light sampling {light:.5}, BSDF sampling {bsdf:.5}");
    // Measured: 0.98296 and 0.98333 against MIS's 0.98343 (differences 5e-4 and 1e-4).
    assert!(
        (light - rough).abs() < 2e-3 && (bsdf - rough).abs() < 2e-3,
        "light {light}, BSDF {bsdf}, MIS {rough}"
    );
}

/// The random walk against an exact solution of radiative transfer: a semi-infinite medium of
/// isotropic scattering behind an index-matched boundary, lit by a uniform environment of radiance 1,
/// reflects I(μ) = 1 − √(1−ω) H(μ) towards μ (Chandrasekhar 1950). A box 10⁴ mean free paths wide
/// and deep seen straight down (4° field of view, μ > 0.998) stands in for the half space; one albedo
/// per colour channel (0.99, 0.9, 0.5) also checks the channel-mixture weights.
#[test]
fn random_walk_reflects_chandrasekhars_semi_infinite_albedo() {
    use glam::Vec3;
    use rtgi::scene::builtin::shapes::MeshBuilder;
    use rtgi::scene::{Camera, Environment, Material, Scene, Subsurface};
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let omega: [f64; 3] = [0.99, 0.9, 0.5];
    let sigma_t = 100.0;
    let medium = Subsurface {
        absorption: Vec3::from(omega.map(|w| (sigma_t * (1.0 - w)) as f32)),
        reduced_scattering: Vec3::from(omega.map(|w| (sigma_t * w) as f32)),
        eta: 1.0,
    };
    let mut block = MeshBuilder::new();
    block.aabb(Vec3::new(-50.0, -100.0, -50.0), Vec3::new(50.0, 0.0, 50.0), 1.0);
    let scene = Scene {
        name: "half-space".into(),
        meshes: vec![block.build("block", 0)],
        materials: vec![Material::translucent("medium", medium)],
        environment: Environment::Uniform(Vec3::ONE),
        camera: Camera {
            position: Vec3::new(0.0, 1.0, 0.0),
            target: Vec3::ZERO,
            up: Vec3::NEG_Z,
            yfov: 4f32.to_radians(),
            znear: 0.01,
            zfar: 10.0,
        },
        ..Default::default()
    };
    let out = render_scene(&ctx, &scene, 32, 256, &[]);
    assert_eq!(out.stats.counters["truncated_walks"], 0.0);
    for (c, w) in omega.iter().enumerate() {
        let (h1, moment) = rtgi::scene::subsurface::chandrasekhar_h(*w, 1.0);
        // The solver against the closed form ∫₀¹ H dμ = (2/ω)(1 − √(1−ω)).
        let exact_moment = 2.0 / w * (1.0 - (1.0 - w).sqrt());
        assert!((moment / exact_moment - 1.0).abs() < 1e-4, "ω = {w}: ∫H = {moment}, exactly {exact_moment}");
        let exact = 1.0 - (1.0 - w).sqrt() * h1;
        let channel: Vec<f32> = out.image.rgb.iter().skip(c).step_by(3).copied().collect();
        let m = mean(&channel);
        eprintln!("ω = {w}: walk {m:.5}, exact I(1) = {exact:.5}");
        assert!((m / exact - 1.0).abs() < 0.02, "ω = {w}: walk {m} against {exact}");
    }
}

/// `subsurface` on `scene` at 32×32 with the exact sum of its samples (ε 0, ρ 0) and `extra` settings.
fn render_subsurface(
    ctx: &GpuContext,
    scene: &rtgi::scene::Scene,
    extra: &[(&str, &str)],
    frames: u32,
) -> RenderOutput {
    let settings = RenderSettings {
        technique: "subsurface".into(),
        technique_settings: [extra, &[("epsilon", "0"), ("rho", "0")]]
            .concat()
            .into_iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        width: 32,
        height: 32,
        frames,
    };
    render(ctx, scene, &settings, &mut |_, _| {}).expect("render")
}

/// Inside the slab's front face and inside the sphere of `translucent` at 32×32 (the patches of
/// `scripts/measure-subsurface-truth.py`): x, y, width, height.
const SLAB_FRONT: [u32; 4] = [22, 10, 6, 10];
const SPHERE: [u32; 4] = [3, 11, 7, 9];

/// The mean luminance of `out` in the patch `at` as a share of `reference`'s.
fn patch_share(out: &RenderOutput, reference: &RenderOutput, [x, y, w, h]: [u32; 4]) -> f64 {
    use rtgi::metrics::{luminance, region_mean};
    let patch = |o: &RenderOutput| luminance(region_mean(&o.image, x, y, w, h).expect("patch"));
    patch(out) / patch(reference)
}

/// `subsurface` against the random walk it approximates, on `translucent` at 32×32 (CI's share of
/// `scripts/measure-subsurface-truth.py`): the walk (`max_bounces=0`, 2048 spp), the Lambertian stand-in
/// every other technique shows, and the exact sums (ε 0, ρ 0) of the classical and the directional
/// dipole. Mean luminance of a patch of the slab's unlit front (light through 12 cm of marble) and of
/// the sphere, as fractions of the walk's, and FLIP over the image. Measured on lavapipe with walk
/// seeds 0 and 3 (the walk's noise moves a patch by about ±4 %): slab front dipole 0.876 / 0.934,
/// stand-in 0.244 / 0.260, directional 0.738 / 0.787; sphere dipole 0.930 / 0.891, directional
/// 1.655 / 1.586; FLIP dipole 0.110 / 0.107, stand-in 0.186 / 0.193. The directional dipole against
/// the classical one is deterministic: 0.842 on the slab, 1.78 on the sphere. The better dipole leaves
/// room for the single-scattering term (`single_scattering=4`, 8 frames): on the sphere 0.742 / 0.711
/// alone, 0.988 / 0.947 with it (a gain of 1.332: a missing 1/η² at the exit would be 1.56). Bounds at
/// about twice the measured distances.
#[test]
fn dipoles_against_the_random_walk() {
    use rtgi::metrics::flip;
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let scene = rtgi::scene::builtin::build("translucent", &[]).expect("translucent");
    let walk = render_scene(&ctx, &scene, 32, 2048, &[("subsurface", "walk"), ("max_bounces", "0")]);
    let stand_in = render_scene(&ctx, &scene, 32, 256, &[("subsurface", "lambertian"), ("max_bounces", "0")]);
    let [dipole, directional] =
        ["classical", "directional"].map(|d| render_subsurface(&ctx, &scene, &[("dipole", d)], 1));
    let better = render_subsurface(&ctx, &scene, &[("dipole", "better")], 1);
    let better_single =
        render_subsurface(&ctx, &scene, &[("dipole", "better"), ("single_scattering", "4")], 8);
    let [sphere_better, sphere_better_single] =
        [&better, &better_single].map(|o| patch_share(o, &walk, SPHERE));
    eprintln!("sphere: better dipole {sphere_better:.3}, with single scattering {sphere_better_single:.3}");
    let [slab_dipole, slab_stand_in, slab_directional] =
        [&dipole, &stand_in, &directional].map(|o| patch_share(o, &walk, SLAB_FRONT));
    let [sphere_dipole, sphere_directional] = [&dipole, &directional].map(|o| patch_share(o, &walk, SPHERE));
    let [flip_dipole, flip_stand_in] =
        [&dipole, &stand_in].map(|o| flip(&walk.image, &o.image).expect("flip"));
    eprintln!(
        "slab front: dipole {slab_dipole:.3}, stand-in {slab_stand_in:.3}, directional {slab_directional:.3}; \
         sphere: dipole {sphere_dipole:.3}, directional {sphere_directional:.3}; \
         FLIP dipole {flip_dipole:.4}, stand-in {flip_stand_in:.4}"
    );
    assert!((0.75..1.05).contains(&slab_dipole), "slab front: dipole {slab_dipole}");
    assert!(slab_stand_in < 0.45, "slab front: stand-in {slab_stand_in}");
    assert!((0.75..1.05).contains(&sphere_dipole), "sphere: dipole {sphere_dipole}");
    assert!(sphere_directional > 1.3, "sphere: directional {sphere_directional}");
    let (slab_lean, sphere_lean) = (slab_directional / slab_dipole, sphere_directional / sphere_dipole);
    assert!((0.75..0.95).contains(&slab_lean), "slab front: directional / dipole {slab_lean}");
    assert!((1.5..2.1).contains(&sphere_lean), "sphere: directional / dipole {sphere_lean}");
    assert!(flip_dipole < 0.75 * flip_stand_in, "FLIP: dipole {flip_dipole}, stand-in {flip_stand_in}");
    assert!(
        (0.88..1.12).contains(&sphere_better_single),
        "sphere: better dipole + single {sphere_better_single}"
    );
    let single_gain = sphere_better_single / sphere_better;
    assert!((1.25..1.42).contains(&single_gain), "sphere: single scattering's gain {single_gain}");
    assert!(
        (1.0 - sphere_better_single).abs() < 0.4 * (1.0 - sphere_better).abs(),
        "sphere: better dipole + single {sphere_better_single} no nearer the walk than alone {sphere_better}"
    );
}

/// `subsurface indirect_samples` against the walk with one bounce (`max_bounces=1`, 2048 spp) on
/// `translucent` at 32×32, in the translucent patches only (the technique lights opaque surfaces with
/// direct light alone): without indirect light the sphere and the slab's front miss what the floor,
/// the wall and the other object send them. Measured on lavapipe with walk seeds 0 and 3: direct light
/// only, slab front 0.781 / 0.826 and sphere 0.705 / 0.680 of the walk's; with 4 rays per sample over
/// 8 frames 0.900 / 0.953 and 0.903 / 0.871 (a gain of 1.15 on the slab's front, 1.28 on the sphere).
/// Bounds at about twice the measured distances from the walk.
#[test]
fn indirect_light_on_the_samples_against_the_walk() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let scene = rtgi::scene::builtin::build("translucent", &[]).expect("translucent");
    let walk = render_scene(&ctx, &scene, 32, 2048, &[("subsurface", "walk"), ("max_bounces", "1")]);
    let direct = render_subsurface(&ctx, &scene, &[("indirect_samples", "0")], 1);
    let indirect = render_subsurface(&ctx, &scene, &[("indirect_samples", "4")], 8);
    let [slab_direct, slab_indirect] = [&direct, &indirect].map(|o| patch_share(o, &walk, SLAB_FRONT));
    let [sphere_direct, sphere_indirect] = [&direct, &indirect].map(|o| patch_share(o, &walk, SPHERE));
    eprintln!(
        "slab front: direct {slab_direct:.3}, indirect {slab_indirect:.3}; \
         sphere: direct {sphere_direct:.3}, indirect {sphere_indirect:.3}"
    );
    assert!(sphere_direct < 0.8, "sphere: direct light only {sphere_direct}");
    assert!((0.75..1.1).contains(&sphere_indirect), "sphere: with indirect light {sphere_indirect}");
    assert!((0.75..1.15).contains(&slab_indirect), "slab front: with indirect light {slab_indirect}");
    assert!(
        (1.0 - sphere_indirect).abs() < 0.6 * (1.0 - sphere_direct).abs(),
        "sphere: indirect light {sphere_indirect} no nearer the walk than direct {sphere_direct}"
    );
    let (slab_gain, sphere_gain) = (slab_indirect / slab_direct, sphere_indirect / sphere_direct);
    assert!(slab_gain > 1.07 && sphere_gain > 1.14, "gains: slab {slab_gain}, sphere {sphere_gain}");
}

/// A walk cut short loses its light: the stats count such walks and a warning says so.
#[test]
fn truncated_walks_are_counted_and_warned_of() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let scene = rtgi::scene::builtin::build("translucent", &[]).expect("translucent");
    let out = render_scene(&ctx, &scene, 16, 1, &[("walk_steps", "2")]);
    assert!(out.stats.counters["truncated_walks"] > 0.0, "{:?}", out.stats.counters);
    assert!(out.stats.warnings.iter().any(|w| w.contains("cut short")), "{:?}", out.stats.warnings);
}
