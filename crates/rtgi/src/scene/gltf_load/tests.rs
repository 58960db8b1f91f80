//! Loader tests: hand-written glTF documents (transforms, primitive modes, warnings) and bad input,
//! which must always come back as `SceneError::File` naming the file and the problem, never a panic.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use serde_json::{Value, json};

use super::load;
use crate::error::SceneError;
use crate::scene::gltf_export::tests::{pattern_texture, representative_scene};
use crate::scene::gltf_export::to_glb;
use crate::scene::{AlphaMode, Light, Scene};

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!("data:{mime};base64,{}", base64(bytes))
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn png_bytes() -> Vec<u8> {
    let t = pattern_texture("t", 2, 2, 7, true);
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &t.rgba8,
        2,
        2,
        image::ExtendedColorType::Rgba8,
    )
    .unwrap();
    png
}

/// A one-triangle glTF document with an embedded buffer: positions (3 × VEC3) then indices (u16).
/// Tests patch the returned JSON to introduce one feature or one fault at a time.
fn triangle_gltf(indices: &[u16]) -> Value {
    let positions = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let mut bytes = f32_bytes(&positions);
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    json!({
        "asset": { "version": "2.0" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "name": "tri", "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] }],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0] },
            { "bufferView": 1, "componentType": 5123, "count": indices.len(), "type": "SCALAR" }
        ],
        "bufferViews": [
            { "buffer": 0, "byteOffset": 0, "byteLength": 36 },
            { "buffer": 0, "byteOffset": 36, "byteLength": indices.len() * 2 }
        ],
        "buffers": [{ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) }]
    })
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn write_json(dir: &Path, name: &str, doc: &Value) -> PathBuf {
    write(dir, name, serde_json::to_string_pretty(doc).unwrap().as_bytes())
}

/// Loads a file that must fail, checks that the error is a file error naming the file, and returns
/// its message.
#[track_caller]
fn load_err(path: &Path) -> String {
    match load(path) {
        Ok(_) => panic!("{} loaded but should have failed", path.display()),
        Err(SceneError::File { path: p, message }) => {
            assert_eq!(p, path);
            let shown = SceneError::File { path: p, message: message.clone() }.to_string();
            let name = path.file_name().unwrap().to_string_lossy();
            assert!(shown.contains(&*name), "error does not name the file: {shown}");
            message
        }
        Err(other) => panic!("expected a file error, got {other:?}"),
    }
}

#[track_caller]
fn assert_contains(message: &str, parts: &[&str]) {
    for part in parts {
        assert!(message.contains(part), "expected '{part}' in: {message}");
    }
}

#[test]
fn minimal_triangle_loads_with_generated_attributes() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_json(dir.path(), "tri.gltf", &triangle_gltf(&[0, 1, 2]));
    let scene = load(&path).unwrap();
    assert_eq!(scene.name, "tri");
    assert_eq!(scene.meshes.len(), 1);
    let m = &scene.meshes[0];
    assert_eq!(m.indices, [0, 1, 2]);
    assert!(m.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)), "flat normals: {:?}", m.normals);
    assert!(m.uvs.iter().all(|uv| *uv == Vec2::ZERO));
    assert_eq!(m.tangents.len(), 3);
    // No material: the glTF default material is appended.
    assert_eq!(scene.materials.len(), 1);
    assert_eq!(m.material, 0);
    assert_eq!((scene.materials[0].metallic, scene.materials[0].roughness), (1.0, 1.0));
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // No camera in the file: one framing the bounds, looking at their centre.
    assert!(scene.camera.target.abs_diff_eq(Vec3::new(0.5, 0.5, 0.0), 1e-6));
    assert!(scene.camera.position.z > 0.5);
}

