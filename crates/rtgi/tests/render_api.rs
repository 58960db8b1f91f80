//! The headless render API: determinism and clear errors for invalid settings.

use glam::{Vec2, Vec3};
use rtgi::gpu::{GpuContext, GpuOptions};
use rtgi::render::{RenderError, RenderSettings, render};
use rtgi::scene::{Camera, Environment, Light, Material, Mesh, Scene};

fn quad(name: &str, corners: [Vec3; 4], material: u32) -> Mesh {
    let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]).normalize();
    Mesh::with_generated_tangents(
        name,
        corners.to_vec(),
        vec![n; 4],
        vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        vec![0, 1, 2, 0, 2, 3],
        material,
    )
}

/// A floor, a wall, an emissive panel, a point light and a sky: every stochastic path of `direct`.
fn small_scene() -> Scene {
    Scene {
        name: "small".into(),
        meshes: vec![
            quad(
                "floor",
                [
                    Vec3::new(-2.0, 0.0, 2.0),
                    Vec3::new(2.0, 0.0, 2.0),
                    Vec3::new(2.0, 0.0, -2.0),
                    Vec3::new(-2.0, 0.0, -2.0),
                ],
                0,
            ),
            quad(
                "wall",
                [
                    Vec3::new(-2.0, 0.0, -2.0),
                    Vec3::new(2.0, 0.0, -2.0),
                    Vec3::new(2.0, 2.0, -2.0),
                    Vec3::new(-2.0, 2.0, -2.0),
                ],
                1,
            ),
            quad(
                "panel",
                [
                    Vec3::new(-0.5, 1.5, -0.5),
                    Vec3::new(-0.5, 1.5, 0.5),
                    Vec3::new(0.5, 1.5, 0.5),
                    Vec3::new(0.5, 1.5, -0.5),
                ],
                2,
            ),
        ],
        materials: vec![
            Material::diffuse("floor", Vec3::splat(0.6)),
            Material { roughness: 0.3, ..Material::diffuse("wall", Vec3::new(0.7, 0.3, 0.2)) },
            Material::emitter("panel", Vec3::splat(5.0)),
        ],
        lights: vec![Light::Point { position: Vec3::new(1.0, 1.0, 1.0), intensity: Vec3::splat(2.0) }],
        environment: Environment::Uniform(Vec3::new(0.2, 0.3, 0.5)),
        camera: Camera {
            position: Vec3::new(0.0, 1.2, 3.0),
            target: Vec3::new(0.0, 0.5, 0.0),
            ..Default::default()
        },
        ..Default::default()
    }
}

fn settings(technique: &str, w: u32, h: u32) -> RenderSettings {
    RenderSettings { technique: technique.into(), technique_settings: vec![], width: w, height: h, frames: 2 }
}

#[test]
fn renders_are_bit_identical() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let scene = small_scene();
    let a = render(&ctx, &scene, &settings("direct", 48, 32), &mut |_, _| {}).expect("render");
    let b = render(&ctx, &scene, &settings("direct", 48, 32), &mut |_, _| {}).expect("render");
    assert!(a.image.rgb.iter().any(|v| *v > 0.0));
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.image.rgb), bits(&b.image.rgb));
    // A different seed changes the stochastic terms.
    let mut other = settings("direct", 48, 32);
    other.technique_settings = vec![("seed".into(), "7".into())];
    let c = render(&ctx, &scene, &other, &mut |_, _| {}).expect("render");
    assert_ne!(bits(&a.image.rgb), bits(&c.image.rgb));
    assert_eq!(a.stats.technique, "direct");
    assert!(a.stats.passes.iter().any(|p| p.name == "gbuffer"));
}

#[test]
fn invalid_settings_are_clear_errors() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let scene = small_scene();
    let e = render(&ctx, &scene, &settings("nope", 8, 8), &mut |_, _| {}).err().expect("error");
    assert!(matches!(e, RenderError::UnknownTechnique { .. }));
    assert!(e.to_string().contains("direct"), "{e}");
    let e = render(&ctx, &scene, &settings("direct", 0, 0), &mut |_, _| {}).err().expect("error");
    assert!(e.to_string().contains("0x0"), "{e}");
    let mut s = settings("direct", 8, 8);
    s.technique_settings = vec![("shadow_map_size".into(), "3".into())];
    let e = render(&ctx, &scene, &s, &mut |_, _| {}).err().expect("error");
    assert!(e.to_string().contains("shadow_map_size"), "{e}");
    let e = render(&ctx, &scene, &settings("direct", 100_000, 8), &mut |_, _| {}).err().expect("error");
    assert!(e.to_string().contains("max_texture_dimension_2d"), "{e}");
}

/// Changes the GPU upload has to make are reported, not silent: a texture wider than the array limit
/// is downsampled with a warning in the stats.
#[test]
fn downsampled_textures_are_reported() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let mut scene = small_scene();
    let width = rtgi::gpu::scene::MAX_TEXTURE_SIZE * 2;
    scene.textures.push(rtgi::scene::Texture {
        name: "wide".into(),
        width,
        height: 2,
        rgba8: vec![200; (width * 2 * 4) as usize],
        srgb: true,
    });
    scene.materials[0].base_color_texture = Some(rtgi::scene::TextureRef::new(0));
    let out = render(&ctx, &scene, &settings("direct", 16, 16), &mut |_, _| {}).expect("render");
    assert!(out.stats.warnings.iter().any(|w| w.contains("downsampled")), "{:?}", out.stats.warnings);
    let plain = render(&ctx, &small_scene(), &settings("direct", 16, 16), &mut |_, _| {}).expect("render");
    assert!(plain.stats.warnings.is_empty(), "{:?}", plain.stats.warnings);
}
