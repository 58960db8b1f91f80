//! End-to-end renders through the `rtgi` binary (these need a Vulkan adapter; lavapipe is enough).

use std::path::Path;

mod common;
use common::rtgi_in as rtgi;

fn ok(out: &std::process::Output) {
    assert!(out.status.success(), "rtgi failed: {}", String::from_utf8_lossy(&out.stderr));
}

/// The same command twice gives bit-identical EXR files (stochastic area-light and environment sampling
/// included: every random number is a function of pixel, frame and seed).
#[test]
fn same_command_twice_gives_identical_exr() {
    let dir = tempfile::tempdir().expect("temp dir");
    // Every registered technique, on the spot-lit box (which the RSM family can light).
    for technique in rtgi::techniques::registry().iter().map(|t| t.name) {
        let args = |out: &'static str| {
            vec![
                "render",
                "--scene",
                "cornell-spot",
                "--technique",
                technique,
                "--size",
                "64x64",
                "--frames",
                "2",
                "--out",
                out,
            ]
        };
        ok(&rtgi(dir.path(), &args("a.exr")));
        ok(&rtgi(dir.path(), &args("b.exr")));
        let a = std::fs::read(dir.path().join("a.exr")).expect("a.exr");
        let b = std::fs::read(dir.path().join("b.exr")).expect("b.exr");
        assert!(a == b, "{technique}: two renders differ");
        let img = rtgi::image::HdrImage::read(dir.path().join("a.exr")).expect("readable EXR");
        assert_eq!((img.width, img.height), (64, 64));
        assert!(img.rgb.iter().any(|v| *v > 0.0), "{technique}: black image");
    }
}

/// `--stats` writes the documented keys, and per-pass times either come from reliable timestamps or the
/// file says why they do not. `--timing frame` (the default) has per-frame wall times and per-pass GPU
/// times; `--timing passes` adds a wall time per pass.
#[test]
fn stats_json_has_the_documented_keys() {
    let dir = tempfile::tempdir().expect("temp dir");
    for timing in ["frame", "passes"] {
        ok(&rtgi(
            dir.path(),
            &[
                "render",
                "--scene",
                "cornell-spot",
                "--size",
                "48x32",
                "--frames",
                "3",
                "--timing",
                timing,
                "--out",
                "x.png",
                "--stats",
                "s.json",
            ],
        ));
        let text = std::fs::read_to_string(dir.path().join("s.json")).expect("stats file");
        let v: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
        for key in [
            "scene",
            "technique",
            "width",
            "height",
            "adapter",
            "wall_ms",
            "passes",
            "timestamps",
            "timing",
            "frame_wall",
            "renderer",
            "memory",
        ] {
            assert!(v.get(key).is_some(), "missing {key} in {text}");
        }
        assert_eq!(v["scene"], "cornell-spot");
        assert_eq!(v["width"], 48);
        assert_eq!(v["timing"], timing);
        // Frames 2 and 3 are the steady ones.
        assert_eq!(v["frame_wall"]["count"], 2, "{text}");
        assert!(v["frame_wall"]["p95_ms"].as_f64().is_some_and(|t| t > 0.0), "{text}");
        assert_eq!(v["renderer"]["scene_uploads"], 1, "{text}");
        let passes = v["passes"].as_array().expect("passes");
        assert!(passes.iter().any(|p| p["name"] == "shadow maps" && p["calls"] == 1), "{text}");
        assert!(passes.iter().any(|p| p["name"] == "gbuffer" && p["calls"] == 3), "{text}");
        let reliable = v["timestamps"] == "reliable";
        for p in passes {
            assert_eq!(p["gpu_ms"].is_number(), reliable, "{text}");
            let walled = p["wall_ms"].as_f64().is_some_and(|t| t >= 0.0);
            assert_eq!(walled, timing == "passes", "{text}");
        }
        let png = image_size(&dir.path().join("x.png"));
        assert_eq!(png, (48, 32));
    }
}

fn image_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).expect("png");
    // PNG IHDR: width and height are big-endian u32 at bytes 16..24.
    let w = u32::from_be_bytes([bytes[16], bytes[17], bytes[18], bytes[19]]);
    let h = u32::from_be_bytes([bytes[20], bytes[21], bytes[22], bytes[23]]);
    (w, h)
}

fn mean_abs_difference(a: &Path, b: &Path) -> f64 {
    let (a, b) = (rtgi::image::HdrImage::read(a).expect("a"), rtgi::image::HdrImage::read(b).expect("b"));
    a.rgb.iter().zip(&b.rgb).map(|(x, y)| f64::from((x - y).abs())).sum::<f64>() / a.rgb.len() as f64
}

/// `--warmup` frames at `--warmup-time`, then a `--hold` sequence at `--time`: the step response of a
/// temporal technique to a moved light. DDGI's frames approach their final state (each differs less
/// from the last than the one before it did, on average), while the light itself moved at once.
#[test]
fn warmup_and_hold_show_a_temporal_technique_settling_after_a_step() {
    let dir = tempfile::tempdir().expect("temp dir");
    let common = [
        "render",
        "--scene",
        "cornell-spot:animate=spot",
        "--technique",
        "ddgi",
        "--size",
        "32x32",
        "--set",
        "hysteresis=0.8",
        "--warmup",
        "20",
        "--warmup-time",
        "0",
        "--time",
        "1.5",
    ];
    let mut step = common.to_vec();
    step.extend(["--hold", "--frames", "24", "--out", "step_%02d.exr"]);
    ok(&rtgi(dir.path(), &step));
    let frame = |k: u32| dir.path().join(format!("step_{k:02}.exr"));
    let to_last: Vec<f64> =
        [0, 4, 8, 16].iter().map(|&k| mean_abs_difference(&frame(k), &frame(23))).collect();
    assert!(to_last.windows(2).all(|w| w[1] < w[0]), "not settling: {to_last:?}");
    // Without --hold the frames advance 1/30 s each: the light sweeps on and the last frames differ.
    let mut moving = common.to_vec();
    moving.extend(["--frames", "2", "--fps", "2", "--out", "move_%02d.exr"]);
    ok(&rtgi(dir.path(), &moving));
    let moved = mean_abs_difference(&dir.path().join("move_00.exr"), &dir.path().join("move_01.exr"));
    assert!(
        moved > to_last[3],
        "a moving light changes the image more ({moved}) than settling ({to_last:?})"
    );
}