#[test]
fn node_transforms_and_spot_light_are_baked_into_world_space() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let (s45, c45) = (22.5f32.to_radians().sin(), 22.5f32.to_radians().cos());
    // Parent: T(1,2,3) · R_y(90°) · S(2), carrying the mesh; child: T(0,0,1) · R_x(−45°), the spot.
    doc["nodes"] = json!([
        { "name": "parent", "mesh": 0, "translation": [1.0, 2.0, 3.0], "rotation": [0.0, h, 0.0, h],
          "scale": [2.0, 2.0, 2.0], "children": [1] },
        { "name": "spot node", "translation": [0.0, 0.0, 1.0], "rotation": [-s45, 0.0, 0.0, c45],
          "extensions": { "KHR_lights_punctual": { "light": 0 } } }
    ]);
    doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(2);
    let mut buffer_bytes = {
        let uri = doc["buffers"][0]["uri"].as_str().unwrap();
        super::container::decode_base64(uri.split_once(',').unwrap().1).unwrap()
    };
    while !buffer_bytes.len().is_multiple_of(4) {
        buffer_bytes.push(0);
    }
    let normals_at = buffer_bytes.len();
    buffer_bytes.extend(f32_bytes(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0]));
    doc["buffers"][0] = json!({ "byteLength": buffer_bytes.len(), "uri": data_uri("application/octet-stream", &buffer_bytes) });
    doc["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "buffer": 0, "byteOffset": normals_at, "byteLength": 36 }));
    doc["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3" }));
    doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    doc["extensions"] = json!({ "KHR_lights_punctual": { "lights": [
        { "name": "cone", "type": "spot", "color": [1.0, 0.5, 0.25], "intensity": 8.0,
          "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.5 } }
    ] } });
    let path = write_json(dir.path(), "transformed.gltf", &doc);
    let scene = load(&path).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);

    // Vertices (0,0,0), (1,0,0), (0,1,0): scale 2, then (x,y,z) → (z,y,−x), then + (1,2,3).
    let expected = [Vec3::new(1.0, 2.0, 3.0), Vec3::new(1.0, 2.0, 1.0), Vec3::new(1.0, 4.0, 3.0)];
    let m = &scene.meshes[0];
    for (p, e) in m.positions.iter().zip(expected) {
        assert!(p.abs_diff_eq(e, 1e-5), "{p} vs {e}");
    }
    // The normal +Z rotates to +X and agrees with the (still counter-clockwise) winding.
    assert!(m.normals.iter().all(|n| n.abs_diff_eq(Vec3::X, 1e-6)), "{:?}", m.normals);
    let [a, b, c] = [0, 1, 2].map(|k| m.positions[m.indices[k] as usize]);
    assert!((b - a).cross(c - a).normalize().abs_diff_eq(Vec3::X, 1e-6));

    // Spot: local −Z → R_x(−45°) → (0, −√½, −√½) → R_y(90°) → (−√½, −√½, 0); origin (0,0,1) → (3,2,3).
    let [Light::Spot { position, direction, intensity, inner_angle, outer_angle }] = scene.lights[..] else {
        panic!("expected one spot light, got {:?}", scene.lights);
    };
    assert!(position.abs_diff_eq(Vec3::new(3.0, 2.0, 3.0), 1e-5), "{position}");
    assert!(direction.abs_diff_eq(Vec3::new(-h, -h, 0.0), 1e-5), "{direction}");
    assert!(intensity.abs_diff_eq(Vec3::new(8.0, 4.0, 2.0), 1e-6), "{intensity}");
    assert_eq!((inner_angle, outer_angle), (0.2, 0.5));
}

#[test]
fn mirroring_transform_flips_winding() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    doc["nodes"][0]["scale"] = json!([-1.0, 1.0, 1.0]);
    let path = write_json(dir.path(), "mirror.gltf", &doc);
    let scene = load(&path).unwrap();
    let m = &scene.meshes[0];
    let [a, b, c] = [0, 1, 2].map(|k| m.positions[m.indices[k] as usize]);
    let geometric = (b - a).cross(c - a).normalize();
    // Mirrored in x, the triangle still faces +Z, and the winding agrees with the normals.
    assert!(geometric.abs_diff_eq(Vec3::Z, 1e-6), "{geometric}");
    assert!(m.normals.iter().all(|n| n.abs_diff_eq(geometric, 1e-6)));
}

