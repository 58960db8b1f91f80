//! The viewer's side panel: pickers, one typed control per technique parameter (built from the
//! parameter registry, so only valid values can be entered), view and comparison settings, timings,
//! memory and capture. It draws from the render thread's [`Status`] and returns what the user asked
//! for; it holds no GPU state, so tests drive it headless.

use std::collections::BTreeMap;
use std::path::PathBuf;

use eframe::egui;
use rtgi::params::{GridCounts, ParamKind, ParamSpec, ParamValue};

use super::worker::{Command, Status};

/// Something the panel asks for: a render-thread command or a window-side action.
#[derive(Clone, Debug, PartialEq)]
pub enum Request {
    Command(Command),
    WindowScreenshot(PathBuf),
    CopyText(String),
}

/// The panel's own state: edits in progress and view settings.
#[derive(Clone, Debug)]
pub struct PanelState {
    pub scene_text: String,
    pub technique: String,
    /// The technique's parameters as edited (valid by construction), name → value.
    pub values: BTreeMap<String, String>,
    /// Parameters changed but not yet sent (sent when no pointer button is held, so dragging a value
    /// rebuilds once, at the end).
    pub dirty: bool,
    /// What `values` were last synchronised from (technique and parameters of the status).
    synced: (String, Vec<(String, String)>),
    pub exposure: f32,
    /// Motion blur's shutter in scene seconds (0: off).
    pub shutter: f32,
    pub comparison: Option<String>,
    /// Where the comparison starts, as a fraction of the image width (0: all comparison).
    pub split: f32,
    pub flip_map: bool,
    pub playing: bool,
    /// Render resolution as a fraction of the image area (ignored with a fixed --render-size).
    pub render_scale: f32,
    pub fixed_size: bool,
    pub captures: u32,
    pub speed: f32,
}

impl PanelState {
    pub fn new(scene: &str, technique: &str, exposure: f32, fixed_size: bool) -> PanelState {
        PanelState {
            scene_text: scene.to_string(),
            technique: technique.to_string(),
            values: BTreeMap::new(),
            dirty: false,
            synced: Default::default(),
            exposure,
            shutter: 0.0,
            comparison: None,
            split: 0.5,
            flip_map: false,
            playing: false,
            render_scale: 0.5,
            fixed_size,
            captures: 0,
            speed: 1.0,
        }
    }

    /// Takes the technique and parameters the render thread reports, unless the user is editing.
    fn sync(&mut self, status: &Status) {
        if self.dirty || status.technique.is_empty() {
            return;
        }
        let current = (status.technique.clone(), status.parameters.clone());
        if current != self.synced {
            self.technique = status.technique.clone();
            self.values = status.parameters.iter().cloned().collect();
            self.synced = current;
        }
    }
}

fn technique_info(name: &str) -> Option<&'static rtgi::techniques::TechniqueInfo> {
    rtgi::techniques::registry().iter().find(|t| t.name == name)
}

