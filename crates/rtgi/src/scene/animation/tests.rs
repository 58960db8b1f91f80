//! Interpolation against hand-computed values, hierarchy, posing and clip selection.

use std::f32::consts::FRAC_PI_2;

use glam::{Mat4, Quat, Vec3, Vec4};

use super::*;
use crate::scene::builtin::shapes::MeshBuilder;
use crate::scene::{Camera, Material};

fn v3(x: f32, y: f32, z: f32) -> Vec4 {
    Vec4::new(x, y, z, 0.0)
}

fn close4(a: Vec4, b: Vec4, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol
}

#[track_caller]
fn assert_close(a: Vec3, b: Vec3) {
    assert!((a - b).abs().max_element() < 1e-5, "{a} vs {b}");
}

#[test]
fn step_holds_each_key_until_the_next() {
    let s = Sampler::new(
        Interpolation::Step,
        vec![0.0, 1.0, 2.0],
        vec![v3(1.0, 0.0, 0.0), v3(2.0, 0.0, 0.0), v3(3.0, 0.0, 0.0)],
    );
    s.check().unwrap();
    let x = |t: f32| s.sample(t, Property::Translation).x;
    assert_eq!([x(0.0), x(0.5), x(0.999), x(1.0), x(1.5), x(2.0)], [1.0, 1.0, 1.0, 2.0, 2.0, 3.0]);
}

#[test]
fn linear_midpoint_and_clamping() {
    let s = Sampler::new(Interpolation::Linear, vec![1.0, 3.0], vec![v3(0.0, 2.0, -4.0), v3(4.0, 2.0, 0.0)]);
    assert!(close4(s.sample(2.0, Property::Translation), v3(2.0, 2.0, -2.0), 1e-6));
    assert!(close4(s.sample(2.5, Property::Scale), v3(3.0, 2.0, -1.0), 1e-6));
    // Before the first key and after the last, the end keys hold (NaN counts as "before").
    assert_eq!(s.sample(0.0, Property::Translation), v3(0.0, 2.0, -4.0));
    assert_eq!(s.sample(-5.0, Property::Translation), v3(0.0, 2.0, -4.0));
    assert_eq!(s.sample(f32::NAN, Property::Translation), v3(0.0, 2.0, -4.0));
    assert_eq!(s.sample(9.0, Property::Translation), v3(4.0, 2.0, 0.0));
}

#[test]
fn linear_rotation_is_slerp() {
    let q0 = Quat::IDENTITY;
    let q1 = Quat::from_rotation_y(FRAC_PI_2);
    let s = Sampler::new(Interpolation::Linear, vec![0.0, 2.0], vec![Vec4::from(q0), Vec4::from(q1)]);
    let half = Quat::from_vec4(s.sample(1.0, Property::Rotation));
    let expected = Quat::from_rotation_y(FRAC_PI_2 * 0.5);
    assert!(half.angle_between(expected) < 1e-5, "{half:?} vs {expected:?}");
    assert!((half.length() - 1.0).abs() < 1e-6);
    // A quarter of the way is 22.5°, which a normalised lerp would not give exactly (it gives ≈ 20.1°).
    let quarter = Quat::from_vec4(s.sample(0.5, Property::Rotation));
    assert!((quarter.angle_between(q0) - 22.5f32.to_radians()).abs() < 1e-5);
    // −q1 is the same rotation: the shorter arc must still be taken.
    let s = Sampler::new(Interpolation::Linear, vec![0.0, 2.0], vec![Vec4::from(q0), -Vec4::from(q1)]);
    let half = Quat::from_vec4(s.sample(1.0, Property::Rotation));
    assert!(half.angle_between(expected) < 1e-5);
}

