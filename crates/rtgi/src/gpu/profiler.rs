//! Per-pass and per-frame timing.
//!
//! Two modes ([`TimingMode`]):
//! - [`TimingMode::Frame`] (the default): every pass of a frame is recorded into one command encoder,
//!   bracketed by timestamp queries where the device has them; the frame is submitted once, its
//!   timestamps are resolved once and read back after the frame completes. Per-pass times come from the
//!   timestamps only; the frame's wall time (submission to completion) is always measured.
//! - [`TimingMode::Passes`]: every pass is submitted on its own and waited for. This serialises the GPU
//!   and adds a submission per pass, but gives an exact wall time per pass on CPU drivers (lavapipe
//!   executes a submission synchronously), where timestamps are unusable.
//!
//! Drivers can stamp timestamps late: Mesa 22.3's lavapipe stamped a pass's start after its work unless
//! something flushed in between (0.03 ms for the ray-cast G-buffer's 22 ms), which
//! [`Timestamps::write_start`] works around. Timestamps are still only reported when they are consistent
//! with the wall clock; otherwise the stats say why they are absent.
//!
//! Statistics are over the "steady" calls: every call after a pass's first, whose time includes the
//! driver's lazy pipeline compilation on some drivers.

use std::collections::BTreeMap;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::{GpuContext, GpuError};

/// How passes are submitted and timed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TimingMode {
    /// One command encoder and one submission per frame; per-pass GPU timestamps.
    #[default]
    Frame,
    /// One submission per pass, each waited for: exact per-pass wall times on CPU drivers.
    Passes,
}

impl std::str::FromStr for TimingMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "frame" => Ok(TimingMode::Frame),
            "passes" => Ok(TimingMode::Passes),
            _ => Err(format!("unknown timing mode '{s}'; use 'frame' or 'passes'")),
        }
    }
}

/// Mean and 95th percentile of a series of times, in milliseconds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeSummary {
    pub mean_ms: f64,
    pub p95_ms: f64,
    /// How many values the summary covers (0 when read from results written without it).
    #[serde(default)]
    pub count: usize,
}

