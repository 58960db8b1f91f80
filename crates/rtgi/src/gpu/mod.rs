//! GPU plumbing shared by every technique: device, resources, scene upload, BVH, timing, readback.

pub mod bvh;
pub mod context;
pub mod readback;

pub use bvh::{Bvh, GpuBvh};
pub use context::{AdapterSummary, GpuContext, GpuError, GpuOptions};
