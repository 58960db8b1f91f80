//! Runs the built `rtgi` binary the way users do and checks what they see: exit codes and one-line
//! errors, never a panic.
//!
//! Every test here fails before the GPU is needed, so the suite runs on machines without one.

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::rtgi_in;

/// Runs in a fresh folder so default outputs (out.png) never land in the source tree.
fn rtgi(args: &[&str]) -> Output {
    let dir = tempfile::tempdir().expect("temp dir");
    rtgi_in(dir.path(), args)
}

/// Asserts the documented failure shape (exit 1, exactly one stderr line `error: ...`, no panic) and
/// returns that line.
fn expect_error(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked") && !stderr.contains("internal error"), "panic: {stderr}");
    assert_eq!(out.status.code(), Some(1), "exit status; stderr: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one error line expected, got: {stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    lines[0].to_string()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn list_prints_both_sections_and_every_entry() {
    let out = rtgi(&["list"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = stdout(&out);
    assert!(text.contains("Built-in scenes"), "{text}");
    assert!(text.contains("Techniques"), "{text}");
    for scene in rtgi::scene::builtin::list() {
        assert!(text.contains(scene.name), "{} missing:\n{text}", scene.name);
        for p in scene.params {
            assert!(text.contains(&format!("{}={}", p.name, p.default)), "{}:\n{text}", p.name);
        }
    }
    for technique in rtgi::techniques::registry() {
        assert!(text.contains(technique.name), "{} missing:\n{text}", technique.name);
    }
    assert!(text.contains("Post-processes") && text.contains("motion-blur"), "{text}");
    for p in rtgi::post::motion_blur::MOTION_BLUR_PARAMS {
        assert!(text.contains(&format!("{}={}", p.name, p.default)), "{}:\n{text}", p.name);
    }
}

#[test]
fn list_names_cornell() {
    let text = stdout(&rtgi(&["list"]));
    let scenes = text.split("Techniques").next().unwrap_or_default();
    assert!(scenes.contains("cornell"), "{text}");
}

#[test]
fn list_names_direct() {
    let text = stdout(&rtgi(&["list"]));
    let techniques = text.split("Techniques").nth(1).unwrap_or_default();
    assert!(techniques.contains("direct"), "{text}");
}

#[test]
fn bad_sizes_are_one_line_errors() {
    for size in ["0x0", "0x16", "16", "axb", "-1x4", "99999999999x2"] {
        // `--size=` so that clap takes "-1x4" as the value rather than as a flag.
        let line = expect_error(&rtgi(&["render", &format!("--size={size}")]));
        assert!(line.starts_with(&format!("error: --size '{size}'")), "{line}");
    }
}

#[test]
fn zero_frames_is_an_error() {
    let line = expect_error(&rtgi(&["render", "--frames", "0"]));
    assert!(line.contains("--frames"), "{line}");
}

#[test]
fn unsupported_output_format_is_refused_before_rendering() {
    let line = expect_error(&rtgi(&["render", "--out", "picture.jpg"]));
    assert!(line.contains("picture.jpg") && line.contains(".png") && line.contains(".exr"), "{line}");
}

#[test]
fn bad_jitter_is_an_error() {
    let line = expect_error(&rtgi(&["render", "--jitter", "sometimes"]));
    assert!(line.contains("--jitter") && line.contains("halton"), "{line}");
    let line = expect_error(&rtgi(&["render", "--size", "16x16", "--jitter", "0.5,0", "--out", "j.exr"]));
    assert!(line.contains("[-0.5, 0.5)"), "{line}");
}

#[test]
fn bad_motion_blur_settings_are_errors() {
    for (args, expected) in [
        (vec!["--shutter=-0.1"], "--shutter"),
        (vec!["--shutter", "inf"], "--shutter"),
        (vec!["--shutter", "0.1", "--motion-blur-set", "segments=0"], "segments"),
        (vec!["--shutter", "0.1", "--motion-blur-set", "blur=1"], "background_weight"),
        (vec!["--motion-blur-set", "sigma=1"], "--shutter"),
        (vec!["--shutter-reference", "8"], "--shutter"),
        (vec!["--shutter", "0.1", "--shutter-reference", "0"], "at least 1"),
        (vec!["--shutter", "0.1", "--shutter-reference", "8", "--frames", "2"], "--frames"),
    ] {
        let mut argv = vec!["render", "--size", "16x16", "--out", "m.exr"];
        argv.extend(args.iter().copied());
        let line = expect_error(&rtgi(&argv));
        assert!(line.contains(expected), "{args:?}: {line}");
    }
}

#[test]
fn set_without_equals_is_an_error() {
    let line = expect_error(&rtgi(&["render", "--set", "novalue"]));
    assert!(line.contains("--set 'novalue'") && line.contains("key=value"), "{line}");
}

#[test]
fn malformed_scene_specs_are_errors() {
    let line = expect_error(&rtgi(&["render", "--scene", "cornell:detail"]));
    assert!(line.contains("--scene") && line.contains("key=value"), "{line}");
    let line = expect_error(&rtgi(&["render", "--scene", "model.obj"]));
    assert!(line.contains("model.obj") && line.contains(".gltf or .glb"), "{line}");
}

#[test]
fn unknown_scene_lists_builtin_scenes() {
    let line = expect_error(&rtgi(&["render", "--scene", "nosuch"]));
    assert!(line.contains("unknown scene 'nosuch'") && line.contains("built-in scenes"), "{line}");
    for scene in rtgi::scene::builtin::list() {
        assert!(line.contains(scene.name), "{line}");
    }
}

/// The scene is a file that does not exist: the technique must be checked before the scene is loaded.
#[test]
fn unknown_technique_lists_techniques_before_loading_the_scene() {
    let line = expect_error(&rtgi(&["render", "--scene", "never-loaded.glb", "--technique", "nosuch"]));
    assert!(line.contains("unknown technique 'nosuch'") && line.contains("techniques:"), "{line}");
    assert!(!line.contains("never-loaded.glb"), "{line}");
    for technique in rtgi::techniques::registry() {
        assert!(line.contains(technique.name), "{line}");
    }
}

#[test]
fn missing_scene_file_is_named() {
    let line = expect_error(&rtgi(&["render", "--scene", "missing.glb"]));
    assert!(line.contains("missing.glb"), "{line}");
}

#[test]
fn export_scene_rejects_unknown_scenes_and_bad_outputs() {
    let line = expect_error(&rtgi(&["export-scene", "nosuch", "out.glb"]));
    assert!(line.contains("unknown scene 'nosuch'") && line.contains("built-in scenes"), "{line}");
    let line = expect_error(&rtgi(&["export-scene", "cornell", "out.gltf"]));
    assert!(line.contains("out.gltf") && line.contains(".glb"), "{line}");
    let line = expect_error(&rtgi(&["export-scene", "scene.glb", "out.glb"]));
    assert!(line.contains("scene.glb") && line.contains("built-in"), "{line}");
}

#[test]
fn later_options_override_earlier_ones() {
    let line = expect_error(&rtgi(&["render", "--size", "64x64", "--size", "0x0"]));
    assert!(line.starts_with("error: --size '0x0'"), "{line}");
}

#[test]
fn usage_errors_keep_clap_exit_code() {
    let out = rtgi(&["render", "--no-such-flag"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
}

// glTF files through the CLI. They need the real loader (branch gltf) and, because the technique is
// validated before the scene is loaded, the `direct` technique (main).

/// One triangle with UVs, positions and UVs in `tri.bin` next to the file.
fn write_triangle_gltf(dir: &Path, extra_json: &str) -> std::path::PathBuf {
    let floats: [f32; 15] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
    let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
    std::fs::write(dir.join("tri.bin"), bytes).expect("write tri.bin");
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "material": 0}}]}}],
  "buffers": [{{"uri": "tri.bin", "byteLength": 60}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 36}},
    {{"buffer": 0, "byteOffset": 36, "byteLength": 24}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
      "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}}
  ]{extra_json}
}}"#
    );
    let path = dir.join("scene.gltf");
    std::fs::write(&path, json).expect("write scene.gltf");
    path
}