#[test]
fn strips_fans_and_unindexed_primitives_become_triangle_lists() {
    let dir = tempfile::tempdir().unwrap();
    // Four vertices of a unit quad in z = 0, in strip order.
    let positions = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
    let bytes = f32_bytes(&positions);
    let fan: [u16; 4] = [0, 1, 3, 2];
    let mut all = bytes.clone();
    all.extend(fan.iter().flat_map(|i| i.to_le_bytes()));
    let doc = json!({
        "asset": { "version": "2.0" },
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "name": "modes", "primitives": [
            { "attributes": { "POSITION": 0 }, "mode": 5 },
            { "attributes": { "POSITION": 0 }, "indices": 1, "mode": 6 },
            { "attributes": { "POSITION": 0 }, "mode": 0 },
            { "attributes": { "POSITION": 0 }, "mode": 1 }
        ] }],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
              "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0] },
            { "bufferView": 1, "componentType": 5123, "count": 4, "type": "SCALAR" }
        ],
        "bufferViews": [
            { "buffer": 0, "byteLength": 48 },
            { "buffer": 0, "byteOffset": 48, "byteLength": 8 }
        ],
        "buffers": [{ "byteLength": all.len(), "uri": data_uri("application/gltf-buffer", &all) }]
    });
    // No "scenes": every root node is drawn.
    let path = write_json(dir.path(), "modes.gltf", &doc);
    let scene = load(&path).unwrap();
    assert_eq!(scene.meshes.len(), 2, "points and lines are skipped");
    assert_eq!(scene.meshes[0].name, "modes#0");
    for m in &scene.meshes {
        assert_eq!(m.indices.len(), 6, "{}", m.name);
        for tri in m.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| m.positions[tri[k] as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.z > 0.0, "{}: triangle {tri:?} is not counter-clockwise", m.name);
        }
    }
    assert_contains(&scene.warnings.join("\n"), &["mesh 'modes': point and line primitives skipped"]);
}

/// Without `scenes`, glTF leaves what to draw to the application: rtgi draws every root node and warns.
#[test]
fn file_without_scenes_draws_every_root_node_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    // Two root nodes and a child of the second: the child comes with its parent, drawn once.
    doc["nodes"] = json!([
        { "mesh": 0 },
        { "mesh": 0, "translation": [2.0, 0.0, 0.0], "children": [2] },
        { "mesh": 0, "translation": [0.0, 2.0, 0.0] }
    ]);
    let with_scenes = load(&write_json(dir.path(), "with.gltf", &doc)).unwrap();
    assert!(with_scenes.warnings.is_empty(), "{:?}", with_scenes.warnings);
    assert_eq!(with_scenes.meshes.len(), 1, "the scene lists node 0 only");
    let object = doc.as_object_mut().unwrap();
    object.remove("scene");
    object.remove("scenes");
    let scene = load(&write_json(dir.path(), "without.gltf", &doc)).unwrap();
    assert_eq!(scene.meshes.len(), 3, "every root node with its children");
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert_contains(&scene.warnings[0], &["no scenes", "all 2 root nodes"]);
}

#[test]
fn unsupported_features_become_warnings_naming_the_material() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["extensionsUsed"] = json!(["KHR_texture_transform", "KHR_materials_clearcoat"]);
    doc["images"] = json!([{ "uri": data_uri("image/png", &png_bytes()) }]);
    doc["samplers"] = json!([{ "wrapS": 33071 }]);
    doc["textures"] = json!([{ "source": 0, "sampler": 0 }]);
    doc["materials"] = json!([{
        "name": "fancy",
        "pbrMetallicRoughness": {
            "baseColorTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "scale": [2.0, 2.0] } } },
            "metallicRoughnessTexture": { "index": 0 },
            "baseColorFactor": [0.5, 0.25, 1.0, 0.8]
        },
        "emissiveTexture": { "index": 0, "texCoord": 1 },
        "occlusionTexture": { "index": 0 },
        "alphaMode": "BLEND",
        "extensions": { "KHR_materials_clearcoat": { "clearcoatFactor": 1.0 } }
    }]);
    let path = write_json(dir.path(), "warn.gltf", &doc);
    let scene = load(&path).unwrap();
    let w = scene.warnings.join("\n");
    assert_contains(
        &w,
        &[
            "material 'fancy': glTF extension 'KHR_texture_transform' ignored",
            "material 'fancy': glTF extension 'KHR_materials_clearcoat' ignored",
            "material 'fancy': occlusion texture ignored",
            "material 'fancy': alphaMode BLEND rendered opaque",
            "material 'fancy' emissiveTexture: textures using TEXCOORD_1 dropped",
            "texture 0: texture wrap mode other than REPEAT ignored",
        ],
    );
    // Named once, per material, not again as a file-level extension warning.
    assert!(!w.contains("optional glTF extension"), "{w}");
    let mat = &scene.materials[0];
    assert_eq!(mat.alpha_mode, AlphaMode::Blend);
    assert_eq!(mat.emissive_texture, None);
    // The same image as sRGB colour and as linear data: two textures, same pixels.
    let (base, mr) =
        (mat.base_color_texture.unwrap().texture, mat.metallic_roughness_texture.unwrap().texture);
    assert_ne!(base, mr);
    let (tb, tm) = (&scene.textures[base as usize], &scene.textures[mr as usize]);
    assert!(tb.srgb && !tm.srgb);
    assert_eq!(tb.rgba8, tm.rgba8);
    assert_eq!(tb.rgba8, pattern_texture("t", 2, 2, 7, true).rgba8);
}

