//! Animation through the persistent renderer: frame k of an animated glTF (written by hand by
//! `testing::animated_gltf`, not by rtgi's exporter; moving camera, box and point light) renders like a
//! fresh static render of the scene posed at t_k, for the path tracer and for `direct`: when the still
//! starts its random numbers where the animation's frame did, exactly (`direct`) or up to the rounding
//! of rays moved into a moving mesh's space (`path`, whose moving box is a BVH instance), and within
//! noise when it does not.

use rtgi::gpu::{GpuContext, GpuOptions, TimingMode};
use rtgi::image::HdrImage;
use rtgi::renderer::{Renderer, RendererSettings};
use rtgi::scene::Scene;
use rtgi::techniques::Motion;

const SIZE: u32 = 32;
const TIMES: [f32; 4] = [0.0, 0.4, 1.25, 1.9];

fn ctx() -> GpuContext {
    GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (lavapipe)")
}

fn animated_scene(dir: &std::path::Path) -> Scene {
    let path = rtgi::testing::animated_gltf(dir).expect("write the animated glTF");
    let scene = rtgi::scene::gltf_load::load(&path).expect("load the animated glTF");
    assert!(scene.is_animated());
    scene
}

fn settings(technique: &str, set: &[(&str, &str)]) -> RendererSettings {
    RendererSettings {
        technique: technique.into(),
        technique_settings: set.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
        width: SIZE,
        height: SIZE,
        timing: TimingMode::Frame,
    }
}

fn mean(image: &HdrImage) -> f64 {
    image.rgb.iter().map(|&v| f64::from(v)).sum::<f64>() / image.rgb.len() as f64
}

/// Renders the animation frame by frame in one renderer (`steps` renderer frames at each time) and each
/// pose in a renderer of its own; returns per time (relative mean difference, FLIP).
fn animation_against_stills(
    technique: &str,
    set: &[(&str, &str)],
    steps: u32,
    same_random_numbers: bool,
) -> Vec<(f64, f64)> {
    let ctx = ctx();
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = animated_scene(dir.path());
    let mut animated = Renderer::new(&ctx, scene.clone(), &settings(technique, set)).expect("renderer");
    let mut results = Vec::new();
    for t in TIMES {
        animated.set_time(t).expect("set time");
        let first_frame = animated.frame_counter();
        assert_eq!(animated.sample_index(), 0, "a moved scene restarts accumulation");
        for _ in 0..steps {
            animated.step().expect("frame");
        }
        let frame = animated.read_image().expect("readback");

        let mut still = Renderer::new(&ctx, scene.posed(t), &settings(technique, set)).expect("renderer");
        if same_random_numbers {
            still.set_frame_counter(first_frame);
        }
        for _ in 0..steps {
            still.step().expect("frame");
        }
        let expected = still.read_image().expect("readback");
        let m = rtgi::metrics::compare(&expected, &frame).expect("metrics");
        let relative = (mean(&frame) - mean(&expected)).abs() / mean(&expected);
        eprintln!("{technique} t={t}: mean difference {relative:.6}, FLIP {:.5}", m.flip);
        results.push((relative, m.flip));
    }
    results
}

#[test]
fn direct_frames_equal_static_renders_of_the_posed_scene() {
    // One point light through a cube shadow map and no stochastic light: the same pose gives the same
    // image whichever frame it is, up to rounding. Measured: identical on lavapipe; on an NVIDIA H200
    // the moving box (transformed per frame vs posed once) rounds otherwise, largest mean difference
    // 2.1e-9, FLIP 0 (bounds about 2x). One pixel of another shadow or shade at 32² moves the mean by
    // ~1e-3 and FLIP by ~5e-4, so these bounds still tell rounding from a wrong pose.
    for (k, (mean_difference, flip)) in
        animation_against_stills("direct", &[], 1, false).into_iter().enumerate()
    {
        assert!(mean_difference < 5e-9 && flip < 1e-4, "frame {k}: mean {mean_difference:e}, FLIP {flip}");
    }
}

