//! `rtgi view`: a window to fly through a scene and switch techniques live. It adds no rendering of its
//! own: a render thread ([`worker`]) drives the library's renderer and its GPU tone map; the window
//! (eframe on the same wgpu device) shows the result beside an egui panel ([`panel`]).

mod fly;
pub mod panel;
mod script;
pub mod worker;

use std::path::PathBuf;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use anyhow::{Context, anyhow, bail};
use clap::Args;
use eframe::egui;
use rtgi::params::{parse_setting, parse_size};

use fly::{FlyCamera, FlyInput};
use panel::{PanelState, Request};
use script::Action;
use worker::{Command, Shared, Status};

#[derive(Args)]
pub struct ViewArgs {
    /// Built-in scene (NAME or NAME:key=value,...) or a .gltf/.glb file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Technique (see `rtgi list`).
    #[arg(long, default_value = "ddgi")]
    technique: String,
    /// Technique parameter; repeat for several.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Window size, WxH (logical points).
    #[arg(long, default_value = "1280x720", value_name = "WxH")]
    size: String,
    /// Render at this fixed size instead of following the image area (times --render-scale of the panel).
    #[arg(long, value_name = "WxH")]
    render_size: Option<String>,
    /// Exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_name = "EV")]
    exposure: f32,
    /// Start from this camera instead of the scene's (as `rtgi render --camera`).
    #[arg(long, value_name = "X,Y,Z,TX,TY,TZ,FOV", allow_hyphen_values = true)]
    camera: Option<String>,
    /// Run the UI actions of this file (one per line; see the module documentation of `script`:
    /// frames N, technique NAME [K=V..], set K=V.., camera .., time S, shutter S, compare T|off, flip on|off,
    /// screenshot FILE, window-screenshot FILE, measure N FILE.json, quit, ...).
    #[arg(long, value_name = "FILE")]
    script: Option<PathBuf>,
    #[command(flatten)]
    gpu: crate::GpuArgs,
}

pub fn run(args: &ViewArgs) -> anyhow::Result<()> {
    let (width, height) = parse_size(&args.size).map_err(|e| anyhow!("--size {e}"))?;
    let render_size =
        args.render_size.as_deref().map(parse_size).transpose().map_err(|e| anyhow!("--render-size {e}"))?;
    if !args.exposure.is_finite() {
        bail!("--exposure '{}' is not a finite number of stops", args.exposure);
    }
    let settings = args
        .set
        .iter()
        .map(|s| parse_setting(s).map_err(|e| anyhow!("--set {e}")))
        .collect::<anyhow::Result<Vec<_>>>()?;
    rtgi::scene::SceneSpec::parse(&args.scene).map_err(|e| anyhow!("--scene {e}"))?.validate()?;
    rtgi::techniques::resolve(&args.technique, &settings).map_err(anyhow::Error::msg)?;
    let script = match &args.script {
        Some(path) => {
            let text =
                std::fs::read_to_string(path).with_context(|| format!("--script {}", path.display()))?;
            Some(script::parse(path, &text)?)
        }
        None => None,
    };
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        bail!(
            "rtgi view needs a display: neither DISPLAY nor WAYLAND_DISPLAY is set. On a headless machine \
             run it under a virtual X server (`xvfb-run -a rtgi view ...`), or use `rtgi render`"
        );
    }
    let gpu = args.gpu.context()?;
    let shared: Arc<Mutex<Shared>> = Arc::default();
    report_uncaptured_errors(&gpu.device, &shared);
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("rtgi view")
            .with_inner_size([width as f32, height as f32]),
        renderer: eframe::Renderer::Wgpu,
        wgpu_options: eframe::egui_wgpu::WgpuConfiguration {
            wgpu_setup: eframe::egui_wgpu::WgpuSetup::Existing(eframe::egui_wgpu::WgpuSetupExisting {
                instance: gpu.instance.clone(),
                adapter: gpu.adapter.clone(),
                device: gpu.device.clone(),
                queue: gpu.queue.clone(),
            }),
            ..Default::default()
        },
        ..Default::default()
    };
    let failure: Arc<Mutex<Option<String>>> = Arc::default();
    let start = worker::Start {
        ctx: gpu,
        scene: args.scene.clone(),
        technique: args.technique.clone(),
        settings,
        // Until the window reports its image area: a small first frame.
        size: render_size.unwrap_or((320, 180)),
        exposure: args.exposure,
        camera: args.camera.clone(),
    };
    let panel = PanelState::new(&args.scene, &args.technique, args.exposure, render_size.is_some());
    let app_failure = failure.clone();
    eframe::run_native(
        "rtgi view",
        options,
        Box::new(move |cc| Ok(Box::new(Viewer::new(cc, start, shared, panel, script, app_failure)))),
    )
    .map_err(|e| anyhow!("rtgi view: the window could not run: {e}"))?;
    if let Some(message) = failure.lock().ok().and_then(|f| f.clone()) {
        bail!("{message}");
    }
    Ok(())
}

