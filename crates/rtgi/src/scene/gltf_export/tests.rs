//! Export → load round trips.

use std::path::Path;

use glam::{Vec2, Vec3, Vec4};

use super::{assert_scenes_equivalent, export, scene_differences, to_glb};
use crate::scene::gltf_load::load;
use crate::scene::{
    AlphaMode, Camera, Environment, EnvironmentMap, Light, Material, Mesh, Scene, Texture, TextureRef,
};

/// A small RGBA texture with distinct, non-trivial bytes (alpha included), so that any channel
/// swap, colour-space conversion or premultiplication in the round trip shows up.
pub(crate) fn pattern_texture(name: &str, width: u32, height: u32, seed: u32, srgb: bool) -> Texture {
    let rgba8 = (0..width * height * 4).map(|i| ((i * 37 + seed * 101) % 251) as u8).collect();
    Texture { name: name.into(), width, height, rgba8, srgb }
}

fn quad(name: &str, origin: Vec3, u: Vec3, v: Vec3, material: u32) -> Mesh {
    let positions = vec![origin, origin + u, origin + u + v, origin + v];
    let normal = u.cross(v).normalize();
    let uvs = vec![Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)];
    Mesh::with_generated_tangents(name, positions, vec![normal; 4], uvs, vec![0, 1, 2, 0, 2, 3], material)
}

fn cube(name: &str, center: Vec3, half: f32, material: u32) -> Mesh {
    let mut mesh = Mesh { name: name.into(), material, ..Default::default() };
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let base = mesh.positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                mesh.positions.push(center + (n + u * a + v * b) * half);
                mesh.normals.push(n);
                mesh.uvs.push(Vec2::new((a + 1.0) * 0.5, (b + 1.0) * 0.5));
            }
            mesh.indices.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    mesh.tangents = crate::scene::generate_tangents(&mesh.positions, &mesh.normals, &mesh.uvs, &mesh.indices);
    mesh
}

/// A scene that exercises everything the exporter writes: textured, normal-mapped, emissive (strength
/// above 1), masked and blended materials, all three light kinds (including directions parallel to
/// ±Z, the degenerate cases of a rotation arc), a camera looking down at an angle, and a sky.
pub(crate) fn representative_scene() -> Scene {
    let textures = vec![
        pattern_texture("albedo", 4, 4, 1, true),
        pattern_texture("metal_rough", 2, 2, 2, false),
        pattern_texture("normal", 4, 2, 3, false),
        pattern_texture("glow", 2, 3, 4, true),
    ];
    let materials = vec![
        Material {
            name: "textured".into(),
            base_color: Vec4::new(0.8, 0.7, 0.6, 1.0),
            base_color_texture: Some(TextureRef::new(0)),
            metallic: 0.3,
            roughness: 0.55,
            metallic_roughness_texture: Some(TextureRef::new(1)),
            ..Default::default()
        },
        Material {
            name: "normal_mapped".into(),
            base_color: Vec4::new(0.2, 0.4, 0.9, 1.0),
            normal_texture: Some(TextureRef::new(2)),
            normal_scale: 0.75,
            double_sided: true,
            ..Default::default()
        },
        Material {
            emissive_texture: Some(TextureRef::new(3)),
            ..Material::emitter("emitter", Vec3::new(12.5, 10.0, 3.3))
        },
        Material {
            name: "masked".into(),
            base_color: Vec4::new(0.5, 0.9, 0.1, 0.4),
            alpha_mode: AlphaMode::Mask { cutoff: 0.3 },
            ..Default::default()
        },
        Material { alpha_mode: AlphaMode::Blend, ..Material::diffuse("glass", Vec3::new(0.9, 0.9, 0.95)) },
        Material { emissive: Vec3::new(0.25, 0.5, 1.0), ..Material::diffuse("dim_glow", Vec3::splat(0.5)) },
    ];
    let meshes = vec![
        quad("floor", Vec3::new(-2.0, 0.0, 2.0), Vec3::new(4.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -4.0), 0),
        cube("box", Vec3::new(0.5, 0.75, -0.25), 0.75, 1),
        quad("lamp", Vec3::new(-0.5, 2.9, 0.5), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -1.0), 2),
        quad("leaf", Vec3::new(-1.5, 0.1, -1.0), Vec3::new(0.7, 0.3, 0.0), Vec3::new(0.0, 0.8, 0.1), 3),
        cube("pane", Vec3::new(-1.0, 0.5, 1.0), 0.25, 4),
        cube("dim", Vec3::new(1.2, 0.3, 1.1), 0.3, 5),
    ];
    let lights = vec![
        Light::Point { position: Vec3::new(1.0, 2.0, 3.0), intensity: Vec3::new(10.0, 8.0, 6.0) },
        Light::Spot {
            position: Vec3::new(0.0, 4.0, 0.5),
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            intensity: Vec3::new(50.0, 45.0, 40.0),
            inner_angle: 0.3,
            outer_angle: 0.6,
        },
        Light::Directional {
            direction: Vec3::new(-1.0, -2.0, -0.5).normalize(),
            irradiance: Vec3::new(3.0, 2.9, 2.5),
        },
        Light::Spot {
            position: Vec3::new(0.0, 1.0, -3.0),
            direction: Vec3::Z,
            intensity: Vec3::new(0.5, 1.0, 2.0),
            inner_angle: 0.1,
            outer_angle: 0.9,
        },
        Light::Directional { direction: Vec3::NEG_Z, irradiance: Vec3::new(0.1, 0.1, 0.1) },
    ];
    Scene {
        name: "representative".into(),
        meshes,
        materials,
        textures,
        lights,
        environment: Environment::Sky {
            sun_direction: Vec3::new(0.3, 0.8, 0.2).normalize(),
            sun_radiance: Vec3::new(2.0e4, 1.9e4, 1.7e4),
            sky_radiance: Vec3::new(0.3, 0.5, 1.1),
            ground_radiance: Vec3::new(0.1, 0.09, 0.08),
        },
        environment_rotation: glam::Quat::from_axis_angle(Vec3::new(0.3, 1.0, -0.2).normalize(), 0.7),
        camera: Camera {
            position: Vec3::new(2.0, 1.5, 4.0),
            target: Vec3::new(0.0, 0.5, 0.0),
            up: Vec3::Y,
            yfov: 50f32.to_radians(),
            znear: 0.05,
            zfar: 200.0,
        },
        warnings: Vec::new(),
        animation: None,
    }
}

