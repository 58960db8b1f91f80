//! The persistent renderer: a scene on the GPU, its frame resources and one active technique, stepped
//! one frame at a time while the time, camera, technique, parameters or size change.
//!
//! A change rebuilds only what it invalidates:
//! - time: poses the scene; a moved camera restarts accumulation; moved lights rewrite the light
//!   buffer, re-aim and re-render the shadow maps, and either update the technique in place
//!   ([`Technique::scene_changed`]) or create it anew; a moved sky sun is re-baked in place
//!   ([`GpuScene::update_environment`], [`Technique::scene_changed`]); moved meshes (rigid instances
//!   of the two-level BVH) have their vertices rewritten and the BVH's top level rebuilt
//!   ([`GpuScene::move_meshes`]; no upload, no bottom-level build), and shadow maps and RSMs render
//!   again;
//! - camera: restarts accumulation, keeps history (a camera move is not a cut; [`Renderer::cut`] is);
//! - parameters that only feed uniforms (`seed`, shadow filter, bias and offset) write uniforms; others
//!   create the technique anew (and the frame resources when the shadow-map size changes);
//! - technique: creates the new one (frame resources only if its shadow settings differ);
//! - size: frame resources, output and technique.
//!
//! History (`history_valid` in the frame uniforms) is invalid on the first frame and after a cut, a
//! parameter or technique change, a resize or a scene re-upload; accumulation (`sample_index`) restarts
//! after any change at all.

use std::collections::BTreeMap;
use std::time::Instant;

use glam::Mat4;
use serde::Serialize;

use crate::frame::{
    FRAME_UNIFORM_PARAMS, FrameResources, FrameSettings, FrameView, OUTPUT_FORMAT, ShadowSettings,
};
use crate::gpu::{
    AdapterSummary, GpuContext, GpuError, GpuScene, MemoryReport, PassTiming, Profiler, TimeSummary,
    TimingMode, readback,
};
use crate::image::HdrImage;
use crate::params::ParamValues;
use crate::post::motion_blur::{MotionBlur, MotionBlurSettings, ShutterPose};
use crate::scene::{Camera, Environment, Scene};
use crate::techniques::{
    self, FrameContext, Measured, NextPose, RenderError, SceneChange, Technique, TechniqueInfo,
    TechniqueSetup,
};

/// What to create a [`Renderer`] with.
#[derive(Clone, Debug)]
pub struct RendererSettings {
    /// A technique name from [`crate::techniques::registry`].
    pub technique: String,
    /// `key=value` technique parameters, validated against the technique's specs.
    pub technique_settings: Vec<(String, String)>,
    pub width: u32,
    pub height: u32,
    pub timing: TimingMode,
}

/// Where in its pixel each frame samples (the frame uniforms' `jitter`): the G-buffer and primary rays
/// sample pixel centre + jitter, and motion vectors stay those of the unjittered projection, so
/// history lookups need no correction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Jitter {
    /// Pixel centres: every technique's images compare pixel for pixel (the default).
    #[default]
    None,
    /// One offset in pixels, each component in [-0.5, 0.5).
    Fixed(glam::Vec2),
    /// The Halton (2, 3) sequence over 16 frames, by frame counter: accumulated frames box-filter
    /// each pixel (anti-aliasing), and temporal techniques get a new sub-pixel position every frame.
    Halton,
}

/// Length of the [`Jitter::Halton`] cycle.
pub const JITTER_CYCLE: u32 = 16;

impl Jitter {
    /// The offset of frame `frame_counter`.
    pub fn offset(self, frame_counter: u32) -> glam::Vec2 {
        match self {
            Jitter::None => glam::Vec2::ZERO,
            Jitter::Fixed(o) => o,
            Jitter::Halton => {
                let i = frame_counter % JITTER_CYCLE + 1;
                let halton = |base| crate::sequences::radical_inverse(base, i) as f32;
                glam::Vec2::new(halton(2), halton(3)) - 0.5
            }
        }
    }
}

impl std::str::FromStr for Jitter {
    type Err = String;
    /// `none`, `halton`, or a fixed offset `X,Y` in pixels.
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "none" => Ok(Jitter::None),
            "halton" => Ok(Jitter::Halton),
            other => {
                let parsed: Option<Vec<f32>> = other.split(',').map(|c| c.trim().parse().ok()).collect();
                match parsed.as_deref() {
                    Some([x, y]) => Ok(Jitter::Fixed(glam::Vec2::new(*x, *y))),
                    _ => Err(format!(
                        "unknown jitter '{other}'; use 'none', 'halton' or an offset 'X,Y' in pixels"
                    )),
                }
            }
        }
    }
}

/// How often the renderer had to redo setup work: a steady run shows none after the first frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RendererCounters {
    /// GPU scene uploads, each with a BVH build of every mesh.
    pub scene_uploads: u32,
    /// BVH builds of the scene's meshes (bottom levels; one per scene upload).
    pub bvh_builds: u32,
    /// Moving meshes moved in place: their vertices rewritten and the BVH's top level over instances
    /// rebuilt (no bottom-level build).
    pub geometry_updates: u32,
    /// Frame resources (G-buffer, shadow maps) created.
    pub frame_builds: u32,
    /// Techniques created.
    pub technique_builds: u32,
    /// Shader modules compiled, one per pipeline (on this renderer's device, by any user of it).
    pub shader_compilations: u64,
    /// Light updates applied in place (light buffer, shadow maps; technique updated itself).
    pub light_updates: u32,
    /// Environment updates applied in place (a moving sky sun re-baked; technique updated itself).
    pub environment_updates: u32,
}