#[test]
fn cubic_spline_matches_the_hermite_formula() {
    // Keys at t = 1 and t = 3 (Δ = 2): value 1 → 5, out-tangent of key 0 = 3/s, in-tangent of key 1 = −1/s.
    let (p0, p1, out0, in1) = (1.0f32, 5.0f32, 3.0f32, -1.0f32);
    let values = vec![
        v3(9.0, 0.0, 0.0),
        v3(p0, 0.0, 0.0),
        v3(out0, 0.0, 0.0),
        v3(in1, 0.0, 0.0),
        v3(p1, 0.0, 0.0),
        v3(7.0, 0.0, 0.0),
    ];
    let s = Sampler::new(Interpolation::CubicSpline, vec![1.0, 3.0], values);
    s.check().unwrap();
    for t in [1.5f32, 2.0, 2.7] {
        let u = (t - 1.0) / 2.0;
        let (m0, m1) = (out0 * 2.0, in1 * 2.0);
        let h = (2.0 * u.powi(3) - 3.0 * u * u + 1.0) * p0
            + (u.powi(3) - 2.0 * u * u + u) * m0
            + (-2.0 * u.powi(3) + 3.0 * u * u) * p1
            + (u.powi(3) - u * u) * m1;
        let got = s.sample(t, Property::Translation).x;
        assert!((got - h).abs() < 1e-5, "t = {t}: {got} vs {h}");
    }
    // At t = 2 by hand: 0.5·1 + 0.125·6 + 0.5·5 − 0.125·(−2) = 4.
    assert!((s.sample(2.0, Property::Translation).x - 4.0).abs() < 1e-6);
    // Keys give the spline vertex (not the tangents), and the ends hold.
    assert_eq!(s.sample(0.0, Property::Translation).x, p0);
    assert_eq!(s.sample(3.0, Property::Translation).x, p1);
    assert_eq!(s.sample(4.0, Property::Translation).x, p1);
}

#[test]
fn cubic_spline_rotations_come_back_normalised() {
    let q1 = Vec4::from(Quat::from_rotation_x(1.0));
    let tangent = Vec4::new(0.3, 0.0, 0.0, 0.0);
    let s = Sampler::new(
        Interpolation::CubicSpline,
        vec![0.0, 1.0],
        vec![tangent, Vec4::W, tangent, tangent, q1, tangent],
    );
    let q = s.sample(0.4, Property::Rotation);
    assert!((q.length() - 1.0).abs() < 1e-6);
}

#[test]
fn sampler_check_reports_bad_keys() {
    let bad_count = Sampler::new(Interpolation::CubicSpline, vec![0.0, 1.0], vec![Vec4::ZERO; 2]);
    assert!(bad_count.check().unwrap_err().contains("need 6"));
    let not_increasing = Sampler::new(Interpolation::Linear, vec![0.0, 1.0, 1.0], vec![Vec4::ZERO; 3]);
    assert!(not_increasing.check().unwrap_err().contains("increase strictly"));
    let empty = Sampler::new(Interpolation::Step, vec![], vec![]);
    assert!(empty.check().is_err());
}

fn cube(name: &str, center: Vec3, half: f32) -> Mesh {
    let mut b = MeshBuilder::new();
    b.aabb(center - Vec3::splat(half), center + Vec3::splat(half), 1.0);
    b.build(name, 0)
}

