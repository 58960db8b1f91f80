//! `rtgi`: the command-line front end of the rtgi library.
//!
//! Every failure reaches the user as one line `error: <message>` on stderr. Exit codes: 0 success; 1 an
//! error rtgi reports (bad values, files, GPU, rendering); 2 a command line clap cannot parse (unknown
//! flag, missing or mistyped argument); 101 an internal error (a bug: a panic, still printed as one line).

mod bench;
mod list;
mod render;
mod view;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Parser, Subcommand};

use rtgi::scene::SceneSpec;

const EXIT_CODES: &str = "Exit codes: 0 success, 1 error (one line 'error: ...' on stderr), \
                          2 command-line syntax error, 101 internal error (a bug).";

#[derive(Parser)]
#[command(name = "rtgi", version, about = "rtgi: a real-time global illumination laboratory", after_help = EXIT_CODES)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene with one technique and write the image (.png tone-mapped, .exr linear).
    // A repeated option overrides the earlier one, so wrappers (scripts/demo.sh) can pass defaults first
    // and the user's arguments after them.
    #[command(args_override_self = true)]
    Render(Box<render::RenderArgs>),
    /// Open a window to fly through a scene and switch techniques and parameters live (needs a
    /// display; under Xvfb on headless machines). Keys: WASD move, Q/E down/up, Shift faster, drag in
    /// the image to turn, wheel changes the speed.
    View(Box<view::ViewArgs>),
    /// List the built-in scenes and the techniques with their parameters.
    List,
    /// Run a bench suite (scenes × techniques × parameter sweeps × sizes): GPU time per frame and per
    /// pass, memory and error against the path-traced reference of every cell, written as results.json,
    /// report.html (Pareto plots of FLIP against time) and report.md. `rtgi bench merge` joins shards.
    Bench(Box<bench::BenchArgs>),
    /// Render (or reuse from the cache) a path-traced reference EXR.
    Reference {
        /// Built-in scene (NAME or NAME:key=value,...) or a .gltf/.glb file.
        #[arg(long, default_value = "cornell")]
        scene: String,
        /// Image size, WxH.
        #[arg(long, default_value = "256x256", value_name = "WxH")]
        size: String,
        /// Samples per pixel.
        #[arg(long, default_value_t = 1024)]
        spp: u32,
        /// Path tracer parameter (e.g. max_bounces=1); repeat for several.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// Also write the reference here (.exr or .png).
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Compare a test image with a reference: RMSE, relative MSE and mean FLIP. With two sequence
    /// patterns ('ref_%04d.exr' 'test_%04d.exr') frame by frame, plus each side's temporal stability.
    Compare {
        /// Reference image (.exr, .hdr or .png) or sequence pattern with %0Nd; with --temporal, the one
        /// sequence to measure.
        reference: PathBuf,
        /// Test image of the same size, or a sequence pattern when REFERENCE is one.
        test: Option<PathBuf>,
        /// Measure one sequence's temporal stability: mean FLIP and relative MSE between consecutive
        /// frames.
        #[arg(long)]
        temporal: bool,
        /// Print one JSON object instead of text: {"rmse", "rel_mse", "flip"} for images,
        /// {"frames", "mean", "temporal"} for sequences, {"pairs", "flip", "rel_mse"} for --temporal.
        #[arg(long)]
        json: bool,
        /// Also write the FLIP error map as a PNG (magma colours).
        #[arg(long, value_name = "FILE.png")]
        error_map: Option<PathBuf>,
        /// Also report the mean radiance of both images in this pixel rectangle (e.g. a dark room).
        #[arg(long, value_name = "X,Y,W,H")]
        region: Option<String>,
    },
    /// Tone-map an HDR image (.exr or .hdr) to PNG, as `render` does for .png outputs.
    Tonemap {
        /// Linear HDR image.
        input: PathBuf,
        /// Output .png.
        output: PathBuf,
        /// Exposure in stops applied before the tone curve.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        exposure: f32,
    },
    /// Lay HDR images (.exr, .hdr, .png) side by side in one labelled PNG, each tone-mapped as `render`
    /// does for .png outputs: e.g. a technique next to the path-traced reference.
    Montage {
        /// The images, left to right.
        #[arg(required = true)]
        images: Vec<PathBuf>,
        /// A label above each image, in order: none, or one per image.
        #[arg(long = "label", value_name = "TEXT")]
        labels: Vec<String>,
        /// Output .png.
        #[arg(long, value_name = "FILE.png")]
        out: PathBuf,
        /// Exposure in stops applied before the tone curve.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        exposure: f32,
    },
    /// Write a built-in scene as binary glTF (.glb).
    ExportScene {
        /// Built-in scene, optionally with parameters: NAME or NAME:key=value,...
        name: String,
        /// Output file; must end in .glb.
        out: PathBuf,
    },
}

