//! GPU plumbing shared by every technique: device, resources, scene upload, BVH, timing, readback.

pub mod bvh;
pub mod context;
pub mod kernel;
pub mod profiler;
pub mod readback;
pub mod scene;

pub use bvh::{Bvh, GpuBvh};
pub use context::{AdapterSummary, GpuContext, GpuError, GpuOptions, MemoryReport};
pub use profiler::{PassTiming, Profiler, TimeSummary, TimingMode};
pub use scene::GpuScene;