/// A static floor, a cube on a node translating along +x (1 m/s for 2 s), a child node rotating 90°
/// about y that carries a spot light and a second cube, and the camera on the parent.
pub(crate) fn animated_scene() -> Scene {
    let mut anim = SceneAnimation::default();
    let parent =
        anim.add_node("mover", None, Trs { translation: Vec3::new(0.0, 1.0, 0.0), ..Default::default() });
    let child = anim.add_node(
        "spinner",
        Some(parent),
        Trs { translation: Vec3::new(0.0, 0.0, -1.0), ..Default::default() },
    );
    anim.clips.push(AnimationClip {
        name: "move".into(),
        channels: vec![
            Channel {
                node: parent,
                property: Property::Translation,
                sampler: Sampler::new(
                    Interpolation::Linear,
                    vec![0.0, 2.0],
                    vec![v3(0.0, 1.0, 0.0), v3(2.0, 1.0, 0.0)],
                ),
            },
            Channel {
                node: child,
                property: Property::Rotation,
                sampler: Sampler::new(
                    Interpolation::Linear,
                    vec![0.0, 2.0],
                    vec![Vec4::from(Quat::IDENTITY), Vec4::from(Quat::from_rotation_y(FRAC_PI_2))],
                ),
            },
        ],
    });
    anim.clips.push(AnimationClip { name: "idle".into(), channels: Vec::new() });
    anim.clips.push(AnimationClip {
        name: "rise".into(),
        channels: vec![Channel {
            node: parent,
            property: Property::Translation,
            sampler: Sampler::new(
                Interpolation::Step,
                vec![0.5, 1.0],
                vec![v3(0.0, 1.0, 0.0), v3(0.0, 1.5, 0.0)],
            ),
        }],
    });
    anim.bindings = Bindings {
        meshes: vec![None, Some(parent), Some(child)],
        lights: vec![None, Some(child)],
        camera: Some(parent),
        sun: Some(child),
        environment: Some(parent),
    };
    let mut floor = MeshBuilder::new();
    floor.axis_rect(1, 0.0, glam::Vec2::splat(-3.0), glam::Vec2::splat(3.0), 1.0, 1.0);
    Scene {
        name: "test".into(),
        meshes: vec![
            floor.build("floor", 0),
            cube("cube", Vec3::new(0.0, 1.0, 0.0), 0.25),
            cube("child-cube", Vec3::new(0.5, 1.0, -1.0), 0.1),
        ],
        materials: vec![Material::diffuse("grey", Vec3::splat(0.5))],
        lights: vec![
            Light::Point { position: Vec3::new(0.0, 2.0, 0.0), intensity: Vec3::ONE },
            Light::Spot {
                position: Vec3::new(0.0, 1.0, -1.0),
                direction: Vec3::NEG_Z,
                intensity: Vec3::ONE,
                inner_angle: 0.2,
                outer_angle: 0.4,
            },
        ],
        environment: Environment::Sky {
            sun_direction: Vec3::NEG_Z,
            sun_radiance: Vec3::ONE,
            sky_radiance: Vec3::ONE,
            ground_radiance: Vec3::ZERO,
        },
        camera: Camera {
            position: Vec3::new(0.0, 1.0, 3.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            ..Default::default()
        },
        animation: Some(anim),
        ..Default::default()
    }
}

#[test]
fn a_child_of_an_animated_parent_moves_with_it() {
    let scene = animated_scene();
    scene.validate().unwrap();
    assert!(scene.is_animated());
    assert_eq!(scene.animation_duration(), 2.0);
    assert_eq!(scene.moving_meshes(), [false, true, true]);
    let pose = scene.pose_at(1.0);
    assert_eq!(pose.mesh_transforms[0], Mat4::IDENTITY);
    // The parent moved 1 m along +x.
    assert_close(
        pose.mesh_transforms[1].transform_point3(Vec3::new(0.0, 1.0, 0.0)),
        Vec3::new(1.0, 1.0, 0.0),
    );
    assert_close(pose.camera.position, Vec3::new(1.0, 1.0, 3.0));
    assert_close(pose.camera.target, Vec3::new(1.0, 1.0, 0.0));
    // The child: carried 1 m along +x and turned 45° about its own origin (0, 1, −1) → (1, 1, −1).
    let spot = pose.lights[1];
    let Light::Spot { position, direction, .. } = spot else { panic!("{spot:?}") };
    assert_close(position, Vec3::new(1.0, 1.0, -1.0));
    let s = std::f32::consts::FRAC_1_SQRT_2;
    assert_close(direction, Vec3::new(-s, 0.0, -s));
    assert_close(
        pose.mesh_transforms[2].transform_point3(Vec3::new(0.5, 1.0, -1.0)),
        Vec3::new(1.0 + 0.5 * s, 1.0, -1.0 - 0.5 * s),
    );
    assert_close(pose.environment_sun.unwrap(), Vec3::new(-s, 0.0, -s));
    // Unbound lights are untouched (bit-identical).
    assert_eq!(pose.lights[0], scene.lights[0]);
    // Clamped after the end and before the start.
    assert_close(scene.pose_at(10.0).camera.position, Vec3::new(2.0, 1.0, 3.0));
    assert_close(scene.pose_at(-1.0).camera.position, Vec3::new(0.0, 1.0, 3.0));
}

#[test]
fn posed_agrees_with_pose_at() {
    let scene = animated_scene();
    for t in [0.0, 0.3, 1.0, 1.7, 2.0] {
        let pose = scene.pose_at(t);
        let still = scene.posed(t);
        assert!(still.animation.is_none() && !still.is_animated());
        still.validate().unwrap();
        assert_eq!(still.camera, pose.camera);
        assert_eq!(still.lights, pose.lights);
        let Environment::Sky { sun_direction, .. } = still.environment else { panic!() };
        assert_eq!(Some(sun_direction), pose.environment_sun);
        for ((a, b), m) in scene.meshes.iter().zip(&still.meshes).zip(&pose.mesh_transforms) {
            assert_eq!(a.indices, b.indices);
            for (p, q) in a.positions.iter().zip(&b.positions) {
                assert_close(m.transform_point3(*p), *q);
            }
        }
        // The static floor is not even touched.
        assert_eq!(format!("{:?}", scene.meshes[0]), format!("{:?}", still.meshes[0]));
        // A posed scene is static: posing it again changes nothing.
        assert_eq!(format!("{:?}", still.posed(t)), format!("{still:?}"));
    }
}

#[test]
fn posed_normals_stay_unit_and_perpendicular() {
    let mut scene = animated_scene();
    // Non-uniform scale makes the inverse transpose matter.
    let anim = scene.animation.as_mut().unwrap();
    anim.clips[0].channels.push(Channel {
        node: 1,
        property: Property::Scale,
        sampler: Sampler::new(
            Interpolation::Linear,
            vec![0.0, 2.0],
            vec![v3(1.0, 1.0, 1.0), v3(3.0, 0.5, 1.0)],
        ),
    });
    let still = scene.posed(1.3);
    let m = &still.meshes[2];
    for tri in m.indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| tri[k] as usize);
        let face = (m.positions[b] - m.positions[a]).cross(m.positions[c] - m.positions[a]).normalize();
        for v in [a, b, c] {
            let n = m.normals[v];
            assert!((n.length() - 1.0).abs() < 1e-5);
            assert!((m.positions[b] - m.positions[a]).normalize().dot(n).abs() < 1e-5);
            assert!((m.positions[c] - m.positions[a]).normalize().dot(n).abs() < 1e-5);
            // Winding and normal still agree.
            assert!(face.dot(n) > 0.999);
            let t = m.tangents[v];
            assert!((t.truncate().length() - 1.0).abs() < 1e-5 && (t.w == 1.0 || t.w == -1.0));
        }
    }
}