#[test]
fn path_frames_equal_static_renders_of_the_posed_scene_with_the_same_samples() {
    // Same pose, same random numbers. The animated renderer traces the moving box as an instance of a
    // two-level BVH (rays moved into its space), the still renderer the posed box in one BVH, so hit
    // points differ by rounding and nothing else: measured on lavapipe, mean differences 0 to 4.1e-10
    // and FLIP 0. One path that took another branch (a wrong transform, a stale top level) moves the
    // mean by about one sample in the 16 384 of a pose (~6e-5), far over the bound; a branch decided by
    // rounding needs a ray within ~1e-7 of an instance's edge, which none of those paths comes near.
    for (k, (mean_difference, flip)) in
        animation_against_stills("path", &[("spp", "8")], 2, true).into_iter().enumerate()
    {
        assert!(mean_difference < 1e-6 && flip < 1e-4, "frame {k}: mean {mean_difference:e}, FLIP {flip}");
    }
}

#[test]
fn path_frames_match_static_renders_of_the_posed_scene_within_noise() {
    // 512 samples per pixel each (128 per frame, 4 frames) with other random numbers than the stills:
    // they differ by Monte Carlo noise only. Measured on lavapipe at 32x32: mean differences
    // 0.00055-0.00070, FLIP 0.0183-0.0200 (two independent 512-spp renders); bounds 1.5x that, the
    // mean's at the 0.5 %.
    for (k, (mean_difference, flip)) in
        animation_against_stills("path", &[("spp", "128")], 4, false).into_iter().enumerate()
    {
        assert!(mean_difference < 0.005 && flip < 0.03, "frame {k}: mean {mean_difference}, FLIP {flip}");
    }
}

/// Checks the motion AOV of the frame at `t1` (after a frame at `t0`) against a CPU computation: each
/// pixel's surface point, rebuilt from the depth AOV and the camera at `t1`, moved back by its mesh's
/// transforms (instance AOV, `Scene::pose_at`) and projected with the camera at `t0`, must land where the
/// motion vector points. Returns (pixels within 0.5 px, surface pixels) over all surface pixels and over
/// the pixels of meshes that moved. `primary` makes the G-buffer (`raster` or `trace`).
fn motion_vectors_against_cpu(scene: Scene, t0: f32, t1: f32, primary: &str) -> [(usize, usize); 2] {
    use rtgi::renderer::Aov;
    let ctx = ctx();
    let size = 64;
    let settings =
        RendererSettings { width: size, height: size, ..settings("direct", &[("primary", primary)]) };
    let mut r = Renderer::new(&ctx, scene.clone(), &settings).expect("renderer");
    r.set_time(t0).expect("time");
    r.step().expect("frame");
    r.set_time(t1).expect("time");
    r.step().expect("frame");
    let motion = r.read_aov(Aov::Motion).expect("motion");
    let depth = r.read_aov(Aov::Depth).expect("depth");
    let instance = r.read_aov(Aov::Instance).expect("instance");

    let (pose0, pose1) = (scene.pose_at(t0), scene.pose_at(t1));
    let view_proj0 = pose0.camera.view_projection(1.0);
    let inverse1 = pose1.camera.view_projection(1.0).inverse();
    let s = size as f32;
    let (mut within, mut surface) = ([0; 2], [0; 2]);
    for y in 0..size {
        for x in 0..size {
            let i = (y * size + x) as usize * 3;
            let mesh = instance.rgb[i];
            if mesh < 0.0 {
                continue;
            }
            let centre = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let ndc = glam::Vec2::new(centre.x / s * 2.0 - 1.0, 1.0 - centre.y / s * 2.0);
            let near = inverse1.project_point3(ndc.extend(0.0));
            let far = inverse1.project_point3(ndc.extend(1.0));
            let world = pose1.camera.position + (far - near).normalize() * depth.rgb[i];
            let m = mesh as usize;
            let previous = pose0.mesh_transforms[m] * pose1.mesh_transforms[m].inverse();
            let object_moved = pose0.mesh_transforms[m] != pose1.mesh_transforms[m];
            let before = view_proj0.project_point3(previous.transform_point3(world));
            let expected = glam::Vec2::new((before.x + 1.0) * 0.5 * s, (1.0 - before.y) * 0.5 * s);
            let vector = glam::Vec2::new(motion.rgb[i], motion.rgb[i + 1]);
            let good = usize::from((centre + vector - expected).length() < 0.5);
            for k in [0, 1].into_iter().filter(|&k| k == 0 || object_moved) {
                surface[k] += 1;
                within[k] += good;
            }
        }
    }
    eprintln!(
        "motion {} ({primary}): {} of {} pixels within 0.5 px; on moving objects {} of {}",
        scene.name, within[0], surface[0], within[1], surface[1]
    );
    [(within[0], surface[0]), (within[1], surface[1])]
}

