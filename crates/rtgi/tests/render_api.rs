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

/// Alpha-masked geometry is cut out of every ray, and the traversal compiled for a scene is the one
/// its triangles need (`BVH_ALPHA_TESTS`, see `common/bvh.wgsl`): a fully transparent masked quad in
/// front of the camera and another between the point light and the floor leave the path tracer's
/// image as it is without them (camera, bounce and shadow rays all pass), while the same quads made
/// opaque change it.
#[test]
fn alpha_masked_geometry_is_cut_out_of_every_ray() {
    let ctx = GpuContext::new(&GpuOptions::default()).expect("GPU adapter");
    let with_quads = |alpha: f32| {
        let mut scene = small_scene();
        let material = scene.materials.len() as u32;
        scene.materials.push(Material {
            base_color: glam::Vec4::new(0.9, 0.9, 0.9, alpha),
            alpha_mode: rtgi::scene::AlphaMode::Mask { cutoff: 0.5 },
            ..Material::diffuse("masked", Vec3::splat(0.9))
        });
        let facing_camera = [
            Vec3::new(-0.5, 0.3, 1.5),
            Vec3::new(0.5, 0.3, 1.5),
            Vec3::new(0.5, 1.2, 1.5),
            Vec3::new(-0.5, 1.2, 1.5),
        ];
        let under_light = [
            Vec3::new(0.3, 0.8, 1.2),
            Vec3::new(1.2, 0.8, 1.2),
            Vec3::new(1.2, 0.8, 0.3),
            Vec3::new(0.3, 0.8, 0.3),
        ];
        scene.meshes.push(quad("masked in view", facing_camera, material));
        scene.meshes.push(quad("masked under the light", under_light, material));
        scene
    };
    let mut s = settings("path", 48, 32);
    s.technique_settings = vec![("spp".into(), "4".into())];
    let plain = render(&ctx, &small_scene(), &s, &mut |_, _| {}).expect("render");
    let cut_out = render(&ctx, &with_quads(0.0), &s, &mut |_, _| {}).expect("render");
    let opaque = render(&ctx, &with_quads(1.0), &s, &mut |_, _| {}).expect("render");
    assert!(plain.image.rgb.iter().any(|v| *v > 0.0));
    // The same hits give the same image: bit-identical on lavapipe. The two scenes compile different
    // traversals (with and without the alpha test), so another driver may round the shading otherwise;
    // the bound allows for rounding alone (a quad that blocked a ray would change a whole region).
    let mean = plain.image.rgb.iter().map(|v| f64::from(*v)).sum::<f64>() / plain.image.rgb.len() as f64;
    let worst = plain
        .image
        .rgb
        .iter()
        .zip(&cut_out.image.rgb)
        .map(|(a, b)| f64::from((a - b).abs()))
        .fold(0.0, f64::max);
    assert!(worst <= 1e-5 * mean, "transparent masked quads changed the image: {worst} (mean {mean})");
    let changed = plain.image.rgb.iter().zip(&opaque.image.rgb).filter(|(a, b)| a != b).count();
    // Measured on lavapipe: 3645 of the 4608 values change (the quads block camera, bounce and shadow
    // rays alike); half of that is the bound.
    assert!(changed > 1800, "opaque masked quads changed only {changed} values");
}