impl TimeSummary {
    /// `None` for an empty series. The percentile is the nearest-rank one.
    pub fn of(values: &[f64]) -> Option<TimeSummary> {
        if values.is_empty() {
            return None;
        }
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let rank = ((0.95 * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
        Some(TimeSummary {
            mean_ms: sorted.iter().sum::<f64>() / sorted.len() as f64,
            p95_ms: sorted[rank - 1],
            count: sorted.len(),
        })
    }
}

/// Time spent in one named pass.
#[derive(Clone, Debug, Serialize)]
pub struct PassTiming {
    pub name: String,
    /// Total GPU time from timestamp queries over all calls; `None` when they are unavailable or
    /// unreliable.
    pub gpu_ms: Option<f64>,
    /// GPU time per steady call (every call after the first).
    pub gpu: Option<TimeSummary>,
    /// Total wall time from submission to completion with passes serialised (exact on CPU drivers, an
    /// upper bound on GPUs); `None` in [`TimingMode::Frame`], where passes are not submitted alone.
    pub wall_ms: Option<f64>,
    /// How often the pass ran (e.g. once per frame).
    pub calls: u32,
    /// Mean wall time of the calls after the first (whose time includes lazy pipeline compilation on
    /// some drivers); `None` after a single call or in [`TimingMode::Frame`].
    pub steady_wall_ms: Option<f64>,
    /// Wall time per steady call; `None` in [`TimingMode::Frame`].
    pub wall: Option<TimeSummary>,
}

/// Keeps at most this many samples per series, so a 10 000-frame run does not grow without bound;
/// later samples replace earlier ones at deterministic pseudo-random positions (a reservoir).
const MAX_SAMPLES: usize = 8192;

#[derive(Default)]
struct Series {
    values: Vec<f64>,
    seen: u64,
}

impl Series {
    fn push(&mut self, v: f64) {
        self.seen += 1;
        if self.values.len() < MAX_SAMPLES {
            self.values.push(v);
        } else {
            // Algorithm R with a fixed hash instead of a random generator: deterministic runs.
            let j = (self.seen.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 17) % self.seen;
            if (j as usize) < MAX_SAMPLES {
                self.values[j as usize] = v;
            }
        }
    }
}

#[derive(Default)]
struct PassRecord {
    calls: u32,
    wall_total: f64,
    gpu_total: f64,
    wall_steady: Series,
    gpu_steady: Series,
}

const MAX_QUERIES: u32 = 256;
/// Timestamp pairs a frame can time: the last query is the scratch of [`Timestamps::write_start`].
const MAX_PAIRS: u32 = MAX_QUERIES / 2 - 1;

struct Timestamps {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    /// The resolved values are copied here in the same submission as the passes, so reading them
    /// costs a map, not another submission and buffer per frame.
    readback: wgpu::Buffer,
    period_ns: f64,
}

impl Timestamps {
    /// Writes the start timestamp of pair `pair`, then one into the scratch query. Mesa 22.3's lavapipe
    /// (llvmpipe) stamps a timestamp when it next flushes the raster scene of the framebuffer a render
    /// pass left bound, and a timestamp write flushes before it is queued: without the second write, a
    /// pass whose dispatches do not flush (the VXGI mips, the ray-cast G-buffer) got its start stamped
    /// after its own work, which then counted in no pass at all. Elsewhere it costs one timestamp.
    fn write_start(&self, encoder: &mut wgpu::CommandEncoder, pair: u32) {
        encoder.write_timestamp(&self.queries, 2 * pair);
        encoder.write_timestamp(&self.queries, MAX_QUERIES - 1);
    }

    /// Resolves the first `pairs` timestamp pairs and copies them to the readback buffer.
    fn record_resolve(&self, encoder: &mut wgpu::CommandEncoder, pairs: u32) {
        encoder.resolve_query_set(&self.queries, 0..2 * pairs, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, u64::from(pairs) * 16);
    }
}

/// Records named passes of a frame and accumulates their times.
pub struct Profiler {
    mode: TimingMode,
    timestamps: Option<Timestamps>,
    order: Vec<String>,
    passes: BTreeMap<String, PassRecord>,
    /// The frame being recorded: its encoder and the passes that wrote timestamps into it.
    encoder: Option<wgpu::CommandEncoder>,
    frame_passes: Vec<String>,
    frame_start: Option<Instant>,
    frames: u32,
    frame_wall: Series,
    frame_gpu: Series,
    wall_total: f64,
    gpu_total: f64,
}

impl Profiler {
    pub fn new(ctx: &GpuContext, mode: TimingMode) -> Self {
        let timestamps = ctx.has_timestamps.then(|| Timestamps {
            queries: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: MAX_QUERIES,
            }),
            resolve: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: u64::from(MAX_QUERIES) * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            readback: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp readback"),
                size: u64::from(MAX_QUERIES) * 8,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            period_ns: f64::from(ctx.queue.get_timestamp_period()),
        });
        Profiler {
            mode,
            timestamps,
            order: Vec::new(),
            passes: BTreeMap::new(),
            encoder: None,
            frame_passes: Vec::new(),
            frame_start: None,
            frames: 0,
            frame_wall: Series::default(),
            frame_gpu: Series::default(),
            wall_total: 0.0,
            gpu_total: 0.0,
        }
    }

    pub fn mode(&self) -> TimingMode {
        self.mode
    }

    /// Starts a frame: in [`TimingMode::Frame`] its passes go into one encoder until [`Self::end_frame`].
    pub fn begin_frame(&mut self, ctx: &GpuContext) {
        self.frame_passes.clear();
        self.frame_start = Some(Instant::now());
        if self.mode == TimingMode::Frame {
            self.encoder = Some(
                ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") }),
            );
        }
    }