/// Statistics of a run, written by `rtgi render --stats`.
#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    pub scene: String,
    pub technique: String,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub adapter: AdapterSummary,
    /// Wall time of the frames (excluding scene upload and pipeline creation).
    pub wall_ms: f64,
    /// Wall time of the first setup: scene upload, BVH build and pipeline creation.
    pub setup_ms: f64,
    /// How passes were submitted and timed (`frame`: one encoder per frame; `passes`: one submission
    /// per pass).
    pub timing: TimingMode,
    /// `reliable`, or why per-pass GPU times are absent.
    pub timestamps: String,
    /// Wall time per frame after the first (submission to completion), mean and 95th percentile.
    pub frame_wall: Option<TimeSummary>,
    /// GPU time per frame after the first (sum of the passes' timestamps), when reliable.
    pub frame_gpu: Option<TimeSummary>,
    pub passes: Vec<PassTiming>,
    pub parameters: BTreeMap<String, String>,
    pub triangles: usize,
    pub bvh_build_ms: f64,
    /// Where the BVH keeps its node and triangle tables (`textures` or `buffers`, see
    /// [`crate::gpu::BvhTables`]).
    pub bvh_tables: String,
    pub gpu_scene_bytes: u64,
    /// Setup work done while running (uploads, builds, shader compilations).
    pub renderer: RendererCounters,
    /// Scene time of the last frame, seconds.
    pub time: f32,
    /// Process and GPU memory after frames 1, 10, 100, 1000, ... and at the end of the run: a steady
    /// renderer keeps them flat after warm-up.
    pub memory: Vec<MemorySample>,
    /// How the G-buffer was made (`raster` or `trace`), for techniques that use one.
    pub primary: Option<String>,
    /// Technique-specific counters (e.g. VPL counts, bytes per pixel), and the G-buffer's
    /// `gbuffer_bytes_per_pixel` for techniques that use one.
    pub counters: BTreeMap<String, f64>,
    /// What the GPU upload had to change (e.g. textures downsampled to the array size).
    pub warnings: Vec<String>,
    /// The motion blur post-process's shutter and parameters, when it was on.
    pub motion_blur: Option<BTreeMap<String, String>>,
}

/// Memory after a number of frames.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MemorySample {
    pub frames: u32,
    #[serde(flatten)]
    pub report: MemoryReport,
}

/// A G-buffer channel that [`Renderer::read_aov`] can return.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    /// Distance along the primary ray (0 where it left the scene), in R, G and B.
    Depth,
    /// World-space shading normal, xyz in RGB.
    Normal,
    /// Base colour (linear RGB).
    Albedo,
    /// Emitted radiance.
    Emission,
    /// Screen-space motion in pixels (R: x, G: y, B: 0): from the pixel to where its surface point was
    /// in the previous frame, camera and object motion included.
    Motion,
    /// Index of the visible mesh (instance) in R, G and B; −1 where the primary ray left the scene.
    Instance,
}

impl std::str::FromStr for Aov {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "depth" => Ok(Aov::Depth),
            "normal" => Ok(Aov::Normal),
            "albedo" => Ok(Aov::Albedo),
            "emission" => Ok(Aov::Emission),
            "motion" => Ok(Aov::Motion),
            "instance" => Ok(Aov::Instance),
            _ => Err(format!("unknown AOV '{s}'; AOVs: depth, normal, albedo, emission, motion, instance")),
        }
    }
}

fn resolve(
    name: &str,
    settings: &[(String, String)],
) -> Result<(&'static TechniqueInfo, ParamValues), RenderError> {
    techniques::resolve(name, settings).map_err(|e| {
        if techniques::registry().iter().any(|t| t.name == name) {
            RenderError::InvalidSettings(e)
        } else {
            RenderError::UnknownTechnique {
                name: name.to_string(),
                available: techniques::registry().iter().map(|t| t.name).collect::<Vec<_>>().join(", "),
            }
        }
    })
}

fn check_size(width: u32, height: u32) -> Result<(), RenderError> {
    if width == 0 || height == 0 {
        return Err(RenderError::InvalidSettings(format!(
            "image size {width}x{height} is empty; width and height must be at least 1"
        )));
    }
    Ok(())
}

fn seed_of(params: &ParamValues) -> u32 {
    params.get("seed").map_or(0, |_| params.int("seed") as u32)
}

/// The radiance every technique writes (in place) and readback copies from.
fn output_texture(ctx: &GpuContext, width: u32, height: u32) -> Result<wgpu::Texture, GpuError> {
    crate::gpu::TextureBuilder::d2("radiance", width, height, OUTPUT_FORMAT)
        .storage()
        .sampled()
        .copy()
        .build(ctx)
}

/// The state the scene is shown in: the posed scene (world space at the current time).
struct Posed {
    scene: Scene,
    /// Per mesh, the transform of the uploaded geometry (identity for a static scene).
    mesh_transforms: Vec<Mat4>,
}

