//! `rtgi view` in a real window: under Xvfb on whatever adapter `render` picks (lavapipe in CI), a
//! script renders `cornell`, switches technique and a parameter, takes screenshots and copies the
//! `rtgi render` command of its view; that command must reproduce the viewer's image.
//!
//! Needs `xvfb-run` (Debian's `xvfb`, installed by `scripts/ensure-xvfb.sh`). Without it the window
//! tests are skipped locally and fail in CI (`CI` set), so CI cannot silently lose them.

use std::path::Path;
use std::process::{Command, Output};

use rtgi::image::HdrImage;

mod common;
use common::rtgi_in as rtgi;

/// `rtgi view ARGS` under a fresh virtual X server, or `None` where there is no Xvfb (outside CI).
fn view_under_xvfb(dir: &Path, args: &[&str]) -> Option<Output> {
    let available = Command::new("xvfb-run").arg("--help").output().is_ok();
    if !available {
        assert!(std::env::var_os("CI").is_none(), "CI must install xvfb (scripts/ensure-xvfb.sh)");
        eprintln!("skipped: no xvfb-run on this machine (install Debian's xvfb)");
        return None;
    }
    let output = Command::new("timeout")
        .args(["300", "xvfb-run", "-a", "-s", "-screen 0 1280x720x24", env!("CARGO_BIN_EXE_rtgi"), "view"])
        .args(args)
        .current_dir(dir)
        .env("RTGI_CACHE_DIR", dir.join("cache"))
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("xvfb-run runs");
    Some(output)
}

fn text(output: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr))
}

#[test]
fn scripted_view_matches_the_render_command_it_copies() {
    let dir = tempfile::tempdir().expect("temp dir");
    let script = "frames 2\n\
                  technique path\n\
                  set max_bounces=2\n\
                  frames 4\n\
                  screenshot view.exr\n\
                  window-screenshot window.png\n\
                  render-command command.txt\n\
                  quit\n";
    std::fs::write(dir.path().join("script.txt"), script).expect("write the script");
    let args =
        ["--scene", "cornell", "--technique", "direct", "--render-size", "96x96", "--script", "script.txt"];
    let Some(output) = view_under_xvfb(dir.path(), &args) else { return };
    assert!(output.status.success(), "rtgi view failed:\n{}", text(&output));

    // The copied command names the technique, the changed parameter and where the view's random
    // numbers started; run it (to an EXR) and compare.
    let command = std::fs::read_to_string(dir.path().join("command.txt")).expect("the render command");
    let words: Vec<&str> = command.split_whitespace().collect();
    assert_eq!(&words[..2], ["rtgi", "render"], "{command}");
    for expected in
        ["--technique path", "--set max_bounces=2", "--size 96x96", "--frames 4", "--out view.png"]
    {
        assert!(command.contains(expected), "'{expected}' missing from: {command}");
    }
    let mut render_args: Vec<&str> = words[1..words.len() - 1].to_vec();
    render_args.push("render.exr");
    let rendered = rtgi(dir.path(), &render_args);
    assert!(rendered.status.success(), "{command}:\n{}", text(&rendered));
    let viewed = HdrImage::read(dir.path().join("view.exr")).expect("the viewer's screenshot");
    let reference = HdrImage::read(dir.path().join("render.exr")).expect("the render");
    let flip = rtgi::metrics::flip(&reference, &viewed).expect("same size");
    // Measured 0 (bit-identical: same adapter, same frames, same random numbers); anything above
    // noise-free equality means the viewer rendered another view, technique or parameter.
    assert!(flip < 1e-4, "FLIP {flip} between the viewer's image and `{command}`");

    // The window screenshot holds the panel (light text on egui's dark background at the left) and
    // the picture (the Cornell box's red wall right of the panel).
    let window = image::open(dir.path().join("window.png")).expect("window screenshot").to_rgb8();
    assert!(window.width() >= 640 && window.height() >= 360, "{}x{}", window.width(), window.height());
    let panel_text = (0..250)
        .flat_map(|x| (0..window.height()).map(move |y| (x, y)))
        .filter(|&(x, y)| window.get_pixel(x, y).0.iter().all(|&c| c > 150))
        .count();
    // Measured 2607 bright text pixels in the left 250 columns at 1280x720 on lavapipe; half of it
    // allows for another font rasteriser or panel layout, none means no panel.
    assert!(panel_text > 1300, "only {panel_text} bright pixels where the panel's text should be");
    let red = (250..window.width())
        .flat_map(|x| (0..window.height()).map(move |y| (x, y)))
        .filter(|&(x, y)| {
            let [r, g, b] = window.get_pixel(x, y).0;
            r > 100 && u16::from(g) + u16::from(b) < u16::from(r) / 2
        })
        .count();
    // Measured 40967 red-wall pixels (the 96² image scaled to the 720-pixel-high area); half of it.
    assert!(red > 20000, "only {red} red pixels right of the panel: the picture is not shown");
}