    /// Records one pass with `record`. In [`TimingMode::Frame`] it goes into the frame's encoder; in
    /// [`TimingMode::Passes`] (or outside a frame) it is submitted and waited for.
    pub fn pass<R>(
        &mut self,
        ctx: &GpuContext,
        name: &str,
        record: impl FnOnce(&mut wgpu::CommandEncoder) -> R,
    ) -> Result<R, GpuError> {
        if !self.passes.contains_key(name) {
            self.order.push(name.to_string());
            self.passes.insert(name.to_string(), PassRecord::default());
        }
        if let Some(encoder) = self.encoder.as_mut() {
            let slot = self.frame_passes.len() as u32;
            let timed = slot < MAX_PAIRS;
            if let (Some(ts), true) = (&self.timestamps, timed) {
                ts.write_start(encoder, slot);
            }
            let result = record(encoder);
            if let (Some(ts), true) = (&self.timestamps, timed) {
                encoder.write_timestamp(&ts.queries, 2 * slot + 1);
            }
            self.frame_passes.push(name.to_string());
            return Ok(result);
        }
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(name) });
        if let Some(ts) = &self.timestamps {
            ts.write_start(&mut encoder, 0);
        }
        let result = record(&mut encoder);
        if let Some(ts) = &self.timestamps {
            encoder.write_timestamp(&ts.queries, 1);
            ts.record_resolve(&mut encoder, 1);
        }
        let start = Instant::now();
        ctx.queue.submit([encoder.finish()]);
        ctx.wait_idle()?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let gpu = self.read_intervals(ctx, 1)?;
        self.add(name, Some(wall_ms), gpu.first().copied());
        Ok(result)
    }

    /// Submits the frame (in [`TimingMode::Frame`]), waits for it and reads its timestamps.
    pub fn end_frame(&mut self, ctx: &GpuContext) -> Result<(), GpuError> {
        let passes = std::mem::take(&mut self.frame_passes);
        if let Some(mut encoder) = self.encoder.take() {
            let timed = (passes.len() as u32).min(MAX_PAIRS);
            if let (Some(ts), true) = (&self.timestamps, timed > 0) {
                ts.record_resolve(&mut encoder, timed);
            }
            ctx.queue.submit([encoder.finish()]);
            ctx.wait_idle()?;
            let gpu = self.read_intervals(ctx, timed)?;
            for (i, name) in passes.iter().enumerate() {
                self.add(name, None, gpu.get(i).copied());
            }
            let gpu_frame: f64 = gpu.iter().sum();
            if !gpu.is_empty() {
                self.gpu_total += gpu_frame;
                if self.frames > 0 {
                    self.frame_gpu.push(gpu_frame);
                }
            }
        }
        if let Some(start) = self.frame_start.take() {
            let wall = start.elapsed().as_secs_f64() * 1e3;
            self.wall_total += wall;
            if self.frames > 0 {
                self.frame_wall.push(wall);
            }
        }
        self.frames += 1;
        Ok(())
    }

    /// GPU milliseconds of the first `count` timestamp pairs in the resolve buffer.
    fn read_intervals(&self, ctx: &GpuContext, count: u32) -> Result<Vec<f64>, GpuError> {
        let Some(ts) = &self.timestamps else { return Ok(Vec::new()) };
        if count == 0 {
            return Ok(Vec::new());
        }
        let bytes = super::readback::map_and_copy(ctx, &ts.readback)?;
        let t: &[u64] = bytemuck::cast_slice(&bytes[..count as usize * 16]);
        Ok(t.chunks_exact(2).map(|p| p[1].saturating_sub(p[0]) as f64 * ts.period_ns * 1e-6).collect())
    }

    fn add(&mut self, name: &str, wall_ms: Option<f64>, gpu_ms: Option<f64>) {
        let Some(p) = self.passes.get_mut(name) else { return };
        p.calls += 1;
        let steady = p.calls > 1;
        if let Some(w) = wall_ms {
            p.wall_total += w;
            if steady {
                p.wall_steady.push(w);
            }
        }
        if let Some(g) = gpu_ms {
            p.gpu_total += g;
            if steady {
                p.gpu_steady.push(g);
            }
        }
    }

    /// Whether the timestamps can be trusted, judged against the wall clock: passes cannot take less GPU
    /// time than a small fraction of the time from submission to completion once the wall time is long
    /// enough for submission overhead not to dominate.
    pub fn timestamp_status(&self) -> Result<(), String> {
        if self.timestamps.is_none() {
            return Err("unsupported: the adapter has no timestamp queries inside encoders".into());
        }
        let (wall, gpu) = match self.mode {
            TimingMode::Passes => {
                self.passes.values().fold((0.0, 0.0), |a, p| (a.0 + p.wall_total, a.1 + p.gpu_total))
            }
            TimingMode::Frame => (self.wall_total, self.gpu_total),
        };
        if wall > 20.0 && gpu < 0.25 * wall {
            return Err(format!(
                "unreliable: timestamps sum to {gpu:.3} ms for {wall:.1} ms of wall time (a known driver bug, \
                 e.g. Mesa 22.3 lavapipe); use --timing passes for per-pass wall times"
            ));
        }
        Ok(())
    }

    /// Wall time of all frames ended so far, submission of the first pass to completion of the last.
    pub fn wall_ms(&self) -> f64 {
        self.wall_total
    }

    /// Frames ended so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Wall time per steady frame (every frame after the first), submission of the first pass to
    /// completion of the last.
    pub fn frame_wall(&self) -> Option<TimeSummary> {
        TimeSummary::of(&self.frame_wall.values)
    }

    /// GPU time per steady frame: the sum of its passes' timestamps, when they are reliable.
    pub fn frame_gpu(&self) -> Option<TimeSummary> {
        if self.timestamp_status().is_err() {
            return None;
        }
        TimeSummary::of(&self.frame_gpu.values)
    }

    /// Per-pass totals in first-recorded order.
    pub fn timings(&self) -> Vec<PassTiming> {
        let reliable = self.timestamp_status().is_ok();
        let walled = self.mode == TimingMode::Passes;
        self.order
            .iter()
            .filter_map(|name| Some((name, self.passes.get(name)?)))
            .map(|(name, p)| {
                let wall = TimeSummary::of(&p.wall_steady.values);
                PassTiming {
                    name: name.clone(),
                    gpu_ms: reliable.then_some(p.gpu_total),
                    gpu: if reliable { TimeSummary::of(&p.gpu_steady.values) } else { None },
                    wall_ms: walled.then_some(p.wall_total),
                    calls: p.calls,
                    steady_wall_ms: if walled { wall.map(|w| w.mean_ms) } else { None },
                    wall: if walled { wall } else { None },
                }
            })
            .collect()
    }

    /// Forgets every time recorded so far (e.g. after a change that recompiles pipelines).
    pub fn reset(&mut self) {
        self.order.clear();
        self.passes.clear();
        self.frames = 0;
        self.frame_wall = Series::default();
        self.frame_gpu = Series::default();
        self.wall_total = 0.0;
        self.gpu_total = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_is_mean_and_nearest_rank_percentile() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = TimeSummary::of(&v).expect("non-empty");
        assert_eq!(s.mean_ms, 50.5);
        assert_eq!(s.p95_ms, 95.0);
        assert_eq!(TimeSummary::of(&[3.0]).map(|s| s.p95_ms), Some(3.0));
        assert!(TimeSummary::of(&[]).is_none());
    }

    /// Each pass's timestamps must bracket its own work. A frame runs a short pass, then a long one: one
    /// dispatch of eight workgroups whose threads each run a long dependent chain (long on any device:
    /// a GPU's width does not help). The long pass's GPU time must be most of the frame's wall time.
    #[test]
    fn timestamps_bracket_the_work_of_their_pass() {
        use crate::gpu::resources::BufferBuilder;
        let ctx = GpuContext::new(&crate::gpu::GpuOptions::default()).expect("a GPU adapter (lavapipe)");
        assert!(ctx.has_timestamps, "lavapipe and the NVIDIA driver both have timestamps inside encoders");
        let module = crate::shaders::create_module(
            &ctx,
            "chain",
            "@group(0) @binding(0) var<storage, read> steps: u32;
@group(0) @binding(1) var<storage, read_write> out: array<f32, 64>;
@compute @workgroup_size(64)
fn main(@builtin(local_invocation_index) i: u32) {
    var x = f32(i) / 64.0;
    // llvmpipe ends a loop after 65535 iterations: the chain is ten steps per iteration.
    for (var k = 0u; k < steps; k++) {
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
        x = fract(x * 1.618034 + 0.2360679);
    }
    out[i] = x;
}",
            &crate::shaders::Defines::new(),
        )
        .expect("shader");
        let pipeline = ctx.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("chain"),
            layout: None,
            module: &module,
            entry_point: Some("main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let group = |steps: u32| {
            let out = BufferBuilder::new("out", 256).storage().build(&ctx).expect("out");
            let steps = BufferBuilder::with_contents("steps", bytemuck::bytes_of(&steps))
                .storage()
                .build(&ctx)
                .expect("steps");
            ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &pipeline.get_bind_group_layout(0),
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: steps.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
                ],
            })
        };
        // About 130 ms on lavapipe (2 cores, 8 lanes at a time) and a few ms on an H100 (600 000 steps
        // of about 8 cycles each per thread).
        let (short, long) = (group(1), group(60_000));
        // A render pass first, as in a frame: lavapipe queues its timestamps in the raster scene of the
        // framebuffer a render pass leaves bound (with none, it stamps them at once: no defect to see).
        let target =
            crate::gpu::resources::TextureBuilder::d2("target", 64, 64, wgpu::TextureFormat::Rgba8Unorm)
                .usage(wgpu::TextureUsages::RENDER_ATTACHMENT)
                .build(&ctx)
                .expect("target");
        let target = target.create_view(&Default::default());
        let mut profiler = Profiler::new(&ctx, TimingMode::Frame);
        for _ in 0..3 {
            profiler.begin_frame(&ctx);
            profiler
                .pass(&ctx, "clear", |e| {
                    e.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some("clear"),
                        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                            view: &target,
                            depth_slice: None,
                            resolve_target: None,
                            ops: wgpu::Operations {
                                load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                                store: wgpu::StoreOp::Store,
                            },
                        })],
                        ..Default::default()
                    });
                })
                .expect("clear");
            for (name, group) in [("short", &short), ("long", &long)] {
                profiler
                    .pass(&ctx, name, |e| {
                        crate::gpu::dispatch::compute_pass(e, name, &pipeline, &[group])
                            .dispatch_workgroups(8, 1, 1)
                    })
                    .expect("pass");
            }
            profiler.end_frame(&ctx).expect("frame");
        }
        let wall = profiler.frame_wall().expect("steady frames").mean_ms;
        let timings = profiler.timings();
        let status = profiler.timestamp_status();
        let long = timings.iter().find(|t| t.name == "long").and_then(|t| t.gpu);
        let long = long.unwrap_or_else(|| panic!("no timestamps: {status:?}")).mean_ms;
        // Measured on lavapipe: 125 ms of a 130 ms frame (0.97). Without the scratch write the passes'
        // timestamps summed to under a quarter of the frame and were withheld as unreliable.
        assert!(long > 0.5 * wall, "the long pass took {long:.3} ms of a {wall:.1} ms frame");
    }

    #[test]
    fn series_stays_bounded_and_keeps_the_distribution() {
        let mut s = Series::default();
        for i in 0..100_000u32 {
            s.push(f64::from(i % 100));
        }
        assert_eq!(s.values.len(), MAX_SAMPLES);
        let mean = s.values.iter().sum::<f64>() / s.values.len() as f64;
        // The population mean is 49.5; a uniform reservoir of 8192 values has a standard error of ~0.3.
        assert!((mean - 49.5).abs() < 1.5, "{mean}");
    }
}