#[test]
fn truncated_glb_is_an_error() {
    let dir = tempfile::tempdir().expect("temp dir");
    let json = br#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[]}],"scene":0}  "#;
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&((12 + 8 + json.len()) as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(json);
    // Cut inside the JSON chunk: the header promises more bytes than the file has.
    glb.truncate(12 + 8 + json.len() / 2);
    std::fs::write(dir.path().join("cut.glb"), glb).expect("write cut.glb");
    let line = expect_error(&rtgi_in(dir.path(), &["render", "--scene", "cut.glb"]));
    assert!(line.contains("cut.glb"), "{line}");
}

#[test]
fn missing_texture_is_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let extra = r#",
  "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
  "textures": [{"source": 0}],
  "images": [{"uri": "missing-albedo.png"}]"#;
    let scene = write_triangle_gltf(dir.path(), extra);
    let line = expect_error(&rtgi_in(dir.path(), &["render", "--scene", &scene.to_string_lossy()]));
    assert!(line.contains("missing-albedo.png"), "{line}");
}

#[test]
fn unknown_required_extension_is_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let extra = r#",
  "materials": [{}],
  "extensionsUsed": ["EXT_rtgi_does_not_exist"],
  "extensionsRequired": ["EXT_rtgi_does_not_exist"]"#;
    let scene = write_triangle_gltf(dir.path(), extra);
    let line = expect_error(&rtgi_in(dir.path(), &["render", "--scene", &scene.to_string_lossy()]));
    assert!(line.contains("EXT_rtgi_does_not_exist"), "{line}");
}