/// A persistent renderer. See the module documentation for what each change rebuilds.
pub struct Renderer {
    ctx: GpuContext,
    /// The scene as given (with its animation); [`Posed::scene`] is what is on the GPU.
    source: Scene,
    posed: Posed,
    gpu_scene: GpuScene,
    frame: FrameResources,
    output: wgpu::Texture,
    info: &'static TechniqueInfo,
    params: ParamValues,
    technique: Box<dyn Technique>,
    profiler: Profiler,
    time: f32,
    previous_time: Option<f32>,
    /// Scene seconds between frames, when the caller knows them ([`Self::set_time_step`]).
    time_step: Option<f32>,
    /// The time step over which the last frame predicted a change ([`NextPose`]), if it did.
    predicted_change_step: Option<f32>,
    /// Meshes, lights or the environment moved since the last frame.
    scene_moved: bool,
    camera: Camera,
    camera_override: bool,
    jitter: Jitter,
    previous_view_proj: Option<Mat4>,
    frame_counter: u32,
    sample_index: u32,
    history_valid: bool,
    counters: RendererCounters,
    /// Per mesh, the transform of the geometry in the previous frame (object motion vectors).
    previous_mesh_transforms: Option<Vec<Mat4>>,
    /// Per mesh, the transform of the geometry when the GPU scene was uploaded (its BVH instances map
    /// from there).
    uploaded_mesh_transforms: Vec<Mat4>,
    shader_compilations_at_start: u64,
    setup_ms: f64,
    memory: Vec<MemorySample>,
    /// The motion blur post-process, when on, and the `frame_builds` count it was built for (it binds
    /// the output and the frame's layouts, so it follows their rebuilds).
    motion_blur: Option<(MotionBlur, u32)>,
    motion_blur_settings: Option<MotionBlurSettings>,
}

impl Renderer {
    /// Uploads `scene` (posed at time 0 when animated), creates the frame resources and the technique.
    pub fn new(ctx: &GpuContext, scene: Scene, settings: &RendererSettings) -> Result<Self, RenderError> {
        let (info, params) = resolve(&settings.technique, &settings.technique_settings)?;
        check_size(settings.width, settings.height)?;
        let start = Instant::now();
        let shader_compilations_at_start = ctx.shader_compilations();
        let posed = pose(&scene, 0.0);
        let camera = posed.scene.camera;
        let (gpu_scene, frame, output, technique) = ctx.checked("setting up the render", || {
            let gpu_scene = GpuScene::with_moving_meshes(ctx, &posed.scene, &scene.moving_meshes())?;
            let frame = FrameResources::new(
                ctx,
                &gpu_scene,
                &posed.scene,
                settings.width,
                settings.height,
                FrameSettings::from_params(&params),
            )?;
            let output = output_texture(ctx, settings.width, settings.height)?;
            let technique = create_technique(ctx, &posed.scene, &gpu_scene, &frame, &output, info, &params)?;
            Ok::<_, RenderError>((gpu_scene, frame, output, technique))
        })??;
        ctx.wait_idle()?;
        let uploaded_mesh_transforms = posed.mesh_transforms.clone();
        let mut renderer = Renderer {
            ctx: ctx.clone(),
            source: scene,
            posed,
            gpu_scene,
            frame,
            output,
            info,
            params,
            technique,
            profiler: Profiler::new(ctx, settings.timing),
            time: 0.0,
            previous_time: None,
            time_step: None,
            predicted_change_step: None,
            scene_moved: false,
            camera,
            camera_override: false,
            jitter: Jitter::None,
            previous_view_proj: None,
            frame_counter: 0,
            sample_index: 0,
            history_valid: false,
            counters: RendererCounters {
                scene_uploads: 1,
                bvh_builds: 1,
                frame_builds: 1,
                technique_builds: 1,
                ..Default::default()
            },
            previous_mesh_transforms: None,
            uploaded_mesh_transforms,
            shader_compilations_at_start,
            setup_ms: 0.0,
            memory: Vec::new(),
            motion_blur: None,
            motion_blur_settings: None,
        };
        renderer.setup_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(renderer)
    }

    pub fn ctx(&self) -> &GpuContext {
        &self.ctx
    }

    /// The scene as given, with its animation.
    pub fn scene(&self) -> &Scene {
        &self.source
    }