#[test]
fn camera_node_defines_the_view() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    doc["cameras"] = json!([{ "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }]);
    // Turned 90° about Y: looks along −X.
    doc["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "camera": 0, "translation": [5.0, 1.0, 0.0], "rotation": [0.0, h, 0.0, h] }));
    doc["scenes"][0]["nodes"] = json!([0, 1]);
    let path = write_json(dir.path(), "camera.gltf", &doc);
    let cam = load(&path).unwrap().camera;
    assert!(cam.position.abs_diff_eq(Vec3::new(5.0, 1.0, 0.0), 1e-6));
    assert!(cam.target.abs_diff_eq(Vec3::new(4.0, 1.0, 0.0), 1e-6), "{}", cam.target);
    assert!(cam.up.abs_diff_eq(Vec3::Y, 1e-6));
    assert_eq!((cam.yfov, cam.znear, cam.zfar), (0.8, 0.1, 1000.0));
}

// ---- bad input -------------------------------------------------------------------------------------

#[test]
fn nonexistent_path_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let message = load_err(&dir.path().join("nowhere.glb"));
    assert_contains(&message, &["file not found"]);
}

#[test]
fn non_gltf_files_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let text = write(dir.path(), "notes.gltf", b"hello, this is not glTF");
    assert_contains(&load_err(&text), &["not a glTF file"]);
    let png = write(dir.path(), "picture.glb", &png_bytes());
    assert_contains(&load_err(&png), &["not a glTF file"]);
    let empty = write(dir.path(), "empty.gltf", b"");
    assert_contains(&load_err(&empty), &["not a glTF file"]);
    let broken = write(dir.path(), "broken.gltf", b"{ \"asset\": { \"version\": ");
    assert_contains(&load_err(&broken), &["malformed glTF JSON"]);
    let other_json = write(dir.path(), "other.gltf", b"{ \"name\": \"a package.json perhaps\" }");
    assert_contains(&load_err(&other_json), &["not a valid glTF 2.0 document", "asset"]);
    let mut v1 = triangle_gltf(&[0, 1, 2]);
    v1["asset"]["version"] = json!("1.0");
    assert_contains(&load_err(&write_json(dir.path(), "old.gltf", &v1)), &["version '1.0' is not supported"]);
}

#[test]
fn truncated_glb_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let glb = to_glb(&representative_scene()).unwrap();
    for cut in [4, 11, 12, 19, 20, 100, glb.len() / 2, glb.len() - 1] {
        let path = write(dir.path(), "cut.glb", &glb[..cut]);
        assert_contains(&load_err(&path), &["truncated or malformed .glb"]);
    }
}

#[test]
fn required_unsupported_extension_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    doc["extensionsUsed"] = json!(["KHR_draco_mesh_compression", "KHR_lights_punctual"]);
    doc["extensionsRequired"] = json!(["KHR_draco_mesh_compression", "KHR_lights_punctual"]);
    let path = write_json(dir.path(), "draco.gltf", &doc);
    assert_contains(
        &load_err(&path),
        &[
            "requires glTF extension 'KHR_draco_mesh_compression', which rtgi does not support",
            "supported: KHR_lights_punctual, KHR_materials_emissive_strength",
        ],
    );
    // Used but not required: a warning.
    doc["extensionsRequired"] = json!([]);
    let scene = load(&write_json(dir.path(), "optional.gltf", &doc)).unwrap();
    assert_eq!(
        scene.warnings,
        ["optional glTF extension 'KHR_draco_mesh_compression' is not supported by rtgi and is ignored"]
    );
    // Required but supported is fine.
    doc["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    doc["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
    load(&write_json(dir.path(), "quantized.gltf", &doc)).unwrap();
}