#[test]
fn motion_vectors_follow_the_camera_and_moving_objects() {
    let dir = tempfile::tempdir().expect("temp dir");
    let cases = [
        // Camera only (a flight through the atrium), object only (a box through the Cornell box,
        // static camera), and both at once (the hand-written file: camera, box and light move).
        (
            rtgi::scene::builtin::build("atrium", &[("animate".into(), "camera".into())]).expect("atrium"),
            2.0,
            2.2,
        ),
        (
            rtgi::scene::builtin::build("cornell", &[("animate".into(), "box".into())]).expect("cornell"),
            1.0,
            1.1,
        ),
        (animated_scene(dir.path()), 0.4, 0.6),
    ];
    for (k, (scene, t0, t1)) in cases.into_iter().enumerate() {
        let name = scene.name.clone();
        // Both G-buffer passes (rasterised, ray-cast through the two-level BVH).
        for primary in ["raster", "trace"] {
            let [(within, surface), (object_within, object_pixels)] =
                motion_vectors_against_cpu(scene.clone(), t0, t1, primary);
            // Measured on lavapipe: every surface pixel within 0.5 px (the issue asks for ≥ 99 %), on the
            // moving objects too, with either pass.
            assert!(
                within as f64 >= 0.99 * surface as f64,
                "{name} ({primary}): {within} of {surface} within 0.5 px"
            );
            assert!(
                object_within as f64 >= 0.99 * object_pixels as f64,
                "{name} ({primary}): moving objects {object_within} of {object_pixels}"
            );
            // The object cases really show the moving box.
            assert!(k == 0 || object_pixels >= 20, "{name}: only {object_pixels} pixels of moving objects");
        }
    }
}

/// For every registered technique (small settings, 32x32): a renderer stepped at `times[0]` then at
/// `times[1]`, and a fresh renderer of the scene posed at `times[1]` with the same random numbers.
/// Temporal techniques carry history from `times[0]`, so both renderers go on for
/// [`TEMPORAL_SETTLE_FRAMES`] more frames at `times[1]` (with a fast hysteresis) before the images are
/// read: what is left of the old pose then is below the tests' bounds. Returns per technique its name,
/// motion, the two images and the animated renderer's counters.
fn every_technique_animated_and_fresh(
    scene: &Scene,
    times: [f32; 2],
) -> Vec<(&'static str, Motion, HdrImage, HdrImage, rtgi::renderer::RendererCounters)> {
    let small: &[(&str, &str)] =
        &[("vpls", "64"), ("samples", "16"), ("spp", "1"), ("rsm_size", "64"), ("hysteresis", "0.5")];
    rtgi::techniques::registry()
        .iter()
        .map(|info| {
            let set: Vec<(&str, &str)> =
                small.iter().copied().filter(|(k, _)| info.params.iter().any(|p| p.name == *k)).collect();
            let (frame, expected, counters) = animated_and_fresh(scene, times, info, &set);
            (info.name, info.motion, frame, expected, counters)
        })
        .collect()
}

/// [`every_technique_animated_and_fresh`] for one technique with settings `set`: the animated
/// renderer's image, the fresh renderer's and the animated renderer's counters.
fn animated_and_fresh(
    scene: &Scene,
    times: [f32; 2],
    info: &rtgi::techniques::TechniqueInfo,
    set: &[(&str, &str)],
) -> (HdrImage, HdrImage, rtgi::renderer::RendererCounters) {
    let ctx = ctx();
    let settings = RendererSettings { width: 32, height: 32, ..settings(info.name, set) };
    let frames_after = 1 + if info.motion == Motion::Temporal { TEMPORAL_SETTLE_FRAMES } else { 0 };
    let mut animated = Renderer::new(&ctx, scene.clone(), &settings).expect("renderer");
    animated.set_time(times[0]).expect("time");
    animated.step().expect("frame");
    animated.set_time(times[1]).expect("time");
    let first_frame = animated.frame_counter();
    for _ in 0..frames_after {
        animated.step().expect("frame");
    }
    let frame = animated.read_image().expect("readback");

    let mut fresh = Renderer::new(&ctx, scene.posed(times[1]), &settings).expect("renderer");
    fresh.set_frame_counter(first_frame);
    for _ in 0..frames_after {
        fresh.step().expect("frame");
    }
    let expected = fresh.read_image().expect("readback");
    (frame, expected, animated.counters())
}