    pub fn technique(&self) -> &'static TechniqueInfo {
        self.info
    }

    pub fn size(&self) -> (u32, u32) {
        (self.frame.width, self.frame.height)
    }

    /// The camera of the next frame.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    pub fn time(&self) -> f32 {
        self.time
    }

    /// Frames accumulated into the current image (restarts at 0 after any change).
    pub fn sample_index(&self) -> u32 {
        self.sample_index
    }

    /// Frames rendered so far, counting from the renderer's creation or the last
    /// [`Renderer::set_frame_counter`]: the dimension of the next frame's random numbers.
    pub fn frame_counter(&self) -> u32 {
        self.frame_counter
    }

    /// Starts the next frame's random numbers at frame `n`, so one frame of a sequence can be rendered
    /// on its own with exactly the samples it had in the sequence.
    pub fn set_frame_counter(&mut self, n: u32) {
        self.frame_counter = n;
    }

    /// Sets where the next frames sample within their pixels. Changing it restarts accumulation unless
    /// it is [`Jitter::Halton`], whose frames are meant to accumulate.
    pub fn set_jitter(&mut self, jitter: Jitter) -> Result<(), RenderError> {
        if let Jitter::Fixed(o) = jitter
            && !(o.cmpge(glam::Vec2::splat(-0.5)).all() && o.cmplt(glam::Vec2::splat(0.5)).all())
        {
            return Err(RenderError::InvalidSettings(format!(
                "jitter {o} is outside the pixel: each component must be in [-0.5, 0.5)"
            )));
        }
        if jitter != self.jitter {
            self.jitter = jitter;
            self.restart_accumulation();
        }
        Ok(())
    }

    pub fn jitter(&self) -> Jitter {
        self.jitter
    }

    /// Setup work done so far.
    pub fn counters(&self) -> RendererCounters {
        RendererCounters {
            shader_compilations: self.ctx.shader_compilations() - self.shader_compilations_at_start,
            ..self.counters
        }
    }

    /// Restarts accumulation (something the next frame shows changed).
    fn restart_accumulation(&mut self) {
        self.sample_index = 0;
    }

    /// Forgets the frame and pass times recorded so far (a benchmark's warm-up): [`Self::stats`] times
    /// the frames from here on, all but the first, as after creation.
    pub fn reset_timings(&mut self) {
        self.profiler.reset();
    }

    /// Marks the next frame as a cut: no history is valid, accumulation restarts.
    pub fn cut(&mut self) {
        self.history_valid = false;
        self.previous_view_proj = None;
        self.previous_mesh_transforms = None;
        self.restart_accumulation();
    }

    /// Views the scene from `camera` from now on (overriding the scene's camera and its animation).
    pub fn set_camera(&mut self, camera: Camera) {
        self.camera_override = true;
        self.look_through(camera);
    }

    /// Goes back to the scene's own (possibly animated) camera.
    pub fn use_scene_camera(&mut self) {
        self.camera_override = false;
        self.look_through(self.posed.scene.camera);
    }

    /// Renders the next frames from `camera`; a move restarts accumulation (and is not a cut).
    fn look_through(&mut self, camera: Camera) {
        if camera != self.camera {
            self.camera = camera;
            self.restart_accumulation();
        }
    }

    /// Poses the scene at time `t` (seconds). On a static scene only the time uniform changes.
    pub fn set_time(&mut self, t: f32) -> Result<(), RenderError> {
        if !t.is_finite() {
            return Err(RenderError::InvalidSettings(format!("time {t} is not a finite number of seconds")));
        }
        self.time = t;
        if !self.source.is_animated() {
            return Ok(());
        }
        let pose = self.source.pose_at(t);
        if !self.camera_override {
            self.look_through(pose.camera);
        }
        let ctx = self.ctx.clone();
        if pose.mesh_transforms != self.posed.mesh_transforms {
            self.restart_accumulation();
            self.scene_moved = true;
            let moved: Vec<usize> = (0..pose.mesh_transforms.len())
                .filter(|&m| pose.mesh_transforms[m] != self.posed.mesh_transforms[m])
                .collect();
            // Only the moved meshes are posed anew.
            for &m in &moved {
                self.posed.scene.meshes[m] = self.source.meshes[m].posed(pose.mesh_transforms[m]);
            }
            self.posed.mesh_transforms.clone_from(&pose.mesh_transforms);
            let from_upload: Vec<Mat4> = self
                .posed
                .mesh_transforms
                .iter()
                .zip(&self.uploaded_mesh_transforms)
                .map(
                    |(now, uploaded)| {
                        if now == uploaded { Mat4::IDENTITY } else { *now * uploaded.inverse() }
                    },
                )
                .collect();
            let in_place = ctx.checked("moving meshes", || {
                self.gpu_scene.move_meshes(&ctx, &self.posed.scene, &moved, &from_upload)
            })??;
            if !in_place {
                self.posed.scene.place_lights_and_camera(pose);
                return self.rebuild_scene();
            }
            self.counters.geometry_updates += 1;
            ctx.checked("moving meshes", || -> Result<(), RenderError> {
                self.frame.update_shadow_views(&ctx, &self.gpu_scene);
                if self.technique.scene_changed(&ctx, &self.gpu_scene, SceneChange::Geometry)? {
                    Ok(())
                } else {
                    self.rebuild_technique()
                }
            })??;
        }
        // Posing changes the environment only through a sky's sun; comparing that avoids copying a map.
        let sun = |e: &Environment| match e {
            Environment::Sky { sun_direction, .. } => Some(*sun_direction),
            _ => None,
        };
        let sun_before = sun(&self.posed.scene.environment);
        let lights_moved = pose.lights != self.posed.scene.lights;
        let environment_turned = pose.environment_rotation != self.posed.scene.environment_rotation;
        self.posed.scene.place_lights_and_camera(pose);
        let environment_changed = sun(&self.posed.scene.environment) != sun_before;
        if environment_turned {
            self.restart_accumulation();
            self.scene_moved = true;
            self.gpu_scene.rotate_environment(&ctx, self.posed.scene.environment_rotation);
            let updated = ctx.checked("turning the environment", || {
                self.technique.scene_changed(&ctx, &self.gpu_scene, SceneChange::EnvironmentRotation)
            })??;
            if updated {
                self.counters.environment_updates += 1;
            } else {
                self.rebuild_technique()?;
            }
        }
        if environment_changed {
            self.restart_accumulation();
            self.scene_moved = true;
            let in_place = ctx.checked("changing the environment", || {
                self.gpu_scene.update_environment(&ctx, &self.posed.scene.environment)
            })??;
            if !in_place {
                return self.rebuild_scene();
            }
            let updated = ctx.checked("changing the environment", || {
                self.technique.scene_changed(&ctx, &self.gpu_scene, SceneChange::Environment)
            })??;
            if updated {
                self.counters.environment_updates += 1;
            } else {
                self.rebuild_technique()?;
            }
        }
        if lights_moved {
            self.restart_accumulation();
            self.scene_moved = true;
            ctx.checked("moving the lights", || -> Result<(), RenderError> {
                self.gpu_scene.update_lights(&ctx, &self.posed.scene.lights)?;
                self.frame.update_shadow_views(&ctx, &self.gpu_scene);
                if self.technique.scene_changed(&ctx, &self.gpu_scene, SceneChange::Lights)? {
                    self.counters.light_updates += 1;
                    Ok(())
                } else {
                    self.rebuild_technique()
                }
            })??;
        }
        Ok(())
    }

    /// The scene time between this frame and the next (a sequence's 1 / fps; 0 for a held pose), for
    /// techniques that predict the next frame. Unset, the last step between frames stands for it.
    pub fn set_time_step(&mut self, seconds: f32) -> Result<(), RenderError> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(RenderError::InvalidSettings(format!(
                "time step {seconds} is not a finite, non-negative number of seconds"
            )));
        }
        self.time_step = Some(seconds);
        Ok(())
    }

    /// The animated scene a time step ahead, when the technique predicts it and anything moves.
    fn next_pose(&self, view: &FrameView) -> Option<NextPose> {
        let step = self.time_step.unwrap_or(view.delta_time);
        if !(self.technique.predicts_next_frame() && self.source.is_animated() && step > 0.0) {
            return None;
        }
        let pose = self.source.pose_at(self.time + step);
        let mesh_motion = pose
            .mesh_transforms
            .iter()
            .zip(&self.posed.mesh_transforms)
            .map(|(next, now)| if next == now { Mat4::IDENTITY } else { *next * now.inverse() })
            .collect();
        Some(NextPose { time_step: step, mesh_motion, lights: pose.lights })
    }

    /// Whether `next` moves anything.
    fn predicts_change(&self, next: &NextPose) -> bool {
        next.mesh_motion.iter().any(|m| *m != Mat4::IDENTITY) || next.lights != self.posed.scene.lights
    }

    /// Whether the frame about to be rendered shows the pose the last one predicted: the predicted
    /// change came about over a time step of the predicted length, or nothing was predicted to change
    /// and nothing moved. A jump in time, a pause after a predicted move, or a move nobody predicted
    /// (a scrubbed time line, an edited light) is not. Frame times jitter in the viewer, whose step is
    /// the last frame's, so a step between half and twice the predicted one counts as the predicted.
    fn prediction_held(&self, view: &FrameView) -> bool {
        match self.predicted_change_step {
            Some(step) => (0.5 * step..=2.0 * step).contains(&view.delta_time),
            None => !self.scene_moved,
        }
    }

    /// Validates and applies new technique parameters (all of them: unnamed ones take their defaults).
    /// Parameters that only feed uniforms (`seed`, `shadow_filter`, `shadow_bias`,
    /// `shadow_normal_offset`) rebuild nothing; others create the technique anew.
    pub fn set_parameters(&mut self, settings: &[(String, String)]) -> Result<(), RenderError> {
        let (_, params) = resolve(self.info.name, settings)?;
        let (old, new) = (self.params.to_map(), params.to_map());
        if old == new {
            return Ok(());
        }
        let structural =
            new.iter().any(|(k, v)| old.get(k) != Some(v) && !FRAME_UNIFORM_PARAMS.contains(&k.as_str()));
        self.params = params;
        self.cut();
        if structural {
            return self.rebuild_technique();
        }
        if let Some(shadows) = ShadowSettings::from_params(&self.params) {
            self.frame.set_shadow_settings(shadows)?;
        }
        Ok(())
    }

    /// Switches to another technique with `settings`.
    pub fn set_technique(&mut self, name: &str, settings: &[(String, String)]) -> Result<(), RenderError> {
        let (info, params) = resolve(name, settings)?;
        self.info = info;
        self.params = params;
        self.cut();
        // Timings and counters are per technique.
        self.profiler.reset();
        self.memory.clear();
        self.rebuild_technique()
    }

    /// Changes the image size.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<(), RenderError> {
        check_size(width, height)?;
        if (width, height) == self.size() {
            return Ok(());
        }
        self.cut();
        let ctx = self.ctx.clone();
        ctx.checked("resizing", || -> Result<(), RenderError> {
            self.frame = FrameResources::new(
                &ctx,
                &self.gpu_scene,
                &self.posed.scene,
                width,
                height,
                FrameSettings::from_params(&self.params),
            )?;
            self.counters.frame_builds += 1;
            self.output = output_texture(&ctx, width, height)?;
            self.technique = self.new_technique()?;
            self.counters.technique_builds += 1;
            Ok(())
        })?
    }

    fn new_technique(&self) -> Result<Box<dyn Technique>, RenderError> {
        create_technique(
            &self.ctx,
            &self.posed.scene,
            &self.gpu_scene,
            &self.frame,
            &self.output,
            self.info,
            &self.params,
        )
    }

    /// Creates the technique anew (and the frame resources when its shadow settings need other maps).
    fn rebuild_technique(&mut self) -> Result<(), RenderError> {
        let ctx = self.ctx.clone();
        ctx.checked("creating the technique", || -> Result<(), RenderError> {
            let settings = FrameSettings::from_params(&self.params);
            let same_maps = match (settings.shadows, self.frame.shadow_settings) {
                (Some(a), Some(b)) => a.size == b.size,
                (None, None) => true,
                _ => false,
            };
            if same_maps && settings.primary == self.frame.requested_primary {
                if let Some(s) = settings.shadows {
                    self.frame.set_shadow_settings(s)?;
                }
            } else {
                self.rebuild_frame(&ctx, settings)?;
            }
            self.technique = self.new_technique()?;
            self.counters.technique_builds += 1;
            Ok(())
        })?
    }

    fn rebuild_frame(&mut self, ctx: &GpuContext, settings: FrameSettings) -> Result<(), RenderError> {
        let (w, h) = self.size();
        self.frame = FrameResources::new(ctx, &self.gpu_scene, &self.posed.scene, w, h, settings)?;
        self.counters.frame_builds += 1;
        Ok(())
    }

    /// Uploads the posed scene anew, with the frame resources and technique that bind its buffers.
    fn rebuild_scene(&mut self) -> Result<(), RenderError> {
        // History stays valid: the new upload is the same scene moved, and motion vectors bridge it.
        let ctx = self.ctx.clone();
        ctx.checked("uploading the moved scene", || -> Result<(), RenderError> {
            self.gpu_scene =
                GpuScene::with_moving_meshes(&ctx, &self.posed.scene, &self.source.moving_meshes())?;
            self.uploaded_mesh_transforms.clone_from(&self.posed.mesh_transforms);
            self.counters.scene_uploads += 1;
            self.counters.bvh_builds += 1;
            self.rebuild_frame(&ctx, FrameSettings::from_params(&self.params))?;
            self.technique = self.new_technique()?;
            self.counters.technique_builds += 1;
            Ok(())
        })?
    }

    /// Blurs every frame from now on over `settings.shutter` seconds around its time with the
    /// non-linear motion blur post-process ([`crate::post::motion_blur`]); `None` turns it off.
    /// [`Self::output`] and [`Self::read_image`] then give the blurred image.
    pub fn set_motion_blur(&mut self, settings: Option<MotionBlurSettings>) -> Result<(), RenderError> {
        self.motion_blur = None;
        self.motion_blur_settings = settings;
        self.ensure_motion_blur()
    }

    /// Builds the motion blur post-process if it is on and not built for the current frame resources.
    fn ensure_motion_blur(&mut self) -> Result<(), RenderError> {
        let Some(settings) = &self.motion_blur_settings else {
            self.motion_blur = None;
            return Ok(());
        };
        let builds = self.counters.frame_builds;
        if self.motion_blur.as_ref().is_some_and(|(_, built_for)| *built_for == builds) {
            return Ok(());
        }
        let ctx = self.ctx.clone();
        let blur = ctx.checked("creating the motion blur", || {
            MotionBlur::new(&ctx, &self.gpu_scene, &self.frame, &self.output, settings.clone())
        })??;
        self.motion_blur = Some((blur, builds));
        Ok(())
    }

    /// Camera and meshes at the opening and closing of a `shutter` centred on the current time,
    /// relative to the current pose.
    fn shutter_pose(&self, shutter: f32) -> ShutterPose {
        let (w, h) = self.size();
        let aspect = w as f32 / h as f32;
        let meshes = self.posed.mesh_transforms.len();
        let at = |t: f32| -> (Mat4, Vec<Mat4>) {
            if !self.source.is_animated() {
                return (self.camera.view_projection(aspect), vec![Mat4::IDENTITY; meshes]);
            }
            let pose = self.source.pose_at(t);
            let camera = if self.camera_override { self.camera } else { pose.camera };
            let motion = pose
                .mesh_transforms
                .iter()
                .zip(&self.posed.mesh_transforms)
                .map(|(then, now)| if then == now { Mat4::IDENTITY } else { *then * now.inverse() })
                .collect();
            (camera.view_projection(aspect), motion)
        };
        let (open_view_proj, open) = at(self.time - 0.5 * shutter);
        let (close_view_proj, close) = at(self.time + 0.5 * shutter);
        ShutterPose {
            open_view_proj,
            close_view_proj,
            mesh_motion: open.into_iter().zip(close).map(|(o, c)| [o, c]).collect(),
        }
    }

    /// The brute-force reference of motion blur: the mean of `samples` frames at times stratified over
    /// a `shutter` centred on the current time (sample i at t + ((i + ½) / samples − ½) · shutter), each
    /// a fresh frame (history cut; `path` gives each one sample per pixel, so the mean also converges
    /// its noise). The motion blur post-process is off for these frames; the time is restored after.
    pub fn render_shutter_reference(&mut self, shutter: f32, samples: u32) -> Result<HdrImage, RenderError> {
        if !(shutter.is_finite() && shutter >= 0.0) || samples == 0 {
            return Err(RenderError::InvalidSettings(format!(
                "shutter reference: shutter {shutter} s must be finite and not negative, samples {samples} at \
                 least 1"
            )));
        }
        let blur = self.motion_blur_settings.take();
        self.motion_blur = None;
        let t = self.time;
        let (w, h) = self.size();
        let mut sum = vec![0.0f64; (w * h * 3) as usize];
        let result = (|| -> Result<(), RenderError> {
            for i in 0..samples {
                self.set_time(t + ((i as f32 + 0.5) / samples as f32 - 0.5) * shutter)?;
                self.cut();
                self.step()?;
                for (s, v) in sum.iter_mut().zip(self.read_image()?.rgb) {
                    *s += f64::from(v);
                }
            }
            Ok(())
        })();
        self.motion_blur_settings = blur;
        self.set_time(t)?;
        result?;
        let rgb = sum.iter().map(|&s| (s / f64::from(samples)) as f32).collect();
        Ok(HdrImage { width: w, height: h, rgb })
    }

    /// Per mesh, the matrix from its world position in this frame to the previous frame's: the uploaded
    /// geometry is posed at the current transform T, so the previous position is T_prev · T⁻¹ · p.
    fn mesh_motion(&self) -> Vec<Mat4> {
        match &self.previous_mesh_transforms {
            Some(previous) if previous.len() == self.posed.mesh_transforms.len() => previous
                .iter()
                .zip(&self.posed.mesh_transforms)
                .map(|(p, c)| if p == c { Mat4::IDENTITY } else { *p * c.inverse() })
                .collect(),
            _ => vec![Mat4::IDENTITY; self.posed.mesh_transforms.len()],
        }
    }

    /// The view data of the next frame.
    fn next_view(&self) -> FrameView {
        let (w, h) = self.size();
        let view_proj = self.camera.view_projection(w as f32 / h as f32);
        FrameView {
            camera: self.camera,
            view_proj,
            prev_view_proj: self.previous_view_proj.unwrap_or(view_proj),
            time: self.time,
            delta_time: self.previous_time.map_or(0.0, |p| self.time - p),
            jitter: self.jitter.offset(self.frame_counter),
            frame_counter: self.frame_counter,
            sample_index: self.sample_index,
            history_valid: self.history_valid,
        }
    }

    /// Renders one frame: its passes go into one command encoder (or one submission each with
    /// [`TimingMode::Passes`]), submitted and waited for.
    pub fn step(&mut self) -> Result<(), RenderError> {
        let view = self.next_view();
        let ctx = self.ctx.clone();
        self.ensure_motion_blur()?;
        let shutter = self.motion_blur.as_ref().map(|(m, _)| self.shutter_pose(m.settings().shutter));
        ctx.checked("rendering", || -> Result<(), RenderError> {
            self.frame.set_view(&ctx, &view, seed_of(&self.params));
            self.frame.set_mesh_motion(&ctx, &self.mesh_motion())?;
            self.profiler.begin_frame(&ctx);
            if self.info.needs.gbuffer || shutter.is_some() {
                self.frame.render_inputs(&ctx, &self.gpu_scene, &mut self.profiler)?;
            }
            let next = self.next_pose(&view);
            let fc = FrameContext {
                ctx: &ctx,
                gpu_scene: &self.gpu_scene,
                frame: &self.frame,
                view,
                next: next.as_ref(),
                prediction_held: self.prediction_held(&view),
            };
            self.technique.render_frame(&fc, &mut self.profiler)?;
            if let (Some((blur, _)), Some(pose)) = (self.motion_blur.as_mut(), shutter.as_ref()) {
                blur.record(&ctx, &self.gpu_scene, &self.frame, pose, &mut self.profiler)?;
            }
            self.predicted_change_step =
                next.as_ref().filter(|n| self.predicts_change(n)).map(|n| n.time_step);
            self.profiler.end_frame(&ctx)?;
            Ok(())
        })??;
        let frames = self.profiler.frames();
        let mut decade = frames;
        while decade.is_multiple_of(10) {
            decade /= 10;
        }
        if decade == 1 {
            self.memory.push(MemorySample { frames, report: self.ctx.memory_report() });
        }
        self.previous_view_proj = Some(view.view_proj);
        self.previous_mesh_transforms = Some(self.posed.mesh_transforms.clone());
        self.previous_time = Some(self.time);
        self.scene_moved = false;
        self.frame_counter = self.frame_counter.wrapping_add(1);
        self.sample_index += 1;
        self.history_valid = true;
        Ok(())
    }

    /// The radiance texture of the last frame (rgba32float, the size of the frame), for display on the
    /// GPU ([`crate::gpu::display::Display`]) without a readback: the technique's output, or its
    /// motion-blurred copy when motion blur is on. Replaced by a resize.
    pub fn output(&self) -> &wgpu::Texture {
        match &self.motion_blur {
            Some((blur, _)) => blur.blurred(),
            None => &self.output,
        }
    }

    /// The radiance of the last frame (the technique's output: accumulated where it accumulates;
    /// motion-blurred when motion blur is on).
    pub fn read_image(&self) -> Result<HdrImage, RenderError> {
        let texels = readback::read_texture(&self.ctx, self.output(), 16)?;
        Ok(rgba_to_image(self.size(), bytemuck::cast_slice(&texels), |p| [p[0], p[1], p[2]]))
    }

    /// A G-buffer channel of the current view, rendered now if the technique does not use the G-buffer.
    pub fn read_aov(&mut self, aov: Aov) -> Result<HdrImage, RenderError> {
        let ctx = self.ctx.clone();
        if !self.info.needs.gbuffer || self.profiler.frames() == 0 {
            let view = self.next_view();
            ctx.checked("rendering the G-buffer", || -> Result<(), RenderError> {
                self.frame.set_view(&ctx, &view, seed_of(&self.params));
                self.frame.set_mesh_motion(&ctx, &self.mesh_motion())?;
                let mut profiler = Profiler::new(&ctx, TimingMode::Passes);
                self.frame.render_inputs(&ctx, &self.gpu_scene, &mut profiler)?;
                Ok(())
            })??;
        }
        let g = &self.frame.gbuffer;
        let size = self.size();
        let half = |bytes: &[u8]| -> Vec<f32> {
            bytemuck::cast_slice::<u8, u16>(bytes).iter().map(|&b| half::f16::from_bits(b).to_f32()).collect()
        };
        Ok(match aov {
            Aov::Depth => {
                let d = readback::read_texture(&ctx, &g.distance, 4)?;
                let d: &[f32] = bytemuck::cast_slice(&d);
                HdrImage { width: size.0, height: size.1, rgb: d.iter().flat_map(|&v| [v, v, v]).collect() }
            }
            Aov::Normal => {
                let n = half(&readback::read_texture(&ctx, &g.normal, 8)?);
                rgba_to_image(size, &n, |p| decode_octahedral(p[0], p[1]))
            }
            Aov::Albedo => rgba_to_image(size, &half(&readback::read_texture(&ctx, &g.albedo, 8)?), |p| {
                [p[0], p[1], p[2]]
            }),
            Aov::Emission => {
                rgba_to_image(size, &half(&readback::read_texture(&ctx, &g.emission, 8)?), |p| {
                    [p[0], p[1], p[2]]
                })
            }
            Aov::Motion => {
                let m = readback::read_texture(&ctx, &g.motion, 8)?;
                let m: &[f32] = bytemuck::cast_slice(&m);
                HdrImage {
                    width: size.0,
                    height: size.1,
                    rgb: m.chunks_exact(2).flat_map(|v| [v[0], v[1], 0.0]).collect(),
                }
            }
            Aov::Instance => {
                let ids = readback::read_texture(&ctx, &g.instance, 4)?;
                let ids: &[u32] = bytemuck::cast_slice(&ids);
                let rgb = ids.iter().flat_map(|&id| [id as f32 - 1.0; 3]).collect();
                HdrImage { width: size.0, height: size.1, rgb }
            }
        })
    }

    /// Statistics of the frames since creation (or since the last technique change).
    pub fn stats(&mut self) -> Result<RenderStats, RenderError> {
        let passes = self.profiler.timings();
        let frames = self.profiler.frames();
        let measured = Measured { passes: &passes, frames_wall_ms: self.profiler.wall_ms() };
        let mut counters = self.technique.counters(&self.ctx, &measured)?;
        let primary = self.info.needs.gbuffer.then(|| {
            counters
                .insert("gbuffer_bytes_per_pixel".into(), f64::from(self.frame.gbuffer_bytes_per_pixel()));
            self.frame.primary.name().to_string()
        });
        let timestamps = match self.profiler.timestamp_status() {
            Ok(()) => "reliable".to_string(),
            Err(why) => why,
        };
        let mut memory = self.memory.clone();
        if memory.last().is_none_or(|m| m.frames != frames) {
            memory.push(MemorySample { frames, report: self.ctx.memory_report() });
        }
        let mut warnings: Vec<String> = self.gpu_scene.warnings.clone();
        warnings.extend(self.technique.warnings());
        if let Some((blur, _)) = &self.motion_blur {
            counters.insert("motion_blur_bytes".into(), blur.bytes() as f64);
        }
        let motion_blur = self.motion_blur_settings.as_ref().map(|m| {
            let mut settings = m.params.to_map();
            settings.insert("shutter".into(), m.shutter.to_string());
            settings
        });
        Ok(RenderStats {
            scene: self.source.name.clone(),
            technique: self.info.name.to_string(),
            width: self.frame.width,
            height: self.frame.height,
            frames,
            adapter: self.ctx.summary.clone(),
            wall_ms: self.profiler.wall_ms(),
            setup_ms: self.setup_ms,
            timing: self.profiler.mode(),
            timestamps,
            frame_wall: self.profiler.frame_wall(),
            frame_gpu: self.profiler.frame_gpu(),
            passes,
            parameters: self.params.to_map(),
            triangles: self.posed.scene.triangle_count(),
            bvh_build_ms: self.gpu_scene.bvh_build_ms,
            bvh_tables: self.gpu_scene.bvh_tables().name().to_string(),
            gpu_scene_bytes: self.gpu_scene.memory_bytes,
            renderer: self.counters(),
            time: self.time,
            memory,
            primary,
            counters,
            warnings,
            motion_blur,
        })
    }
}

