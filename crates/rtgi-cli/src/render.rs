//! `rtgi render`.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, anyhow, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use rtgi::gpu::{GpuContext, GpuOptions};
use rtgi::image::{FileFormat, ToneMap};
use rtgi::params::{parse_setting, parse_size};
use rtgi::render::{RenderSettings, render};

use crate::scene_spec::SceneSpec;
use crate::{create_parent, print_warnings};

#[derive(Args)]
pub struct RenderArgs {
    /// Built-in scene (NAME or NAME:key=value,...) or a .gltf/.glb file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Technique (see `rtgi list`).
    #[arg(long, default_value = "direct")]
    technique: String,
    /// Image size, WxH.
    #[arg(long, default_value = "256x256", value_name = "WxH")]
    size: String,
    /// Output image: .png (tone-mapped, 8-bit sRGB) or .exr (linear radiance).
    #[arg(long, default_value = "out.png", value_name = "FILE")]
    out: PathBuf,
    /// Technique parameter; repeat for several.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Frames to run (progressive techniques accumulate, temporal ones converge).
    #[arg(long, default_value_t = 1)]
    frames: u32,
    /// Also write the render statistics as JSON.
    #[arg(long, value_name = "FILE.json")]
    stats: Option<PathBuf>,
    /// Exposure in stops applied before the PNG tone map (EXR output is never scaled).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_name = "EV")]
    exposure: f32,
    /// Light the scene with this equirectangular radiance map (.hdr or .exr) instead of its own environment.
    #[arg(long, value_name = "FILE")]
    environment: Option<PathBuf>,
    /// Scale of the --environment map's radiance.
    #[arg(long, default_value_t = 1.0, value_name = "SCALE")]
    environment_intensity: f32,
    /// Use the first GPU adapter whose name contains this (case-insensitive).
    #[arg(long, value_name = "NAME")]
    adapter: Option<String>,
}

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    // Everything the user typed is checked before the slow parts (scene loading, GPU start-up, frames).
    let (width, height) = parse_size(&args.size).map_err(|e| anyhow!("--size {e}"))?;
    if args.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if !args.exposure.is_finite() {
        bail!("--exposure '{}' is not a finite number of stops", args.exposure);
    }
    FileFormat::for_writing(&args.out).context("--out")?;
    let technique_settings = args
        .set
        .iter()
        .map(|s| parse_setting(s).map_err(|e| anyhow!("--set {e}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let scene_spec = SceneSpec::parse(&args.scene).map_err(|e| anyhow!("--scene {e}"))?;
    scene_spec.validate()?;
    rtgi::techniques::resolve(&args.technique, &technique_settings).map_err(anyhow::Error::msg)?;

    let mut scene = scene_spec.load()?;
    if let Some(path) = &args.environment {
        let map =
            rtgi::scene::EnvironmentMap::load(path, args.environment_intensity).context("--environment")?;
        scene.environment = rtgi::scene::Environment::Map(map);
    }
    print_warnings(&scene);
    let gpu = GpuContext::new(&GpuOptions { adapter_filter: args.adapter.clone() }).map_err(|e| {
        let e = anyhow::Error::new(e);
        match &args.adapter {
            Some(name) => e.context(format!("--adapter '{name}'")),
            None => e,
        }
    })?;

    let settings = RenderSettings {
        technique: args.technique.clone(),
        technique_settings,
        width,
        height,
        frames: args.frames,
    };
    let bar = progress_bar(args.frames);
    let mut progress = |done: u32, _total: u32| {
        if let Some(bar) = &bar {
            bar.set_position(u64::from(done));
        }
    };
    let result = render(&gpu, &scene, &settings, &mut progress);
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let output = result?;
    for warning in &output.stats.warnings {
        eprintln!("warning: {warning}");
    }

    create_parent(&args.out)?;
    output.image.write(&args.out, &ToneMap { exposure_ev: args.exposure })?;
    if let Some(path) = &args.stats {
        let json = serde_json::to_string_pretty(&output.stats).context("serialising the statistics")?;
        create_parent(path)?;
        std::fs::write(path, json + "\n").with_context(|| format!("{}: cannot write", path.display()))?;
    }
    let stats = &output.stats;
    println!(
        "wrote {} ({}x{}, {} frame{} of {}, {:.1} ms on {})",
        args.out.display(),
        width,
        height,
        stats.frames,
        if stats.frames == 1 { "" } else { "s" },
        stats.technique,
        stats.wall_ms,
        stats.adapter.name
    );
    Ok(())
}

/// A bar only where someone watches it: scripts and CI logs get no control characters.
pub fn progress_bar(frames: u32) -> Option<ProgressBar> {
    if frames <= 1 || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = ProgressBar::new(u64::from(frames));
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} frames  {elapsed} (eta {eta})") {
        bar.set_style(style);
    }
    Some(bar)
}