/// Frames a temporal technique renders after a move before it is compared with a fresh renderer: with
/// DDGI's hysteresis 0.5 the old pose's share falls by at least 0.5 + 0.5·ρ per frame (ρ < 0.8 on
/// these scenes), to below 0.9^40 ≈ 1.5 % of its first-frame difference.
const TEMPORAL_SETTLE_FRAMES: u32 = 40;

/// The largest difference of a channel relative to its magnitude (at least 1e-3).
fn largest_relative_difference(a: &HdrImage, b: &HdrImage) -> f32 {
    a.rgb.iter().zip(&b.rgb).map(|(x, y)| (x - y).abs() / x.abs().max(y.abs()).max(1e-3)).fold(0.0, f32::max)
}

fn largest_difference(a: &HdrImage, b: &HdrImage) -> f32 {
    a.rgb.iter().zip(&b.rgb).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
}

/// A swinging spot light, a sun (directional light and sky) turning over the atrium, and the sky of
/// spheres-env turning about the vertical: after they move, every registered technique renders what a
/// fresh renderer of the posed scene renders with the same random numbers (shadow maps and RSMs
/// re-aimed and re-rendered, the sky re-baked with its sampling table, or only turned: SH projections
/// rotated instead of projected again), and all of them update in place instead of being created anew.
fn moved_light_renders_like_a_fresh_renderer_for_every_technique(name: &str, animate: &str, times: [f32; 2]) {
    let mut settings = vec![("animate".to_string(), animate.to_string())];
    if name == "spheres-env" {
        // Two spheres per row keep the per-vertex techniques' precomputation short.
        settings.push(("count".to_string(), "2".to_string()));
    }
    let scene = rtgi::scene::builtin::build(name, &settings).expect("scene");
    for (technique, motion, frame, expected, c) in every_technique_animated_and_fresh(&scene, times) {
        let difference = largest_difference(&frame, &expected);
        let relative = (mean(&frame) - mean(&expected)).abs() / mean(&expected);
        eprintln!("{name} {technique}: largest difference {difference:e}, mean difference {relative:e}");
        if motion == Motion::Temporal {
            // The blend into the f16 atlas stalls within a rounding step of its target, on the
            // side of the old pose: a residue of up to 2^-10 of the stored irradiance, so at most
            // about 1e-3 of a pixel (the blend's stochastic rounding walks within a few steps).
            // Measured (ddgi, 40 frames after the move), largest absolute / relative to its pixel /
            // mean: lavapipe (stochastic rounding) cornell-spot 6.7e-6 / 2.2e-4 / 1.9e-6, atrium
            // 5.5e-7 / 4.5e-6 / 4.0e-10; an NVIDIA H100 (plain blend, 1370470) cornell-spot
            // 1.4e-5 / – / 1.4e-6, atrium 6.8e-5 / – / 4.2e-8. A probe state left from the old pose
            // would differ by the light's move (~0.1, many pixels).
            let relative_pixel = largest_relative_difference(&frame, &expected);
            eprintln!("{name} {technique}: largest difference relative to the pixel {relative_pixel:e}");
            assert!(
                relative_pixel < 2e-3 && relative < 1.5e-5,
                "{name} {technique}: {relative_pixel:e}, {relative:e}"
            );
        } else {
            // Measured: identical for every technique on both scenes.
            assert_eq!(difference, 0.0, "{name} {technique}: largest difference {difference}");
        }
        let light_updates = if animate == "environment" { 0 } else { 2 };
        assert_eq!(
            (c.scene_uploads, c.technique_builds, c.light_updates),
            (1, 1, light_updates),
            "{name} {technique}"
        );
        let environment_updates = if animate == "spot" { 0 } else { 2 };
        assert_eq!(c.environment_updates, environment_updates, "{name} {technique}");
    }
}

