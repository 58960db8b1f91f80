//! Analytic checks of the `direct` technique: a Lambertian plane under a point light, a spot light and a
//! directional light renders to albedo/π · E · cos θ, where E is the light's irradiance at the point.

use glam::{Vec2, Vec3};
use rtgi::gpu::{GpuContext, GpuOptions};
use rtgi::render::{RenderSettings, render};
use rtgi::scene::{Camera, Light, Material, Mesh, Scene};

const ALBEDO: f32 = 0.5;
const SIZE: u32 = 64;

fn plane_scene(light: Light) -> Scene {
    let h = 20.0;
    let positions =
        vec![Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)];
    let mesh = Mesh::with_generated_tangents(
        "plane",
        positions,
        vec![Vec3::Y; 4],
        vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        vec![0, 2, 1, 0, 3, 2],
        0,
    );
    Scene {
        name: "analytic-plane".into(),
        meshes: vec![mesh],
        materials: vec![Material::diffuse("grey", Vec3::splat(ALBEDO))],
        lights: vec![light],
        camera: Camera {
            position: Vec3::new(0.0, 4.0, 4.0),
            target: Vec3::new(0.0, 0.0, 0.0),
            up: Vec3::Y,
            yfov: 60f32.to_radians(),
            znear: 0.05,
            zfar: 100.0,
        },
        ..Default::default()
    }
}

/// The world point seen through the centre of pixel (x, y), by intersecting the primary ray with y = 0.
fn plane_point(cam: &Camera, x: u32, y: u32) -> Option<Vec3> {
    let vp = cam.view_projection(1.0);
    let ndc = glam::Vec4::new(
        (x as f32 + 0.5) / SIZE as f32 * 2.0 - 1.0,
        1.0 - (y as f32 + 0.5) / SIZE as f32 * 2.0,
        0.5,
        1.0,
    );
    let p = vp.inverse() * ndc;
    let dir = (p.truncate() / p.w - cam.position).normalize();
    let t = -cam.position.y / dir.y;
    (t > 0.0).then(|| cam.position + dir * t)
}

/// Checks `direct` (shadow maps) and `path` with `max_bounces=0` (shadow rays) against the closed form.
fn check(light: Light, expected_irradiance: impl Fn(Vec3) -> Vec3) {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("a GPU adapter (install mesa-vulkan-drivers)");
    let scene = plane_scene(light);
    for (technique, setting) in [("direct", ("shadow_map_size", "512")), ("path", ("max_bounces", "0"))] {
        let settings = RenderSettings {
            technique: technique.into(),
            technique_settings: vec![(setting.0.into(), setting.1.into())],
            width: SIZE,
            height: SIZE,
            frames: 1,
        };
        check_image(
            &scene,
            technique,
            &render(&ctx, &scene, &settings, &mut |_, _| {}).expect("render"),
            &expected_irradiance,
        );
    }
}

fn check_image(
    scene: &Scene,
    technique: &str,
    out: &rtgi::render::RenderOutput,
    expected_irradiance: &impl Fn(Vec3) -> Vec3,
) {
    let mut checked = 0;
    for (x, y) in [(32, 32), (10, 40), (50, 50), (20, 60), (60, 30), (5, 63), (32, 10)] {
        let Some(p) = plane_point(&scene.camera, x, y) else { continue };
        let e = expected_irradiance(p);
        let want = e * ALBEDO / std::f32::consts::PI;
        let got = Vec3::from(out.image.pixel(x, y));
        if want.max_element() < 1e-4 {
            assert!(
                got.max_element() < 1e-4,
                "{technique}: pixel ({x},{y}) at {p}: expected dark, got {got}"
            );
        } else {
            let rel = ((got - want).abs() / want).max_element();
            assert!(
                rel < 0.01,
                "{technique}: pixel ({x},{y}) at {p}: got {got}, closed form {want} (rel. error {rel})"
            );
        }
        checked += 1;
    }
    assert!(checked >= 5);
}

#[test]
fn point_light_over_lambertian_plane() {
    let pos = Vec3::new(0.5, 2.0, 0.3);
    let intensity = Vec3::new(10.0, 7.0, 4.0);
    check(Light::Point { position: pos, intensity }, |p| {
        let d = pos - p;
        intensity * (d.normalize().y / d.length_squared())
    });
}