/// Draws the panel into `ui`.
pub fn panel(ui: &mut egui::Ui, state: &mut PanelState, status: &Status) -> Vec<Request> {
    state.sync(status);
    let mut out = Vec::new();
    let send = |out: &mut Vec<Request>, c: Command| out.push(Request::Command(c));
    shortcuts(ui, state, status, &mut out);

    ui.heading("rtgi");
    if let Some(what) = &status.building {
        ui.horizontal(|ui| {
            ui.spinner();
            ui.label(format!("{what}…"));
        });
    }
    if let Some(error) = &status.error {
        ui.colored_label(ui.visuals().error_fg_color, error);
    }
    if let Some(message) = &status.message {
        ui.label(message);
    }
    ui.label(format!(
        "{} × {}, {} frame{} accumulated{}",
        status.size.0,
        status.size.1,
        status.samples,
        if status.samples == 1 { "" } else { "s" },
        if status.idle { " (holding)" } else { "" }
    ));

    egui::CollapsingHeader::new("Scene").default_open(true).show(ui, |ui| {
        ui.horizontal(|ui| {
            let mut picked = None;
            let label = ui.label("built-in");
            egui::ComboBox::from_id_salt("scene")
                .selected_text(state.scene_text.split(':').next().unwrap_or("").to_string())
                .show_ui(ui, |ui| {
                    for scene in rtgi::scene::builtin::list() {
                        if ui.selectable_label(state.scene_text == scene.name, scene.name).clicked() {
                            picked = Some(scene.name.to_string());
                        }
                    }
                })
                .response
                .labelled_by(label.id);
            if let Some(name) = picked {
                state.scene_text = name.clone();
                send(&mut out, Command::Scene(name));
            }
        });
        ui.horizontal(|ui| {
            let label = ui.label("spec");
            let edit = ui
                .add(
                    egui::TextEdit::singleline(&mut state.scene_text)
                        .hint_text("NAME:key=value or a .glb")
                        .desired_width(190.0),
                )
                .labelled_by(label.id);
            let entered = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if ui.button("Load").clicked() || entered {
                send(&mut out, Command::Scene(state.scene_text.clone()));
            }
        });
        if let Some(duration) = status.animation {
            ui.horizontal(|ui| {
                let label = if state.playing { "⏸ Pause" } else { "▶ Play" };
                if ui.button(label).clicked() {
                    state.playing = !state.playing;
                }
                let mut t = status.time;
                if ui.add(egui::Slider::new(&mut t, 0.0..=duration).text("s")).changed() {
                    state.playing = false;
                    send(&mut out, Command::Time(t));
                }
            });
            let shutter = egui::Slider::new(&mut state.shutter, 0.0..=0.5).text("shutter s (motion blur)");
            if ui.add(shutter).changed() {
                send(&mut out, Command::Shutter(state.shutter));
            }
        }
    });

    egui::CollapsingHeader::new("Technique").default_open(true).show(ui, |ui| {
        let mut picked = None;
        ui.horizontal(|ui| {
            let label = ui.label("technique");
            egui::ComboBox::from_id_salt("technique")
                .selected_text(state.technique.clone())
                .show_ui(ui, |ui| {
                    for t in rtgi::techniques::registry() {
                        if ui
                            .selectable_label(state.technique == t.name, t.name)
                            .on_hover_text(t.description)
                            .clicked()
                        {
                            picked = Some(t.name);
                        }
                    }
                })
                .response
                .labelled_by(label.id);
        });
        if let Some(name) = picked
            && name != state.technique
        {
            state.technique = name.to_string();
            state.values.clear();
            state.dirty = false;
            send(&mut out, Command::Technique { name: name.to_string(), settings: Vec::new() });
        }
        if let Some(info) = technique_info(&state.technique) {
            ui.label(egui::RichText::new(info.description).small());
            egui::Grid::new("parameters").num_columns(2).striped(true).show(ui, |ui| {
                for spec in info.params {
                    let value =
                        state.values.entry(spec.name.to_string()).or_insert_with(|| spec.default.to_string());
                    let label = ui.label(spec.name).on_hover_text(spec.doc);
                    if parameter_control(ui, spec, value, label.id) {
                        state.dirty = true;
                    }
                    ui.end_row();
                }
            });
            if ui.button("Defaults").clicked() {
                state.values.clear();
                state.dirty = false;
                send(&mut out, Command::Parameters(Vec::new()));
            }
        }
        if state.dirty && !ui.input(|i| i.pointer.any_down()) {
            state.dirty = false;
            send(&mut out, Command::Parameters(state.values.clone().into_iter().collect()));
        }
    });

    egui::CollapsingHeader::new("View").default_open(true).show(ui, |ui| {
        if ui
            .add(egui::Slider::new(&mut state.exposure, -8.0..=8.0).step_by(0.25).text("exposure (EV)"))
            .changed()
        {
            send(&mut out, Command::Exposure(state.exposure));
        }
        if !state.fixed_size {
            ui.add(egui::Slider::new(&mut state.render_scale, 0.125..=1.0).text("render scale"));
        }
        ui.horizontal(|ui| {
            if ui.add_enabled(!status.scene_camera, egui::Button::new("Scene camera")).clicked() {
                send(&mut out, Command::SceneCamera);
            }
            ui.label(format!("speed {:.2}/s", state.speed));
        });
        ui.label(
            egui::RichText::new(
                "WASD move, Q/E down/up, Shift faster, drag to turn, wheel: speed; C scene camera, B view / \
                 comparison, F FLIP map",
            )
            .small(),
        );
    });

    egui::CollapsingHeader::new("Compare").default_open(true).show(ui, |ui| {
        let mut choice = state.comparison.clone();
        ui.horizontal(|ui| {
            let label = ui.label("against");
            egui::ComboBox::from_id_salt("compare")
                .selected_text(choice.clone().unwrap_or_else(|| "off".into()))
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut choice, None, "off");
                    ui.selectable_value(&mut choice, Some("path".to_string()), "path (reference)");
                    for t in rtgi::techniques::registry().iter().filter(|t| t.name != "path") {
                        ui.selectable_value(&mut choice, Some(t.name.to_string()), t.name);
                    }
                })
                .response
                .labelled_by(label.id);
        });
        if choice != state.comparison {
            state.comparison = choice.clone();
            send(&mut out, Command::Compare(choice));
        }
        if state.comparison.is_some() {
            ui.add(egui::Slider::new(&mut state.split, 0.0..=1.0).text("split"));
            if ui.checkbox(&mut state.flip_map, "FLIP map").changed() {
                send(&mut out, Command::FlipMap(state.flip_map));
            }
            if let Some((flip, samples)) = status.flip {
                ui.label(format!("FLIP {flip:.4} against {samples} frames of the comparison"));
            }
        }
    });

    egui::CollapsingHeader::new("Timings").default_open(true).show(ui, |ui| timings(ui, status));

    egui::CollapsingHeader::new("Memory and adapter").default_open(false).show(ui, |ui| {
        if let Some(bytes) = status.gpu_bytes {
            ui.label(format!("GPU buffers and textures: {:.1} MiB", bytes as f64 / 1048576.0));
        }
        if let Some(bytes) = status.process_bytes {
            ui.label(format!("process: {:.1} MiB", bytes as f64 / 1048576.0));
        }
        ui.label(format!("adapter: {}", status.adapter));
    });

    egui::CollapsingHeader::new("Capture").default_open(true).show(ui, |ui| {
        ui.horizontal(|ui| {
            let stem = format!("rtgi-view-{}-{}", status.technique, state.captures);
            if ui.button("PNG").on_hover_text("the rendered image, tone-mapped").clicked() {
                state.captures += 1;
                send(&mut out, Command::Screenshot(PathBuf::from(format!("{stem}.png"))));
            }
            if ui.button("EXR").on_hover_text("the rendered image, linear radiance").clicked() {
                state.captures += 1;
                send(&mut out, Command::Screenshot(PathBuf::from(format!("{stem}.exr"))));
            }
            if ui.button("Window").on_hover_text("the whole window as PNG").clicked() {
                state.captures += 1;
                out.push(Request::WindowScreenshot(PathBuf::from(format!("{stem}-window.png"))));
            }
        });
        let command = render_command(status, &state.values);
        if ui.button("Copy `rtgi render` command").on_hover_text(&command).clicked() {
            out.push(Request::CopyText(command));
        }
    });
    out
}

