//! Loading animations: the hand-written file of `testing::animated_gltf` gives the poses computed by
//! hand from its keys, and malformed animation data is an error naming the file.

use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use serde_json::{Value, json};

use super::load;
use crate::scene::animation::{Interpolation, Property};
use crate::scene::{Light, Scene};
use crate::testing::animated_gltf;

#[track_caller]
fn assert_close(a: Vec3, b: Vec3) {
    assert!((a - b).abs().max_element() < 1e-5, "{a} vs {b}");
}

fn point_light(scene: &Scene, t: f32) -> Vec3 {
    match scene.pose_at(t).lights[..] {
        [Light::Point { position, .. }] => position,
        ref other => panic!("{other:?}"),
    }
}

#[test]
fn hand_written_file_loads_with_its_poses() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&animated_gltf(dir.path()).unwrap()).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert!(scene.is_animated());
    assert_eq!(scene.animation_duration(), 2.0);
    assert_eq!(scene.moving_meshes(), [false, true]);
    let anim = scene.animation.as_ref().unwrap();
    assert_eq!(anim.clips.len(), 1);
    assert_eq!(anim.clips[0].name, "move");
    let modes: Vec<(Property, Interpolation, usize)> = anim.clips[0]
        .channels
        .iter()
        .map(|c| (c.property, c.sampler.interpolation, c.sampler.times.len()))
        .collect();
    use Interpolation::*;
    use Property::*;
    assert_eq!(
        modes,
        [
            (Translation, Linear, 3),
            (Rotation, CubicSpline, 2),
            (Translation, Linear, 2),
            (Translation, Step, 2),
            (Translation, Linear, 2)
        ]
    );

    // The rest pose (what the static layers see) is the nodes' own transforms.
    assert_close(scene.camera.position, Vec3::new(0.0, 1.5, 1.8));
    assert_close(point_light(&scene, 0.0), Vec3::new(-0.5, 2.3, 0.0));
    let box_centre =
        |t: f32| scene.pose_at(t).mesh_transforms[1].transform_point3(Vec3::new(-0.8, 0.5, -0.5));
    assert_close(box_centre(0.0), Vec3::new(-0.8, 0.5, -0.5));

    // t = 0.5: box halfway between its first two keys, turned 90° · smoothstep(0.25) = 14.0625°.
    let pose = scene.pose_at(0.5);
    assert_close(box_centre(0.5), Vec3::new(-0.4, 0.5, -0.65));
    let corner_rest = Vec3::new(-0.8, 0.5, -0.5) + Vec3::splat(0.3);
    let angle = 90f32.to_radians() * (3.0 * 0.0625 - 2.0 * 0.015625);
    let expected = Vec3::new(-0.4, 0.5, -0.65) + Quat::from_rotation_y(angle) * Vec3::splat(0.3);
    // Hermite with zero tangents interpolates the quaternion components by smoothstep, then
    // normalises: the angle is that of the normalised blend, not exactly smoothstep × 90°.
    let blend =
        (Quat::IDENTITY * (1.0 - 0.15625) + Quat::from_rotation_y(90f32.to_radians()) * 0.15625).normalize();
    let expected_exact = Vec3::new(-0.4, 0.5, -0.65) + blend * Vec3::splat(0.3);
    assert_close(pose.mesh_transforms[1].transform_point3(corner_rest), expected_exact);
    assert!((expected - expected_exact).length() < 0.05);
    assert_close(pose.camera.position, Vec3::new(0.15, 1.475, 1.8));
    // The camera only translates: it still looks along −z.
    assert_close((pose.camera.target - pose.camera.position).normalize(), Vec3::NEG_Z);
    assert_close(point_light(&scene, 0.5), Vec3::new(-0.5, 2.3, 0.2));

    // t = 1 exactly: the box midpoint turned 45° (symmetric blend), and the rig's STEP key jumps.
    let half_turn = scene.pose_at(1.0).mesh_transforms[1].transform_point3(corner_rest);
    assert_close(
        half_turn,
        Vec3::new(0.0, 0.5, -0.8) + Quat::from_rotation_y(45f32.to_radians()) * Vec3::splat(0.3),
    );
    assert_close(point_light(&scene, 0.999), Vec3::new(-0.5, 2.3, 0.3996));
    assert_close(point_light(&scene, 1.5), Vec3::new(0.5, 2.3, 0.6));
    // Clamped after the end.
    assert_close(box_centre(5.0), Vec3::new(0.8, 0.5, -0.5));
    assert_close(scene.pose_at(5.0).camera.position, Vec3::new(0.6, 1.4, 1.8));

    // A posed still is a valid static scene with the room untouched.
    let still = scene.posed(1.5);
    still.validate().unwrap();
    assert_eq!(format!("{:?}", still.meshes[0]), format!("{:?}", scene.meshes[0]));
}

