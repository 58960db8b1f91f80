//! GPU plumbing shared by every technique: device, resources, scene upload, BVH, timing, readback.

pub mod bvh;
pub mod context;
pub mod dispatch;
pub mod display;
pub mod features;
pub mod kernel;
pub mod linear_texture;
pub mod mips;
pub mod profiler;
pub mod readback;
pub mod resources;
pub mod scene;

pub use bvh::{Bvh, BvhTables, GpuBvh};
pub use context::{AdapterSummary, GpuContext, GpuError, GpuOptions, MemoryReport};
pub use features::{Need, require};
pub use mips::MipGenerator;
pub use profiler::{PassTiming, Profiler, TimeSummary, TimingMode};
pub use resources::{BufferBuilder, TextureBuilder};
pub use scene::GpuScene;
