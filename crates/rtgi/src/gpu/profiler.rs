//! Per-pass timing.
//!
//! Every pass is recorded into its own command encoder and submitted on its own, and the profiler waits
//! for it: this gives a wall time per pass that is exact on CPU drivers (lavapipe executes the pass on
//! submission) and an upper bound on GPUs. Where the device has timestamp queries, each pass is also
//! bracketed by timestamps. Some drivers return wrong timestamp values (Mesa 22.3's lavapipe reports
//! 0.05 ms for a 430 ms pass), so timestamps are only reported when they are consistent with the wall
//! clock; otherwise the stats say why they are absent.

use std::collections::BTreeMap;
use std::time::Instant;

use super::{GpuContext, GpuError};
use crate::render::PassTiming;

struct Timestamps {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    period_ns: f64,
}

/// Records named passes and accumulates their times.
pub struct Profiler {
    timestamps: Option<Timestamps>,
    order: Vec<String>,
    /// Per pass: wall ms, GPU ms, calls, wall ms of the first call.
    totals: BTreeMap<String, (f64, f64, u32, f64)>,
}

impl Profiler {
    pub fn new(ctx: &GpuContext) -> Self {
        let timestamps = ctx.has_timestamps.then(|| Timestamps {
            queries: ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("timestamp resolve"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }),
            period_ns: f64::from(ctx.queue.get_timestamp_period()),
        });
        Profiler { timestamps, order: Vec::new(), totals: BTreeMap::new() }
    }

    /// Records one pass with `record`, submits it and waits for it.
    pub fn pass<R>(
        &mut self,
        ctx: &GpuContext,
        name: &str,
        record: impl FnOnce(&mut wgpu::CommandEncoder) -> R,
    ) -> Result<R, GpuError> {
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(name) });
        if let Some(ts) = &self.timestamps {
            encoder.write_timestamp(&ts.queries, 0);
        }
        let result = record(&mut encoder);
        if let Some(ts) = &self.timestamps {
            encoder.write_timestamp(&ts.queries, 1);
            encoder.resolve_query_set(&ts.queries, 0..2, &ts.resolve, 0);
        }
        let start = Instant::now();
        ctx.queue.submit([encoder.finish()]);
        ctx.wait_idle()?;
        let wall_ms = start.elapsed().as_secs_f64() * 1e3;
        let gpu_ms = match &self.timestamps {
            Some(ts) => {
                let bytes = super::readback::read_buffer(ctx, &ts.resolve, 0, 16)?;
                let t: &[u64] = bytemuck::cast_slice(&bytes);
                t[1].saturating_sub(t[0]) as f64 * ts.period_ns * 1e-6
            }
            None => 0.0,
        };
        if !self.totals.contains_key(name) {
            self.order.push(name.to_string());
        }
        let e = self.totals.entry(name.to_string()).or_insert((0.0, 0.0, 0, wall_ms));
        e.0 += wall_ms;
        e.1 += gpu_ms;
        e.2 += 1;
        Ok(result)
    }

    /// Whether the timestamps can be trusted, judged against the wall clock: a pass cannot take less GPU
    /// time than a small fraction of the time from submission to completion once the wall time is long
    /// enough for submission overhead not to dominate.
    pub fn timestamp_status(&self) -> Result<(), String> {
        if self.timestamps.is_none() {
            return Err("unsupported: the adapter has no timestamp queries inside encoders".into());
        }
        let (wall, gpu) = self.totals.values().fold((0.0, 0.0), |a, v| (a.0 + v.0, a.1 + v.1));
        if wall > 20.0 && gpu < 0.25 * wall {
            return Err(format!(
                "unreliable: timestamps sum to {gpu:.3} ms for {wall:.1} ms of wall time (a known driver bug, \
                 e.g. Mesa 22.3 lavapipe); per-pass wall times are given instead"
            ));
        }
        Ok(())
    }

    /// Per-pass totals in first-recorded order.
    pub fn timings(&self) -> Vec<PassTiming> {
        let reliable = self.timestamp_status().is_ok();
        self.order
            .iter()
            .map(|name| {
                let (wall, gpu, calls, first) = self.totals[name];
                PassTiming {
                    name: name.clone(),
                    gpu_ms: reliable.then_some(gpu),
                    wall_ms: wall,
                    calls,
                    // Later calls without the first, which includes the driver's lazy pipeline compilation.
                    steady_wall_ms: (calls > 1).then(|| (wall - first) / f64::from(calls - 1)),
                }
            })
            .collect()
    }
}