/// Keys that act while no text field has focus: B flips between the view and the comparison (the split
/// all the way to one side, then the other), F toggles the FLIP map, C goes back to the scene camera.
fn shortcuts(ui: &egui::Ui, state: &mut PanelState, status: &Status, out: &mut Vec<Request>) {
    if ui.ctx().egui_wants_keyboard_input() {
        return;
    }
    let [b, f, c] = ui.input(|i| [egui::Key::B, egui::Key::F, egui::Key::C].map(|k| i.key_pressed(k)));
    if state.comparison.is_some() {
        if b {
            state.split = if state.split < 0.5 { 1.0 } else { 0.0 };
        }
        if f {
            state.flip_map = !state.flip_map;
            out.push(Request::Command(Command::FlipMap(state.flip_map)));
        }
    }
    if c && !status.scene_camera {
        out.push(Request::Command(Command::SceneCamera));
    }
}

/// A control for one parameter; returns whether the user changed it. `value` is always left valid.
fn parameter_control(ui: &mut egui::Ui, spec: &ParamSpec, value: &mut String, label: egui::Id) -> bool {
    let parsed = spec.parse(value).or_else(|_| spec.parse(spec.default));
    let Ok(mut parsed) = parsed else {
        ui.label(value.as_str());
        return false;
    };
    let changed = match (&spec.kind, &mut parsed) {
        (ParamKind::Int { min, max }, ParamValue::Int(v)) => {
            if max - min <= 64 {
                ui.add(egui::Slider::new(v, *min..=*max)).labelled_by(label).changed()
            } else {
                ui.add(
                    egui::DragValue::new(v).range(*min..=*max).speed(((max - min) as f64 / 500.0).max(1.0)),
                )
                .labelled_by(label)
                .changed()
            }
        }
        (ParamKind::Float { min, max }, ParamValue::Float(v)) => {
            let span = max - min;
            ui.add(
                egui::DragValue::new(v)
                    .range(*min..=*max)
                    .speed((span / 500.0).clamp(1e-4, 1.0))
                    .max_decimals(4),
            )
            .labelled_by(label)
            .changed()
        }
        (ParamKind::Bool, ParamValue::Bool(v)) => ui.checkbox(v, "").labelled_by(label).changed(),
        (ParamKind::Choice(options), ParamValue::Choice(v)) => {
            let mut changed = false;
            egui::ComboBox::from_id_salt(spec.name)
                .selected_text(v.clone())
                .show_ui(ui, |ui| {
                    for option in *options {
                        changed |= ui.selectable_value(v, option.to_string(), *option).changed();
                    }
                })
                .response
                .labelled_by(label);
            changed
        }
        (ParamKind::Size2 { max }, ParamValue::Size2(w, h)) => {
            ui.horizontal(|ui| {
                let a = ui.add(egui::DragValue::new(w).range(1..=*max)).labelled_by(label).changed();
                ui.label("×");
                a | ui.add(egui::DragValue::new(h).range(1..=*max)).labelled_by(label).changed()
            })
            .inner
        }
        (ParamKind::GridCounts { min, max }, ParamValue::GridCounts(counts)) => match counts {
            GridCounts::AlongLongest(n) => ui
                .add(egui::DragValue::new(n).range(*min..=*max).suffix(" along longest"))
                .labelled_by(label)
                .changed(),
            GridCounts::Exact(xyz) => {
                ui.horizontal(|ui| {
                    let mut changed = false;
                    for c in xyz.iter_mut() {
                        changed |=
                            ui.add(egui::DragValue::new(c).range(*min..=*max)).labelled_by(label).changed();
                    }
                    changed
                })
                .inner
            }
        },
        _ => false,
    };
    if changed {
        *value = parsed.to_string();
    }
    changed
}