/// How to pick and set up the GPU (`render`, `view` and `bench` take these).
#[derive(clap::Args, Clone, Debug)]
pub struct GpuArgs {
    /// Use the first GPU adapter whose name contains this (case-insensitive).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
    /// Where the BVH keeps its node and triangle tables: auto (textures on CPU adapters, storage
    /// buffers on GPUs), textures or buffers. Images are identical; only the speed differs. Default:
    /// $RTGI_BVH_TABLES, else auto.
    #[arg(long, value_name = "KIND")]
    pub bvh_tables: Option<rtgi::gpu::BvhTables>,
}

impl GpuArgs {
    pub fn options(&self) -> rtgi::gpu::GpuOptions {
        let defaults = rtgi::gpu::GpuOptions::default();
        rtgi::gpu::GpuOptions {
            adapter_filter: self.adapter.clone(),
            bvh_tables: self.bvh_tables.unwrap_or(defaults.bvh_tables),
        }
    }

    /// Opens the device, naming --adapter in the error when it was given.
    pub fn context(&self) -> anyhow::Result<rtgi::gpu::GpuContext> {
        rtgi::gpu::GpuContext::new(&self.options()).map_err(|e| {
            let e = anyhow::Error::new(e);
            match &self.adapter {
                Some(name) => e.context(format!("--adapter '{name}'")),
                None => e,
            }
        })
    }
}

