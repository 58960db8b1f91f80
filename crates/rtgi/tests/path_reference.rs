//! The reference path tracer against exact answers.

use rtgi::gpu::{GpuContext, GpuOptions};
use rtgi::render::{RenderSettings, render};

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
