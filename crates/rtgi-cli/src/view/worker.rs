//! The viewer's render thread: it owns the library's [`Renderer`] (and a second one for comparisons),
//! applies the window's commands between frames, tone-maps each frame into a display texture on the
//! GPU and publishes its state. Rebuilds (a new technique, scene or size) run here, so the window
//! stays responsive and shows what is being built; errors are published, never fatal.

use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use eframe::egui;
use rtgi::gpu::display::Display;
use rtgi::gpu::{GpuContext, TimeSummary};
use rtgi::image::ToneMap;
use rtgi::post::motion_blur::MotionBlurSettings;
use rtgi::renderer::{Renderer, RendererSettings};
use rtgi::scene::{Camera, Scene, SceneSpec};

/// What the window asks of the render thread. Applied in order, between frames.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Load a scene (built-in spec or glTF path); the technique and its parameters stay.
    Scene(String),
    Technique {
        name: String,
        settings: Vec<(String, String)>,
    },
    /// All parameters of the current technique (unnamed ones take their defaults).
    Parameters(Vec<(String, String)>),
    Camera(Camera),
    /// Back to the scene's own (possibly animated) camera.
    SceneCamera,
    /// Scene time, seconds.
    Time(f32),
    RenderSize(u32, u32),
    Exposure(f32),
    /// Motion blur over a shutter of this many scene seconds around each frame's time, with the
    /// post-process's default parameters (0: off); the comparison is blurred alike.
    Shutter(f32),
    /// Render a second technique of the same view beside the first (`path` for the progressive
    /// reference), or stop.
    Compare(Option<String>),
    /// Compute the FLIP map of the view against the comparison (about once a second).
    FlipMap(bool),
    /// Stop rendering once this many frames have accumulated since the last change (`None`: render on).
    Hold(Option<u32>),
    /// Write the current radiance: `.png` (tone-mapped at the current exposure) or `.exr` (linear).
    Screenshot(PathBuf),
    Quit,
}

/// One pass's GPU (or, without reliable timestamps, wall) time per frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PassTime {
    pub name: String,
    pub time: Option<TimeSummary>,
}

/// What the render thread publishes for the window.
#[derive(Clone, Debug, Default)]
pub struct Status {
    pub scene: String,
    pub technique: String,
    /// Every parameter of the technique, resolved (defaults included).
    pub parameters: Vec<(String, String)>,
    pub adapter: String,
    pub size: (u32, u32),
    pub exposure: f32,
    pub time: f32,
    /// Motion blur's shutter, seconds (0: off).
    pub shutter: f32,
    pub camera: Camera,
    /// Whether the scene's camera is in use (false once the window moved it).
    pub scene_camera: bool,
    /// Length of the scene's animation, seconds (`None` for a still scene).
    pub animation: Option<f32>,
    /// Frames accumulated since the last change.
    pub samples: u32,
    /// The frame counter (random-number dimension) the current accumulation started at.
    pub first_frame: u32,
    /// Frames rendered since start.
    pub frames: u64,
    /// Commands applied so far (a script waits for its own).
    pub commands_done: u64,
    /// What is being built now, shown while the window waits.
    pub building: Option<String>,
    pub error: Option<String>,
    /// The last thing done that the user asked for (a screenshot written).
    pub message: Option<String>,
    /// Rendering paused: holding at the requested frame count, or stopped by an error.
    pub idle: bool,
    pub frame_gpu: Option<TimeSummary>,
    pub frame_wall: Option<TimeSummary>,
    /// `true` when the pass times are GPU timestamps, `false` when wall times.
    pub gpu_timings: bool,
    pub passes: Vec<PassTime>,
    pub gpu_bytes: Option<u64>,
    pub process_bytes: Option<u64>,
    /// Mean FLIP of the view against the comparison, and the comparison's sample count then.
    pub flip: Option<(f64, u32)>,
    pub done: bool,
}

/// The images the window shows (display textures are replaced when their size changes).
#[derive(Default)]
pub struct Images {
    pub main: Option<wgpu::Texture>,
    pub comparison: Option<wgpu::Texture>,
    /// The FLIP error map (8-bit sRGB, width, height), replaced about once a second.
    pub flip_map: Option<(Vec<u8>, u32, u32, u64)>,
}

