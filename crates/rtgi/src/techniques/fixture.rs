//! A technique's surroundings for unit tests: a device, a built-in scene on it, frame resources whose
//! G-buffer and shadow maps are rendered, and an output texture.

use crate::frame::{FrameResources, FrameSettings, OUTPUT_FORMAT, ShadowSettings};
use crate::gpu::{GpuContext, GpuOptions, GpuScene, Profiler, TimingMode};
use crate::params::ParamValues;

use super::{FrameContext, Technique, TechniqueSetup, compute};

pub struct Fixture {
    pub ctx: GpuContext,
    pub scene: crate::scene::Scene,
    pub gpu_scene: GpuScene,
    pub frame: FrameResources,
    pub output: wgpu::Texture,
}

/// The built-in `scene` with its defaults, seen at `w`×`h`.
pub fn fixture(scene: &str, w: u32, h: u32) -> Fixture {
    fixture_with(scene, &[], w, h)
}

/// The built-in `scene` with `settings`, seen at `w`×`h`.
pub fn fixture_with(scene: &str, settings: &[(&str, &str)], w: u32, h: u32) -> Fixture {
    let settings: Vec<(String, String)> =
        settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    fixture_of(crate::scene::builtin::build(scene, &settings).expect("scene"), w, h)
}

/// `scene` seen at `w`×`h`.
pub fn fixture_of(scene: crate::scene::Scene, w: u32, h: u32) -> Fixture {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let gpu_scene = GpuScene::new(&ctx, &scene).expect("upload");
    let shadows = ShadowSettings { size: 256, filter_radius: 1, depth_bias: 1e-4, normal_offset: 1.5 };
    let mut frame = FrameResources::new(
        &ctx,
        &gpu_scene,
        &scene,
        w,
        h,
        FrameSettings { shadows: Some(shadows), primary: None },
    )
    .expect("frame");
    let view = frame.view;
    frame.set_view(&ctx, &view, 0);
    frame.render_inputs(&ctx, &gpu_scene, &mut Profiler::new(&ctx, TimingMode::Passes)).expect("gbuffer");
    let output = compute::storage_texture(&ctx, "output", w, h, OUTPUT_FORMAT);
    Fixture { ctx, scene, gpu_scene, frame, output }
}

impl Fixture {
    pub fn setup<'a>(&'a self, params: &'a ParamValues) -> TechniqueSetup<'a> {
        TechniqueSetup {
            ctx: &self.ctx,
            scene: &self.scene,
            gpu_scene: &self.gpu_scene,
            frame: &self.frame,
            params,
            output: &self.output,
        }
    }

    /// Renders frames 0 … `frames` − 1 of `technique` (frame counter = sample index = k), each a
    /// profiler frame of its own.
    pub fn render_frames(&mut self, technique: &mut dyn Technique, frames: u32) {
        let mut profiler = Profiler::new(&self.ctx, TimingMode::Frame);
        for k in 0..frames {
            let mut view = self.frame.view;
            view.frame_counter = k;
            view.sample_index = k;
            self.frame.set_view(&self.ctx, &view, 0);
            let fc = FrameContext {
                ctx: &self.ctx,
                gpu_scene: &self.gpu_scene,
                frame: &self.frame,
                view,
                next: None,
                prediction_held: true,
            };
            profiler.begin_frame(&self.ctx);
            technique.render_frame(&fc, &mut profiler).expect("frame");
            profiler.end_frame(&self.ctx).expect("frame end");
        }
    }

    /// [`Self::render_frames`], then the output's RGB, pixel by pixel.
    pub fn render_rgb(&mut self, technique: &mut dyn Technique, frames: u32) -> Vec<glam::Vec3> {
        self.render_frames(technique, frames);
        let image = crate::gpu::readback::read_texture(&self.ctx, &self.output, 16).expect("image");
        bytemuck::cast_slice::<u8, [f32; 4]>(&image)
            .iter()
            .map(|p| glam::Vec3::new(p[0], p[1], p[2]))
            .collect()
    }
}

/// Sum of |difference| over the sum of the reference, over all pixels and channels.
pub fn mean_relative_difference(pixels: &[glam::Vec3], reference: &[glam::Vec3]) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (p, r) in pixels.iter().zip(reference) {
        num += f64::from((*p - *r).abs().element_sum());
        den += f64::from(r.element_sum());
    }
    num / den
}

/// `source` (a scene with moving meshes) posed at time `t`, uploaded with its moving meshes as
/// instances (so that `GpuScene::move_meshes` can move them), seen at 64×48.
pub fn moving_fixture_at(source: &crate::scene::Scene, t: f32) -> Fixture {
    let mut f = fixture_of(source.posed(t), 64, 48);
    f.gpu_scene = GpuScene::with_moving_meshes(&f.ctx, &f.scene, &source.moving_meshes())
        .expect("upload with moving meshes");
    redraw_inputs(&mut f);
    f
}

/// Moves the meshes `moved` of `f` (a [`moving_fixture_at`] of `source` at time `from`) in place to
/// their pose at time `to`: the fixture's scene is posed anew and its GPU scene moved, as the renderer
/// does; the technique must be told ([`super::SceneChange::Geometry`]) and the inputs redrawn.
pub fn move_meshes_to(f: &mut Fixture, source: &crate::scene::Scene, from: f32, to: f32, moved: &[usize]) {
    let (then, now) = (source.pose_at(from), source.pose_at(to));
    let from_upload: Vec<glam::Mat4> =
        now.mesh_transforms.iter().zip(&then.mesh_transforms).map(|(n, t)| *n * t.inverse()).collect();
    f.scene = source.posed(to);
    assert!(f.gpu_scene.move_meshes(&f.ctx, &f.scene, moved, &from_upload).expect("move"));
}

/// Renders the frame inputs (G-buffer, shadow maps) again, after the scene moved.
pub fn redraw_inputs(f: &mut Fixture) {
    let mut profiler = Profiler::new(&f.ctx, TimingMode::Passes);
    f.frame.render_inputs(&f.ctx, &f.gpu_scene, &mut profiler).expect("gbuffer");
}