/// The hand-written file's JSON, patched by `edit` and written back next to its buffer.
fn patched(dir: &Path, edit: impl FnOnce(&mut Value)) -> PathBuf {
    let path = animated_gltf(dir).unwrap();
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    edit(&mut doc);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// Appends an accessor and makes it the input of sampler 0; returns its index.
fn push_accessor(d: &mut Value, accessor: Value) -> usize {
    let accessors = d["accessors"].as_array_mut().unwrap();
    accessors.push(accessor);
    let index = accessors.len() - 1;
    d["animations"][0]["samplers"][0]["input"] = json!(index);
    index
}

#[track_caller]
fn load_error(edit: impl FnOnce(&mut Value), expected: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let path = patched(dir.path(), edit);
    let message = match load(&path) {
        Ok(_) => panic!("loading should fail with {expected:?}"),
        Err(e) => e.to_string(),
    };
    assert!(message.starts_with(&path.display().to_string()), "does not name the file: {message}");
    for part in expected {
        assert!(message.contains(part), "'{part}' missing in: {message}");
    }
}

#[test]
fn malformed_animations_are_errors_naming_the_problem() {
    // Output count does not match the keys: the camera's 2 keys with a 3-key output.
    load_error(
        |d| d["animations"][0]["samplers"][2]["output"] = json!(3),
        &["animation 0 'move' channel 2", "need 2"],
    );
    // CUBICSPLINE needs three values per key.
    load_error(
        |d| d["animations"][0]["samplers"][1]["interpolation"] = json!("LINEAR"),
        &["channel 1", "2 keys need 2 LINEAR output values, but there are 6"],
    );
    // Times that do not increase.
    load_error(
        |d| d["animations"][0]["samplers"][2]["input"] = json!(3),
        &["channel 2", "input", "must hold float scalars"],
    );
    // A negative time: the rig's STEP values (−0.5, 2.5, 0, …) read as 6 key times.
    load_error(
        |d| {
            let view = d["accessors"][12]["bufferView"].clone();
            push_accessor(
                d,
                json!({ "bufferView": view, "componentType": 5126, "count": 6, "type": "SCALAR" }),
            );
        },
        &["channel 0", "key time -0.5 is not a finite, non-negative number"],
    );
    // Decreasing times: the room's first normal (1, 0, 0) read as the times [1, 0].
    load_error(
        |d| {
            let view = d["accessors"][1]["bufferView"].clone();
            let times = push_accessor(
                d,
                json!({ "bufferView": view, "componentType": 5126, "count": 2, "type": "SCALAR" }),
            );
            d["animations"][0]["samplers"][2]["input"] = json!(times);
            d["animations"][0]["samplers"][0]["input"] = json!(7);
        },
        &["channel 2", "key times must increase strictly, but key 1 (0) follows key 0 (1)"],
    );
    // A node that does not exist, a sampler that does not exist, an unknown path and interpolation.
    load_error(
        |d| d["animations"][0]["channels"][3]["target"]["node"] = json!(42),
        &["channel 3 targets node 42", "does not exist"],
    );
    load_error(
        |d| d["animations"][0]["channels"][4]["sampler"] = json!(9),
        &["channel 4 refers to sampler 9"],
    );
    load_error(
        |d| d["animations"][0]["channels"][0]["target"]["path"] = json!("colour"),
        &["channel 0", "invalid target path"],
    );
    load_error(
        |d| d["animations"][0]["samplers"][0]["interpolation"] = json!("SMOOTH"),
        &["invalid interpolation"],
    );
    // A rotation read from a VEC3 accessor.
    load_error(
        |d| d["animations"][0]["samplers"][1]["output"] = json!(9),
        &["channel 1 rotation output", "expected 4"],
    );
    // Two channels for the same property of the same node.
    load_error(
        |d| d["animations"][0]["channels"][2]["target"]["node"] = json!(1),
        &["channel 2 animates the translation of node 1 again"],
    );
}

#[test]
fn weights_channels_and_skins_are_named_in_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let path = patched(dir.path(), |d| {
        d["animations"][0]["channels"]
            .as_array_mut()
            .unwrap()
            .push(json!({ "sampler": 2, "target": { "node": 1, "path": "weights" } }));
        d["nodes"][1]["skin"] = json!(0);
        d["skins"] = json!([{ "joints": [3] }]);
    });
    let scene = load(&path).unwrap();
    let warnings = scene.warnings.join("\n");
    assert!(warnings.contains("animation 0 'move': morph-target 'weights' channels ignored"), "{warnings}");
    assert!(warnings.contains("node 1 'box': skin ignored"), "{warnings}");
    // The skinned box is not bound; the rest still plays.
    assert!(scene.is_animated());
    assert_eq!(scene.moving_meshes(), [false, false]);
}

#[test]
fn several_animations_load_and_the_first_is_active() {
    let dir = tempfile::tempdir().unwrap();
    let path = patched(dir.path(), |d| {
        let mut second = d["animations"][0].clone();
        second["name"] = json!("camera-only");
        second["channels"] = json!([{ "sampler": 2, "target": { "node": 2, "path": "translation" } }]);
        d["animations"].as_array_mut().unwrap().push(second);
        // An unnamed third one, to select by index.
        let mut third = d["animations"][0].clone();
        third.as_object_mut().unwrap().remove("name");
        d["animations"].as_array_mut().unwrap().push(third);
    });
    let mut scene = load(&path).unwrap();
    assert_eq!(scene.animation.as_ref().unwrap().clips.len(), 3);
    assert_eq!(scene.moving_meshes(), [false, true]);
    scene.select_animation("camera-only").unwrap();
    assert_eq!(scene.moving_meshes(), [false, false]);
    assert_close(scene.pose_at(1.0).camera.position, Vec3::new(0.3, 1.45, 1.8));
    scene.select_animation("2").unwrap();
    assert_eq!(scene.animation.as_ref().unwrap().clips[2].name, "animation 2");
    let err = scene.select_animation("walk").unwrap_err().to_string();
    assert!(err.contains("0 'move', 1 'camera-only', 2 'animation 2'"), "{err}");
}

#[test]
fn files_without_animations_have_none() {
    let dir = tempfile::tempdir().unwrap();
    let path = patched(dir.path(), |d| {
        d.as_object_mut().unwrap().remove("animations");
    });
    let scene = load(&path).unwrap();
    assert!(scene.animation.is_none() && !scene.is_animated());
}