fn timings(ui: &mut egui::Ui, status: &Status) {
    let (what, total) = match (&status.frame_gpu, &status.frame_wall) {
        (Some(gpu), _) if status.gpu_timings => ("GPU", Some(gpu)),
        (_, Some(wall)) => ("wall", Some(wall)),
        _ => ("", None),
    };
    if let Some(total) = total {
        ui.label(format!("frame ({what}): mean {:.2} ms, p95 {:.2} ms", total.mean_ms, total.p95_ms));
    }
    if !status.gpu_timings {
        ui.label(
            egui::RichText::new("no reliable GPU timestamps on this adapter: per-pass times absent").small(),
        );
        return;
    }
    let longest =
        status.passes.iter().filter_map(|p| p.time.map(|t| t.mean_ms)).fold(0.0f64, f64::max).max(1e-6);
    egui::Grid::new("passes").num_columns(3).show(ui, |ui| {
        ui.label("pass");
        ui.label("mean / p95 ms");
        ui.label("");
        ui.end_row();
        for pass in &status.passes {
            let Some(time) = pass.time else { continue };
            ui.label(&pass.name);
            ui.label(format!("{:.3} / {:.3}", time.mean_ms, time.p95_ms));
            let width = 80.0 * (time.mean_ms / longest) as f32;
            let (rect, _) = ui.allocate_exact_size(egui::vec2(80.0, 10.0), egui::Sense::hover());
            let bar = egui::Rect::from_min_size(rect.min, egui::vec2(width.max(1.0), rect.height()));
            ui.painter().rect_filled(bar, 2.0, ui.visuals().selection.bg_fill);
            ui.end_row();
        }
    });
}