fn round_trip(scene: &Scene, dir: &Path) -> Scene {
    let path = dir.join("round_trip.glb");
    export(scene, &path).unwrap();
    load(&path).unwrap()
}

#[test]
fn representative_scene_round_trips() {
    let scene = representative_scene();
    scene.validate().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let back = round_trip(&scene, dir.path());

    assert_eq!(back.name, "round_trip");
    assert_eq!(back.meshes.len(), scene.meshes.len());
    assert_eq!(back.triangle_count(), scene.triangle_count());
    assert_eq!(back.vertex_count(), scene.vertex_count());
    let (a, b) = (scene.bounds(), back.bounds());
    assert!(a.min.abs_diff_eq(b.min, 1e-5) && a.max.abs_diff_eq(b.max, 1e-5), "{a:?} vs {b:?}");
    assert_eq!(back.materials.len(), scene.materials.len());
    assert_eq!(back.lights.len(), 5);
    assert_scenes_equivalent(&scene, &back);
    // The only thing rtgi cannot render faithfully here is the blended material.
    assert_eq!(back.warnings.len(), 1, "{:?}", back.warnings);
    assert!(
        back.warnings[0].contains("'glass'") && back.warnings[0].contains("BLEND"),
        "{:?}",
        back.warnings
    );

    // A second round trip is stable too (nothing accumulates, e.g. duplicated default materials).
    let again = round_trip(&back, dir.path());
    assert_scenes_equivalent(&back, &again);
}

/// A generated environment map (no file behind it) is written beside the `.glb` and loads again:
/// `pillars:sky=patch`'s map, to the precision of Radiance's shared exponent (8 mantissa bits).
#[test]
fn a_generated_environment_map_is_exported_beside_the_scene() {
    let scene = crate::scene::builtin::build("pillars", &[("sky".into(), "patch".into())]).unwrap();
    let Environment::Map(map) = &scene.environment else { panic!("pillars:sky=patch has a map") };
    assert!(!Path::new(&map.path).is_file());
    let dir = tempfile::tempdir().unwrap();
    let back = round_trip(&scene, dir.path());
    assert!(dir.path().join("round_trip.environment.hdr").is_file());
    let Environment::Map(loaded) = &back.environment else {
        panic!("the map did not load again: {:?} {:?}", back.environment, back.warnings)
    };
    assert_eq!((loaded.width, loaded.height, loaded.intensity), (map.width, map.height, map.intensity));
    let worst = map
        .rgb
        .iter()
        .zip(&loaded.rgb)
        .map(|(a, b)| (a - b).abs() / a.abs().max(1e-3))
        .fold(0.0f32, f32::max);
    // RGBE keeps 8 bits of the largest channel's mantissa: ≤ 2⁻⁷ relative to it.
    assert!(worst < 0.01, "worst relative difference {worst}");
}

