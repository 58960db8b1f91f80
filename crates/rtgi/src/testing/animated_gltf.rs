//! A small animated glTF 2.0 file written by hand (JSON plus a binary buffer, not through rtgi's
//! exporter), so that the loader's animation support is checked against an independent writer.
//!
//! The scene: a closed 4 m × 3 m × 4 m room of diffuse grey walls (x, z in −2…2, y in 0…3), lit by one
//! point light, with a reddish 0.6 m box and a camera, all moving over 2 seconds:
//!
//! | node | animated by | interpolation |
//! |---|---|---|
//! | 1 `box` (mesh) | translation (−0.8, 0.5, −0.5) → (0, 0.5, −0.8) → (0.8, 0.5, −0.5) at t = 0, 1, 2 | LINEAR |
//! | 1 `box` | rotation about +y, 0° → 90° at t = 0, 2, zero tangents | CUBICSPLINE |
//! | 2 `camera` | translation (0, 1.5, 1.8) → (0.6, 1.4, 1.8) at t = 0, 2; looks along −z | LINEAR |
//! | 3 `light-rig` | translation (−0.5, 2.5, 0), then (0.5, 2.5, 0) from t = 1 | STEP |
//! | 4 `point-light`, child of 3 | translation (0, −0.2, 0) → (0, −0.2, 0.8) at t = 0, 2 | LINEAR |
//!
//! The point light (KHR_lights_punctual, 8 W/sr white) is on node 4, so it follows both its own keys
//! and its parent's.

use std::path::{Path, PathBuf};

use serde_json::{Value, json};

/// Half the room's width and depth, and its height (metres).
pub const ROOM_HALF: f32 = 2.0;
pub const ROOM_HEIGHT: f32 = 3.0;
/// Half the moving box's edge.
pub const BOX_HALF: f32 = 0.3;

/// Accumulates the binary buffer, its views and accessors.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    /// Appends float data as one accessor of `type_` ("SCALAR", "VEC3", ...); `bounds` adds the min/max
    /// that the spec requires for positions and animation inputs.
    fn floats(&mut self, data: &[f32], type_: &str, components: usize, bounds: bool) -> usize {
        let count = data.len() / components;
        let mut accessor = json!({
            "bufferView": self.view(data.iter().flat_map(|x| x.to_le_bytes()).collect()),
            "componentType": 5126,
            "count": count,
            "type": type_,
        });
        if bounds {
            let column = |c: usize| data.iter().skip(c).step_by(components).copied();
            let min: Vec<f32> = (0..components).map(|c| column(c).fold(f32::INFINITY, f32::min)).collect();
            let max: Vec<f32> =
                (0..components).map(|c| column(c).fold(f32::NEG_INFINITY, f32::max)).collect();
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn indices(&mut self, data: &[u16]) -> usize {
        let view = self.view(data.iter().flat_map(|x| x.to_le_bytes()).collect());
        self.accessors.push(
            json!({ "bufferView": view, "componentType": 5123, "count": data.len(), "type": "SCALAR" }),
        );
        self.accessors.len() - 1
    }

    fn view(&mut self, bytes: Vec<u8>) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views.push(json!({ "buffer": 0, "byteOffset": self.bytes.len(), "byteLength": bytes.len() }));
        self.bytes.extend(bytes);
        self.views.len() - 1
    }
}

/// An axis-aligned box centred on the origin with half extents `half`, faces pointing out
/// (`inward` = false) or in: positions, normals and u16 indices, counter-clockwise from the front.
fn box_faces(half: [f32; 3], inward: bool) -> (Vec<f32>, Vec<f32>, Vec<u16>) {
    let (mut positions, mut normals, mut indices) = (Vec::new(), Vec::new(), Vec::new());
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            // The outward normal is sign · e_axis; u and v span the face with u × v along it.
            let (u_axis, v_axis) = ((axis + 1) % 3, (axis + 2) % 3);
            let facing = if inward { -sign } else { sign };
            let base = (positions.len() / 3) as u16;
            for (a, b) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let mut p = [0.0f32; 3];
                p[axis] = sign * half[axis];
                p[u_axis] = a * half[u_axis];
                p[v_axis] = b * half[v_axis];
                positions.extend(p);
                let mut n = [0.0f32; 3];
                n[axis] = facing;
                normals.extend(n);
            }
            // e_u × e_v = +e_axis, so (0, 1, 2) winds counter-clockwise seen from +axis.
            if facing > 0.0 {
                indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
            } else {
                indices.extend([base, base + 2, base + 1, base, base + 3, base + 2]);
            }
        }
    }
    (positions, normals, indices)
}

