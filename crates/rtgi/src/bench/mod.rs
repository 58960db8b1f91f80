//! `rtgi bench`: runs a suite's matrix (scenes × techniques × parameter sweeps × sizes) on one adapter
//! and measures every cell — GPU time per frame and per pass, wall time, memory, and the error of each
//! frame against the cached path-traced reference — so techniques can be judged at equal time.
//!
//! Each measured frame starts afresh (a camera cut: no accumulation, no history), so a cell's error is
//! what one frame of that cost delivers; animated scenes step through their `times` and are compared
//! frame by frame with references of the posed scene. Results are plain data ([`BenchResults`], the
//! `results.json` schema in `docs/bench.md`); [`merge`] joins shards, [`report`] renders them.

pub mod report;
pub mod suite;

use std::collections::{BTreeMap, HashMap};
use std::io::Cursor;
use std::path::Path;
use std::time::Instant;

use base64::Engine as _;
use serde::{Deserialize, Serialize};

use crate::gpu::{AdapterSummary, GpuContext, TimeSummary};
use crate::image::{HdrImage, ToneMap};
use crate::metrics;
use crate::reference::{ReferenceRequest, reference};
use crate::renderer::{RenderStats, Renderer, RendererSettings};
use crate::scene::Scene;
use crate::techniques::RenderError;

pub use suite::{CellSpec, Shard, Suite, SuiteScene};

/// How long a cell keeps a discrete GPU busy before its warm-up frames (see [`run_cell`]).
const WARM_UP: std::time::Duration = std::time::Duration::from_millis(500);

/// The `schema` field of `results.json`; bumped on any incompatible change.
pub const SCHEMA: &str = "rtgi-bench/1";

