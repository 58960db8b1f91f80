//! The fly camera: WASD (and Q/E down/up, Shift 4× faster) moves, dragging in the image turns, the
//! wheel changes the speed. It starts from whatever camera the renderer shows and keeps its field of
//! view, up axis and clip distances.

use eframe::egui;
use glam::Vec3;
use rtgi::scene::Camera;

/// Radians per point of mouse drag.
const TURN_RATE: f32 = 0.004;
/// Speed factor per point of wheel scroll: ×1.1 per notch (egui reports 50 points per notch on most
/// platforms).
fn wheel_factor(points: f32) -> f32 {
    1.1f32.powf(points / 50.0)
}

#[derive(Clone, Debug, PartialEq)]
pub struct FlyCamera {
    pub camera: Camera,
    yaw: f32,
    pitch: f32,
    /// Distance from the position to the target, kept so the target stays a useful focus point.
    focus: f32,
    /// Units per second.
    pub speed: f32,
}

impl FlyCamera {
    pub fn new(camera: Camera) -> FlyCamera {
        let offset = camera.target - camera.position;
        let focus = offset.length().max(1e-3);
        let (yaw, pitch) = angles(offset / focus);
        // A room-sized scene viewed from a few metres crosses in a few seconds.
        FlyCamera { camera, yaw, pitch, focus, speed: focus.max(0.5) * 0.5 }
    }

    /// Applies this frame's input (keys held for `dt` seconds, `drag` in points); returns whether the
    /// camera moved.
    pub fn update(&mut self, input: &FlyInput, dt: f32) -> bool {
        let mut moved = false;
        if input.wheel != 0.0 {
            self.speed = (self.speed * wheel_factor(input.wheel)).clamp(1e-3, 1e4);
        }
        if input.drag != egui::Vec2::ZERO {
            self.yaw += input.drag.x * TURN_RATE;
            let limit = 89f32.to_radians();
            self.pitch = (self.pitch - input.drag.y * TURN_RATE).clamp(-limit, limit);
            moved = true;
        }
        let forward = direction(self.yaw, self.pitch);
        let right = forward.cross(Vec3::Y).normalize_or_zero();
        let step = input.axes.x * right + input.axes.y * Vec3::Y + input.axes.z * forward;
        let boost = if input.fast { 4.0 } else { 1.0 };
        if step != Vec3::ZERO {
            self.camera.position += step.normalize() * self.speed * boost * dt;
            moved = true;
        }
        if moved {
            self.camera.target = self.camera.position + forward * self.focus;
        }
        moved
    }
}

/// One frame's camera input, gathered from egui.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlyInput {
    /// Right (D − A), up (E − Q), forward (W − S), each −1, 0 or 1.
    pub axes: Vec3,
    pub fast: bool,
    pub drag: egui::Vec2,
    pub wheel: f32,
}

impl FlyInput {
    /// Keys from `input` (when no text field has focus) plus the drag and wheel over the image.
    pub fn gather(input: &egui::InputState, keys: bool, drag: egui::Vec2, hovered: bool) -> FlyInput {
        let axis = |plus: egui::Key, minus: egui::Key| {
            f32::from(u8::from(keys && input.key_down(plus)))
                - f32::from(u8::from(keys && input.key_down(minus)))
        };
        FlyInput {
            axes: Vec3::new(
                axis(egui::Key::D, egui::Key::A),
                axis(egui::Key::E, egui::Key::Q),
                axis(egui::Key::W, egui::Key::S),
            ),
            fast: keys && input.modifiers.shift,
            drag,
            wheel: if hovered { input.smooth_scroll_delta.y } else { 0.0 },
        }
    }

    pub fn any_key(&self) -> bool {
        self.axes != Vec3::ZERO
    }
}

/// Yaw about +Y from −Z towards +X, and pitch up, of the unit vector `d`.
fn angles(d: Vec3) -> (f32, f32) {
    (d.x.atan2(-d.z), d.y.clamp(-1.0, 1.0).asin())
}

fn direction(yaw: f32, pitch: f32) -> Vec3 {
    Vec3::new(pitch.cos() * yaw.sin(), pitch.sin(), -pitch.cos() * yaw.cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> Camera {
        Camera { position: Vec3::new(1.0, 2.0, 5.0), target: Vec3::new(0.0, 1.0, 0.0), ..Camera::default() }
    }

    #[test]
    fn no_input_keeps_the_camera_exactly() {
        let mut fly = FlyCamera::new(camera());
        assert!(!fly.update(&FlyInput::default(), 0.1));
        assert_eq!(fly.camera, camera());
    }

    #[test]
    fn forward_moves_along_the_view_direction_at_the_speed() {
        let mut fly = FlyCamera::new(camera());
        let start = fly.camera;
        let forward = (start.target - start.position).normalize();
        let input = FlyInput { axes: Vec3::Z, ..Default::default() };
        assert!(fly.update(&input, 0.5));
        let moved = fly.camera.position - start.position;
        assert!((moved - forward * fly.speed * 0.5).length() < 1e-5, "{moved}");
        // The direction is unchanged and the target stays at the focus distance.
        let d = fly.camera.target - fly.camera.position;
        assert!((d.normalize() - forward).length() < 1e-5);
        assert!((d.length() - (start.target - start.position).length()).abs() < 1e-4);
    }

    #[test]
    fn dragging_right_turns_right_and_pitch_stops_short_of_vertical() {
        let mut fly = FlyCamera::new(camera());
        let before = (fly.camera.target - fly.camera.position).normalize();
        let right = before.cross(Vec3::Y).normalize();
        fly.update(&FlyInput { drag: egui::vec2(50.0, 0.0), ..Default::default() }, 0.0);
        let after = (fly.camera.target - fly.camera.position).normalize();
        assert!(after.dot(right) > 0.1, "turned {after} (right is {right})");
        fly.update(&FlyInput { drag: egui::vec2(0.0, -1e5), ..Default::default() }, 0.0);
        let up = (fly.camera.target - fly.camera.position).normalize();
        assert!(up.y > 0.99 && up.y < 1.0, "{up}");
    }
}
