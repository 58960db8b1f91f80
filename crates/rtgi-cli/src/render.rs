//! `rtgi render`.

use std::io::IsTerminal;
use std::path::PathBuf;

use anyhow::{Context, anyhow, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use rtgi::gpu::TimingMode;
use rtgi::image::{FileFormat, ToneMap};
use rtgi::metrics::sequence::FramePattern;
use rtgi::params::{parse_setting, parse_size};
use rtgi::renderer::{Aov, Renderer, RendererSettings};

use crate::{create_parent, print_warnings};
use rtgi::scene::SceneSpec;

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
    /// Output image: .png (tone-mapped, 8-bit sRGB) or .exr (linear radiance). A printf-style frame
    /// number (`%04d`, `%d`) makes it an image sequence: one image per frame, e.g. 'frame_%04d.exr'.
    #[arg(long, default_value = "out.png", value_name = "FILE")]
    out: PathBuf,
    /// Technique parameter; repeat for several.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Frames to run. A still (no frame number in --out) accumulates them at --time (progressive
    /// techniques average, temporal ones converge); a sequence writes one image per frame, frame k at
    /// time --time + k / --fps.
    #[arg(long, default_value_t = 1)]
    frames: u32,
    /// Scene time in seconds of the still, or of the first frame of a sequence.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_name = "SECONDS")]
    time: f32,
    /// Frames per second of a sequence (the time step between its frames).
    #[arg(long, default_value_t = 30.0, value_name = "F")]
    fps: f32,
    /// Frames rendered before the first output frame and not written (temporal techniques converge
    /// their history), at --warmup-time.
    #[arg(long, default_value_t = 0, value_name = "N")]
    warmup: u32,
    /// Scene time of the --warmup frames [default: --time]. With --hold, a sequence then shows the step
    /// response to the change from this pose to --time's (e.g. how DDGI's probes lag a moved light).
    #[arg(long, allow_negative_numbers = true, value_name = "SECONDS")]
    warmup_time: Option<f32>,
    /// Every frame of a sequence at --time (a held pose) instead of advancing by 1 / --fps.
    #[arg(long)]
    hold: bool,
    /// Renderer steps per frame of a sequence, all at the frame's time (progressive techniques average
    /// them: `--accumulate 16` gives every frame 16 frames' samples).
    #[arg(long, default_value_t = 1, value_name = "K")]
    accumulate: u32,
    /// Play this animation of the scene (name or index; default: the first).
    #[arg(long, value_name = "NAME")]
    animation: Option<String>,
    /// Also write a G-buffer channel (depth, normal, albedo, emission) of the last frame as EXR;
    /// repeatable. With a frame number in FILE, one per frame of a sequence.
    #[arg(long = "aov", value_name = "NAME=FILE.exr")]
    aov: Vec<String>,
    /// How passes are submitted and timed: `frame` (one command encoder per frame, per-pass GPU
    /// timestamps) or `passes` (one submission per pass, waited for: per-pass wall times, slower).
    #[arg(long, default_value = "frame", value_name = "MODE")]
    timing: String,
    /// Where frames sample within their pixels: `none` (pixel centres, images compare pixel for
    /// pixel), `halton` (a new sub-pixel position every frame, 16-frame Halton (2,3) cycle: accumulated
    /// frames are anti-aliased) or a fixed offset `X,Y` in pixels, each in [-0.5, 0.5).
    #[arg(long, default_value = "none", value_name = "MODE")]
    jitter: String,
    /// Motion blur: the shutter in scene seconds, centred on each frame's time (0: none). Every frame
    /// is blurred by the non-linear motion blur post-process (see `rtgi list`), or, with
    /// --shutter-reference, replaced by the brute-force reference.
    #[arg(long, default_value_t = 0.0, value_name = "SECONDS")]
    shutter: f32,
    /// Motion blur parameter (see `rtgi list`); repeat for several.
    #[arg(long = "motion-blur-set", value_name = "KEY=VALUE")]
    motion_blur_set: Vec<String>,
    /// Render the still as the brute-force reference of motion blur instead: the mean of N frames at
    /// times stratified over --shutter, each a fresh frame (with `path`, one sample per pixel each).
    #[arg(long, value_name = "N")]
    shutter_reference: Option<u32>,
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
    /// View from here instead of the scene's camera: position, target and vertical field of view in
    /// degrees (`rtgi view` copies this for its current view).
    #[arg(long, value_name = "X,Y,Z,TX,TY,TZ,FOV", allow_hyphen_values = true)]
    camera: Option<String>,
    /// Random numbers of the first frame (warm-up included) are those of frame N: `rtgi view` copies
    /// the frame its view's accumulation started at, so a progressive image is reproduced exactly.
    #[arg(long, default_value_t = 0, value_name = "N")]
    first_frame: u32,
    #[command(flatten)]
    gpu: crate::GpuArgs,
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
    let sequence = FramePattern::parse(&args.out).context("--out")?;
    if !args.time.is_finite() {
        bail!("--time '{}' is not a finite number of seconds", args.time);
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        bail!("--fps '{}' must be a positive number of frames per second", args.fps);
    }
    if let Some(t) = args.warmup_time
        && !t.is_finite()
    {
        bail!("--warmup-time '{t}' is not a finite number of seconds");
    }
    if args.accumulate == 0 {
        bail!("--accumulate must be at least 1");
    }
    let timing: TimingMode = args.timing.parse().map_err(|e| anyhow!("--timing {e}"))?;
    let motion_blur = motion_blur_settings(args, sequence.is_some())?;
    let jitter: rtgi::renderer::Jitter = args.jitter.parse().map_err(|e| anyhow!("--jitter: {e}"))?;
    let aovs = args
        .aov
        .iter()
        .map(|a| {
            let (name, file) =
                a.split_once('=').ok_or_else(|| anyhow!("--aov '{a}': expected NAME=FILE.exr"))?;
            let aov: Aov = name.parse().map_err(|e| anyhow!("--aov {e}"))?;
            let file = PathBuf::from(file);
            if FileFormat::for_writing(&file).ok() != Some(FileFormat::Exr) {
                bail!("--aov {name}: '{}' must be an .exr file (AOVs are linear data)", file.display());
            }
            Ok((aov, file))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let technique_settings = args
        .set
        .iter()
        .map(|s| parse_setting(s).map_err(|e| anyhow!("--set {e}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let scene_spec = SceneSpec::parse(&args.scene).map_err(|e| anyhow!("--scene {e}"))?;
    scene_spec.validate()?;
    rtgi::techniques::resolve(&args.technique, &technique_settings).map_err(anyhow::Error::msg)?;

    let mut scene = scene_spec.load()?;
    if let Some(name) = &args.animation {
        scene.select_animation(name).context("--animation")?;
    }
    if let Some(path) = &args.environment {
        let map =
            rtgi::scene::EnvironmentMap::load(path, args.environment_intensity).context("--environment")?;
        scene.environment = rtgi::scene::Environment::Map(map);
    }
    print_warnings(&scene);
    let camera = args
        .camera
        .as_deref()
        .map(|c| rtgi::scene::Camera::parse_placement(c, &scene.camera))
        .transpose()
        .map_err(|e| anyhow!("--camera {e}"))?;
    let gpu = args.gpu.context()?;

    let mut renderer = Renderer::new(
        &gpu,
        scene,
        &RendererSettings { technique: args.technique.clone(), technique_settings, width, height, timing },
    )?;
    let steps = if sequence.is_some() { args.frames * args.accumulate } else { args.frames };
    let bar = progress_bar(steps);
    let result = (|| -> anyhow::Result<Option<rtgi::image::HdrImage>> {
        renderer.set_jitter(jitter)?;
        renderer.set_frame_counter(args.first_frame);
        if let Some(camera) = camera {
            renderer.set_camera(camera);
        }
        // Warm-up frames and stills hold their pose; a sequence advances by 1 / fps (techniques that
        // predict the next frame read the step).
        renderer.set_time_step(0.0)?;
        if args.warmup > 0 {
            renderer.set_time(args.warmup_time.unwrap_or(args.time))?;
            for _ in 0..args.warmup {
                renderer.step()?;
            }
        }
        renderer.set_time(args.time)?;
        if let Some(samples) = args.shutter_reference {
            return Ok(Some(renderer.render_shutter_reference(args.shutter, samples)?));
        }
        renderer.set_motion_blur(motion_blur.clone())?;
        let frame_step = if sequence.is_some() && !args.hold { 1.0 / args.fps } else { 0.0 };
        for frame in 0..args.frames {
            if let Some(pattern) = &sequence {
                let advance = if args.hold { 0.0 } else { frame as f32 / args.fps };
                renderer.set_time(args.time + advance)?;
                // The steps accumulated into one output frame hold its pose; the last one looks
                // ahead to the next output frame.
                for k in 0..args.accumulate {
                    renderer.set_time_step(if k + 1 == args.accumulate { frame_step } else { 0.0 })?;
                    renderer.step()?;
                }
                let path = pattern.path(frame);
                create_parent(&path)?;
                renderer.read_image()?.write(&path, &ToneMap { exposure_ev: args.exposure })?;
                write_aovs(&mut renderer, &aovs, Some(frame))?;
            } else {
                renderer.step()?;
            }
            if let Some(bar) = &bar {
                bar.set_position(u64::from((frame + 1) * steps / args.frames));
            }
        }
        Ok(None)
    })();
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let reference = result?;
    if sequence.is_none() {
        create_parent(&args.out)?;
        let image = match reference {
            Some(image) => image,
            None => renderer.read_image()?,
        };
        image.write(&args.out, &ToneMap { exposure_ev: args.exposure })?;
        write_aovs(&mut renderer, &aovs, None)?;
    }
    let stats = renderer.stats()?;
    for warning in &stats.warnings {
        eprintln!("warning: {warning}");
    }
    if let Some(path) = &args.stats {
        let json = serde_json::to_string_pretty(&stats).context("serialising the statistics")?;
        create_parent(path)?;
        std::fs::write(path, json + "\n").with_context(|| format!("{}: cannot write", path.display()))?;
    }
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

/// The motion blur asked for by --shutter and --motion-blur-set (`None`: off, or the reference).
fn motion_blur_settings(
    args: &RenderArgs,
    sequence: bool,
) -> anyhow::Result<Option<rtgi::post::motion_blur::MotionBlurSettings>> {
    if !(args.shutter.is_finite() && args.shutter >= 0.0) {
        bail!("--shutter '{}' must be a finite, non-negative number of seconds", args.shutter);
    }
    let settings = args
        .motion_blur_set
        .iter()
        .map(|s| parse_setting(s).map_err(|e| anyhow!("--motion-blur-set {e}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    if let Some(samples) = args.shutter_reference {
        if samples == 0 {
            bail!("--shutter-reference must be at least 1 frame");
        }
        if args.shutter == 0.0 {
            bail!("--shutter-reference needs a --shutter above 0 seconds");
        }
        if sequence || args.frames > 1 {
            bail!("--shutter-reference renders one still: it does not combine with --frames or a sequence");
        }
        if !settings.is_empty() {
            bail!("--motion-blur-set sets the post-process, which --shutter-reference replaces");
        }
        return Ok(None);
    }
    if args.shutter == 0.0 {
        if !settings.is_empty() {
            bail!("--motion-blur-set needs a --shutter above 0 seconds");
        }
        return Ok(None);
    }
    let settings = rtgi::post::motion_blur::MotionBlurSettings::new(args.shutter, &settings)
        .map_err(|e| anyhow!("--motion-blur-set {e}"))?;
    Ok(Some(settings))
}

/// Writes each requested AOV; `frame` numbers the files of a sequence.
fn write_aovs(renderer: &mut Renderer, aovs: &[(Aov, PathBuf)], frame: Option<u32>) -> anyhow::Result<()> {
    for (aov, path) in aovs {
        let path = match (FramePattern::parse(path).context("--aov")?, frame) {
            (Some(pattern), Some(k)) => pattern.path(k),
            _ => path.clone(),
        };
        create_parent(&path)?;
        renderer.read_aov(*aov)?.write(&path, &ToneMap::default())?;
    }
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