fn write_exr(dir: &Path, name: &str, w: u32, h: u32, rgb: Vec<f32>) {
    rtgi::image::HdrImage { width: w, height: h, rgb }.write_exr(dir.join(name)).expect("write exr");
}

#[test]
fn compare_prints_the_three_metrics_as_json() {
    let dir = tempfile::tempdir().expect("temp dir");
    write_exr(dir.path(), "r.exr", 2, 1, vec![0.0, 0.5, 1.0, 2.0, 0.0, 0.1]);
    write_exr(dir.path(), "t.exr", 2, 1, vec![0.1, 0.5, 0.8, 2.0, 0.3, 0.1]);
    let out = rtgi_in(dir.path(), &["compare", "r.exr", "t.exr", "--json", "--error-map", "e.png"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).expect("one JSON object");
    let rmse = v["rmse"].as_f64().expect("rmse");
    assert!((rmse - (0.14f64 / 6.0).sqrt()).abs() < 1e-6, "{v}");
    assert!(v["rel_mse"].as_f64().is_some() && v["flip"].as_f64().is_some_and(|f| f > 0.0), "{v}");
    assert!(dir.path().join("e.png").exists());
}

#[test]
fn compare_reports_the_mean_radiance_of_a_region() {
    let dir = tempfile::tempdir().expect("temp dir");
    write_exr(dir.path(), "r.exr", 2, 1, vec![0.0, 0.5, 1.0, 2.0, 0.0, 0.1]);
    write_exr(dir.path(), "t.exr", 2, 1, vec![0.1, 0.5, 0.8, 2.0, 0.3, 0.1]);
    let out = rtgi_in(dir.path(), &["compare", "r.exr", "t.exr", "--json", "--region", "1,0,1,1"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).expect("one JSON object");
    let mean = |key: &str| -> Vec<f64> {
        v["region"][key].as_array().expect(key).iter().map(|x| x.as_f64().expect("number")).collect()
    };
    assert_eq!(mean("reference_mean"), vec![2.0, 0.0, 0.10000000149011612], "{v}");
    assert!((mean("test_mean")[1] - 0.3).abs() < 1e-6, "{v}");
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "r.exr", "t.exr", "--region", "1,0,2,1"]));
    assert!(line.contains("region"), "{line}");
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "r.exr", "t.exr", "--region", "1,0"]));
    assert!(line.contains("X,Y,W,H"), "{line}");
}

#[test]
fn compare_rejects_mismatched_and_missing_images() {
    let dir = tempfile::tempdir().expect("temp dir");
    write_exr(dir.path(), "a.exr", 2, 1, vec![0.0; 6]);
    write_exr(dir.path(), "b.exr", 1, 2, vec![0.0; 6]);
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "a.exr", "b.exr"]));
    assert!(line.contains("2x1") && line.contains("1x2"), "{line}");
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "a.exr", "missing.exr"]));
    assert!(line.contains("missing.exr"), "{line}");
}