#[derive(Default)]
pub struct Shared {
    pub status: Status,
    pub images: Images,
}

/// Everything the render thread starts from.
pub struct Start {
    pub ctx: GpuContext,
    pub scene: String,
    pub technique: String,
    pub settings: Vec<(String, String)>,
    pub size: (u32, u32),
    pub exposure: f32,
    pub camera: Option<String>,
}

struct Comparison {
    renderer: Renderer,
    display: Display,
}

struct Worker {
    ctx: GpuContext,
    shared: Arc<Mutex<Shared>>,
    repaint: egui::Context,
    renderer: Option<Renderer>,
    display: Display,
    comparison: Option<Comparison>,
    comparison_technique: Option<String>,
    scene_spec: String,
    technique: String,
    settings: Vec<(String, String)>,
    size: (u32, u32),
    exposure: f32,
    time: f32,
    /// Motion blur's shutter, seconds (0: off).
    shutter: f32,
    camera: Option<Camera>,
    hold: Option<u32>,
    flip_map: bool,
    last_flip: Option<Instant>,
    last_stats: Option<Instant>,
    failed: bool,
    frames: u64,
    commands_done: u64,
    /// Every parameter of the technique, resolved (defaults included): recomputed when the technique
    /// or its settings change, not per frame.
    parameters: Vec<(String, String)>,
    /// Whether the state since rendering stopped has been published (an idle thread publishes once).
    idle_published: bool,
}

/// Runs the render thread until [`Command::Quit`] or until the window's sender is dropped.
pub fn run(start: Start, commands: Receiver<Command>, shared: Arc<Mutex<Shared>>, repaint: egui::Context) {
    let display = match Display::new(&start.ctx) {
        Ok(d) => d,
        Err(e) => {
            publish_error(&shared, &repaint, format!("display pass: {e}"));
            return;
        }
    };
    let mut worker = Worker {
        ctx: start.ctx,
        shared,
        repaint,
        renderer: None,
        display,
        comparison: None,
        comparison_technique: None,
        scene_spec: start.scene,
        technique: start.technique,
        settings: start.settings,
        size: start.size,
        exposure: start.exposure,
        shutter: 0.0,
        time: 0.0,
        camera: None,
        hold: None,
        flip_map: false,
        last_flip: None,
        last_stats: None,
        failed: false,
        frames: 0,
        commands_done: 0,
        parameters: Vec::new(),
        idle_published: false,
    };
    worker.resolve_parameters();
    {
        let mut shared = worker.lock();
        shared.status.adapter = worker.ctx.summary.name.clone();
    }
    let camera = start.camera;
    worker.attempt("loading the scene", |w| {
        w.load_scene()?;
        if let (Some(text), Some(renderer)) = (&camera, &mut w.renderer) {
            let camera = Camera::parse_placement(text, &renderer.scene().camera)
                .map_err(|e| anyhow::anyhow!("--camera {e}"))?;
            w.camera = Some(camera);
            renderer.set_camera(camera);
        }
        Ok(())
    });
    loop {
        // Block while idle (holding, failed or nothing to render), so an idle viewer costs nothing.
        let idle = worker.idle();
        let command = if idle {
            match commands.recv_timeout(Duration::from_millis(100)) {
                Ok(c) => Some(c),
                Err(RecvTimeoutError::Timeout) => None,
                Err(RecvTimeoutError::Disconnected) => break,
            }
        } else {
            match commands.try_recv() {
                Ok(c) => Some(c),
                Err(TryRecvError::Empty) => None,
                Err(TryRecvError::Disconnected) => break,
            }
        };
        if let Some(command) = command {
            if command == Command::Quit {
                break;
            }
            worker.apply(command);
            worker.commands_done += 1;
            worker.publish(false);
            continue;
        }
        if worker.idle() {
            // Nothing rendered since the last publication but the step to idle: publish that once.
            if !worker.idle_published {
                worker.publish(true);
            }
            continue;
        }
        let result = worker.frame();
        worker.report("rendering", result);
        let stats_due = worker.last_stats.is_none_or(|t| t.elapsed() > Duration::from_millis(500));
        worker.publish(stats_due || worker.idle());
    }
    let mut shared = worker.lock();
    shared.status.done = true;
}

