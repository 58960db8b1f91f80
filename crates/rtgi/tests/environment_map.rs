//! Importance sampling of equirectangular environment maps, against the exact irradiance of an
//! unoccluded Lambertian plane: E = Σ over texels of L · ∫ cos θ dω (the map is piecewise constant).

use glam::{Vec2, Vec3};
use rtgi::gpu::{GpuContext, GpuOptions};
use rtgi::render::{RenderSettings, render};
use rtgi::scene::{Camera, Environment, EnvironmentMap, Material, Mesh, Scene};

const W: u32 = 64;
const H: u32 = 32;
const ALBEDO: f32 = 0.5;

/// A sky gradient plus a small very bright patch: importance sampling matters.
fn map() -> EnvironmentMap {
    let mut rgb = Vec::new();
    for y in 0..H {
        for x in 0..W {
            let up = 1.0 - (y as f32 + 0.5) / H as f32;
            let mut c = Vec3::new(0.3, 0.5, 0.9) * up;
            if (20..23).contains(&x) && (6..8).contains(&y) {
                c = Vec3::new(400.0, 300.0, 200.0);
            }
            rgb.extend(c.to_array());
        }
    }
    EnvironmentMap { path: "generated".into(), width: W, height: H, rgb, intensity: 1.0 }
}

/// Irradiance on an upward-facing surface from the map, exactly.
fn irradiance(map: &EnvironmentMap) -> Vec3 {
    let mut e = Vec3::ZERO;
    for y in 0..H {
        let (t0, t1) =
            (y as f64 / H as f64 * std::f64::consts::PI, (y + 1) as f64 / H as f64 * std::f64::consts::PI);
        let (t0, t1) = (t0.min(std::f64::consts::FRAC_PI_2), t1.min(std::f64::consts::FRAC_PI_2));
        // ∫ cos θ sin θ dθ = (sin² θ1 − sin² θ0) / 2, times the texel's Δφ = 2π / W.
        let weight = (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0 * 2.0 * std::f64::consts::PI / W as f64;
        for x in 0..W {
            let i = ((y * W + x) * 3) as usize;
            e += Vec3::new(map.rgb[i], map.rgb[i + 1], map.rgb[i + 2]) * weight as f32;
        }
    }
    e
}

fn scene() -> Scene {
    let h = 50.0;
    let positions =
        vec![Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)];
    Scene {
        name: "env-plane".into(),
        meshes: vec![Mesh::with_generated_tangents(
            "plane",
            positions,
            vec![Vec3::Y; 4],
            vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            vec![0, 2, 1, 0, 3, 2],
            0,
        )],
        materials: vec![Material::diffuse("grey", Vec3::splat(ALBEDO))],
        environment: Environment::Map(map()),
        camera: Camera {
            position: Vec3::new(0.0, 1.0, 0.0),
            target: Vec3::new(0.0, 0.0, -0.001),
            up: Vec3::NEG_Z,
            yfov: 30f32.to_radians(),
            znear: 0.01,
            zfar: 10.0,
        },
        ..Default::default()
    }
}

#[test]
fn lambertian_plane_under_an_environment_map() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let scene = scene();
    let Environment::Map(m) = &scene.environment else { unreachable!() };
    let want = irradiance(m) * (ALBEDO / std::f32::consts::PI);
    for (technique, settings) in [
        ("direct", vec![("env_samples", "64")]),
        ("path", vec![("max_bounces", "0"), ("spp", "64"), ("nee", "mis")]),
        ("path", vec![("max_bounces", "0"), ("spp", "64"), ("nee", "light")]),
    ] {
        let s = RenderSettings {
            technique: technique.into(),
            technique_settings: settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
            width: 16,
            height: 16,
            frames: 4,
        };
        let img = render(&ctx, &scene, &s, &mut |_, _| {}).expect("render").image;
        let n = (img.width * img.height) as f32;
        let got = img.rgb.chunks_exact(3).fold(Vec3::ZERO, |a, p| a + Vec3::new(p[0], p[1], p[2])) / n;
        let rel = ((got - want).abs() / want).max_element();
        eprintln!("{technique} {settings:?}: mean {got}, exact {want}, rel. error {rel:.4}");
        assert!(rel < 0.02, "{technique} {settings:?}: mean {got}, exact {want}");
    }
}
