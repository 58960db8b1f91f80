//! Keyframed motion for the animated variants of the built-in scenes (`animate=...`).
//!
//! Every motion starts and ends at the scene's rest pose (t = 0 shows the static scene) and loops:
//! the last key equals the first.

use glam::{Quat, Vec3, Vec4};

use crate::params::{ParamKind, ParamSpec};
use crate::scene::animation::{AnimationClip, Channel, Interpolation, Property, Sampler, Trs};
use crate::scene::{Light, Scene, SceneAnimation};

/// The `animate` parameter of a scene offering `choices` (the first is "none").
pub const fn animate_param(choices: &'static [&'static str], doc: &'static str) -> ParamSpec {
    ParamSpec { name: "animate", kind: ParamKind::Choice(choices), default: "none", doc }
}

/// The scene's animation, created with one clip named `clip` if it has none.
fn animation<'a>(scene: &'a mut Scene, clip: &str) -> &'a mut SceneAnimation {
    let anim = scene.animation.get_or_insert_with(Default::default);
    if anim.clips.is_empty() {
        anim.clips.push(AnimationClip { name: clip.into(), channels: Vec::new() });
    }
    anim
}

/// Adds a root node with rest transform `rest` and returns it.
pub fn add_root(scene: &mut Scene, clip: &str, name: &str, rest: Trs) -> usize {
    animation(scene, clip).add_node(name, None, rest)
}

/// Adds a channel of the active clip.
pub fn keys(scene: &mut Scene, node: usize, property: Property, sampler: Sampler) {
    let anim = animation(scene, "");
    let active = anim.active;
    anim.clips[active].channels.push(Channel { node, property, sampler });
}

/// Binds mesh `mesh` to `node`.
pub fn bind_mesh(scene: &mut Scene, mesh: usize, node: usize) {
    let bindings = &mut animation(scene, "").bindings;
    if bindings.meshes.len() <= mesh {
        bindings.meshes.resize(mesh + 1, None);
    }
    bindings.meshes[mesh] = Some(node);
}

/// Rotation keys (LINEAR, slerped) turning `rest` by `angles_deg` about the world axis `axis`.
pub fn turns(rest: Quat, axis: Vec3, times: &[f32], angles_deg: &[f32]) -> Sampler {
    let values =
        angles_deg.iter().map(|a| Vec4::from(Quat::from_axis_angle(axis, a.to_radians()) * rest)).collect();
    Sampler::new(Interpolation::Linear, times.to_vec(), values)
}

/// The `env_rotation` parameter of scenes under an environment.
pub const ENV_ROTATION_PARAM: ParamSpec = ParamSpec {
    name: "env_rotation",
    kind: ParamKind::Float { min: -360.0, max: 360.0 },
    default: "0",
    doc: "degrees the environment is turned about +Y (anticlockwise seen from above)",
};

/// The `animate` parameter of scenes whose only motion is their environment turning.
pub const ENVIRONMENT_ANIMATE_PARAM: ParamSpec = animate_param(
    &["none", "environment"],
    "environment: the environment turns once about +Y (12 s, LINEAR)",
);

/// Seconds per turn of `animate=environment`.
const ENVIRONMENT_TURN_SECONDS: f32 = 12.0;

/// Applies [`ENV_ROTATION_PARAM`] and [`ENVIRONMENT_ANIMATE_PARAM`] to `scene`.
pub fn turn_environment(scene: &mut Scene, params: &crate::params::ParamValues) {
    scene.environment_rotation = Quat::from_rotation_y(params.float("env_rotation").to_radians() as f32);
    if params.choice("animate") == "environment" {
        spin_environment(scene, "environment", ENVIRONMENT_TURN_SECONDS);
    }
}

/// Turns the environment once about +Y every `seconds` (LINEAR keys a quarter turn apart, so that each
/// slerp is unambiguous), through a new root node bound to [`Scene::environment_rotation`]. Returns the
/// node.
pub fn spin_environment(scene: &mut Scene, clip: &str, seconds: f32) -> usize {
    let node = add_root(scene, clip, "environment-turn", Trs::default());
    let times: Vec<f32> = (0..=4).map(|k| seconds * k as f32 / 4.0).collect();
    keys(
        scene,
        node,
        Property::Rotation,
        turns(Quat::IDENTITY, Vec3::Y, &times, &[0.0, 90.0, 180.0, 270.0, 360.0]),
    );
    animation(scene, clip).bindings.environment = Some(node);
    node
}

/// Binds light `index` (a spot or directional light) to a new root node at its position looking
/// along its direction, turning by `angles_deg` about the world axis `axis` through it at `times`.
/// Returns the node.
pub fn sweep_light(
    scene: &mut Scene,
    clip: &str,
    index: usize,
    axis: Vec3,
    times: &[f32],
    angles_deg: &[f32],
) -> usize {
    let (position, direction) = match scene.lights.get(index) {
        Some(Light::Spot { position, direction, .. }) => (*position, *direction),
        Some(Light::Directional { direction, .. }) => (Vec3::ZERO, *direction),
        other => panic!("light {index} cannot be swept: {other:?}"),
    };
    // Up along x when the light points straight down, so the frame is well defined.
    let up = if direction.cross(Vec3::Y).length_squared() < 1e-6 { Vec3::X } else { Vec3::Y };
    let rest = Trs::looking(position, direction, up);
    let node = add_root(scene, clip, "light-sweep", rest);
    keys(scene, node, Property::Rotation, turns(rest.rotation, axis, times, angles_deg));
    let bindings = &mut animation(scene, clip).bindings;
    bindings.lights.resize(bindings.lights.len().max(index + 1), None);
    bindings.lights[index] = Some(node);
    node
}