fn reference(scene: &str, size: &str, spp: u32, set: &[String], out: Option<&Path>) -> anyhow::Result<()> {
    let (width, height) = rtgi::params::parse_size(size).map_err(|e| anyhow::anyhow!("--size {e}"))?;
    if spp == 0 {
        bail!("--spp must be at least 1");
    }
    if let Some(path) = out {
        rtgi::image::FileFormat::for_writing(path).context("--out")?;
    }
    let settings = set
        .iter()
        .map(|s| rtgi::params::parse_setting(s).map_err(|e| anyhow::anyhow!("--set {e}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let request = rtgi::reference::ReferenceRequest { width, height, spp, settings };
    let spec = SceneSpec::parse(scene).map_err(|e| anyhow::anyhow!("--scene {e}"))?;
    spec.validate()?;
    let scene = spec.load()?;
    rtgi::reference::cache_key(&scene, &request)?;
    print_warnings(&scene);
    let gpu = rtgi::gpu::GpuContext::new(&rtgi::gpu::GpuOptions::default())?;
    let bar = render::progress_bar(spp / rtgi::reference::samples_per_frame(spp));
    let mut progress = |done: u32, _total: u32| {
        if let Some(bar) = &bar {
            bar.set_position(u64::from(done));
        }
    };
    let start = std::time::Instant::now();
    let result = rtgi::reference::reference(&gpu, &scene, &request, &mut progress);
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let r = result?;
    if let Some(path) = out {
        create_parent(path)?;
        rtgi::reference::export(&r, path)?;
    }
    println!(
        "{} {} ({} spp, {:.1} s)",
        if r.cached { "cached" } else { "rendered" },
        r.path.display(),
        spp,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn parse_region(text: &str) -> anyhow::Result<[u32; 4]> {
    let v: Vec<u32> = text
        .split(',')
        .map(|p| p.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--region '{text}': expected four whole numbers X,Y,W,H"))?;
    match v.as_slice() {
        [x, y, w, h] => Ok([*x, *y, *w, *h]),
        _ => bail!("--region '{text}': expected four numbers X,Y,W,H, got {}", v.len()),
    }
}

/// The `compare` options that apply to single images only.
#[derive(Clone, Copy)]
struct ImageOptions<'a> {
    error_map: Option<&'a Path>,
    region: Option<&'a str>,
}

/// Dispatches `compare` on its arguments: two images, two sequences, or one sequence with --temporal.
fn compare_command(
    reference: &Path,
    test: Option<&Path>,
    temporal: bool,
    json: bool,
    images: &ImageOptions,
) -> anyhow::Result<()> {
    use rtgi::metrics::sequence::{FramePattern, Sequence};
    let sequence_only = |what: &str| {
        for (given, flag) in
            [(images.error_map.is_some(), "--error-map"), (images.region.is_some(), "--region")]
        {
            if given {
                bail!("{flag} applies to single images, not to {what}");
            }
        }
        Ok(())
    };
    let r_pattern = FramePattern::parse(reference)?;
    match (test, temporal) {
        (Some(_), true) => bail!(
            "--temporal measures one sequence (rtgi compare --temporal 'a_%04d.exr'); comparing two \
             sequences reports the temporal stability of both"
        ),
        (None, true) => {
            sequence_only("--temporal")?;
            let pattern = r_pattern.with_context(|| {
                format!("--temporal needs a sequence pattern with %0Nd, got '{}'", reference.display())
            })?;
            let s = rtgi::metrics::sequence::sequence_temporal_stability(&Sequence::discover(pattern)?)?;
            if json {
                println!("{}", serde_json::to_value(s)?);
            } else {
                println!(
                    "temporal ({} consecutive pairs)  rel_mse {:.6}  flip {:.6}",
                    s.pairs, s.rel_mse, s.flip
                );
            }
            Ok(())
        }
        (None, false) => bail!("compare needs a TEST image after the reference (or --temporal PATTERN)"),
        (Some(test), false) => match (r_pattern, FramePattern::parse(test)?) {
            (None, None) => compare(reference, test, json, images),
            (Some(r), Some(t)) => {
                sequence_only("sequences")?;
                compare_sequences(&Sequence::discover(r)?, &Sequence::discover(t)?, json)
            }
            _ => bail!(
                "'{}' and '{}': either both are sequence patterns (%0Nd) or neither is",
                reference.display(),
                test.display()
            ),
        },
    }
}

fn compare_sequences(
    reference: &rtgi::metrics::sequence::Sequence,
    test: &rtgi::metrics::sequence::Sequence,
    json: bool,
) -> anyhow::Result<()> {
    let c = rtgi::metrics::sequence::compare_sequences(reference, test)?;
    if json {
        println!("{}", serde_json::to_value(&c)?);
        return Ok(());
    }
    for f in &c.frames {
        println!("frame {:>6}  rmse {:.6}  rel_mse {:.6}  flip {:.6}", f.index, f.rmse, f.rel_mse, f.flip);
    }
    let m = c.mean;
    println!(
        "mean ({} frames)  rmse {:.6}  rel_mse {:.6}  flip {:.6}",
        c.frames.len(),
        m.rmse,
        m.rel_mse,
        m.flip
    );
    for (side, t) in [("reference", c.temporal.reference), ("test", c.temporal.test)] {
        match t {
            Some(t) => println!("temporal {side:<9}  rel_mse {:.6}  flip {:.6}", t.rel_mse, t.flip),
            None => println!("temporal {side:<9}  (one frame)"),
        }
    }
    Ok(())
}

fn compare(reference: &Path, test: &Path, json: bool, images: &ImageOptions) -> anyhow::Result<()> {
    let ImageOptions { error_map, region } = *images;
    let region = region.map(parse_region).transpose()?;
    if let Some(path) = error_map {
        rtgi::image::FileFormat::for_writing(path).context("--error-map")?;
        if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
            bail!("--error-map {}: must be a .png file", path.display());
        }
    }
    let r = rtgi::image::HdrImage::read(reference)?;
    let t = rtgi::image::HdrImage::read(test)?;
    let names = (reference.display().to_string(), test.display().to_string());
    rtgi::metrics::check_all_finite(&[(&r, &names.0), (&t, &names.1)])?;
    let m = rtgi::metrics::compare(&r, &t)
        .with_context(|| format!("comparing {} with {}", test.display(), reference.display()))?;
    if let Some(path) = error_map {
        let (map, _) = rtgi::metrics::flip_map(&r, &t)?;
        let rgb = rtgi::metrics::error_map_rgb8(&map, r.width, r.height);
        create_parent(path)?;
        rtgi::image::write_rgb8_png(path, r.width, r.height, &rgb)?;
    }
    let means = match region {
        Some([x, y, w, h]) => Some((
            rtgi::metrics::region_mean(&r, x, y, w, h).context("--region")?,
            rtgi::metrics::region_mean(&t, x, y, w, h).context("--region")?,
        )),
        None => None,
    };
    if json {
        let mut v = serde_json::to_value(m)?;
        if let (Some((rm, tm)), Some(obj)) = (means, v.as_object_mut()) {
            obj.insert(
                "region".into(),
                serde_json::json!({
                    "reference_mean": rm,
                    "test_mean": tm,
                    "reference_luminance": rtgi::metrics::luminance(rm),
                    "test_luminance": rtgi::metrics::luminance(tm),
                }),
            );
        }
        println!("{v}");
    } else {
        println!("rmse {:.6}  rel_mse {:.6}  flip {:.6}", m.rmse, m.rel_mse, m.flip);
        if let Some((rm, tm)) = means {
            println!(
                "region mean luminance: reference {:.6}, test {:.6} (ratio {:.3})",
                rtgi::metrics::luminance(rm),
                rtgi::metrics::luminance(tm),
                rtgi::metrics::luminance(tm) / rtgi::metrics::luminance(rm)
            );
        }
    }
    Ok(())
}

fn tonemap(input: &Path, output: &Path, exposure: f32) -> anyhow::Result<()> {
    if !output.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        bail!("{}: the output must be a .png file", output.display());
    }
    let image = rtgi::image::HdrImage::read(input)?;
    create_parent(output)?;
    image.write_png(output, &rtgi::image::ToneMap { exposure_ev: exposure })?;
    Ok(())
}

fn montage(images: &[PathBuf], labels: &[String], out: &Path, exposure: f32) -> anyhow::Result<()> {
    if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        bail!("{}: the output must be a .png file", out.display());
    }
    if !labels.is_empty() && labels.len() != images.len() {
        bail!("{} labels for {} images: give one --label per image, or none", labels.len(), images.len());
    }
    let read = images.iter().map(rtgi::image::HdrImage::read).collect::<Result<Vec<_>, _>>()?;
    let panels: Vec<(&rtgi::image::HdrImage, &str)> =
        read.iter().enumerate().map(|(k, image)| (image, labels.get(k).map_or("", String::as_str))).collect();
    let m = rtgi::montage::montage(&panels, &rtgi::image::ToneMap { exposure_ev: exposure });
    create_parent(out)?;
    rtgi::image::write_rgb8_png(out, m.width, m.height, &m.rgb)?;
    Ok(())
}

fn main() -> ExitCode {
    // Mesa's implicit VK_LAYER_MESA_device_select probes Wayland and X11 to pick a default device, which
    // prints "XDG_RUNTIME_DIR is invalid" on headless machines. rtgi ranks adapters itself (discrete
    // first), so the layer is turned off unless the user configured it.
    if std::env::var_os("NODEVICE_SELECT").is_none() && std::env::var_os("MESA_VK_DEVICE_SELECT").is_none() {
        // SAFETY: the process is still single-threaded here; nothing else reads the environment yet.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    install_panic_hook();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render::run(&args),
        Command::View(args) => view::run(&args),
        Command::List => list::run(),
        Command::Bench(args) => bench::run(&args),
        Command::ExportScene { name, out } => export_scene(&name, &out),
        Command::Reference { scene, size, spp, set, out } => {
            reference(&scene, &size, spp, &set, out.as_deref())
        }
        Command::Tonemap { input, output, exposure } => tonemap(&input, &output, exposure),
        Command::Montage { images, labels, out, exposure } => montage(&images, &labels, &out, exposure),
        Command::Compare { reference, test, temporal, json, error_map, region } => {
            let images = ImageOptions { error_map: error_map.as_deref(), region: region.as_deref() };
            compare_command(&reference, test.as_deref(), temporal, json, &images)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // `{:#}` joins anyhow's context chain with ": "; `one_line` folds messages (e.g. wgpu
            // validation reports) that carry their own line breaks.
            let _ = writeln!(std::io::stderr(), "error: {}", one_line(&format!("{e:#}")));
            ExitCode::FAILURE
        }
    }
}

/// Turns a panic into the same one-line shape as other errors, so a bug never shows a Rust backtrace
/// dump to users; `RUST_BACKTRACE=1` still prints one for developers.
fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let message = info.payload_as_str().unwrap_or("(no message)");
        let location =
            info.location().map(|l| format!(" (at {}:{})", l.file(), l.line())).unwrap_or_default();
        let mut stderr = std::io::stderr().lock();
        let _ = writeln!(stderr, "error: internal error: {}{location}", one_line(message));
        if std::env::var_os("RUST_BACKTRACE").is_some_and(|v| v != "0") {
            let _ = writeln!(stderr, "{}", std::backtrace::Backtrace::force_capture());
        }
        // Exiting here (instead of unwinding) also covers panics on threads the library spawns.
        std::process::exit(101);
    }));
}

fn one_line(text: &str) -> String {
    text.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" ")
}

fn print_warnings(scene: &rtgi::scene::Scene) {
    for warning in &scene.warnings {
        eprintln!("warning: {}", one_line(warning));
    }
}

/// Creates the folder `path` goes into, so `--out results/a.png` works in a fresh checkout.
fn create_parent(path: &Path) -> anyhow::Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the folder {}", path.display(), dir.display())),
        _ => Ok(()),
    }
}

fn export_scene(name: &str, out: &Path) -> anyhow::Result<()> {
    let spec = SceneSpec::parse(name).map_err(|e| anyhow::anyhow!("scene {e}"))?;
    if let SceneSpec::File(path) = &spec {
        bail!("'{}' is a file; export-scene exports built-in scenes (see `rtgi list`)", path.display());
    }
    if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("glb")) {
        bail!("{}: export-scene writes binary glTF; the output file must end in .glb", out.display());
    }
    spec.validate()?;
    let scene = spec.load()?;
    print_warnings(&scene);
    create_parent(out)?;
    rtgi::scene::gltf_export::export(&scene, out)?;
    println!("wrote {} ({} triangles, {} lights)", out.display(), scene.triangle_count(), scene.lights.len());
    Ok(())
}