#[test]
fn a_moved_spot_renders_like_a_fresh_renderer_for_every_technique() {
    moved_light_renders_like_a_fresh_renderer_for_every_technique("cornell-spot", "spot", [0.3, 0.9]);
}

#[test]
fn a_moved_sun_renders_like_a_fresh_renderer_for_every_technique() {
    moved_light_renders_like_a_fresh_renderer_for_every_technique("atrium", "sun", [1.0, 2.5]);
}

#[test]
fn a_turned_sky_renders_like_a_fresh_renderer_for_every_technique() {
    moved_light_renders_like_a_fresh_renderer_for_every_technique("spheres-env", "environment", [1.0, 4.0]);
}

/// A box moving through the Cornell box: the box is an instance of the two-level BVH, moved in place
/// (its vertices rewritten, the top level rebuilt) with no new upload, BVH build or technique, and
/// every registered technique renders what a fresh renderer of the posed scene renders with the same
/// random numbers, up to the rounding of rays moved into the instance's space.
#[test]
fn moved_meshes_render_like_a_fresh_renderer_for_every_technique() {
    let scene = rtgi::scene::builtin::build("cornell", &[("animate".into(), "box".into())]).expect("scene");
    for (technique, motion, frame, expected, c) in every_technique_animated_and_fresh(&scene, [0.7, 1.6]) {
        let largest = largest_difference(&frame, &expected);
        let relative = (mean(&frame) - mean(&expected)).abs() / mean(&expected);
        eprintln!("{technique}: largest difference {largest:e}, mean difference {relative:e}");
        // Measured on lavapipe: identical for every technique but path (largest pixel difference
        // 2.4e-6, mean 7.4e-10: hit points on the box differ by rounding). A path or VPL that took
        // another branch changes a pixel by a sample's worth (~0.01-1), so these bounds separate
        // rounding from any real difference.
        if motion == Motion::Temporal {
            // Measured on lavapipe (ddgi, 40 frames after the move): largest 1.1e-2, mean 1.1e-4 —
            // probe rays that meet the moved box at rounded hit points take other light samples, and
            // each frame's samples stay in the probes for a few frames. The box leaving its old place
            // un-updated would differ by its shadow's worth (~0.1-0.5) over many pixels.
            assert!(largest < 3e-2 && relative < 3e-4, "{technique}: {largest:e}, {relative:e}");
        } else {
            assert!(largest < 1e-4 && relative < 1e-6, "{technique}: {largest:e}, {relative:e}");
        }
        assert_eq!(
            (c.scene_uploads, c.bvh_builds, c.technique_builds, c.geometry_updates),
            (1, 1, 1, 2),
            "{technique}"
        );
    }
}

/// The imperfect shadow maps' point pool moves with the box: `igi` with `visibility=ism`, stepped from
/// one pose to the next, renders what a fresh renderer of the second pose renders (a pool left at the
/// first pose would cast the box's old shadow into the maps).
#[test]
fn imperfect_shadow_maps_follow_moved_meshes() {
    let scene = rtgi::scene::builtin::build("cornell", &[("animate".into(), "box".into())]).expect("scene");
    let info = rtgi::techniques::registry().iter().find(|t| t.name == "igi").expect("igi");
    let (frame, expected, c) =
        animated_and_fresh(&scene, [0.7, 1.6], info, &[("vpls", "64"), ("visibility", "ism")]);
    let largest = largest_difference(&frame, &expected);
    let relative = (mean(&frame) - mean(&expected)).abs() / mean(&expected);
    eprintln!("igi visibility=ism: largest difference {largest:e}, mean difference {relative:e}");
    // Rounding of points moved with the box, against a shadow's worth of ~0.1 over many pixels.
    // Measured: identical on lavapipe; on an NVIDIA H200 largest 1.8e-4, mean 2.6e-6 (a point moved in
    // place rounds otherwise than the posed one and can land in a neighbouring map texel). Bounds 2x.
    assert!(largest < 4e-4 && relative < 6e-6, "{largest:e}, {relative:e}");
    assert_eq!((c.scene_uploads, c.technique_builds, c.geometry_updates), (1, 1, 2));
}