#[test]
fn missing_texture_file_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc["images"] = json!([{ "uri": "missing.png" }]);
    doc["textures"] = json!([{ "source": 0 }]);
    doc["materials"] =
        json!([{ "name": "m", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }]);
    let path = write_json(dir.path(), "textured.gltf", &doc);
    assert_contains(
        &load_err(&path),
        &["image 0 'missing.png'", "cannot read 'missing.png'", "file not found"],
    );

    // Present but not an image, and of a type rtgi does not decode.
    write(dir.path(), "missing.png", b"definitely not a PNG");
    assert_contains(&load_err(&path), &["image 0 'missing.png'", "cannot decode"]);
    doc["images"] = json!([{ "uri": data_uri("image/webp", b"RIFF\x1a\0\0\0WEBPVP8 ....") }]);
    let path = write_json(dir.path(), "webp.gltf", &doc);
    assert_contains(&load_err(&path), &["image 0", "unsupported image type"]);
}

#[test]
fn missing_or_short_buffer_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    doc["buffers"][0]["uri"] = json!("geometry%20data.bin");
    let path = write_json(dir.path(), "external.gltf", &doc);
    assert_contains(
        &load_err(&path),
        &["buffer 0", "cannot read 'geometry%20data.bin'", "geometry data.bin", "file not found"],
    );

    // Present but shorter than byteLength.
    write(dir.path(), "geometry data.bin", &[0u8; 20]);
    assert_contains(&load_err(&path), &["buffer 0 is too short: byteLength is 42 but only 20 bytes"]);

    // Long enough for byteLength, but a view reaches past it.
    write(dir.path(), "geometry data.bin", &[0u8; 42]);
    doc["bufferViews"][1]["byteLength"] = json!(40);
    let path = write_json(dir.path(), "external.gltf", &doc);
    assert_contains(&load_err(&path), &["buffer view 1 (bytes 36..76) lies outside buffer 0"]);

    // An accessor that does not fit in its view.
    let mut doc = triangle_gltf(&[0, 1, 2]);
    doc["accessors"][0]["count"] = json!(4);
    let path = write_json(dir.path(), "overrun.gltf", &doc);
    assert_contains(&load_err(&path), &["accessor 0", "POSITION", "do not fit in buffer view 0"]);

    // A .gltf whose buffer has no URI at all.
    let mut doc = triangle_gltf(&[0, 1, 2]);
    doc["buffers"][0].as_object_mut().unwrap().remove("uri");
    let path = write_json(dir.path(), "nouri.gltf", &doc);
    assert_contains(&load_err(&path), &["buffer 0 has no URI and the file has no GLB BIN chunk"]);
}

#[test]
fn index_out_of_range_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_json(dir.path(), "badindex.gltf", &triangle_gltf(&[0, 1, 7]));
    assert_contains(&load_err(&path), &["mesh 0 'tri' primitive 0: index 7 out of range (3 vertices)"]);
}

type Patch = Box<dyn Fn(&mut Value)>;

#[test]
fn dangling_references_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, Patch, &str)> = vec![
        ("mesh", Box::new(|d| d["nodes"][0]["mesh"] = json!(5)), "refers to mesh 5, which does not exist"),
        ("node", Box::new(|d| d["scenes"][0]["nodes"] = json!([3])), "node 3 does not exist"),
        ("scene", Box::new(|d| d["scene"] = json!(2)), "default scene 2 does not exist"),
        ("accessor", Box::new(|d| d["meshes"][0]["primitives"][0]["indices"] = json!(9)), "accessor 9"),
        ("view", Box::new(|d| d["accessors"][0]["bufferView"] = json!(9)), "buffer view 9 does not exist"),
        (
            "material",
            Box::new(|d| d["meshes"][0]["primitives"][0]["material"] = json!(0)),
            "material 0 does not exist",
        ),
        (
            "cycle",
            Box::new(|d| d["nodes"] = json!([{ "mesh": 0, "children": [1] }, { "children": [0] }])),
            "reached twice in the node hierarchy",
        ),
        (
            "light",
            Box::new(|d| d["nodes"][0]["extensions"] = json!({ "KHR_lights_punctual": { "light": 0 } })),
            "refers to light 0",
        ),
        ("camera", Box::new(|d| d["nodes"][0]["camera"] = json!(0)), "refers to camera 0"),
        (
            "quaternion",
            Box::new(|d| d["nodes"][0]["rotation"] = json!([0.0, 0.0, 0.0, 0.0])),
            "not a unit quaternion",
        ),
        ("mode", Box::new(|d| d["meshes"][0]["primitives"][0]["mode"] = json!(42)), "invalid primitive mode"),
        (
            "index type",
            Box::new(|d| d["accessors"][1]["componentType"] = json!(5126)),
            "unsigned integer scalars",
        ),
    ];
    for (name, patch, expected) in cases {
        let mut doc = triangle_gltf(&[0, 1, 2]);
        patch(&mut doc);
        let path = write_json(dir.path(), &format!("{}.gltf", name.replace(' ', "_")), &doc);
        let message = load_err(&path);
        assert!(message.contains(expected), "{name}: expected '{expected}' in: {message}");
    }
}