/// Motion blur in the viewer (`shutter` in a script, the panel's shutter slider) is the post-process
/// `rtgi render --shutter` runs: the copied command carries the shutter and renders the same image, which
/// differs from the sharp one.
#[test]
fn scripted_motion_blur_matches_the_render_command_it_copies() {
    let dir = tempfile::tempdir().expect("temp dir");
    let script = "time 0.5\nshutter 0.25\nframes 2\nscreenshot view.exr\nrender-command command.txt\nquit\n";
    std::fs::write(dir.path().join("script.txt"), script).expect("write the script");
    let args = [
        "--scene",
        "cornell:animate=box",
        "--technique",
        "direct",
        "--render-size",
        "96x96",
        "--script",
        "script.txt",
    ];
    let Some(output) = view_under_xvfb(dir.path(), &args) else { return };
    assert!(output.status.success(), "rtgi view failed:\n{}", text(&output));
    let command = std::fs::read_to_string(dir.path().join("command.txt")).expect("the render command");
    assert!(command.contains("--shutter=0.25") && command.contains("--time=0.5"), "{command}");
    let words: Vec<&str> = command.split_whitespace().collect();
    let mut blurred_args: Vec<&str> = words[1..words.len() - 1].to_vec();
    blurred_args.push("render.exr");
    let rendered = rtgi(dir.path(), &blurred_args);
    assert!(rendered.status.success(), "{command}:\n{}", text(&rendered));
    let mut sharp_args: Vec<&str> =
        blurred_args.iter().copied().filter(|w| !w.starts_with("--shutter")).collect();
    *sharp_args.last_mut().expect("an output") = "sharp.exr";
    assert!(rtgi(dir.path(), &sharp_args).status.success());
    let read = |name: &str| HdrImage::read(dir.path().join(name)).expect(name);
    let (viewed, rendered, sharp) = (read("view.exr"), read("render.exr"), read("sharp.exr"));
    // Measured 0: the same frames, post-process and adapter.
    let flip = rtgi::metrics::flip(&rendered, &viewed).expect("same size");
    assert!(flip < 1e-4, "FLIP {flip} between the viewer's image and `{command}`");
    let blur = rtgi::metrics::flip(&sharp, &viewed).expect("same size");
    assert!(blur > 1e-3, "the viewer's image is the sharp one (FLIP {blur})");
}

#[test]
fn a_failing_script_step_names_the_problem_and_exits_non_zero() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("script.txt"), "frames 1\nset max_bounces=5000\nquit\n").expect("write");
    let args = ["--technique", "path", "--render-size", "32x32", "--script", "script.txt"];
    let Some(output) = view_under_xvfb(dir.path(), &args) else { return };
    assert!(!output.status.success(), "an invalid parameter passed:\n{}", text(&output));
    let message = text(&output);
    assert!(message.contains("max_bounces") && message.contains("5000"), "{message}");
}

#[test]
fn without_a_display_it_says_so() {
    let dir = tempfile::tempdir().expect("temp dir");
    let output = Command::new(env!("CARGO_BIN_EXE_rtgi"))
        .args(["view", "--scene", "cornell"])
        .current_dir(dir.path())
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("the rtgi binary runs");
    assert!(!output.status.success());
    let message = text(&output);
    assert!(message.contains("needs a display") && message.contains("xvfb-run"), "{message}");
    assert!(!message.contains("panicked"), "{message}");
}

#[test]
fn bad_arguments_fail_before_any_window() {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("bad.txt"), "frames 2\nfly away\n").expect("write");
    for (args, expected) in [
        (vec!["--technique", "nope"], "nope"),
        (vec!["--set", "max_bounces=abc", "--technique", "path"], "max_bounces"),
        (vec!["--render-size", "0x10"], "--render-size"),
        (vec!["--script", "missing.txt"], "missing.txt"),
        (vec!["--script", "bad.txt"], "bad.txt:2"),
    ] {
        let output = rtgi(dir.path(), &[&["view"][..], &args].concat());
        assert!(!output.status.success(), "{args:?} passed");
        let message = text(&output);
        assert!(message.contains(expected) && !message.contains("panicked"), "{args:?}: {message}");
    }
}