/// Shows device errors outside error scopes in the panel instead of wgpu's default (a panic), so the
/// window survives them. One is expected: wgpu refuses to reconfigure the window's surface (on a
/// resize) while the render thread is submitting, and egui configures it again on the next frame.
fn report_uncaptured_errors(device: &wgpu::Device, shared: &Arc<Mutex<Shared>>) {
    let shared = shared.clone();
    device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
        let text = error_line(&error);
        if let Ok(mut s) = shared.lock() {
            if text.contains("reconfiguring the Surface") {
                s.status.message = Some(format!("window resize raced a frame; retried ({text})"));
            } else {
                s.status.error = Some(format!("GPU error: {text}"));
            }
        }
    }));
}

/// A wgpu error on one line (its `Display` nests causes over lines).
fn error_line(error: &wgpu::Error) -> String {
    error.to_string().split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A registered native texture and the texture it shows.
struct Shown {
    id: egui::TextureId,
    texture: wgpu::Texture,
}

struct Viewer {
    commands: Sender<Command>,
    shared: Arc<Mutex<Shared>>,
    worker: Option<std::thread::JoinHandle<()>>,
    panel: PanelState,
    fly: Option<FlyCamera>,
    /// Commands sent so far, and the number of the last camera move sent: until the render thread has
    /// applied it, its reported camera is older than the fly camera's.
    sent: u64,
    camera_sent: u64,
    main: Option<Shown>,
    comparison: Option<Shown>,
    flip: Option<(egui::TextureHandle, u64)>,
    /// The render size last asked for and since when the image area has had another size.
    requested_size: Option<(u32, u32)>,
    resize_since: Option<(Instant, (u32, u32))>,
    last_frame: Instant,
    script: Option<ScriptRunner>,
    failure: Arc<Mutex<Option<String>>>,
    pending_window_shot: Option<PathBuf>,
    /// Where the window screenshot arrives (egui calls back once the frame is captured).
    window_shot: Arc<Mutex<Option<Arc<egui::ColorImage>>>>,
}

impl Viewer {
    fn new(
        cc: &eframe::CreationContext,
        start: worker::Start,
        shared: Arc<Mutex<Shared>>,
        panel: PanelState,
        script: Option<Vec<Action>>,
        failure: Arc<Mutex<Option<String>>>,
    ) -> Viewer {
        let (commands, receiver) = std::sync::mpsc::channel();
        let worker_shared = shared.clone();
        let repaint = cc.egui_ctx.clone();
        let worker = std::thread::Builder::new()
            .name("rtgi render".into())
            .spawn(move || worker::run(start, receiver, worker_shared, repaint))
            .ok();
        if worker.is_none()
            && let Ok(mut s) = shared.lock()
        {
            s.status.error = Some("could not start the render thread".into());
        }
        Viewer {
            commands,
            shared,
            worker,
            panel,
            fly: None,
            sent: 0,
            camera_sent: 0,
            main: None,
            comparison: None,
            flip: None,
            requested_size: None,
            resize_since: None,
            last_frame: Instant::now(),
            script: script.map(ScriptRunner::new),
            failure,
            pending_window_shot: None,
            window_shot: Arc::default(),
        }
    }

    /// Sends a command to the render thread; returns its number (the thread reports how many it has
    /// applied in `Status::commands_done`).
    fn send(&mut self, command: Command) -> u64 {
        // A closed channel means the render thread ended; its last status says why.
        let _ = self.commands.send(command);
        self.sent += 1;
        self.sent
    }

    fn status(&self) -> Status {
        self.shared.lock().unwrap_or_else(|p| p.into_inner()).status.clone()
    }

    /// Registers (or re-points) the display textures with egui when the render thread replaced them.
    fn refresh_textures(&mut self, frame: &eframe::Frame, ui: &egui::Ui) {
        let Some(render_state) = frame.wgpu_render_state() else { return };
        let shown_flip = self.flip.as_ref().map(|(_, serial)| *serial);
        let (main, comparison, flip) = {
            let shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            // The map's pixels are copied only when a new one arrived.
            let flip = shared
                .images
                .flip_map
                .as_ref()
                .filter(|(.., serial)| Some(*serial) != shown_flip)
                .map(|(rgb, w, h, serial)| (rgb.clone(), *w, *h, *serial));
            (shared.images.main.clone(), shared.images.comparison.clone(), flip)
        };
        let replaced = |slot: &Option<Shown>, texture: &Option<wgpu::Texture>| {
            slot.as_ref().map(|s| &s.texture) != texture.as_ref()
        };
        if replaced(&self.main, &main) || replaced(&self.comparison, &comparison) {
            let mut renderer = render_state.renderer.write();
            for (slot, texture) in [(&mut self.main, main), (&mut self.comparison, comparison)] {
                match texture {
                    Some(texture) => {
                        // sRGB-encoded values in a unorm texture: what egui composites as is.
                        let view = texture.create_view(&Default::default());
                        match slot {
                            Some(shown) if shown.texture == texture => {}
                            Some(shown) => {
                                renderer.update_egui_texture_from_wgpu_texture(
                                    &render_state.device,
                                    &view,
                                    wgpu::FilterMode::Linear,
                                    shown.id,
                                );
                                shown.texture = texture;
                            }
                            None => {
                                let id = renderer.register_native_texture(
                                    &render_state.device,
                                    &view,
                                    wgpu::FilterMode::Linear,
                                );
                                *slot = Some(Shown { id, texture });
                            }
                        }
                    }
                    None => {
                        if let Some(shown) = slot.take() {
                            renderer.free_texture(&shown.id);
                        }
                    }
                }
            }
        }
        if let Some((rgb, w, h, serial)) = flip {
            let image = egui::ColorImage::from_rgb([w as usize, h as usize], &rgb);
            let handle = ui.ctx().load_texture("flip map", image, egui::TextureOptions::LINEAR);
            self.flip = Some((handle, serial));
        }
    }

    /// The central image: the view, the comparison right of the split, or the FLIP map; camera input.
    fn image_area(&mut self, ui: &mut egui::Ui, status: &Status) {
        let area = ui.available_size();
        if !self.panel.fixed_size {
            let pixels = ui.ctx().pixels_per_point();
            let scale = self.panel.render_scale * pixels;
            let wanted = (((area.x * scale) as u32).max(16), ((area.y * scale) as u32).max(16));
            self.follow_area(wanted);
        }
        let (w, h) = status.size;
        if w == 0 || h == 0 {
            ui.centered_and_justified(|ui| ui.spinner());
            return;
        }
        let aspect = w as f32 / h as f32;
        let fit = if area.x / area.y > aspect {
            egui::vec2(area.y * aspect, area.y)
        } else {
            egui::vec2(area.x, area.x / aspect)
        };
        let (rect, response) = ui.allocate_exact_size(area, egui::Sense::click_and_drag());
        let image_rect = egui::Rect::from_center_size(rect.center(), fit);
        let painter = ui.painter_at(rect);
        let full_uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
        let flip = self.flip.as_ref().filter(|_| self.panel.flip_map && self.panel.comparison.is_some());
        if let Some((handle, _)) = flip {
            painter.image(handle.id(), image_rect, full_uv, egui::Color32::WHITE);
        } else if let Some(main) = &self.main {
            painter.image(main.id, image_rect, full_uv, egui::Color32::WHITE);
            if let Some(comparison) = self.comparison.as_ref().filter(|_| self.panel.comparison.is_some()) {
                let s = self.panel.split;
                let right = egui::Rect::from_min_max(
                    egui::pos2(image_rect.left() + s * image_rect.width(), image_rect.top()),
                    image_rect.max,
                );
                let uv = egui::Rect::from_min_max(egui::pos2(s, 0.0), egui::pos2(1.0, 1.0));
                painter.image(comparison.id, right, uv, egui::Color32::WHITE);
                painter.vline(
                    right.left(),
                    image_rect.y_range(),
                    egui::Stroke::new(1.0, egui::Color32::WHITE),
                );
            }
        }
        // Camera: keys while nothing else has keyboard focus, drags and the wheel over the image.
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f32().min(0.1);
        self.last_frame = now;
        let keys = !ui.ctx().egui_wants_keyboard_input();
        let drag = if response.dragged() { response.drag_delta() } else { egui::Vec2::ZERO };
        let input = ui.input(|i| FlyInput::gather(i, keys, drag, response.hovered()));
        let moves_applied = status.commands_done >= self.camera_sent;
        if self.fly.as_ref().is_none_or(|f| f.camera != status.camera && moves_applied) {
            // Follow the renderer's camera when something else set it (scene camera, script, animation,
            // a new scene) once the render thread has applied every move sent from here.
            let speed = self.fly.as_ref().map(|f| f.speed);
            let mut fly = FlyCamera::new(status.camera);
            if let Some(speed) = speed {
                fly.speed = speed;
            }
            self.fly = Some(fly);
        }
        if let Some(mut fly) = self.fly.take() {
            if fly.update(&input, dt) {
                self.camera_sent = self.send(Command::Camera(fly.camera));
            }
            self.panel.speed = fly.speed;
            self.fly = Some(fly);
        }
        if input.any_key() {
            ui.ctx().request_repaint();
        }
    }

    /// Asks for a new render size once the image area has kept its new size for a moment (a window
    /// being resized would otherwise rebuild the frame resources on every step).
    fn follow_area(&mut self, wanted: (u32, u32)) {
        if self.requested_size == Some(wanted) {
            self.resize_since = None;
            return;
        }
        let now = Instant::now();
        match self.resize_since {
            Some((since, size)) if size == wanted => {
                if now - since > std::time::Duration::from_millis(250) || self.requested_size.is_none() {
                    self.requested_size = Some(wanted);
                    self.resize_since = None;
                    self.send(Command::RenderSize(wanted.0, wanted.1));
                }
            }
            _ => self.resize_since = Some((now, wanted)),
        }
    }

    fn handle(&mut self, ui: &egui::Ui, request: Request) {
        match request {
            Request::Command(c) => {
                self.send(c);
            }
            Request::WindowScreenshot(path) => {
                self.pending_window_shot = Some(path);
                let (arrived, ctx) = (self.window_shot.clone(), ui.ctx().clone());
                let callback = egui::ScreenshotCallback::new(move |image| {
                    if let Ok(mut slot) = arrived.lock() {
                        *slot = Some(image);
                    }
                    ctx.request_repaint();
                });
                ui.ctx().send_viewport_cmd(egui::ViewportCommand::Screenshot(callback));
            }
            Request::CopyText(text) => {
                ui.ctx().copy_text(text.clone());
                if let Ok(mut s) = self.shared.lock() {
                    s.status.message = Some(format!("copied: {text}"));
                }
            }
        }
    }

    /// Writes a window screenshot that arrived this frame; returns whether one did.
    fn save_window_screenshot(&mut self) -> anyhow::Result<bool> {
        let image = self.window_shot.lock().ok().and_then(|mut slot| slot.take());
        let Some(image) = image else { return Ok(false) };
        let Some(path) = self.pending_window_shot.take() else { return Ok(false) };
        let rgb: Vec<u8> = image.pixels.iter().flat_map(|p| [p.r(), p.g(), p.b()]).collect();
        crate::create_parent(&path)?;
        rtgi::image::write_rgb8_png(&path, image.size[0] as u32, image.size[1] as u32, &rgb)?;
        if let Ok(mut s) = self.shared.lock() {
            s.status.message = Some(format!("wrote {}", path.display()));
        }
        Ok(true)
    }
}

impl eframe::App for Viewer {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let status = self.status();
        self.refresh_textures(frame, ui);
        let shot = match self.save_window_screenshot() {
            Ok(shot) => shot,
            Err(e) => {
                self.fail(ui, format!("window screenshot: {e:#}"));
                false
            }
        };
        if self.panel.playing
            && let Some(duration) = status.animation
        {
            let dt = ui.input(|i| i.stable_dt).min(0.1);
            self.send(Command::Time((status.time + dt) % duration));
        }
        let requests = egui::Panel::left("panel")
            .resizable(true)
            .default_size(330.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| panel::panel(ui, &mut self.panel, &status)).inner
            })
            .inner;
        for request in requests {
            self.handle(ui, request);
        }
        egui::CentralPanel::default().show(ui, |ui| self.image_area(ui, &status));
        if let Some(mut runner) = self.script.take() {
            match runner.step(self, ui, &status, shot) {
                Ok(true) => self.script = Some(runner),
                Ok(false) => {}
                Err(e) => self.fail(ui, format!("{e:#}")),
            }
        }
        if status.done {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }

    fn on_exit(&mut self) {
        self.send(Command::Quit);
        if let Some(worker) = self.worker.take() {
            let _ = worker.join();
        }
    }
}