/// Every prefix and thousands of corruptions of a valid file: the loader may accept or refuse them, but
/// must never panic (a panic fails this test). Digits in the JSON are swapped for other digits so that
/// the document stays parseable and the corruption reaches offsets, counts and indices; bytes in the
/// BIN chunk are randomised so that it reaches index values, floats and the embedded PNGs.
#[test]
fn corrupted_files_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = representative_scene();
    scene.meshes.truncate(3);
    let glb = to_glb(&scene).unwrap();
    let json_len = u32::from_le_bytes([glb[12], glb[13], glb[14], glb[15]]) as usize;
    let json_range = 20..20 + json_len;
    let bin_range = 28 + json_len..glb.len();
    let path = dir.path().join("fuzz.glb");
    for cut in (0..glb.len()).step_by(13) {
        std::fs::write(&path, &glb[..cut]).unwrap();
        assert!(load(&path).is_err(), "prefix of {cut} bytes accepted");
    }
    let mut state = 0x2545_f491_u32;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state as usize
    };
    let digits: Vec<usize> = json_range.clone().filter(|&i| glb[i].is_ascii_digit()).collect();
    let (mut accepted, mut refused) = (0, 0);
    for round in 0..3000 {
        let mut bytes = glb.clone();
        for _ in 0..1 + next() % 3 {
            match round % 3 {
                0 => bytes[digits[next() % digits.len()]] = b'0' + (next() % 10) as u8,
                1 => bytes[bin_range.start + next() % bin_range.len()] = next() as u8,
                _ => bytes[next() % glb.len()] = next() as u8,
            }
        }
        std::fs::write(&path, &bytes).unwrap();
        match load(&path) {
            Ok(_) => accepted += 1,
            Err(_) => refused += 1,
        }
    }
    // Both outcomes occur, so the corruptions do reach the checks rather than all failing early.
    assert!(accepted > 100 && refused > 100, "accepted {accepted}, refused {refused}");
}

#[test]
fn sparse_accessors_and_normalized_uvs_are_decoded() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    let mut bytes = {
        let uri = doc["buffers"][0]["uri"].as_str().unwrap();
        super::container::decode_base64(uri.split_once(',').unwrap().1).unwrap()
    };
    while !bytes.len().is_multiple_of(4) {
        bytes.push(0);
    }
    // UVs as normalised u8 pairs (padded to 4 bytes per element), then a sparse override:
    // index 2 (u8) → (0.5, 2.0, 0.0).
    let uv_at = bytes.len();
    bytes.extend_from_slice(&[0, 255, 0, 0, 255, 51, 0, 0, 128, 0, 0, 0]);
    let sparse_index_at = bytes.len();
    bytes.extend_from_slice(&[2, 0, 0, 0]);
    let sparse_value_at = bytes.len();
    bytes.extend(f32_bytes(&[0.5, 2.0, 0.0]));
    doc["buffers"][0] =
        json!({ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) });
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({ "buffer": 0, "byteOffset": uv_at, "byteLength": 12, "byteStride": 4 }));
    views.push(json!({ "buffer": 0, "byteOffset": sparse_index_at, "byteLength": 1 }));
    views.push(json!({ "buffer": 0, "byteOffset": sparse_value_at, "byteLength": 12 }));
    doc["accessors"][0]["sparse"] = json!({
        "count": 1,
        "indices": { "bufferView": 3, "componentType": 5121 },
        "values": { "bufferView": 4 }
    });
    doc["accessors"][0]["max"] = json!([1.0, 2.0, 0.0]);
    doc["accessors"].as_array_mut().unwrap().push(json!({
        "bufferView": 2, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC2"
    }));
    doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(2);
    let path = write_json(dir.path(), "sparse.gltf", &doc);
    let m = &load(&path).unwrap().meshes[0];
    assert_eq!(m.positions, [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 2.0, 0.0)]);
    assert_eq!(m.uvs, [Vec2::new(0.0, 1.0), Vec2::new(1.0, 0.2), Vec2::new(128.0 / 255.0, 0.0)]);

    // A sparse index beyond the accessor's count is refused.
    bytes[sparse_index_at] = 3;
    doc["buffers"][0] =
        json!({ "byteLength": bytes.len(), "uri": data_uri("application/octet-stream", &bytes) });
    let path = write_json(dir.path(), "sparse_bad.gltf", &doc);
    assert_contains(&load_err(&path), &["accessor 0", "sparse index 3 out of range (3 elements)"]);
}

