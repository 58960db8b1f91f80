//! `rtgi bench`: a small suite run whole and as two shards merged, its results.json, and its HTML
//! report's SVG plots rendered (resvg) to check they draw what they claim.

use std::path::Path;
use std::process::Output;

use serde_json::Value;

const SUITE: &str = r#"
name = "cli-test"
description = "two techniques on the Cornell box"
sizes = ["32x32"]
frames = 2
[reference]
spp = 32
[[scenes]]
scene = "cornell"
[[scenes]]
scene = "cornell:animate=box"
times = [0.5, 1.5]
sizes = ["16x16"]
set = { max_bounces = 1 }
[[techniques]]
technique = "path"
sweep = { spp = [1, 2] }
[[techniques]]
technique = "igi"
sweep = { vpls = [16, 64] }
scenes = ["cornell"]
"#;

mod common;
use common::rtgi_in as rtgi;

fn ok(out: &Output) {
    assert!(out.status.success(), "stderr: {}", String::from_utf8_lossy(&out.stderr));
}

fn results(dir: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("results.json")).expect("results.json"))
        .expect("valid JSON")
}

/// The (index, series, sweep, FLIP, relMSE) of every cell: what a fixed seed makes reproducible.
fn figures(results: &Value) -> Vec<(u64, String, String, f64, f64)> {
    results["cells"]
        .as_array()
        .expect("cells")
        .iter()
        .map(|c| {
            (
                c["index"].as_u64().expect("index"),
                c["series"].as_str().expect("series").to_string(),
                c["sweep"].to_string(),
                c["error"]["flip"].as_f64().expect("flip"),
                c["error"]["rel_mse"].as_f64().expect("rel_mse"),
            )
        })
        .collect()
}

/// Every `<svg>...</svg>` of the page, rendered.
fn rendered_svgs(html: &str) -> Vec<(String, resvg::tiny_skia::Pixmap)> {
    let mut out = Vec::new();
    let mut rest = html;
    while let Some(start) = rest.find("<svg") {
        let end = rest[start..].find("</svg>").expect("closed svg") + start + "</svg>".len();
        let svg = &rest[start..end];
        let tree = resvg::usvg::Tree::from_str(svg, &resvg::usvg::Options::default()).expect("SVG parses");
        let size = tree.size().to_int_size();
        let mut pixmap = resvg::tiny_skia::Pixmap::new(size.width(), size.height()).expect("pixmap");
        resvg::render(&tree, resvg::tiny_skia::Transform::default(), &mut pixmap.as_mut());
        out.push((svg.to_string(), pixmap));
        rest = &rest[end..];
    }
    out
}

fn pixels_of(pixmap: &resvg::tiny_skia::Pixmap, rgb: [u8; 3]) -> usize {
    pixmap.pixels().iter().filter(|p| [p.red(), p.green(), p.blue()] == rgb && p.alpha() == 255).count()
}

