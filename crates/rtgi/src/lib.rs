//! rtgi: a real-time global illumination laboratory.
//!
//! Headless first: a [`scene::Scene`] goes in, a linear HDR radiance image and statistics come out.

pub mod error;
pub mod gpu;
pub mod params;
pub mod scene;
pub mod shaders;

pub use error::SceneError;