#[test]
fn comparison_detects_differences() {
    let scene = representative_scene();
    assert!(scene_differences(&scene, &scene).is_empty());

    let mut moved = scene.clone();
    if let Light::Spot { direction, .. } = &mut moved.lights[1] {
        *direction = (*direction + Vec3::new(0.0, 0.0, 1e-3)).normalize();
    }
    moved.textures[2].rgba8[5] ^= 1;
    moved.materials[2].emissive.x *= 1.0001;
    moved.camera.target.y += 1e-3;
    moved.meshes[1].positions[3].z += 1e-3;
    moved.environment = Environment::Uniform(Vec3::ONE);
    moved.environment_rotation = glam::Quat::from_rotation_y(1e-3);
    let diffs = scene_differences(&scene, &moved);
    let joined = diffs.join("\n");
    for expected in [
        "light 1 direction",
        "normal_texture: pixel data differ",
        "emissive",
        "camera target",
        "mesh 1 'box' positions[3]",
        "environment: sky vs uniform",
        "environment rotation",
    ] {
        assert!(joined.contains(expected), "missing '{expected}' in:\n{joined}");
    }
}

#[test]
fn glb_is_valid_for_the_gltf_crate_and_needs_no_extension() {
    let glb = to_glb(&representative_scene()).unwrap();
    // The gltf crate's own validator (independent of rtgi's loader) accepts the file.
    let gltf = gltf::Gltf::from_slice(&glb).unwrap();
    assert_eq!(gltf.extensions_required().count(), 0);
    let used: Vec<&str> = gltf.extensions_used().collect();
    assert!(
        used.contains(&"KHR_lights_punctual") && used.contains(&"KHR_materials_emissive_strength"),
        "{used:?}"
    );
    assert_eq!(gltf.meshes().count(), 6);
    assert_eq!(gltf.images().count(), 4);
    // Emissive factors stay in [0, 1]; the excess is in the strength extension.
    let emitter = gltf.materials().find(|m| m.name() == Some("emitter")).unwrap();
    assert_eq!(emitter.emissive_factor(), [1.0, 10.0 / 12.5, 3.3 / 12.5]);
    assert_eq!(emitter.emissive_strength(), Some(12.5));
    let dim = gltf.materials().find(|m| m.name() == Some("dim_glow")).unwrap();
    assert_eq!(dim.emissive_strength(), None);
    // Every buffer view and image resolves, as a third-party importer sees it.
    let (_, buffers, images) = gltf::import_slice(&glb).unwrap();
    assert_eq!(buffers.len(), 1);
    assert_eq!(images.len(), 4);
    assert_eq!(glb.len() % 4, 0);
}

#[test]
fn empty_scene_round_trips() {
    let scene = Scene::default();
    let dir = tempfile::tempdir().unwrap();
    let back = round_trip(&scene, dir.path());
    assert_scenes_equivalent(&scene, &back);
    assert!(back.meshes.is_empty() && back.lights.is_empty());
}

fn write_hdr(path: &Path, width: u32, height: u32) -> Vec<f32> {
    let pixels: Vec<image::Rgb<f32>> =
        (0..width * height).map(|i| image::Rgb([0.5 + i as f32, 2.0, 0.25 * (i % 3) as f32])).collect();
    let file = std::fs::File::create(path).unwrap();
    image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(file))
        .encode(&pixels, width as usize, height as usize)
        .unwrap();
    // Read back what the lossy RGBE encoding kept.
    image::open(path).unwrap().into_rgb32f().into_raw()
}

#[test]
fn environment_map_round_trips_by_path() {
    let dir = tempfile::tempdir().unwrap();
    let rgb = write_hdr(&dir.path().join("sky.hdr"), 4, 2);
    let mut scene = representative_scene();
    scene.environment =
        Environment::Map(EnvironmentMap { path: "sky.hdr".into(), width: 4, height: 2, rgb, intensity: 1.5 });
    let back = round_trip(&scene, dir.path());
    assert_scenes_equivalent(&scene, &back);

    // A map that has gone missing is a warning, not a failure.
    std::fs::remove_file(dir.path().join("sky.hdr")).unwrap();
    let back = load(&dir.path().join("round_trip.glb")).unwrap();
    assert_eq!(back.environment, Environment::None);
    assert!(back.warnings.iter().any(|w| w.contains("'sky.hdr' not found")), "{:?}", back.warnings);

    // OpenEXR maps are refused with a clear message for now.
    std::fs::write(dir.path().join("sky.exr"), b"not really exr").unwrap();
    if let Environment::Map(map) = &mut scene.environment {
        map.path = "sky.exr".into();
    }
    let path = dir.path().join("exr.glb");
    export(&scene, &path).unwrap();
    let err = load(&path).unwrap_err().to_string();
    assert!(err.contains("exr.glb") && err.contains("OpenEXR") && err.contains("not supported yet"), "{err}");
}