#[test]
fn a_suite_runs_whole_and_in_merged_shards_with_the_same_figures() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    std::fs::write(d.join("suite.toml"), SUITE).expect("suite");
    ok(&rtgi(d, &["bench", "suite.toml", "--out", "whole", "--images"]));
    let whole = results(&d.join("whole"));
    assert_eq!(whole["schema"], "rtgi-bench/1");
    assert_eq!(whole["suite"]["cells"], 6);
    let all = whole["cells"].as_array().expect("cells");
    assert_eq!(all.len(), 6);
    // The animated scene (at its own size, 16²): each measured frame at its time, against the reference
    // of that pose.
    for c in &all[4..] {
        assert_eq!(c["scene"], "cornell:animate=box");
        assert_eq!((c["width"].as_u64(), c["height"].as_u64()), (Some(16), Some(16)), "{c}");
        let times: Vec<f64> = c["frames"]
            .as_array()
            .expect("frames")
            .iter()
            .map(|f| f["time"].as_f64().expect("time"))
            .collect();
        assert_eq!(times, vec![0.5, 1.5], "{c}");
    }
    let references: Vec<(String, f64)> = whole["references"]
        .as_array()
        .expect("references")
        .iter()
        .map(|r| (r["scene"].as_str().expect("scene").to_string(), r["time"].as_f64().expect("time")))
        .collect();
    assert_eq!(
        references,
        vec![
            ("cornell".into(), 0.0),
            ("cornell:animate=box".into(), 0.5),
            ("cornell:animate=box".into(), 1.5)
        ]
    );
    // Each reference at its scene's size, with its scene's `path` settings (the suite's: none).
    let shapes: Vec<(u64, String)> = whole["references"]
        .as_array()
        .expect("references")
        .iter()
        .map(|r| (r["width"].as_u64().expect("width"), r["settings"].to_string()))
        .collect();
    let one_bounce = r#"{"max_bounces":"1"}"#.to_string();
    assert_eq!(shapes, vec![(32, "{}".into()), (16, one_bounce.clone()), (16, one_bounce)]);
    let cells = &all[..4];
    // --images: each cell's first compared frame and each reference, readable and of their size.
    let files = all.iter().chain(whole["references"].as_array().expect("references"));
    for c in files {
        let name = c["image_file"].as_str().expect("image_file");
        let image = rtgi::image::HdrImage::read(d.join("whole/images").join(name)).expect("image");
        let size = (c["width"].as_u64().expect("width"), c["height"].as_u64().expect("height"));
        assert_eq!((u64::from(image.width), u64::from(image.height)), size, "{name}");
    }
    // A reference kept is the cached one, bit for bit.
    let r = &whole["references"][0];
    let kept =
        std::fs::read(d.join("whole/images").join(r["image_file"].as_str().expect("name"))).expect("kept");
    let cached =
        std::fs::read(d.join("cache").join(r["image_file"].as_str().expect("name"))).expect("cached");
    assert!(kept == cached, "the kept reference differs from the cache's");
    for c in cells {
        assert!(c["failure"].is_null(), "{c}");
        assert!(c["frame_ms"].as_f64().expect("frame_ms") > 0.0, "{c}");
        assert_eq!(c["frames"].as_array().expect("frames").len(), 2, "both frames compared");
        let flip = c["error"]["flip"].as_f64().expect("flip");
        assert!(flip > 0.0 && flip < 1.0, "{c}");
        assert!(!c["passes"].as_array().expect("passes").is_empty() || c["time_source"] == "wall");
    }
    // More samples per frame, less error: the figures measure what they say.
    let path_flip = |k: usize| cells[k]["error"]["flip"].as_f64().expect("flip");
    assert!(path_flip(1) < path_flip(0), "path 2 spp {} vs 1 spp {}", path_flip(1), path_flip(0));

    for shard in ["0/2", "1/2"] {
        let out = format!("shard{}", &shard[..1]);
        ok(&rtgi(d, &["bench", "suite.toml", "--out", &out, "--shard", shard]));
        assert_eq!(results(&d.join(&out))["cells"].as_array().expect("cells").len(), 3);
    }
    ok(&rtgi(d, &["bench", "merge", "shard0", "shard1/results.json", "--out", "merged"]));
    let merged = results(&d.join("merged"));
    // Same seeds, same images: the merged shards' errors equal the whole run's exactly.
    assert_eq!(figures(&merged), figures(&whole));
    assert_eq!(merged["shards"], serde_json::json!(["0/2", "1/2"]));
    // A shard merged twice is refused.
    let out = rtgi(d, &["bench", "merge", "shard0", "shard0", "--out", "twice"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("two of the merged"));

    let html = std::fs::read_to_string(d.join("merged/report.html")).expect("report.html");
    assert!(!html.contains("<script") && !html.contains("src=\"http"), "the report fetches nothing");
    let svgs = rendered_svgs(&html);
    let pareto: Vec<_> = svgs.iter().filter(|(s, _)| s.contains("class=\"pareto\"")).collect();
    let passes: Vec<_> = svgs.iter().filter(|(s, _)| s.contains("class=\"passes\"")).collect();
    assert_eq!((pareto.len(), passes.len()), (2, 2), "one plot of each kind per scene");
    let (svg, pixmap) = pareto[0];
    assert_eq!(svg.matches("class=\"cell\"").count(), 4, "a point per cell");
    // The two series' colours (path first, igi second) are drawn: their curves and points render.
    let (blue, orange) = (pixels_of(pixmap, [0x4e, 0x79, 0xa7]), pixels_of(pixmap, [0xf2, 0x8e, 0x2b]));
    assert!(blue > 50 && orange > 50, "series pixels: path {blue}, igi {orange}");
    let (_, bars) = passes[0];
    // Measured: every cell's bar has at least one pass segment of the palette's first colour or another.
    let coloured = bars.pixels().iter().filter(|p| p.alpha() == 255 && p.red() != p.green()).count();
    assert!(coloured > 500, "pass bars drew {coloured} coloured pixels");
    assert!(std::fs::read_to_string(d.join("merged/report.md")).expect("report.md").contains("On the front"));
}

#[test]
fn a_bad_suite_is_one_error_naming_the_file_before_any_gpu_work() {
    let dir = tempfile::tempdir().expect("temp dir");
    let d = dir.path();
    std::fs::write(d.join("bad.toml"), SUITE.replace("vpls = [16, 64]", "vpls = [0]")).expect("suite");
    let out = rtgi(d, &["bench", "bad.toml", "--out", "o"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.starts_with("error: ") && stderr.contains("bad.toml") && stderr.contains("vpls"),
        "{stderr}"
    );
    assert!(!d.join("o").exists(), "nothing written for a bad suite");
    let out = rtgi(d, &["bench", "bad.toml", "--out", "o", "--shard", "2/2"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--shard"), "the shard is checked too");
}