fn publish_error(shared: &Arc<Mutex<Shared>>, repaint: &egui::Context, error: String) {
    if let Ok(mut s) = shared.lock() {
        s.status.error = Some(error);
        s.status.idle = true;
    }
    repaint.request_repaint();
}

impl Worker {
    fn lock(&self) -> std::sync::MutexGuard<'_, Shared> {
        // A panic while holding the lock leaves plain data behind: keep using it.
        self.shared.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    fn idle(&self) -> bool {
        let Some(renderer) = &self.renderer else { return true };
        self.failed || self.hold.is_some_and(|n| renderer.sample_index() >= n)
    }

    /// Runs `f`, a rebuild: publishes `what` while it runs (the window shows it), clears the last error
    /// when it succeeds and publishes its error when it fails.
    fn attempt(&mut self, what: &str, f: impl FnOnce(&mut Self) -> anyhow::Result<()>) {
        self.lock().status.building = Some(what.to_string());
        self.repaint.request_repaint();
        let result = f(self);
        let mut shared = self.lock();
        shared.status.building = None;
        if result.is_ok() {
            shared.status.error = None;
        }
        drop(shared);
        self.report(what, result);
    }

    /// Publishes the error of `result`, if any; rendering then stops until the next command.
    fn report(&mut self, what: &str, result: anyhow::Result<()>) {
        if let Err(e) = result {
            self.lock().status.error = Some(format!("{what}: {e:#}"));
            self.failed = true;
        }
    }

    fn apply(&mut self, command: Command) {
        self.failed = false;
        match command {
            Command::Scene(spec) => {
                let previous = std::mem::replace(&mut self.scene_spec, spec);
                self.attempt("loading the scene", |w| w.load_scene());
                if self.failed {
                    self.scene_spec = previous;
                }
            }
            Command::Technique { name, settings } => {
                let previous = (self.technique.clone(), self.settings.clone());
                self.attempt(&format!("building {name}"), |w| {
                    let renderer = w.renderer.as_mut().ok_or_else(|| anyhow::anyhow!("no scene loaded"))?;
                    renderer.set_technique(&name, &settings)?;
                    w.technique = name.clone();
                    w.settings = settings.clone();
                    w.resolve_parameters();
                    Ok(())
                });
                if self.failed {
                    self.restore_technique(previous);
                }
            }
            Command::Parameters(settings) => {
                let previous = (self.technique.clone(), self.settings.clone());
                let name = self.technique.clone();
                self.attempt(&format!("building {name}"), |w| {
                    let renderer = w.renderer.as_mut().ok_or_else(|| anyhow::anyhow!("no scene loaded"))?;
                    renderer.set_parameters(&settings)?;
                    w.settings = settings.clone();
                    w.resolve_parameters();
                    Ok(())
                });
                if self.failed {
                    self.restore_technique(previous);
                }
            }
            Command::Camera(camera) => {
                self.camera = Some(camera);
                for r in self.renderers() {
                    r.set_camera(camera);
                }
            }
            Command::SceneCamera => {
                self.camera = None;
                for r in self.renderers() {
                    r.use_scene_camera();
                }
            }
            Command::Time(t) => {
                self.time = t;
                self.attempt("posing the scene", |w| {
                    for r in w.renderers() {
                        r.set_time(t)?;
                    }
                    Ok(())
                });
            }
            Command::RenderSize(width, height) => {
                self.attempt("resizing", |w| {
                    for r in w.renderers() {
                        r.resize(width, height)?;
                    }
                    w.size = (width, height);
                    Ok(())
                });
            }
            Command::Shutter(seconds) => {
                let previous = self.shutter;
                self.shutter = seconds;
                self.attempt("setting the motion blur", |w| w.apply_shutter());
                if self.failed {
                    self.shutter = previous;
                }
            }
            Command::Exposure(ev) => {
                self.exposure = ev;
                // A held image is shown again at the new exposure.
                let result = self.show();
                self.report("showing", result);
            }
            Command::Compare(technique) => {
                self.comparison = None;
                self.comparison_technique = technique.clone();
                self.lock().status.flip = None;
                if let Some(name) = technique {
                    self.attempt(&format!("building the comparison ({name})"), |w| w.build_comparison(&name));
                }
            }
            Command::FlipMap(on) => {
                self.flip_map = on;
                self.last_flip = None;
            }
            Command::Hold(n) => self.hold = n,
            Command::Screenshot(path) => {
                self.attempt("writing the screenshot", |w| {
                    let renderer = w.renderer.as_ref().ok_or_else(|| anyhow::anyhow!("no scene loaded"))?;
                    crate::create_parent(&path)?;
                    renderer.read_image()?.write(&path, &ToneMap { exposure_ev: w.exposure })?;
                    w.lock().status.message = Some(format!("wrote {}", path.display()));
                    Ok(())
                });
            }
            Command::Quit => {}
        }
    }