/// The `rtgi render` command that renders the current view: scene, technique, parameters that differ
/// from their defaults, size, accumulated frames, camera (when moved), time and exposure.
pub fn render_command(status: &Status, values: &BTreeMap<String, String>) -> String {
    let mut words = vec![
        "rtgi".to_string(),
        "render".into(),
        "--scene".into(),
        quote(&status.scene),
        "--technique".into(),
        quote(&status.technique),
    ];
    if let Some(info) = technique_info(&status.technique) {
        for spec in info.params {
            let Some(value) = values.get(spec.name) else { continue };
            let differs = match (spec.parse(value), spec.parse(spec.default)) {
                (Ok(a), Ok(b)) => a != b,
                _ => true,
            };
            if differs {
                words.push("--set".into());
                words.push(quote(&format!("{}={value}", spec.name)));
            }
        }
    }
    words.push("--size".into());
    words.push(format!("{}x{}", status.size.0, status.size.1));
    words.push("--frames".into());
    words.push(status.samples.max(1).to_string());
    if status.first_frame != 0 {
        words.push(format!("--first-frame={}", status.first_frame));
    }
    if !status.scene_camera {
        words.push(format!("--camera={}", status.camera.placement()));
    }
    if status.time != 0.0 {
        words.push(format!("--time={}", status.time));
    }
    if status.exposure != 0.0 {
        words.push(format!("--exposure={}", status.exposure));
    }
    if status.shutter > 0.0 {
        words.push(format!("--shutter={}", status.shutter));
    }
    words.push("--out".into());
    words.push("view.png".into());
    words.join(" ")
}