fn create_technique(
    ctx: &GpuContext,
    scene: &Scene,
    gpu_scene: &GpuScene,
    frame: &FrameResources,
    output: &wgpu::Texture,
    info: &TechniqueInfo,
    params: &ParamValues,
) -> Result<Box<dyn Technique>, RenderError> {
    crate::gpu::require(ctx, info.features, info.name)?;
    (info.create)(&TechniqueSetup { ctx, scene, gpu_scene, frame, params, output })
}

/// The scene posed at `t`: a static scene as it is.
fn pose(scene: &Scene, t: f32) -> Posed {
    if scene.is_animated() {
        let pose = scene.pose_at(t);
        let mesh_transforms = pose.mesh_transforms.clone();
        Posed { scene: scene.posed_with(pose), mesh_transforms }
    } else {
        let mut still = scene.clone();
        still.animation = None;
        Posed { mesh_transforms: vec![Mat4::IDENTITY; scene.meshes.len()], scene: still }
    }
}

fn rgba_to_image(size: (u32, u32), rgba: &[f32], rgb: impl Fn(&[f32]) -> [f32; 3]) -> HdrImage {
    HdrImage { width: size.0, height: size.1, rgb: rgba.chunks_exact(4).flat_map(rgb).collect() }
}

/// The octahedral encoding of `common/math.wgsl` (shading normal in the G-buffer's xy), decoded.
fn decode_octahedral(x: f32, y: f32) -> [f32; 3] {
    let mut d = glam::Vec3::new(x, y, 1.0 - x.abs() - y.abs());
    let t = (-d.z).clamp(0.0, 1.0);
    d.x += if d.x >= 0.0 { -t } else { t };
    d.y += if d.y >= 0.0 { -t } else { t };
    d.normalize_or_zero().into()
}