#[test]
fn mirroring_flips_winding_and_handedness() {
    let mesh = cube("c", Vec3::ZERO, 1.0);
    let mirrored = mesh.transformed(Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
    assert_eq!(mirrored.tangents[0].w, -mesh.tangents[0].w);
    let tri = &mirrored.indices[..3];
    let [a, b, c] = [0, 1, 2].map(|k| mirrored.positions[tri[k] as usize]);
    assert!((b - a).cross(c - a).normalize().dot(mirrored.normals[tri[0] as usize]) > 0.999);
}

#[test]
fn static_scenes_pose_to_themselves() {
    let scene = crate::scene::builtin::build("cornell-spot", &[]).unwrap();
    assert!(!scene.is_animated());
    assert_eq!(scene.animation_duration(), 0.0);
    assert_eq!(scene.moving_meshes(), vec![false; scene.meshes.len()]);
    let pose = scene.pose_at(1.5);
    assert!(pose.mesh_transforms.iter().all(|m| *m == Mat4::IDENTITY));
    assert_eq!(pose.lights, scene.lights);
    assert_eq!(pose.camera, scene.camera);
    assert_eq!(format!("{:?}", scene.posed(1.5)), format!("{scene:?}"));
    // An animation whose active clip is empty is static too, and poses to the same data.
    let mut idle = animated_scene();
    idle.select_animation("idle").unwrap();
    assert!(!idle.is_animated());
    let still = idle.posed(1.0);
    assert_eq!(still.lights, idle.lights);
    assert_eq!(format!("{:?}", still.meshes), format!("{:?}", idle.meshes));
}

#[test]
fn select_animation_by_name_or_index() {
    let mut scene = animated_scene();
    scene.select_animation("idle").unwrap();
    assert_eq!(scene.animation.as_ref().unwrap().active, 1);
    scene.select_animation("0").unwrap();
    assert_eq!(scene.animation.as_ref().unwrap().active, 0);
    let err = scene.select_animation("run").unwrap_err().to_string();
    assert!(err.contains("'run'") && err.contains("0 'move', 1 'idle', 2 'rise'"), "{err}");
    assert!(scene.select_animation("3").is_err());
    let mut plain = Scene { name: "plain".into(), ..Default::default() };
    let err = plain.select_animation("0").unwrap_err().to_string();
    assert!(err.contains("no animations"), "{err}");
}

#[test]
fn validate_rejects_broken_animation() {
    let mut scene = animated_scene();
    scene.animation.as_mut().unwrap().bindings.camera = Some(7);
    assert!(scene.validate().unwrap_err().contains("out of range"));
    let mut scene = animated_scene();
    scene.animation.as_mut().unwrap().nodes[0].parent = Some(1);
    assert!(scene.validate().unwrap_err().contains("parent"));
    let mut scene = animated_scene();
    scene.animation.as_mut().unwrap().clips[0].channels[0].sampler.times = vec![0.0, -1.0];
    assert!(scene.validate().is_err());
}