/// `text` as one shell word.
fn quote(text: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-=:,./+".contains(c);
    if !text.is_empty() && text.chars().all(plain) {
        text.to_string()
    } else {
        format!("'{}'", text.replace('\'', r"'\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use egui_kittest::Harness;
    use egui_kittest::kittest::Queryable;
    use rtgi::gpu::TimeSummary;

    use crate::view::worker::PassTime;

    struct State {
        panel: PanelState,
        status: Status,
        requests: Vec<Request>,
    }

    fn status(technique: &str) -> Status {
        let (_, values) = rtgi::techniques::resolve(technique, &[]).expect("technique");
        let time = |mean_ms| Some(TimeSummary { mean_ms, p95_ms: mean_ms * 1.2, count: 30 });
        Status {
            scene: "cornell".into(),
            technique: technique.into(),
            parameters: values.to_map().into_iter().collect(),
            adapter: "test adapter".into(),
            size: (64, 48),
            samples: 7,
            scene_camera: true,
            gpu_timings: true,
            frame_gpu: time(3.0),
            passes: vec![
                PassTime { name: "gbuffer".into(), time: time(1.0) },
                PassTime { name: "rsm gather".into(), time: time(2.0) },
            ],
            ..Status::default()
        }
    }

    fn harness(technique: &str) -> Harness<'static, State> {
        let state = State {
            panel: PanelState::new("cornell", technique, 0.0, true),
            status: status(technique),
            requests: Vec::new(),
        };
        Harness::builder().with_size(egui::vec2(360.0, 1600.0)).build_ui_state(
            |ui, s: &mut State| {
                let requests = panel(ui, &mut s.panel, &s.status);
                s.requests.extend(requests);
            },
            state,
        )
    }

    /// The sent parameter changes (the last [`Command::Parameters`]), as a map.
    fn sent_parameters(requests: &[Request]) -> Option<BTreeMap<String, String>> {
        requests.iter().rev().find_map(|r| match r {
            Request::Command(Command::Parameters(p)) => Some(p.iter().cloned().collect()),
            _ => None,
        })
    }

    #[test]
    fn draws_a_control_for_every_parameter_and_the_pass_timings() {
        let mut harness = harness("rsm");
        harness.run();
        let info = technique_info("rsm").expect("rsm");
        // Every parameter has its row (the harness's accessibility check already failed the run if a
        // control had no name).
        for spec in info.params {
            assert!(harness.get_all_by_label(spec.name).count() >= 1, "no row for {}", spec.name);
        }
        for label in ["Scene", "Technique", "View", "Compare", "Timings", "Capture", "gbuffer", "rsm gather"]
        {
            harness.get_by_label(label);
        }
        harness.get_by_label_contains("frame (GPU): mean 3.00 ms, p95 3.60 ms");
        harness.get_by_label_contains("7 frames accumulated");
        assert!(
            harness.state().requests.is_empty(),
            "drawing alone asked for {:?}",
            harness.state().requests
        );
    }

    #[test]
    fn a_toggled_boolean_sends_every_parameter_once() {
        let mut harness = harness("rsm");
        harness.run();
        // rsm has one boolean parameter (brute_force), so one checkbox.
        harness.get_by_role(egui::accesskit::Role::CheckBox).click();
        harness.run();
        let requests = &harness.state().requests;
        let sent = sent_parameters(requests).expect("parameters sent");
        assert_eq!(sent.get("brute_force").map(String::as_str), Some("true"));
        assert_eq!(sent.len(), technique_info("rsm").expect("rsm").params.len(), "{sent:?}");
        assert_eq!(requests.len(), 1, "{requests:?}");
    }

    #[test]
    fn typed_values_are_clamped_to_the_parameter_range() {
        let mut harness = harness("path");
        harness.run();
        let spec = technique_info("path")
            .expect("path")
            .params
            .iter()
            .find(|p| p.name == "max_bounces")
            .expect("max_bounces");
        let ParamKind::Int { max, .. } = spec.kind else { panic!("max_bounces is an int") };
        // The spin button after the label: set far past its maximum.
        let field = harness.get_by_role_and_label(egui::accesskit::Role::SpinButton, "max_bounces");
        field.set_value_accesskit(1.0e6);
        harness.run();
        let sent = sent_parameters(&harness.state().requests).expect("parameters sent");
        assert_eq!(sent.get("max_bounces"), Some(&max.to_string()), "{sent:?}");
    }

    #[test]
    fn picking_a_technique_switches_with_its_defaults() {
        let mut harness = harness("rsm");
        harness.run();
        harness.get_by_role_and_label(egui::accesskit::Role::ComboBox, "technique").click();
        harness.run();
        harness.get_by_label("vxgi").click_accesskit();
        harness.run();
        let requests = &harness.state().requests;
        assert!(
            requests.contains(&Request::Command(Command::Technique {
                name: "vxgi".into(),
                settings: Vec::new()
            })),
            "{requests:?}"
        );
    }

    /// The panel as drawn, against the committed image `tests/snapshots/view_panel.png` (egui's
    /// snapshot test renders it with wgpu on the test machine's adapter; `UPDATE_SNAPSHOTS=1`
    /// rewrites it after an intended change).
    #[test]
    fn looks_as_committed() {
        let state = State {
            panel: PanelState::new("cornell", "rsm", 0.0, true),
            status: status("rsm"),
            requests: Vec::new(),
        };
        let mut harness = Harness::builder().with_size(egui::vec2(340.0, 900.0)).wgpu().build_ui_state(
            |ui, s: &mut State| {
                panel(ui, &mut s.panel, &s.status);
            },
            state,
        );
        harness.run();
        // Measured: 0 failed pixels on lavapipe. Another rasteriser may shade text edges differently;
        // 0.1 % of the 306 000 pixels allows that; a changed line of small text moves more.
        harness.snapshot_options("view_panel", &egui_kittest::SnapshotOptions::new().max_failed_pixels(300));
    }

    #[test]
    fn keys_flip_between_view_and_comparison_and_toggle_the_flip_map() {
        let mut harness = harness("rsm");
        harness.state_mut().panel.comparison = Some("path".into());
        harness.state_mut().status.scene_camera = false;
        harness.run();
        harness.key_press(egui::Key::B);
        harness.run();
        assert_eq!(harness.state().panel.split, 0.0, "B from the middle shows all comparison");
        harness.key_press(egui::Key::B);
        harness.run();
        assert_eq!(harness.state().panel.split, 1.0, "B again shows all view");
        harness.key_press(egui::Key::F);
        harness.key_press(egui::Key::C);
        harness.run();
        let requests = &harness.state().requests;
        assert!(requests.contains(&Request::Command(Command::FlipMap(true))), "{requests:?}");
        assert!(requests.contains(&Request::Command(Command::SceneCamera)), "{requests:?}");
    }

    #[test]
    fn the_copied_command_reproduces_the_view() {
        let mut status = status("path");
        status.scene_camera = false;
        status.camera = rtgi::scene::Camera::default();
        status.samples = 16;
        status.first_frame = 5;
        status.exposure = -1.0;
        let mut values: BTreeMap<String, String> = status.parameters.iter().cloned().collect();
        values.insert("max_bounces".into(), "3".into());
        let command = render_command(&status, &values);
        assert_eq!(
            command,
            format!(
                "rtgi render --scene cornell --technique path --set max_bounces=3 --size 64x48 --frames 16 \
                 --first-frame=5 --camera={} --exposure=-1 --out view.png",
                status.camera.placement()
            )
        );
        status.scene = "my scene.glb".into();
        assert!(render_command(&status, &values).contains("--scene 'my scene.glb'"));
    }
}