/// Writes `animated.gltf` and `animated.bin` (see the module documentation) into `dir` and returns
/// the path of the `.gltf`.
pub fn animated_gltf(dir: &Path) -> std::io::Result<PathBuf> {
    let mut bin = Bin::default();
    let mesh = |bin: &mut Bin, half: [f32; 3], inward: bool, material: usize| {
        let (p, n, i) = box_faces(half, inward);
        let (p, n, i) = (bin.floats(&p, "VEC3", 3, true), bin.floats(&n, "VEC3", 3, false), bin.indices(&i));
        json!({ "primitives": [{ "attributes": { "POSITION": p, "NORMAL": n }, "indices": i, "material": material }] })
    };
    let mut room = mesh(&mut bin, [ROOM_HALF, ROOM_HEIGHT * 0.5, ROOM_HALF], true, 0);
    room["name"] = json!("room");
    let mut moving_box = mesh(&mut bin, [BOX_HALF; 3], false, 1);
    moving_box["name"] = json!("box");

    let s = std::f32::consts::FRAC_1_SQRT_2;
    let t2 = bin.floats(&[0.0, 2.0], "SCALAR", 1, true);
    let t012 = bin.floats(&[0.0, 1.0, 2.0], "SCALAR", 1, true);
    let t01 = bin.floats(&[0.0, 1.0], "SCALAR", 1, true);
    let box_path = bin.floats(&[-0.8, 0.5, -0.5, 0.0, 0.5, -0.8, 0.8, 0.5, -0.5], "VEC3", 3, false);
    // CUBICSPLINE: in-tangent, value, out-tangent per key; zero tangents ease in and out.
    #[rustfmt::skip]
    let box_turn = bin.floats(&[
        0.0, 0.0, 0.0, 0.0,   0.0, 0.0, 0.0, 1.0,   0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0,   0.0, s, 0.0, s,       0.0, 0.0, 0.0, 0.0,
    ], "VEC4", 4, false);
    let camera_path = bin.floats(&[0.0, 1.5, 1.8, 0.6, 1.4, 1.8], "VEC3", 3, false);
    let rig_jump = bin.floats(&[-0.5, 2.5, 0.0, 0.5, 2.5, 0.0], "VEC3", 3, false);
    let light_slide = bin.floats(&[0.0, -0.2, 0.0, 0.0, -0.2, 0.8], "VEC3", 3, false);

    let bin_name = "animated.bin";
    let document = json!({
        "asset": { "version": "2.0", "generator": "rtgi testing::animated_gltf (hand-written)" },
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [
            { "name": "bulb", "type": "point", "color": [1.0, 1.0, 1.0], "intensity": 8.0 }
        ] } },
        "scene": 0,
        "scenes": [{ "name": "animated", "nodes": [0, 1, 2, 3] }],
        "nodes": [
            { "name": "room", "mesh": 0, "translation": [0.0, ROOM_HEIGHT * 0.5, 0.0] },
            { "name": "box", "mesh": 1, "translation": [-0.8, 0.5, -0.5] },
            { "name": "camera", "camera": 0, "translation": [0.0, 1.5, 1.8] },
            { "name": "light-rig", "translation": [-0.5, 2.5, 0.0], "children": [4] },
            { "name": "point-light", "translation": [0.0, -0.2, 0.0],
              "extensions": { "KHR_lights_punctual": { "light": 0 } } }
        ],
        "cameras": [{ "name": "camera", "type": "perspective",
                      "perspective": { "yfov": std::f32::consts::FRAC_PI_3, "znear": 0.05, "zfar": 50.0 } }],
        "meshes": [room, moving_box],
        "materials": [
            { "name": "wall", "pbrMetallicRoughness": { "baseColorFactor": [0.7, 0.7, 0.7, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 } },
            { "name": "box", "pbrMetallicRoughness": { "baseColorFactor": [0.7, 0.3, 0.2, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0 } }
        ],
        "animations": [{
            "name": "move",
            "samplers": [
                { "input": t012, "output": box_path, "interpolation": "LINEAR" },
                { "input": t2, "output": box_turn, "interpolation": "CUBICSPLINE" },
                { "input": t2, "output": camera_path },
                { "input": t01, "output": rig_jump, "interpolation": "STEP" },
                { "input": t2, "output": light_slide, "interpolation": "LINEAR" }
            ],
            "channels": [
                { "sampler": 0, "target": { "node": 1, "path": "translation" } },
                { "sampler": 1, "target": { "node": 1, "path": "rotation" } },
                { "sampler": 2, "target": { "node": 2, "path": "translation" } },
                { "sampler": 3, "target": { "node": 3, "path": "translation" } },
                { "sampler": 4, "target": { "node": 4, "path": "translation" } }
            ]
        }],
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{ "byteLength": bin.bytes.len(), "uri": bin_name }]
    });
    std::fs::write(dir.join(bin_name), &bin.bytes)?;
    let path = dir.join("animated.gltf");
    let text = serde_json::to_string_pretty(&document).map_err(std::io::Error::other)?;
    std::fs::write(&path, text)?;
    Ok(path)
}