#[test]
fn scene_of_other_tools_needs_no_rtgi_extras() {
    // A Scene exported by rtgi, with its extras stripped, still loads (a camera at distance 1, no
    // environment) — what another tool that drops extras would give us back.
    let dir = tempfile::tempdir().unwrap();
    let glb = to_glb(&representative_scene()).unwrap();
    let path = write(dir.path(), "stripped.glb", &glb);
    let scene: Scene = load(&path).unwrap();
    assert!(matches!(scene.environment, crate::scene::Environment::Sky { .. }));
    let json_len = u32::from_le_bytes([glb[12], glb[13], glb[14], glb[15]]) as usize;
    let mut doc: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    doc["scenes"][0].as_object_mut().unwrap().remove("extras");
    for node in doc["nodes"].as_array_mut().unwrap() {
        node.as_object_mut().unwrap().remove("extras");
    }
    let mut json = serde_json::to_vec(&doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let bin = &glb[20 + json_len..];
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + json.len() + bin.len()) as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&json);
    out.extend(bin);
    let path = write(dir.path(), "stripped.glb", &out);
    let stripped = load(&path).unwrap();
    assert_eq!(stripped.environment, crate::scene::Environment::None);
    let cam = stripped.camera;
    assert!((cam.target.distance(cam.position) - 1.0).abs() < 1e-5);
    let original = representative_scene().camera;
    let dir_a = (original.target - original.position).normalize();
    assert!((cam.target - cam.position).abs_diff_eq(dir_a, 1e-5));
}

/// A translucent medium travels in a material's extras (`rtgi_subsurface`); a malformed or
/// meaningless one is an error naming the material.
#[test]
fn subsurface_extras_load_and_bad_ones_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = triangle_gltf(&[0, 1, 2]);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    let medium =
        json!({ "absorption": [1.0, 2.0, 3.0], "reduced_scattering": [40.0, 50.0, 60.0], "eta": 1.3 });
    doc["materials"] = json!([{ "name": "wax", "extras": { "rtgi_subsurface": medium } }]);
    let path = write_json(dir.path(), "wax.gltf", &doc);
    let m = &load(&path).unwrap().materials[0];
    let expected = crate::scene::Subsurface {
        absorption: Vec3::new(1.0, 2.0, 3.0),
        reduced_scattering: Vec3::new(40.0, 50.0, 60.0),
        eta: 1.3,
    };
    assert_eq!(m.subsurface, Some(expected));
    for (bad, message) in [
        (
            json!({ "absorption": [1.0, 2.0], "reduced_scattering": [1.0, 1.0, 1.0], "eta": 1.3 }),
            "array of length 3",
        ),
        (json!({ "absorption": [1.0, 2.0, 3.0], "reduced_scattering": [1.0, 1.0, 1.0], "eta": 0.5 }), "≥ 1"),
        (
            json!({ "absorption": [-1.0, 2.0, 3.0], "reduced_scattering": [1.0, 1.0, 1.0], "eta": 1.3 }),
            "non-negative",
        ),
        (json!("wax"), "rtgi_subsurface"),
    ] {
        doc["materials"][0]["extras"]["rtgi_subsurface"] = bad;
        let path = write_json(dir.path(), "bad.gltf", &doc);
        assert_contains(&load_err(&path), &["material 'wax'", "rtgi_subsurface", message]);
    }
}