/// Longest edge of the thumbnails kept in the results.
const THUMBNAIL_EDGE: u32 = 96;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BenchResults {
    pub schema: String,
    pub suite: SuiteInfo,
    /// rtgi's version and the commit it was built from (`git describe --always --dirty`).
    pub rtgi: BuildInfo,
    /// The shards these results hold (`I/N`), one for a single run.
    pub shards: Vec<String>,
    /// Every adapter that measured a cell.
    pub adapters: Vec<AdapterSummary>,
    pub references: Vec<ReferenceResult>,
    pub cells: Vec<CellResult>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SuiteInfo {
    pub name: String,
    pub description: String,
    pub file: String,
    pub digest: String,
    /// Cells in the whole matrix (all shards).
    pub cells: usize,
    pub frames: u32,
    pub error_frames: u32,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct BuildInfo {
    pub version: String,
    pub commit: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReferenceResult {
    pub scene: String,
    pub time: f32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Its `path` parameters besides `spp` (the scene's or the suite's `set`).
    #[serde(default)]
    pub settings: BTreeMap<String, String>,
    /// Cache key: the file is `<scene>-<W>x<H>-<spp>spp-<key>.exr` in the reference cache.
    pub key: String,
    /// Whether the reference came from the cache.
    pub cached: bool,
    /// Wall time to render it (0 when cached).
    pub render_ms: f64,
    pub thumbnail_png: String,
    /// With [`run`]'s `images` folder: the file name there of the reference (linear EXR, named as in
    /// the cache), for comparisons the bench does not make itself.
    #[serde(default)]
    pub image_file: Option<String>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PassResult {
    pub name: String,
    /// Time of the pass per frame (mean per call × calls per frame), from what the cell's frame times
    /// come from: GPU timestamps, or without usable ones the pass's wall time (suites with
    /// `timing = "passes"`; in `frame` timing a pass has no time of its own then and is left out).
    pub ms_per_frame: f64,
    /// Wall time of the pass per frame (suites with `timing = "passes"`: each pass submitted alone and
    /// waited for).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_ms_per_frame: Option<f64>,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct ErrorResult {
    pub flip: f64,
    pub rel_mse: f64,
    pub rmse: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameError {
    pub time: f32,
    #[serde(flatten)]
    pub error: ErrorResult,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CellResult {
    pub index: usize,
    pub scene: String,
    pub technique: String,
    pub series: String,
    pub settings: BTreeMap<String, String>,
    pub sweep: BTreeMap<String, String>,
    pub width: u32,
    pub height: u32,
    /// Frames rendered before the measured ones (the technique entry's `warmup`).
    #[serde(default = "one")]
    pub warmup: u32,
    /// The adapter's name.
    pub adapter: String,
    /// The time per frame the plots use: `gpu_ms.mean_ms` where timestamps are reliable, else
    /// `wall_ms.mean_ms`.
    pub frame_ms: Option<f64>,
    /// "gpu" or "wall": where `frame_ms` comes from.
    pub time_source: String,
    /// "reliable", or why the GPU timestamps are not used (then passes carry wall times, if any).
    #[serde(default)]
    pub timestamps: String,
    /// Mean and 95th percentile over the measured frames.
    pub gpu_ms: Option<TimeSummary>,
    pub wall_ms: Option<TimeSummary>,
    pub passes: Vec<PassResult>,
    /// The warm-up frames' passes (all their calls' time per warm-up frame, first calls included): what
    /// a technique builds once and keeps (a photon map, a filled cache), which the measured frames do
    /// not show.
    #[serde(default)]
    pub warmup_passes: Vec<PassResult>,
    /// Renderer creation: scene upload, BVH build, pipelines.
    pub setup_ms: f64,
    /// The whole cell: setup, frames, read-backs and metrics (on a discrete GPU the metrics overlap the
    /// next cell's rendering, so the cells' wall times add up to more than the run's).
    pub cell_wall_ms: f64,
    /// wgpu's live buffer + texture bytes after the last frame.
    pub gpu_memory_bytes: u64,
    pub gpu_scene_bytes: u64,
    /// Where the BVH kept its tables (`textures` or `buffers`; `rtgi bench --bvh-tables`).
    #[serde(default)]
    pub bvh_tables: String,
    /// Mean over the compared frames.
    pub error: Option<ErrorResult>,
    pub frames: Vec<FrameError>,
    pub counters: BTreeMap<String, f64>,
    pub warnings: Vec<String>,
    /// Tone-mapped first compared frame and its FLIP error map (PNG, base64), at most 96 px.
    pub thumbnail_png: Option<String>,
    pub error_map_png: Option<String>,
    /// Why the cell has no figures, when it failed.
    pub failure: Option<String>,
    /// With [`run`]'s `images` folder: the file name there of the first compared frame (linear EXR), for
    /// comparisons the bench does not make itself.
    #[serde(default)]
    pub image_file: Option<String>,
}

impl CellResult {
    /// The summary `frame_ms` and the plots come from (`time_source`).
    pub fn frame_time(&self) -> Option<TimeSummary> {
        if self.time_source == "gpu" { self.gpu_ms } else { self.wall_ms }
    }
}

/// What [`run`] reports as it goes.
pub enum Progress<'a> {
    Reference { scene: &'a str, time: f32, width: u32, height: u32, spp: u32 },
    Cell { done: usize, total: usize, cell: &'a CellSpec, scene: &'a str },
}

/// `warmup` of results written before the key existed.
fn one() -> u32 {
    1
}

fn png_base64(rgb: &[u8], width: u32, height: u32) -> Result<String, RenderError> {
    let img = image::RgbImage::from_raw(width, height, rgb.to_vec()).ok_or_else(|| {
        RenderError::InvalidSettings("thumbnail: pixel count does not match its size".into())
    })?;
    let scale = (THUMBNAIL_EDGE as f32 / width.max(height) as f32).min(1.0);
    let (w, h) = (((width as f32 * scale) as u32).max(1), ((height as f32 * scale) as u32).max(1));
    let small = image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle);
    let mut bytes = Vec::new();
    small
        .write_to(&mut Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| RenderError::InvalidSettings(format!("thumbnail: {e}")))?;
    Ok(base64::engine::general_purpose::STANDARD.encode(bytes))
}

fn tone_mapped_thumbnail(image: &HdrImage) -> Result<String, RenderError> {
    png_base64(&image.to_rgb8(&ToneMap::default()), image.width, image.height)
}

fn metric_error(e: metrics::MetricsError) -> RenderError {
    RenderError::InvalidSettings(e.to_string())
}

/// FLIP (with its map), relMSE and RMSE of one compared frame.
fn frame_error(reference: &HdrImage, image: &HdrImage) -> Result<(Vec<f32>, ErrorResult), RenderError> {
    let (map, flip) = metrics::flip_map(reference, image).map_err(metric_error)?;
    let rel_mse = metrics::rel_mse(reference, image).map_err(metric_error)?;
    let rmse = metrics::rmse(reference, image).map_err(metric_error)?;
    Ok((map, ErrorResult { flip, rel_mse, rmse }))
}

/// A worker thread's result, its panic as an error.
fn joined<T>(result: std::thread::Result<Result<T, RenderError>>) -> Result<T, RenderError> {
    result.unwrap_or_else(|_| Err(RenderError::InvalidSettings("a bench worker thread panicked".into())))
}

/// The cell's figures from the renderer's statistics over `frames` frames.
fn timings(stats: &RenderStats) -> (Option<TimeSummary>, Option<TimeSummary>, Vec<PassResult>) {
    let (gpu, wall) = (stats.frame_gpu, stats.frame_wall);
    let passes = stats
        .passes
        .iter()
        .filter_map(|p| {
            let per_frame = |per_call: f64| per_call * f64::from(p.calls) / f64::from(stats.frames.max(1));
            let wall_ms_per_frame = p.steady_wall_ms.map(per_frame);
            Some(PassResult {
                name: p.name.clone(),
                ms_per_frame: p.gpu.map(|g| per_frame(g.mean_ms)).or(wall_ms_per_frame)?,
                wall_ms_per_frame,
            })
        })
        .collect();
    (gpu, wall, passes)
}

/// Per pass, its whole time over the warm-up frames per frame (GPU where timestamps are reliable, else
/// wall): a pass run once there, such as a build, has no steady calls to average.
fn warmup_timings(stats: &RenderStats) -> Vec<PassResult> {
    let frames = f64::from(stats.frames.max(1));
    stats
        .passes
        .iter()
        .filter_map(|p| {
            Some(PassResult {
                name: p.name.clone(),
                ms_per_frame: p.gpu_ms.or(p.wall_ms)? / frames,
                wall_ms_per_frame: p.wall_ms.map(|w| w / frames),
            })
        })
        .collect()
}

/// References of one run, rendered once per (scene, time, size) and shared by every cell; with
/// `folder`, each is also written there.
struct References<'a> {
    images: HashMap<(usize, u32, u32, u32), HdrImage>,
    results: Vec<ReferenceResult>,
    folder: Option<&'a Path>,
}

impl References<'_> {
    #[allow(clippy::too_many_arguments)]
    fn get(
        &mut self,
        ctx: &GpuContext,
        suite: &Suite,
        scene_index: usize,
        scene: &Scene,
        time: f32,
        width: u32,
        height: u32,
        progress: &mut dyn FnMut(Progress),
    ) -> Result<&HdrImage, RenderError> {
        let key = (scene_index, time.to_bits(), width, height);
        if !self.images.contains_key(&key) {
            let s = &suite.scenes[scene_index];
            progress(Progress::Reference { scene: &s.text, time, width, height, spp: s.reference_spp });
            // Without a `seed` the reference uses its own (REFERENCE_SEED), so a `path` cell never
            // shares random numbers with the reference it is compared with.
            let settings = s.reference_settings.clone();
            let request = ReferenceRequest { width, height, spp: s.reference_spp, settings };
            let start = Instant::now();
            let posed = scene.posed(time);
            let r = reference(ctx, &posed, &request, &mut |_, _| {})?;
            let render_ms = if r.cached { 0.0 } else { start.elapsed().as_secs_f64() * 1e3 };
            metrics::check_finite(&r.image, &format!("the reference of {}", s.text)).map_err(metric_error)?;
            let image_file = match self.folder {
                None => None,
                Some(dir) => {
                    let name =
                        r.path.file_name().map(|n| n.to_string_lossy().into_owned()).ok_or_else(|| {
                            RenderError::InvalidSettings(format!("{}: no file name", r.path.display()))
                        })?;
                    r.image
                        .write_exr(dir.join(&name))
                        .map_err(|e| RenderError::InvalidSettings(e.to_string()))?;
                    Some(name)
                }
            };
            self.results.push(ReferenceResult {
                scene: s.text.clone(),
                time,
                width,
                height,
                spp: s.reference_spp,
                settings: request.settings.into_iter().collect(),
                key: r.key.clone(),
                cached: r.cached,
                render_ms,
                thumbnail_png: tone_mapped_thumbnail(&r.image)?,
                image_file,
            });
            self.images.insert(key, r.image);
        }
        Ok(&self.images[&key])
    }
}

/// A compared frame waiting for its figures.
struct Compared {
    time: f32,
    image: HdrImage,
    reference: HdrImage,
}

/// Measures one cell on the GPU: its timings and its compared frames, whose figures `finish_cell`
/// computes. Errors of the technique on this scene become the cell's `failure`.
fn run_cell(
    ctx: &GpuContext,
    suite: &Suite,
    cell: &CellSpec,
    scene: &Scene,
    references: &mut References<'_>,
    progress: &mut dyn FnMut(Progress),
) -> Result<(CellResult, Vec<Compared>), RenderError> {
    let s = &suite.scenes[cell.scene];
    let start = Instant::now();
    let settings = RendererSettings {
        technique: cell.technique.clone(),
        technique_settings: cell.settings.clone(),
        width: cell.width,
        height: cell.height,
        timing: suite.timing,
    };
    let mut result = CellResult {
        index: cell.index,
        scene: s.text.clone(),
        technique: cell.technique.clone(),
        series: cell.series.clone(),
        settings: cell.settings.iter().cloned().collect(),
        sweep: cell.sweep.iter().cloned().collect(),
        width: cell.width,
        height: cell.height,
        warmup: cell.warmup,
        adapter: ctx.summary.name.clone(),
        frame_ms: None,
        time_source: String::new(),
        timestamps: String::new(),
        gpu_ms: None,
        wall_ms: None,
        passes: Vec::new(),
        warmup_passes: Vec::new(),
        setup_ms: 0.0,
        cell_wall_ms: 0.0,
        gpu_memory_bytes: 0,
        gpu_scene_bytes: 0,
        bvh_tables: String::new(),
        error: None,
        frames: Vec::new(),
        counters: BTreeMap::new(),
        warnings: Vec::new(),
        thumbnail_png: None,
        error_map_png: None,
        failure: None,
        image_file: None,
    };
    let mut measure = || -> Result<Vec<Compared>, RenderError> {
        let mut renderer = Renderer::new(ctx, scene.clone(), &settings)?;
        // Measured frame m (1-based) at times[m − 1]; warm-up frames (m = 0) at times[0].
        let time_of = |m: u32| -> f32 {
            if s.times.is_empty() { 0.0 } else { s.times[m.saturating_sub(1) as usize % s.times.len()] }
        };
        // Warm-up: the cell's `warmup` frames (at least one: lazy pipeline compilation), after busy
        // work that raises a discrete GPU's clocks (it idles at low clocks while a cell is set up).
        // Then the timed frames, back to back, their images read back by nobody; then the compared
        // frames, untimed, so that computing their errors on the CPU leaves no idle gap before a
        // timed frame. The frame counts are fixed, so the images are the same on every run.
        crate::gpu::kernel::keep_busy(ctx, WARM_UP)?;
        for _ in 0..cell.warmup.max(1) {
            if !s.times.is_empty() {
                renderer.set_time(time_of(0))?;
            }
            renderer.cut();
            renderer.step()?;
        }
        result.warmup_passes = warmup_timings(&renderer.stats()?);
        renderer.reset_timings();
        // One more than `frames`: the first after the reset is not timed.
        for frame in 0..=suite.frames {
            if !s.times.is_empty() {
                renderer.set_time(time_of(frame))?;
            }
            renderer.cut();
            renderer.step()?;
        }
        let stats = renderer.stats()?;
        let mut compared = Vec::new();
        for frame in 1..=suite.error_frames {
            let t = time_of(frame);
            if !s.times.is_empty() {
                renderer.set_time(t)?;
            }
            renderer.cut();
            renderer.step()?;
            let image = renderer.read_image()?;
            metrics::check_finite(&image, &format!("{} on {}", cell.series, s.text)).map_err(metric_error)?;
            let reference =
                references.get(ctx, suite, cell.scene, scene, t, cell.width, cell.height, progress)?.clone();
            compared.push(Compared { time: t, image, reference });
        }
        let (gpu, wall, passes) = timings(&stats);
        result.gpu_ms = gpu;
        result.wall_ms = wall;
        result.passes = passes;
        (result.frame_ms, result.time_source) = match (gpu, wall) {
            (Some(g), _) => (Some(g.mean_ms), "gpu".into()),
            (None, Some(w)) => (Some(w.mean_ms), "wall".into()),
            (None, None) => (None, String::new()),
        };
        result.timestamps = stats.timestamps.clone();
        result.setup_ms = stats.setup_ms;
        if let Some(m) = stats.memory.last() {
            result.gpu_memory_bytes = m.report.gpu_buffer_bytes + m.report.gpu_texture_bytes;
        }
        result.gpu_scene_bytes = stats.gpu_scene_bytes;
        result.bvh_tables = stats.bvh_tables;
        result.counters = stats.counters;
        result.warnings = stats.warnings;
        Ok(compared)
    };
    let compared = measure().unwrap_or_else(|e| {
        result.failure = Some(e.to_string());
        Vec::new()
    });
    result.cell_wall_ms = start.elapsed().as_secs_f64() * 1e3;
    Ok((result, compared))
}

/// A cell's figures from its compared frames: FLIP (with its map), relMSE and RMSE per frame, and the
/// first frame's kept image (in `images`), thumbnail and error map, all at once on the CPU's cores
/// (FLIP takes about a second per 1080p frame on one core). Each figure is the same as computed one
/// after the other. A failure here becomes the cell's `failure`.
fn finish_cell(mut result: CellResult, compared: Vec<Compared>, images: Option<&Path>) -> CellResult {
    let start = Instant::now();
    let cell_index = result.index;
    let (errors, kept) = std::thread::scope(|scope| {
        let workers: Vec<_> = compared
            .iter()
            .enumerate()
            .map(|(i, c)| {
                scope.spawn(move || -> Result<_, RenderError> {
                    let (map, error) = frame_error(&c.reference, &c.image)?;
                    let error_map = match i {
                        0 => Some(png_base64(
                            &metrics::error_map_rgb8(&map, c.image.width, c.image.height),
                            c.image.width,
                            c.image.height,
                        )?),
                        _ => None,
                    };
                    Ok((error, error_map))
                })
            })
            .collect();
        let keeper = compared.first().map(|c| {
            scope.spawn(move || -> Result<_, RenderError> {
                let file = match images {
                    Some(dir) => {
                        let name = format!("cell-{cell_index:04}.exr");
                        c.image
                            .write_exr(dir.join(&name))
                            .map_err(|e| RenderError::InvalidSettings(e.to_string()))?;
                        Some(name)
                    }
                    None => None,
                };
                Ok((file, tone_mapped_thumbnail(&c.image)?))
            })
        });
        let errors: Vec<_> = workers.into_iter().map(|w| joined(w.join())).collect();
        (errors, keeper.map(|k| joined(k.join())))
    });
    let figures = || -> Result<(), RenderError> {
        for (c, figures) in compared.iter().zip(errors) {
            let (error, error_map) = figures?;
            if error_map.is_some() {
                result.error_map_png = error_map;
            }
            result.frames.push(FrameError { time: c.time, error });
        }
        if let Some(kept) = kept {
            (result.image_file, result.thumbnail_png) =
                kept.map(|(file, thumbnail)| (file, Some(thumbnail)))?;
        }
        Ok(())
    };
    if let Err(e) = figures() {
        result.failure = Some(e.to_string());
        result.frames.clear();
    }
    let n = result.frames.len() as f64;
    if n > 0.0 {
        let mean = |f: fn(&ErrorResult) -> f64| result.frames.iter().map(|e| f(&e.error)).sum::<f64>() / n;
        result.error = Some(ErrorResult {
            flip: mean(|e| e.flip),
            rel_mse: mean(|e| e.rel_mse),
            rmse: mean(|e| e.rmse),
        });
    }
    result.cell_wall_ms += start.elapsed().as_secs_f64() * 1e3;
    result
}

/// Measures `cells` in order; with `overlap` each cell's figures are computed on a thread of their own
/// while the next cell renders (at most one cell waits for its figures).
#[allow(clippy::too_many_arguments)]
fn run_cells(
    ctx: &GpuContext,
    suite: &Suite,
    cells: &[&CellSpec],
    scenes: &HashMap<usize, Scene>,
    images: Option<&Path>,
    references: &mut References<'_>,
    progress: &mut dyn FnMut(Progress),
    overlap: bool,
) -> Result<Vec<CellResult>, RenderError> {
    let folder = images.map(Path::to_path_buf);
    let mut results = Vec::new();
    let mut pending: Option<std::thread::JoinHandle<CellResult>> = None;
    for (done, cell) in cells.iter().enumerate() {
        let s = &suite.scenes[cell.scene];
        progress(Progress::Cell { done, total: cells.len(), cell, scene: &s.text });
        let (result, compared) = run_cell(ctx, suite, cell, &scenes[&cell.scene], references, progress)?;
        if let Some(previous) = pending.take() {
            results.push(joined(previous.join().map(Ok))?);
        }
        if overlap {
            let folder = folder.clone();
            pending = Some(std::thread::spawn(move || finish_cell(result, compared, folder.as_deref())));
        } else {
            results.push(finish_cell(result, compared, images));
        }
    }
    if let Some(last) = pending {
        results.push(joined(last.join().map(Ok))?);
    }
    Ok(results)
}

/// Runs the cells of `shard` on `ctx`. A cell that fails (the technique cannot run on that scene, a
/// non-finite pixel, ...) is kept with its `failure`; a reference or scene that cannot be had stops
/// the run. With `images`, each cell's first compared frame is also written there as
/// `cell-NNNN.exr`, and each reference under its cache file name (the folder must exist).
pub fn run(
    ctx: &GpuContext,
    suite: &Suite,
    shard: Shard,
    build: BuildInfo,
    images: Option<&Path>,
    progress: &mut dyn FnMut(Progress),
) -> Result<BenchResults, RenderError> {
    // On a discrete GPU a cell's figures are computed on the CPU while the next cell renders (they
    // took most of a cell's time there); on a CPU adapter the two would share the cores, so one after
    // the other. The figures are the same either way.
    let overlap = ctx.adapter.get_info().device_type != wgpu::DeviceType::Cpu;
    run_shard(ctx, suite, shard, build, images, progress, overlap)
}

fn run_shard(
    ctx: &GpuContext,
    suite: &Suite,
    shard: Shard,
    build: BuildInfo,
    images: Option<&Path>,
    progress: &mut dyn FnMut(Progress),
    overlap: bool,
) -> Result<BenchResults, RenderError> {
    let cells: Vec<&CellSpec> = suite.cells.iter().filter(|c| shard.contains(c.index)).collect();
    let mut scenes: HashMap<usize, Scene> = HashMap::new();
    let mut references = References { images: HashMap::new(), results: Vec::new(), folder: images };
    // References first: rendering one between a cell's frames would disturb its timing (on lavapipe
    // its timestamps came out 3x too short), and the cells' wall times should not include them.
    for cell in &cells {
        let s = &suite.scenes[cell.scene];
        let scene = match scenes.entry(cell.scene) {
            std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::hash_map::Entry::Vacant(v) => v.insert(
                s.spec
                    .load()
                    .map_err(|e| RenderError::InvalidSettings(format!("scene '{}': {e}", s.text)))?,
            ),
        };
        let times = if s.times.is_empty() { vec![0.0] } else { s.times.clone() };
        for t in times.into_iter().take(suite.error_frames as usize) {
            references.get(ctx, suite, cell.scene, scene, t, cell.width, cell.height, progress)?;
        }
    }
    let results = run_cells(ctx, suite, &cells, &scenes, images, &mut references, progress, overlap)?;
    Ok(BenchResults {
        schema: SCHEMA.into(),
        suite: SuiteInfo {
            name: suite.name.clone(),
            description: suite.description.clone(),
            file: suite.path.display().to_string(),
            digest: suite.digest.clone(),
            cells: suite.cells.len(),
            frames: suite.frames,
            error_frames: suite.error_frames,
        },
        rtgi: build,
        shards: vec![shard.to_string()],
        adapters: vec![ctx.summary.clone()],
        references: references.results,
        cells: results,
    })
}

/// Joins the results of shards of one suite into one: same suite (name and file digest) and schema,
/// no cell twice. Cells come out in matrix order; [`missing_cells`] says which the shards did not cover.
pub fn merge(parts: Vec<BenchResults>) -> Result<BenchResults, String> {
    let mut parts = parts.into_iter();
    let mut merged = parts.next().ok_or("nothing to merge")?;
    for part in parts {
        if part.schema != merged.schema {
            return Err(format!("schema {} cannot be merged with {}", part.schema, merged.schema));
        }
        if part.suite != merged.suite {
            return Err(format!(
                "results of suite '{}' ({}) cannot be merged with suite '{}' ({}): not the same suite file",
                part.suite.name, part.suite.digest, merged.suite.name, merged.suite.digest
            ));
        }
        if part.rtgi != merged.rtgi {
            return Err(format!(
                "results of rtgi {} ({}) cannot be merged with rtgi {} ({})",
                part.rtgi.version, part.rtgi.commit, merged.rtgi.version, merged.rtgi.commit
            ));
        }
        merged.shards.extend(part.shards);
        for a in part.adapters {
            if !merged.adapters.contains(&a) {
                merged.adapters.push(a);
            }
        }
        for r in part.references {
            if !merged.references.iter().any(|m| m.key == r.key) {
                merged.references.push(r);
            }
        }
        merged.cells.extend(part.cells);
    }
    merged.cells.sort_by_key(|c| c.index);
    if let Some(w) = merged.cells.windows(2).find(|w| w[0].index == w[1].index) {
        return Err(format!("cell {} is in two of the merged results (overlapping shards)", w[0].index));
    }
    merged.shards.sort();
    Ok(merged)
}

/// Indices of the suite's cells that `results` lacks.
pub fn missing_cells(results: &BenchResults) -> Vec<usize> {
    let have: std::collections::HashSet<usize> = results.cells.iter().map(|c| c.index).collect();
    (0..results.suite.cells).filter(|i| !have.contains(i)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::GpuOptions;

    /// Figures computed while the next cell renders are those computed one after the other: errors per
    /// frame, thumbnails, error maps and kept images.
    #[test]
    fn overlapped_figures_equal_sequential_ones() {
        let ctx = GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (lavapipe)");
        let suite = Suite::parse(
            r#"
name = "overlap"
sizes = ["24x16"]
frames = 2
error_frames = 2
[reference]
spp = 4
[[scenes]]
scene = "cornell-spot:animate=spot"
times = [0.0, 0.5]
[[techniques]]
technique = "path"
sweep = { spp = [1, 2] }
[[techniques]]
technique = "direct"
"#,
            Path::new("benches/overlap.toml"),
        )
        .expect("suite");
        let run = |overlap: bool| {
            let dir = tempfile::tempdir().expect("temp dir");
            let build = BuildInfo { version: "test".into(), commit: "test".into() };
            let results = run_shard(&ctx, &suite, Shard::ALL, build, Some(dir.path()), &mut |_| {}, overlap)
                .expect("bench");
            let images: Vec<Vec<u8>> = results
                .cells
                .iter()
                .map(|c| {
                    std::fs::read(dir.path().join(c.image_file.as_ref().expect("kept image"))).expect("image")
                })
                .collect();
            (results, images)
        };
        let (sequential, sequential_images) = run(false);
        let (overlapped, overlapped_images) = run(true);
        assert_eq!(sequential.cells.len(), 3);
        for (a, b) in sequential.cells.iter().zip(&overlapped.cells) {
            assert_eq!(a.failure, None);
            assert_eq!(a.frames.len(), 2);
            assert_eq!(serde_json::to_string(&a.frames).ok(), serde_json::to_string(&b.frames).ok());
            assert_eq!((&a.thumbnail_png, &a.error_map_png), (&b.thumbnail_png, &b.error_map_png));
        }
        assert_eq!(sequential_images, overlapped_images);
    }
}