    /// After a failed technique change: back to what rendered before, so the window keeps a picture.
    fn restore_technique(&mut self, (name, settings): (String, Vec<(String, String)>)) {
        if let Some(renderer) = &mut self.renderer
            && renderer.set_technique(&name, &settings).is_ok()
        {
            self.technique = name;
            self.settings = settings;
            self.resolve_parameters();
            // The error stays on screen; rendering goes on with the previous technique.
            self.failed = false;
        }
    }

    fn resolve_parameters(&mut self) {
        if let Ok((_, values)) = rtgi::techniques::resolve(&self.technique, &self.settings) {
            self.parameters = values.to_map().into_iter().collect();
        }
    }

    fn renderers(&mut self) -> impl Iterator<Item = &mut Renderer> {
        self.renderer.iter_mut().chain(self.comparison.iter_mut().map(|c| &mut c.renderer))
    }

    fn load_scene(&mut self) -> anyhow::Result<()> {
        let spec = SceneSpec::parse(&self.scene_spec).map_err(|e| anyhow::anyhow!("scene {e}"))?;
        spec.validate()?;
        let scene = spec.load()?;
        if !scene.warnings.is_empty() {
            self.lock().status.message = Some(format!("warning: {}", scene.warnings.join("; ")));
        }
        self.renderer = None;
        self.comparison = None;
        let mut renderer =
            Renderer::new(&self.ctx, scene, &self.settings_for(&self.technique, &self.settings))?;
        renderer.set_time(self.time)?;
        self.renderer = Some(renderer);
        self.camera = None;
        if let Some(name) = self.comparison_technique.clone() {
            self.build_comparison(&name)?;
        }
        self.apply_shutter()
    }

    /// Gives every renderer the current shutter's motion blur (or none).
    fn apply_shutter(&mut self) -> anyhow::Result<()> {
        let blur = if self.shutter > 0.0 {
            Some(MotionBlurSettings::new(self.shutter, &[]).map_err(anyhow::Error::msg)?)
        } else {
            None
        };
        for r in self.renderers() {
            r.set_motion_blur(blur.clone())?;
        }
        Ok(())
    }

    fn settings_for(&self, technique: &str, settings: &[(String, String)]) -> RendererSettings {
        RendererSettings {
            technique: technique.to_string(),
            technique_settings: settings.to_vec(),
            width: self.size.0,
            height: self.size.1,
            timing: rtgi::gpu::TimingMode::Frame,
        }
    }

    fn build_comparison(&mut self, technique: &str) -> anyhow::Result<()> {
        let renderer = self.renderer.as_ref().ok_or_else(|| anyhow::anyhow!("no scene loaded"))?;
        let scene: Scene = renderer.scene().clone();
        let mut comparison = Renderer::new(&self.ctx, scene, &self.settings_for(technique, &[]))?;
        comparison.set_time(self.time)?;
        if let Some(camera) = self.camera {
            comparison.set_camera(camera);
        }
        self.comparison = Some(Comparison { renderer: comparison, display: Display::new(&self.ctx)? });
        self.apply_shutter()
    }