/// An adapter rtgi cannot run on is skipped with its reason, and with none left the error lists them and
/// names the driver to install. Mesa's GL adapter (llvmpipe) cannot render to R32Float; a machine
/// without any GL adapter gets "none found". (Where a GL driver can run rtgi, it renders.)
#[test]
fn gl_only_without_a_usable_adapter_names_each_adapter_and_the_driver() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = Command::new(env!("CARGO_BIN_EXE_rtgi"))
        .args(["render", "--size", "8x8", "--out", "gl.png"])
        .env("WGPU_BACKEND", "gl")
        .current_dir(dir.path())
        .output()
        .expect("the rtgi binary runs");
    if out.status.success() {
        eprintln!("a GL adapter here can run rtgi; nothing to check");
        return;
    }
    let line = expect_error(&out);
    assert!(line.contains("no usable GPU adapter (wgpu backends: GL;"), "{line}");
    assert!(line.contains("scripts/ensure-vulkan.sh") && line.contains("mesa-vulkan-drivers"), "{line}");
    if line.contains("llvmpipe") {
        assert!(line.contains("(Gl, Cpu): no RENDER_ATTACHMENT on R32Float textures"), "{line}");
    } else {
        assert!(line.contains("none found") || line.contains("(Gl,"), "{line}");
    }
}

/// Refused while the parameters are resolved, before the GPU adapter is even looked for.
#[test]
fn too_few_vpls_for_the_interleaving_pattern_is_an_error() {
    let err = expect_error(&rtgi(&[
        "render",
        "--technique",
        "igi",
        "--size",
        "8x8",
        "--set",
        "vpls=8",
        "--set",
        "interleave=4x4",
        "--out",
        "unused.png",
    ]));
    assert!(err.contains("vpls=8") && err.contains("16 interleaving sets"), "{err}");
}

#[test]
fn tonemap_writes_a_png_and_refuses_other_outputs() {
    let dir = tempfile::tempdir().expect("tempdir");
    write_exr(dir.path(), "in.exr", 2, 1, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
    let out = rtgi_in(dir.path(), &["tonemap", "in.exr", "out.png"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let png = rtgi::image::HdrImage::read(dir.path().join("out.png")).expect("png");
    assert_eq!(&png.rgb[..3], &[0.0, 0.0, 0.0]);
    // ACES fit of 1.0 is 0.80, sRGB-encoded and read back linear.
    assert!((png.rgb[3] - 0.80).abs() < 0.01, "{:?}", png.rgb);
    let err = expect_error(&rtgi_in(dir.path(), &["tonemap", "in.exr", "out.jpg"]));
    assert!(err.contains("out.jpg"), "{err}");
    let err = expect_error(&rtgi_in(dir.path(), &["tonemap", "missing.exr", "out.png"]));
    assert!(err.contains("missing.exr"), "{err}");
}

#[test]
fn montage_lays_out_labelled_images_and_refuses_bad_arguments() {
    let dir = tempfile::tempdir().expect("tempdir");
    write_exr(dir.path(), "a.exr", 2, 1, vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
    write_exr(dir.path(), "b.exr", 3, 2, vec![0.5; 18]);
    let out =
        rtgi_in(dir.path(), &["montage", "a.exr", "b.exr", "--label", "A", "--label", "B", "--out", "m.png"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let png = rtgi::image::HdrImage::read(dir.path().join("m.png")).expect("png");
    // Gaps of 8 around and between; a label strip of one 9-pixel line and a gap above the images.
    let gap = rtgi::montage::GAP;
    assert_eq!((png.width, png.height), (2 + 3 + 3 * gap, 9 + gap + 2 + 2 * gap));
    let err =
        expect_error(&rtgi_in(dir.path(), &["montage", "a.exr", "b.exr", "--label", "A", "--out", "m.png"]));
    assert!(err.contains("1 labels for 2 images"), "{err}");
    let err = expect_error(&rtgi_in(dir.path(), &["montage", "a.exr", "--out", "m.exr"]));
    assert!(err.contains("m.exr") && err.contains(".png"), "{err}");
    let err = expect_error(&rtgi_in(dir.path(), &["montage", "a.exr", "missing.exr", "--out", "m.png"]));
    assert!(err.contains("missing.exr"), "{err}");
}

#[test]
fn compare_refuses_images_with_nan_and_counts_them() {
    let dir = tempfile::tempdir().expect("temp dir");
    write_exr(dir.path(), "r.exr", 2, 1, vec![0.5; 6]);
    write_exr(dir.path(), "t.exr", 2, 1, vec![0.5, f32::NAN, 0.5, f32::INFINITY, 0.5, 0.5]);
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "r.exr", "t.exr", "--json"]));
    assert!(line.contains("t.exr") && line.contains("holds 2 non-finite pixel(s)"), "{line}");
    // Both images are counted, not only the first that fails.
    write_exr(dir.path(), "r.exr", 2, 1, vec![f32::NAN, 0.5, 0.5, 0.5, 0.5, 0.5]);
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "r.exr", "t.exr", "--json"]));
    assert!(line.contains("r.exr holds 1 non-finite") && line.contains("t.exr holds 2 non-finite"), "{line}");
}