#[test]
fn spot_light_cone_over_lambertian_plane() {
    let pos = Vec3::new(0.0, 3.0, 0.0);
    let dir = Vec3::new(0.2, -1.0, 0.1).normalize();
    let (inner, outer) = (20f32.to_radians(), 35f32.to_radians());
    let intensity = Vec3::splat(30.0);
    check(
        Light::Spot { position: pos, direction: dir, intensity, inner_angle: inner, outer_angle: outer },
        |p| {
            let d = pos - p;
            let cd = dir.dot(-d.normalize());
            // KHR_lights_punctual: a linear ramp in cos between the cones, squared.
            let a = ((cd - outer.cos()) / (inner.cos() - outer.cos())).clamp(0.0, 1.0);
            intensity * (a * a * d.normalize().y / d.length_squared())
        },
    );
}

#[test]
fn directional_light_over_lambertian_plane() {
    let dir = Vec3::new(0.3, -1.0, -0.4).normalize();
    let irradiance = Vec3::new(2.0, 1.5, 1.0);
    check(Light::Directional { direction: dir, irradiance }, |_| irradiance * (-dir).y);
}

/// A pixel whose centre sees the plane at `target` (searched over the image).
fn pixel_seeing(cam: &Camera, target: Vec3) -> (u32, u32) {
    let mut best = (0, 0, f32::MAX);
    for y in 0..SIZE {
        for x in 0..SIZE {
            if let Some(p) = plane_point(cam, x, y) {
                let d = (p - target).length();
                if d < best.2 {
                    best = (x, y, d);
                }
            }
        }
    }
    (best.0, best.1)
}

/// Shadow maps of every light kind: an opaque square between the light and the plane darkens the plane
/// below it (umbra) in `direct`, exactly where shadow rays of `path` (max_bounces=0) say so.
#[test]
fn shadow_maps_of_every_light_kind_cast_umbras() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let lights = [
        Light::Point { position: Vec3::new(0.0, 2.0, 0.0), intensity: Vec3::splat(10.0) },
        Light::Spot {
            position: Vec3::new(0.0, 2.0, 0.0),
            direction: Vec3::NEG_Y,
            intensity: Vec3::splat(10.0),
            inner_angle: 0.9,
            outer_angle: 1.1,
        },
        Light::Directional { direction: Vec3::NEG_Y, irradiance: Vec3::splat(3.0) },
    ];
    for light in lights {
        let mut scene = plane_scene(light);
        let h = 0.3;
        scene.meshes.push(Mesh::with_generated_tangents(
            "occluder",
            vec![Vec3::new(-h, 1.0, -h), Vec3::new(h, 1.0, -h), Vec3::new(h, 1.0, h), Vec3::new(-h, 1.0, h)],
            vec![Vec3::Y; 4],
            vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            vec![0, 2, 1, 0, 3, 2],
            0,
        ));
        // The camera looks from the side so that the occluder does not hide the umbra.
        scene.camera.position = Vec3::new(0.0, 2.5, 4.5);
        let umbra = pixel_seeing(&scene.camera, Vec3::new(0.0, 0.0, 0.0));
        let lit = pixel_seeing(&scene.camera, Vec3::new(0.0, 0.0, 1.5));
        for (technique, setting) in [("direct", ("shadow_map_size", "1024")), ("path", ("max_bounces", "0"))]
        {
            let settings = RenderSettings {
                technique: technique.into(),
                technique_settings: vec![(setting.0.into(), setting.1.into())],
                width: SIZE,
                height: SIZE,
                frames: 1,
            };
            let out = render(&ctx, &scene, &settings, &mut |_, _| {}).expect("render");
            let dark = Vec3::from(out.image.pixel(umbra.0, umbra.1)).max_element();
            let bright = Vec3::from(out.image.pixel(lit.0, lit.1)).max_element();
            assert!(bright > 0.05, "{} {technique}: lit pixel {lit:?} is {bright}", light.kind_name());
            assert!(
                dark < 0.01 * bright,
                "{} {technique}: umbra pixel {umbra:?} is {dark} (lit {bright})",
                light.kind_name()
            );
        }
    }
}