impl Viewer {
    /// Ends a scripted run with an error (the process exits non-zero).
    fn fail(&mut self, ui: &egui::Ui, message: String) {
        if let Ok(mut f) = self.failure.lock() {
            f.get_or_insert(message);
        }
        self.script = None;
        ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
    }
}

/// Runs a script's actions, one at a time, each waiting for the render thread where it must.
struct ScriptRunner {
    actions: std::collections::VecDeque<Action>,
    /// The number of the script's last command; an action is done once the render thread has applied it.
    sent: u64,
    waiting: Option<Wait>,
}

enum Wait {
    Applied,
    Frames(u32),
    WindowShot,
    Measure { frames: u32, from: u64, since: Instant, path: PathBuf },
}

impl ScriptRunner {
    fn new(actions: Vec<Action>) -> ScriptRunner {
        ScriptRunner { actions: actions.into(), sent: 0, waiting: None }
    }

    fn send(&mut self, viewer: &mut Viewer, command: Command) {
        self.sent = viewer.send(command);
        self.waiting = Some(Wait::Applied);
    }

    /// Advances the script; `false` once it has ended.
    fn step(
        &mut self,
        viewer: &mut Viewer,
        ui: &egui::Ui,
        status: &Status,
        shot: bool,
    ) -> anyhow::Result<bool> {
        ui.ctx().request_repaint();
        let applied = status.commands_done >= self.sent && status.building.is_none();
        if applied && let Some(error) = &status.error {
            bail!("script: the renderer reported: {error}");
        }
        match &self.waiting {
            Some(Wait::Applied) if !applied => return Ok(true),
            Some(Wait::Frames(n)) if !(applied && status.idle && status.samples >= *n) => return Ok(true),
            Some(Wait::WindowShot) if !shot => return Ok(true),
            Some(Wait::Measure { frames, from, since, path }) => {
                if status.frames < from + u64::from(*frames) {
                    return Ok(true);
                }
                let elapsed = since.elapsed().as_secs_f64() * 1000.0;
                let per_frame = elapsed / (status.frames - from) as f64;
                let json = serde_json::json!({
                    "frames": status.frames - from,
                    "wall_ms_per_frame": per_frame,
                    "size": [status.size.0, status.size.1],
                    "technique": status.technique,
                    "scene": status.scene,
                    "adapter": status.adapter,
                });
                crate::create_parent(path)?;
                std::fs::write(path, format!("{json:#}\n")).with_context(|| format!("{}", path.display()))?;
            }
            _ => {}
        }
        self.waiting = None;
        let Some(action) = self.actions.pop_front() else {
            // A script without `quit` leaves the window open for the user.
            return Ok(false);
        };
        match action {
            Action::Frames(n) => {
                self.send(viewer, Command::Hold(Some(n)));
                self.waiting = Some(Wait::Frames(n));
            }
            Action::Run => self.send(viewer, Command::Hold(None)),
            Action::Scene(spec) => {
                viewer.panel.scene_text = spec.clone();
                self.send(viewer, Command::Scene(spec));
            }
            Action::Technique(name, settings) => self.send(viewer, Command::Technique { name, settings }),
            Action::Set(settings) => {
                let mut all: std::collections::BTreeMap<String, String> =
                    status.parameters.iter().cloned().collect();
                all.extend(settings);
                self.send(viewer, Command::Parameters(all.into_iter().collect()));
            }
            Action::Camera(text) => {
                let camera = rtgi::scene::Camera::parse_placement(&text, &status.camera)
                    .map_err(|e| anyhow!("script: camera {e}"))?;
                self.send(viewer, Command::Camera(camera));
            }
            Action::SceneCamera => self.send(viewer, Command::SceneCamera),
            Action::Time(t) => self.send(viewer, Command::Time(t)),
            Action::Exposure(ev) => {
                viewer.panel.exposure = ev;
                self.send(viewer, Command::Exposure(ev));
            }
            Action::Shutter(seconds) => {
                viewer.panel.shutter = seconds;
                self.send(viewer, Command::Shutter(seconds));
            }
            Action::Compare(technique) => {
                viewer.panel.comparison = technique.clone();
                self.send(viewer, Command::Compare(technique));
            }
            Action::Flip(on) => {
                viewer.panel.flip_map = on;
                self.send(viewer, Command::FlipMap(on));
            }
            Action::Screenshot(path) => self.send(viewer, Command::Screenshot(path)),
            Action::WindowScreenshot(path) => {
                viewer.handle(ui, Request::WindowScreenshot(path));
                self.waiting = Some(Wait::WindowShot);
            }
            Action::RenderCommand(path) => {
                let values = status.parameters.iter().cloned().collect();
                let command = panel::render_command(status, &values);
                crate::create_parent(&path)?;
                std::fs::write(&path, command + "\n").with_context(|| format!("{}", path.display()))?;
            }
            Action::Measure(frames, path) => {
                self.waiting =
                    Some(Wait::Measure { frames, from: status.frames, since: Instant::now(), path });
            }
            Action::Quit => {
                ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                return Ok(false);
            }
        }
        Ok(true)
    }
}