    /// Renders one frame of each renderer and shows it.
    fn frame(&mut self) -> anyhow::Result<()> {
        for r in self.renderers() {
            r.step()?;
        }
        self.frames += 1;
        self.show()?;
        // About once a second while rendering, and on the frame a hold stops at (the image then shown).
        let due = self.last_flip.is_none_or(|t| t.elapsed() > Duration::from_secs(1)) || self.idle();
        if self.flip_map && due {
            self.update_flip()?;
        }
        Ok(())
    }

    /// Tone-maps the latest frames into the display textures.
    fn show(&mut self) -> anyhow::Result<()> {
        let Some(renderer) = &self.renderer else { return Ok(()) };
        self.display.update(&self.ctx, renderer.output(), self.exposure)?;
        if let Some(c) = &mut self.comparison {
            c.display.update(&self.ctx, c.renderer.output(), self.exposure)?;
        }
        let main = self.display.texture().clone();
        let comparison = self.comparison.as_ref().map(|c| c.display.texture().clone());
        let mut shared = self.lock();
        shared.images.main = Some(main);
        shared.images.comparison = comparison;
        Ok(())
    }

    fn update_flip(&mut self) -> anyhow::Result<()> {
        let (Some(renderer), Some(c)) = (&self.renderer, &self.comparison) else { return Ok(()) };
        let reference = c.renderer.read_image()?;
        let image = renderer.read_image()?;
        let (map, mean) = rtgi::metrics::flip_map(&reference, &image)?;
        let rgb = rtgi::metrics::error_map_rgb8(&map, image.width, image.height);
        let samples = c.renderer.sample_index();
        self.last_flip = Some(Instant::now());
        let mut shared = self.lock();
        shared.status.flip = Some((mean, samples));
        let serial = shared.images.flip_map.as_ref().map_or(0, |m| m.3 + 1);
        shared.images.flip_map = Some((rgb, image.width, image.height, serial));
        Ok(())
    }

    /// Publishes the state; `stats` also gathers timings and memory (a readback of timestamps, so not
    /// every frame).
    fn publish(&mut self, stats: bool) {
        let idle = self.idle();
        self.idle_published = idle && stats;
        let stats = if stats { self.renderer.as_mut().map(|r| r.stats()) } else { None };
        if stats.is_some() {
            self.last_stats = Some(Instant::now());
        }
        let renderer_state = self.renderer.as_ref().map(|r| {
            (
                r.sample_index(),
                r.frame_counter().wrapping_sub(r.sample_index()),
                r.size(),
                r.camera(),
                Some(r.scene().animation_duration()),
            )
        });
        let mut shared = self.lock();
        let s = &mut shared.status;
        s.scene = self.scene_spec.clone();
        s.technique = self.technique.clone();
        // Not from the (occasional) statistics, so a script's next `set` starts from the technique
        // just switched to.
        s.parameters = self.parameters.clone();
        s.exposure = self.exposure;
        s.time = self.time;
        s.shutter = self.shutter;
        s.frames = self.frames;
        s.commands_done = self.commands_done;
        s.idle = idle;
        s.scene_camera = self.camera.is_none();
        if let Some((samples, first_frame, size, camera, animation)) = renderer_state {
            s.samples = samples;
            s.first_frame = first_frame;
            s.size = size;
            s.camera = camera;
            s.animation = animation.filter(|d| *d > 0.0);
        }
        match stats {
            Some(Ok(stats)) => {
                s.frame_gpu = stats.frame_gpu;
                s.frame_wall = stats.frame_wall;
                s.gpu_timings = stats.timestamps == "reliable";
                s.passes = stats
                    .passes
                    .into_iter()
                    .map(|p| PassTime { name: p.name, time: if s.gpu_timings { p.gpu } else { None } })
                    .collect();
                let memory = stats.memory.last().map(|m| m.report);
                s.gpu_bytes = memory.map(|m| m.gpu_buffer_bytes + m.gpu_texture_bytes);
                s.process_bytes = memory.and_then(|m| m.rss_bytes);
            }
            Some(Err(e)) => s.error = Some(format!("statistics: {e}")),
            None => {}
        }
        drop(shared);
        self.repaint.request_repaint();
    }
}
