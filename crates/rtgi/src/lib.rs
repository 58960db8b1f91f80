//! rtgi: a real-time global illumination laboratory.
//!
//! Headless first: a [`scene::Scene`] goes in, a linear HDR radiance image and statistics come out
//! ([`render::render`]), or frame by frame through the persistent [`renderer::Renderer`].

pub mod bench;
pub mod cache;
pub mod error;
pub mod frame;
pub mod gpu;
pub mod hsh;
pub mod image;
pub mod metrics;
pub mod montage;
pub mod params;
pub mod post;
pub mod reference;
pub mod render;
pub mod renderer;
pub mod scene;
pub mod sequences;
pub mod sh;
pub mod shaders;
pub mod stable_hash;
pub mod techniques;
pub mod testing;

pub use error::SceneError;