/// A 16×16 frame: a ramp plus deterministic noise of `noise` amplitude (seeded per frame).
fn sequence_frame(noise: f32, seed: u32) -> Vec<f32> {
    (0..16 * 16 * 3u32)
        .map(|i| {
            let n =
                ((i ^ seed.wrapping_mul(0x9e37_79b9)).wrapping_mul(2_654_435_761) >> 8) as f32 / 16_777_216.0;
            0.2 + 0.5 * (i % 16) as f32 / 16.0 + noise * (n - 0.5)
        })
        .collect()
}

#[test]
fn compare_sequences_frame_by_frame_with_temporal_stability() {
    let dir = tempfile::tempdir().expect("temp dir");
    for i in 1..=3u32 {
        write_exr(dir.path(), &format!("ref_{i:04}.exr"), 16, 16, sequence_frame(0.0, 0));
        write_exr(dir.path(), &format!("test_{i:04}.exr"), 16, 16, sequence_frame(0.2, i));
    }
    let out = rtgi_in(dir.path(), &["compare", "ref_%04d.exr", "test_%04d.exr", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_str(stdout(&out).trim()).expect("one JSON object");
    let frames = v["frames"].as_array().expect("frames");
    assert_eq!(frames.iter().map(|f| f["index"].as_u64().unwrap_or(99)).collect::<Vec<_>>(), vec![1, 2, 3]);
    for key in ["flip", "rel_mse", "rmse"] {
        let mean = frames.iter().map(|f| f[key].as_f64().expect(key)).sum::<f64>() / 3.0;
        assert!((v["mean"][key].as_f64().expect(key) - mean).abs() < 1e-12, "{key}: {v}");
        assert!(mean > 0.0, "{key}: {v}");
    }
    assert_eq!(v["temporal"]["reference"]["flip"].as_f64(), Some(0.0), "{v}");
    assert!(v["temporal"]["test"]["flip"].as_f64().is_some_and(|f| f > 0.0), "{v}");

    let text = stdout(&rtgi_in(dir.path(), &["compare", "ref_%04d.exr", "test_%04d.exr"]));
    assert!(text.contains("frame      3") && text.contains("mean (3 frames)"), "{text}");
    assert!(text.contains("temporal reference") && text.contains("temporal test"), "{text}");

    let out = rtgi_in(dir.path(), &["compare", "--temporal", "test_%04d.exr", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let t: serde_json::Value = serde_json::from_str(stdout(&out).trim()).expect("one JSON object");
    assert_eq!(t["pairs"].as_u64(), Some(2), "{t}");
    assert_eq!(t["flip"], v["temporal"]["test"]["flip"], "{t} vs {v}");
}

#[test]
fn compare_sequences_name_missing_frames() {
    let dir = tempfile::tempdir().expect("temp dir");
    for i in [0u32, 1, 3] {
        write_exr(dir.path(), &format!("gap_{i:02}.exr"), 16, 16, sequence_frame(0.0, 0));
    }
    for i in 0..2u32 {
        write_exr(dir.path(), &format!("a_{i:02}.exr"), 16, 16, sequence_frame(0.0, 0));
    }
    for i in 0..3u32 {
        write_exr(dir.path(), &format!("b_{i:02}.exr"), 16, 16, sequence_frame(0.0, 0));
    }
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "--temporal", "gap_%02d.exr"]));
    assert!(line.contains("gap_02.exr: missing"), "{line}");
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "b_%02d.exr", "a_%02d.exr"]));
    assert!(line.contains("a_02.exr: missing"), "{line}");
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "b_%02d.exr", "none_%02d.exr"]));
    assert!(line.contains("no file matches") && line.contains("none_%02d.exr"), "{line}");
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "b_%02d.exr", "a_00.exr"]));
    assert!(line.contains("both are sequence patterns"), "{line}");
    let line = expect_error(&rtgi_in(dir.path(), &["compare", "--temporal", "a_00.exr"]));
    assert!(line.contains("--temporal needs a sequence pattern"), "{line}");
    let line =
        expect_error(&rtgi_in(dir.path(), &["compare", "a_%02d.exr", "b_%02d.exr", "--region", "0,0,1,1"]));
    assert!(line.contains("--region"), "{line}");
}