#[test]
fn export_reports_unwritable_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("no_such_dir").join("x.glb");
    let err = export(&representative_scene(), &path).unwrap_err().to_string();
    assert!(err.contains("x.glb") && err.contains("cannot write"), "{err}");
}

/// Every built-in scene (at default parameters) survives export and reload: counts, bounds, materials,
/// textures, lights, camera and environment.
#[test]
fn every_builtin_scene_round_trips() {
    let dir = tempfile::tempdir().expect("temp dir");
    for entry in crate::scene::builtin::list() {
        let scene = crate::scene::builtin::build(entry.name, &[]).expect("built-in scene");
        let back = round_trip(&scene, dir.path());
        assert_scenes_equivalent(&scene, &back);
        assert_eq!(scene.triangle_count(), back.triangle_count(), "{}", entry.name);
        assert_eq!(scene.lights.len(), back.lights.len(), "{}", entry.name);
    }
}

/// A turned environment keeps its turn through export and reload.
#[test]
fn environment_rotation_round_trips() {
    let dir = tempfile::tempdir().expect("temp dir");
    let settings = [("env_rotation".to_string(), "-47.5".to_string())];
    let scene = crate::scene::builtin::build("spheres-env", &settings).expect("built-in scene");
    assert_ne!(scene.environment_rotation, glam::Quat::IDENTITY);
    let back = round_trip(&scene, dir.path());
    assert_scenes_equivalent(&scene, &back);
}

/// `b` plays the same animation as `a`: the same clips (names, animated properties, interpolation,
/// key times and values) and, at several times, posed scenes equivalent within 1e-5.
pub(crate) fn assert_animations_equivalent(a: &Scene, b: &Scene) {
    let (x, y) = (a.animation.as_ref().expect("a is animated"), b.animation.as_ref().expect("b is animated"));
    assert_eq!(x.active, y.active);
    assert_eq!(x.clips.len(), y.clips.len());
    for (cx, cy) in x.clips.iter().zip(&y.clips) {
        assert_eq!(cx.name, cy.name);
        assert_eq!(cx.channels.len(), cy.channels.len(), "clip '{}'", cx.name);
        for (chx, chy) in cx.channels.iter().zip(&cy.channels) {
            assert_eq!(x.nodes[chx.node].name, y.nodes[chy.node].name);
            assert_eq!(chx.property, chy.property);
            assert_eq!(chx.sampler.interpolation, chy.sampler.interpolation);
            assert_eq!(chx.sampler.times, chy.sampler.times);
            assert_eq!(chx.sampler.values, chy.sampler.values);
        }
    }
    assert_eq!(a.moving_meshes(), b.moving_meshes());
    let d = a.animation_duration();
    assert_eq!(d, b.animation_duration());
    for t in [0.0, 0.13 * d, 0.5 * d, 0.77 * d, d, d + 1.0] {
        let diffs = scene_differences(&a.posed(t), &b.posed(t));
        assert!(diffs.is_empty(), "t = {t}: posed scenes differ:\n  {}", diffs.join("\n  "));
    }
}

fn animation_round_trip(scene: &Scene) {
    let dir = tempfile::tempdir().unwrap();
    let back = round_trip(scene, dir.path());
    assert_scenes_equivalent(scene, &back);
    assert_animations_equivalent(scene, &back);
    // Exporting what was loaded gives the same animation again (nothing accumulates or drifts).
    let again = round_trip(&back, dir.path());
    assert_animations_equivalent(scene, &again);
}

#[test]
fn animated_scene_round_trips() {
    let full = crate::scene::animation::tests::animated_scene();
    let mut scene = full.clone();
    scene.animation.as_mut().unwrap().clips.remove(1);
    animation_round_trip(&scene);
    // Every clip travels, not only the active one, and which one is active too.
    let mut rise = scene.clone();
    rise.select_animation("rise").unwrap();
    animation_round_trip(&rise);
    // A clip without channels cannot be written (glTF wants at least one); the others still are.
    let dir = tempfile::tempdir().unwrap();
    let back = round_trip(&full, dir.path());
    let names: Vec<&str> = back.animation.as_ref().unwrap().clips.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["move", "rise"]);
}

#[test]
fn hand_written_animated_gltf_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&crate::testing::animated_gltf(dir.path()).unwrap()).unwrap();
    animation_round_trip(&scene);
}

#[test]
fn animated_builtin_scenes_round_trip() {
    for (name, motion) in [
        ("cornell", "box"),
        ("cornell-spot", "spot"),
        ("atrium", "camera"),
        ("atrium", "sun"),
        ("spheres-env", "environment"),
    ] {
        let settings = [("animate".to_string(), motion.to_string())];
        let scene = crate::scene::builtin::build(name, &settings).expect("built-in scene");
        animation_round_trip(&scene);
    }
}
