//! The headless rendering API for stills: scene in, HDR radiance image and statistics out. A thin
//! driver of the persistent [`Renderer`].

use crate::gpu::{GpuContext, TimingMode};
use crate::image::HdrImage;
use crate::scene::Scene;

pub use crate::gpu::PassTiming;
pub use crate::renderer::{RenderStats, Renderer, RendererSettings};
pub use crate::techniques::RenderError;

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// A technique name from [`crate::techniques::registry`].
    pub technique: String,
    /// `key=value` technique parameters, validated against the technique's specs.
    pub technique_settings: Vec<(String, String)>,
    pub width: u32,
    pub height: u32,
    /// Frames to run; progressive techniques accumulate over them, temporal ones update history.
    pub frames: u32,
}

/// A finished render.
pub struct RenderOutput {
    pub image: HdrImage,
    pub stats: RenderStats,
}

/// Progress of a render: `done` of `total` frames.
pub type ProgressFn<'a> = dyn FnMut(u32, u32) + 'a;

/// Renders `scene` as `settings` say (at time 0 when it is animated): uploads the scene, builds the
/// frame inputs and the technique, runs `settings.frames` frames and reads the radiance back.
pub fn render(
    ctx: &GpuContext,
    scene: &Scene,
    settings: &RenderSettings,
    progress: &mut ProgressFn<'_>,
) -> Result<RenderOutput, RenderError> {
    if settings.frames == 0 {
        return Err(RenderError::InvalidSettings("frames must be at least 1".into()));
    }
    let mut renderer = Renderer::new(
        ctx,
        scene.clone(),
        &RendererSettings {
            technique: settings.technique.clone(),
            technique_settings: settings.technique_settings.clone(),
            width: settings.width,
            height: settings.height,
            timing: TimingMode::Frame,
        },
    )?;
    for done in 1..=settings.frames {
        renderer.step()?;
        progress(done, settings.frames);
    }
    Ok(RenderOutput { image: renderer.read_image()?, stats: renderer.stats()? })
}
