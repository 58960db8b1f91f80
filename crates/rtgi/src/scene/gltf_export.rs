//! Writing a scene as glTF 2.0 binary (.glb).
//!
//! The output is self-contained (textures embedded as PNG in the BIN chunk) and requires no
//! extension, so any glTF viewer opens it; rtgi-specific data that glTF cannot express (the
//! environment, the camera's look-at distance) travels in `extras`, which other tools preserve or
//! ignore. Geometry is already in world space, so every mesh node of a static scene has an identity
//! transform. An animated scene also gets its node hierarchy (rest TRS) and every clip; meshes, lights
//! and the camera bound to a node become its children, their data written in its local space, so that
//! loading the file back gives the same animation.

mod compare;
#[cfg(test)]
pub(crate) mod tests;

use std::collections::BTreeMap;
use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use gltf::json;
use gltf::json::validation::{Checked, USize64};
use gltf::json::{Index, extras::RawValue};
use serde::{Deserialize, Serialize};

use super::animation::{Bindings, Interpolation, Property, Trs, look_rotation};
use super::{AlphaMode, Environment, Light, Scene, SceneAnimation, TextureRef};
use crate::error::SceneError;

pub use compare::{assert_scenes_equivalent, scene_differences};

/// Key in `scenes[0].extras` holding the environment (see `EnvironmentJson`).
pub const ENVIRONMENT_KEY: &str = "rtgi_environment";
/// Key in `scenes[0].extras` holding the index of the node whose rotation turns the sun of a sky
/// environment (see [`crate::scene::animation::Bindings::sun`]).
pub const SUN_NODE_KEY: &str = "rtgi_sun_node";
/// Key in `scenes[0].extras` holding [`Scene::environment_rotation`] as a unit quaternion `[x, y, z, w]`
/// (absent for no turn).
pub const ENVIRONMENT_ROTATION_KEY: &str = "rtgi_environment_rotation";
/// Key in `scenes[0].extras` holding the index of the node whose rotation turns the environment (see
/// [`crate::scene::animation::Bindings::environment`]).
pub const ENVIRONMENT_NODE_KEY: &str = "rtgi_environment_node";
/// Key in `scenes[0].extras` holding the index of the animation that plays (glTF has no such notion;
/// without it the first one plays).
pub const ACTIVE_ANIMATION_KEY: &str = "rtgi_active_animation";
/// Key in a material's `extras` holding its [`crate::scene::Subsurface`] medium (see `SubsurfaceJson`),
/// which no glTF extension describes.
pub const SUBSURFACE_KEY: &str = "rtgi_subsurface";
/// Key in a camera node's `extras` holding the distance from the camera to its look-at target, which
/// glTF cameras do not have.
pub const TARGET_DISTANCE_KEY: &str = "rtgi_target_distance";

/// The JSON form of [`Environment`] stored under [`ENVIRONMENT_KEY`]. Maps are stored by path, not by
/// value: an HDR map can be hundreds of megabytes of floats.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub(crate) enum EnvironmentJson {
    None,
    Uniform {
        radiance: [f32; 3],
    },
    Sky {
        sun_direction: [f32; 3],
        sun_radiance: [f32; 3],
        sky_radiance: [f32; 3],
        ground_radiance: [f32; 3],
    },
    Map {
        path: String,
        #[serde(default = "one")]
        intensity: f32,
    },
}

fn one() -> f32 {
    1.0
}

/// A translucent medium in a material's extras: σ_a and σ_s' per metre (linear RGB) and the boundary's
/// relative index of refraction.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SubsurfaceJson {
    pub absorption: [f32; 3],
    pub reduced_scattering: [f32; 3],
    pub eta: f32,
}

impl SubsurfaceJson {
    pub(crate) fn medium(self) -> crate::scene::Subsurface {
        crate::scene::Subsurface {
            absorption: self.absorption.into(),
            reduced_scattering: self.reduced_scattering.into(),
            eta: self.eta,
        }
    }
}

impl EnvironmentJson {
    fn from_environment(env: &Environment) -> Self {
        match env {
            Environment::None => EnvironmentJson::None,
            Environment::Uniform(r) => EnvironmentJson::Uniform { radiance: r.to_array() },
            Environment::Sky { sun_direction, sun_radiance, sky_radiance, ground_radiance } => {
                EnvironmentJson::Sky {
                    sun_direction: sun_direction.to_array(),
                    sun_radiance: sun_radiance.to_array(),
                    sky_radiance: sky_radiance.to_array(),
                    ground_radiance: ground_radiance.to_array(),
                }
            }
            Environment::Map(map) => {
                EnvironmentJson::Map { path: map.path.clone(), intensity: map.intensity }
            }
        }
    }
}

/// Writes `scene` to `path` as a self-contained `.glb`. An environment map that is no file (one a
/// built-in scene generates, e.g. `pillars:sky=patch`) is written beside it as a Radiance `.hdr`
/// (`NAME.environment.hdr`) and referred to by that file's name, so that the scene loads again whole.
pub fn export(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let written;
    let scene = match &scene.environment {
        // Where the loader looks for it: as given (absolute, or from the working directory), or
        // relative to the glTF file.
        Environment::Map(map)
            if !Path::new(&map.path).is_file()
                && !path.parent().is_some_and(|dir| dir.join(&map.path).is_file()) =>
        {
            let stem = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
            let name = format!("{stem}.environment.hdr");
            let hdr = path.with_file_name(&name);
            write_hdr(map, &hdr).map_err(|m| SceneError::file(&hdr, m))?;
            let mut copy = scene.clone();
            copy.environment = Environment::Map(crate::scene::EnvironmentMap { path: name, ..map.clone() });
            written = copy;
            &written
        }
        _ => scene,
    };
    let glb = to_glb(scene).map_err(|m| SceneError::file(path, m))?;
    std::fs::write(path, glb).map_err(|e| SceneError::file(path, format!("cannot write file: {e}")))
}

/// Writes an equirectangular map's radiance (without its intensity, which the extras keep) as a
/// Radiance `.hdr`.
fn write_hdr(map: &crate::scene::EnvironmentMap, path: &Path) -> Result<(), String> {
    let pixels: Vec<image::Rgb<f32>> =
        map.rgb.chunks_exact(3).map(|c| image::Rgb([c[0], c[1], c[2]])).collect();
    let file = std::fs::File::create(path).map_err(|e| format!("cannot write file: {e}"))?;
    image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(file))
        .encode(&pixels, map.width as usize, map.height as usize)
        .map_err(|e| format!("cannot encode the environment map: {e}"))
}

/// The bytes of the `.glb` that [`export`] writes.
///
/// Meshes without triangles are left out: glTF accessors must not be empty.
pub fn to_glb(scene: &Scene) -> Result<Vec<u8>, String> {
    scene.validate().map_err(|e| format!("cannot export an invalid scene: {e}"))?;
    let mut b = Builder::default();
    b.root.asset = json::Asset { generator: Some("rtgi".into()), ..Default::default() };

    for (i, texture) in scene.textures.iter().enumerate() {
        let png = encode_png(texture).map_err(|e| format!("texture {i} '{}': {e}", texture.name))?;
        let view = b.view(&png, None);
        b.root.images.push(json::Image {
            buffer_view: Some(view),
            mime_type: Some(json::image::MimeType("image/png".into())),
            name: non_empty(&texture.name),
            uri: None,
            extensions: None,
            extras: None,
        });
        b.root.textures.push(json::Texture {
            name: non_empty(&texture.name),
            sampler: None,
            source: Index::new(i as u32),
            extensions: None,
            extras: None,
        });
    }

    let mut uses_emissive_strength = false;
    let mut uses_specular = false;
    for m in &scene.materials {
        let info = |t: &Option<TextureRef>| {
            t.map(|t| json::texture::Info {
                index: Index::new(t.texture),
                tex_coord: t.tex_coord,
                extensions: None,
                extras: None,
            })
        };
        // glTF clamps emissiveFactor to [0, 1]; brighter emitters need KHR_materials_emissive_strength.
        let peak = m.emissive.max_element();
        let (emissive_factor, mut extensions) = if peak > 1.0 {
            uses_emissive_strength = true;
            ((m.emissive / peak).to_array(), Some(emissive_strength_extension(peak)))
        } else {
            (m.emissive.to_array(), None)
        };
        if m.specular != 1.0 {
            uses_specular = true;
            extensions.get_or_insert_with(Default::default).specular = Some(specular_extension(m.specular));
        }
        let (alpha_mode, alpha_cutoff) = match m.alpha_mode {
            AlphaMode::Opaque => (json::material::AlphaMode::Opaque, None),
            AlphaMode::Mask { cutoff } => {
                (json::material::AlphaMode::Mask, Some(json::material::AlphaCutoff(cutoff)))
            }
            AlphaMode::Blend => (json::material::AlphaMode::Blend, None),
        };
        b.root.materials.push(json::Material {
            alpha_cutoff,
            alpha_mode: Checked::Valid(alpha_mode),
            double_sided: m.double_sided,
            name: non_empty(&m.name),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor(m.base_color.to_array()),
                base_color_texture: info(&m.base_color_texture),
                metallic_factor: json::material::StrengthFactor(m.metallic),
                roughness_factor: json::material::StrengthFactor(m.roughness),
                metallic_roughness_texture: info(&m.metallic_roughness_texture),
                ..Default::default()
            },
            normal_texture: m.normal_texture.map(|t| json::material::NormalTexture {
                index: Index::new(t.texture),
                scale: m.normal_scale,
                tex_coord: t.tex_coord,
                extensions: None,
                extras: None,
            }),
            emissive_texture: info(&m.emissive_texture),
            emissive_factor: json::material::EmissiveFactor(emissive_factor),
            extensions,
            extras: match m.subsurface {
                Some(medium) => Some(extras(&[(
                    SUBSURFACE_KEY,
                    json_text(&SubsurfaceJson {
                        absorption: medium.absorption.to_array(),
                        reduced_scattering: medium.reduced_scattering.to_array(),
                        eta: medium.eta,
                    })?,
                )])?),
                None => None,
            },
            ..Default::default()
        });
    }

    let mut hierarchy = Hierarchy::new(&mut b, scene.animation.as_ref());
    for (i, mesh) in scene.meshes.iter().enumerate().filter(|(_, m)| m.indices.len() >= 3) {
        let bound = hierarchy.binding(|a| a.meshes.get(i));
        // A bound mesh is written in its node's local space, so that the node carries it when it moves.
        let local = bound.map(|(_, rest)| mesh.transformed(rest.inverse()));
        let mesh_index = b.mesh(local.as_ref().unwrap_or(mesh));
        let node =
            b.node(json::Node { mesh: Some(mesh_index), name: non_empty(&mesh.name), ..Default::default() });
        hierarchy.attach(&mut b, Objects::Meshes, bound.map(|(n, _)| n), node);
    }

    let mut lights = Vec::new();
    for (i, light) in scene.lights.iter().enumerate() {
        use json::extensions::scene::khr_lights_punctual as khr;
        let (kind, position, direction, radiance, spot) = match *light {
            Light::Point { position, intensity } => (khr::Type::Point, Some(position), None, intensity, None),
            Light::Spot { position, direction, intensity, inner_angle, outer_angle } => (
                khr::Type::Spot,
                Some(position),
                Some(direction),
                intensity,
                Some(khr::Spot { inner_cone_angle: inner_angle, outer_cone_angle: outer_angle }),
            ),
            Light::Directional { direction, irradiance } => {
                (khr::Type::Directional, None, Some(direction), irradiance, None)
            }
        };
        // glTF splits radiance into a colour in [0, 1] and a scalar intensity.
        let peak = radiance.max_element();
        let (color, intensity) =
            if peak > 0.0 { ((radiance / peak).to_array(), peak) } else { ([1.0; 3], 0.0) };
        lights.push(khr::Light {
            color,
            extensions: None,
            extras: None,
            intensity,
            name: Some(format!("{} light {i}", light.kind_name())),
            range: None,
            spot,
            type_: Checked::Valid(kind),
        });
        // Lights shine along their node's −Z.
        let rotation = direction.map(|d| Quat::from_rotation_arc(Vec3::NEG_Z, d.normalize_or(Vec3::NEG_Z)));
        let node = json::Node {
            name: Some(format!("{} light {i}", light.kind_name())),
            extensions: Some(light_extension(i)),
            ..Default::default()
        };
        let bound = hierarchy.binding(|a| a.lights.get(i));
        let world = Mat4::from_rotation_translation(
            rotation.unwrap_or(Quat::IDENTITY),
            position.unwrap_or(Vec3::ZERO),
        );
        let node = match bound {
            Some((_, rest)) => with_local_transform(node, rest.inverse() * world),
            None => json::Node {
                translation: position.map(|p| p.to_array()),
                rotation: rotation.map(|q| json::scene::UnitQuaternion(q.to_array())),
                ..node
            },
        };
        let node = b.node(node);
        hierarchy.attach(&mut b, Objects::Lights, bound.map(|(n, _)| n), node);
    }
    if !lights.is_empty() {
        b.root.extensions = Some(lights_extension(lights));
        b.root.extensions_used.push("KHR_lights_punctual".into());
    }
    if uses_specular {
        b.root.extensions_used.push("KHR_materials_specular".into());
    }
    if uses_emissive_strength {
        b.root.extensions_used.push("KHR_materials_emissive_strength".into());
    }

    let cam = &scene.camera;
    b.root.cameras.push(json::Camera {
        name: Some("camera".into()),
        orthographic: None,
        perspective: Some(json::camera::Perspective {
            aspect_ratio: None,
            yfov: cam.yfov,
            zfar: Some(cam.zfar),
            znear: cam.znear,
            extensions: None,
            extras: None,
        }),
        type_: Checked::Valid(json::camera::Type::Perspective),
        extensions: None,
        extras: None,
    });
    let to_target = cam.target - cam.position;
    let rotation = look_rotation(to_target, cam.up);
    let camera_extras = extras(&[(TARGET_DISTANCE_KEY, json_text(&to_target.length())?)])?;
    let node = json::Node {
        camera: Some(Index::new(0)),
        name: Some("camera".into()),
        extras: Some(camera_extras),
        ..Default::default()
    };
    let bound = hierarchy.binding(|a| Some(&a.camera));
    let node = match bound {
        Some((_, rest)) => with_local_transform(
            node,
            rest.inverse() * Mat4::from_rotation_translation(rotation, cam.position),
        ),
        None => json::Node {
            translation: Some(cam.position.to_array()),
            rotation: Some(json::scene::UnitQuaternion(rotation.to_array())),
            ..node
        },
    };
    let node = b.node(node);
    hierarchy.attach(&mut b, Objects::Camera, bound.map(|(n, _)| n), node);

    let environment = EnvironmentJson::from_environment(&scene.environment);
    let mut scene_extras = vec![(ENVIRONMENT_KEY, json_text(&environment)?)];
    if let Some((sun, _)) = hierarchy.binding(|a| Some(&a.sun)) {
        scene_extras.push((SUN_NODE_KEY, json_text(&hierarchy.nodes[sun].value())?));
    }
    if scene.environment_rotation != glam::Quat::IDENTITY {
        scene_extras.push((ENVIRONMENT_ROTATION_KEY, json_text(&scene.environment_rotation.to_array())?));
    }
    if let Some(node) = scene.animation.as_ref().and_then(|a| a.bindings.environment) {
        scene_extras.push((ENVIRONMENT_NODE_KEY, json_text(&hierarchy.nodes[node].value())?));
    }
    if let Some(anim) = &scene.animation {
        let active = hierarchy.clips(&mut b, anim);
        if active != 0 {
            scene_extras.push((ACTIVE_ANIMATION_KEY, json_text(&active)?));
        }
    }
    let scene_extras = extras(&scene_extras)?;
    b.root.scenes.push(json::Scene {
        extensions: None,
        extras: Some(scene_extras),
        name: non_empty(&scene.name),
        nodes: hierarchy.root_nodes(),
    });
    b.root.scene = Some(Index::new(0));
    b.finish()
}

// The `..Default::default()` in these three keeps them compiling if more `gltf` features (which add
// fields to the extension structs) are enabled later.
#[allow(clippy::needless_update)]
fn light_extension(light: usize) -> json::extensions::scene::Node {
    use json::extensions::scene::khr_lights_punctual::KhrLightsPunctual;
    json::extensions::scene::Node {
        khr_lights_punctual: Some(KhrLightsPunctual { light: Index::new(light as u32) }),
        ..Default::default()
    }
}

#[allow(clippy::needless_update)]
fn emissive_strength_extension(strength: f32) -> json::extensions::material::Material {
    use json::extensions::material::{EmissiveStrength, EmissiveStrengthFactor};
    json::extensions::material::Material {
        emissive_strength: Some(EmissiveStrength { emissive_strength: EmissiveStrengthFactor(strength) }),
        ..Default::default()
    }
}

fn specular_extension(factor: f32) -> json::extensions::material::Specular {
    use json::extensions::material::{Specular, SpecularFactor};
    Specular {
        specular_factor: SpecularFactor(factor),
        specular_texture: None,
        specular_color_factor: Default::default(),
        specular_color_texture: None,
        extras: Default::default(),
    }
}

#[allow(clippy::needless_update)]
fn lights_extension(
    lights: Vec<json::extensions::scene::khr_lights_punctual::Light>,
) -> json::extensions::Root {
    json::extensions::Root {
        khr_lights_punctual: Some(json::extensions::root::KhrLightsPunctual { lights }),
        ..Default::default()
    }
}

/// Little-endian bytes, as glTF requires whatever the host's byte order.
fn le_f32(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// A JSON array of the shortest decimals that read back as the same f32s (a plain f32 → f64 widening
/// would print `0.10000000149011612`).
fn json_f32s(v: &[f32]) -> serde_json::Value {
    v.iter().map(|x| x.to_string().parse::<f64>().unwrap_or(f64::from(*x))).collect()
}

fn non_empty(s: &str) -> Option<String> {
    (!s.is_empty()).then(|| s.to_string())
}

/// `value` as JSON text. Serialised straight to text (not through `serde_json::Value`, which widens
/// f32 to f64) so that floats read `0.1`, not `0.10000000149011612`.
fn json_text(value: &impl Serialize) -> Result<String, String> {
    serde_json::to_string(value).map_err(|e| format!("cannot encode extras: {e}"))
}

/// `{key: value, ...}` as raw JSON, from values already encoded by [`json_text`].
fn extras(entries: &[(&str, String)]) -> Result<Box<RawValue>, String> {
    let mut text = String::from("{");
    for (i, (key, value)) in entries.iter().enumerate() {
        if i > 0 {
            text.push(',');
        }
        text += &json_text(key)?;
        text.push(':');
        text += value;
    }
    text.push('}');
    RawValue::from_string(text).map_err(|e| format!("cannot encode extras: {e}"))
}

/// `node` placed by the local transform `m`: as TRS when that represents `m` exactly (what viewers
/// prefer), else as a matrix (a shear, from a non-uniformly scaled and rotated parent).
fn with_local_transform(node: json::Node, m: Mat4) -> json::Node {
    let trs = Trs::from_matrix(m);
    let scale = m.abs().to_cols_array().into_iter().fold(1.0f32, f32::max);
    if trs.matrix().abs_diff_eq(m, 1e-6 * scale) {
        json::Node {
            translation: Some(trs.translation.to_array()),
            rotation: Some(json::scene::UnitQuaternion(trs.rotation.to_array())),
            scale: Some(trs.scale.to_array()),
            ..node
        }
    } else {
        json::Node { matrix: Some(m.to_cols_array()), ..node }
    }
}

/// The kinds of objects whose order the loader rebuilds from the node order.
#[derive(Clone, Copy)]
enum Objects {
    Meshes = 0,
    Lights = 1,
    Camera = 2,
}

/// The scene's node tree: for an animated scene, one node per animation node (same order) with the
/// objects bound to it as children; every other object a root node.
///
/// The loader collects meshes and lights depth-first from the scene's root nodes, so the order of
/// the roots decides the order of the objects read back. Each kind of object asks for its roots in
/// its own order; the roots are put in an order that satisfies all three (see [`Self::root_nodes`]).
/// Within a node, objects come before child nodes. Objects bound under one root node that are
/// interleaved with objects outside it (in the same kind) cannot keep their order; they come back
/// grouped by root node.
struct Hierarchy<'a> {
    animation: Option<&'a SceneAnimation>,
    nodes: Vec<Index<json::Node>>,
    /// Per animation node: its root, and how many objects have been attached to it.
    root_of: Vec<usize>,
    objects: Vec<usize>,
    /// Per kind of object: the root node of each object, in object order.
    sequences: [Vec<Index<json::Node>>; 3],
}

impl<'a> Hierarchy<'a> {
    /// Writes the animation's nodes with their rest TRS and their children. Nothing without an
    /// animation, so static scenes export as before.
    fn new(b: &mut Builder, animation: Option<&'a SceneAnimation>) -> Self {
        let mut h = Hierarchy {
            animation,
            nodes: Vec::new(),
            root_of: Vec::new(),
            objects: Vec::new(),
            sequences: Default::default(),
        };
        for (i, node) in animation.iter().flat_map(|a| a.nodes.iter().enumerate()) {
            let index = b.node(json::Node {
                name: non_empty(&node.name),
                translation: Some(node.rest.translation.to_array()),
                rotation: Some(json::scene::UnitQuaternion(node.rest.rotation.to_array())),
                scale: Some(node.rest.scale.to_array()),
                ..Default::default()
            });
            let parent = node.parent.filter(|&p| p < i);
            if let Some(p) = parent
                && let Some(parent) = b.root.nodes.get_mut(h.nodes[p].value())
            {
                parent.children.get_or_insert_with(Vec::new).push(index);
            }
            h.root_of.push(parent.map_or(i, |p| h.root_of[p]));
            h.nodes.push(index);
        }
        h.objects = vec![0; h.nodes.len()];
        h
    }

    /// Makes `child` the next object of animation node `parent`, or a root of the scene.
    fn attach(&mut self, b: &mut Builder, kind: Objects, parent: Option<usize>, child: Index<json::Node>) {
        let root = match parent.filter(|&p| p < self.nodes.len()) {
            Some(p) => {
                if let Some(node) = b.root.nodes.get_mut(self.nodes[p].value()) {
                    node.children.get_or_insert_with(Vec::new).insert(self.objects[p], child);
                    self.objects[p] += 1;
                }
                self.nodes[self.root_of[p]]
            }
            None => child,
        };
        self.sequences[kind as usize].push(root);
    }

    /// The scene's root nodes, ordered so that each kind of object meets its roots in its own order
    /// where the kinds agree: a topological order of "comes before" edges between consecutive roots of
    /// each sequence, ties (and cycles, from interleaved objects) broken by first appearance. Static
    /// scenes get their objects' nodes in the order they were written.
    fn root_nodes(&self) -> Vec<Index<json::Node>> {
        use std::cmp::Reverse;
        use std::collections::{BinaryHeap, HashMap};
        let mut keys: Vec<Index<json::Node>> = Vec::new();
        let mut rank: HashMap<u32, usize> = HashMap::new();
        let unused_roots = (0..self.nodes.len()).filter(|&i| self.root_of[i] == i).map(|i| self.nodes[i]);
        for key in self.sequences.iter().flatten().copied().chain(unused_roots) {
            rank.entry(key.value() as u32).or_insert_with(|| {
                keys.push(key);
                keys.len() - 1
            });
        }
        let mut successors = vec![Vec::new(); keys.len()];
        let mut indegree = vec![0usize; keys.len()];
        for seq in &self.sequences {
            for w in seq.windows(2) {
                let (a, b) = (rank[&(w[0].value() as u32)], rank[&(w[1].value() as u32)]);
                if a != b && !successors[a].contains(&b) {
                    successors[a].push(b);
                    indegree[b] += 1;
                }
            }
        }
        let mut ready: BinaryHeap<Reverse<usize>> =
            (0..keys.len()).filter(|&k| indegree[k] == 0).map(Reverse).collect();
        let mut done = vec![false; keys.len()];
        let mut order = Vec::with_capacity(keys.len());
        while order.len() < keys.len() {
            let next = match ready.pop() {
                Some(Reverse(k)) if !done[k] => k,
                Some(_) => continue,
                // A cycle: take the earliest root still waiting.
                None => (0..keys.len()).find(|&k| !done[k]).unwrap_or(0),
            };
            done[next] = true;
            order.push(keys[next]);
            for &s in &successors[next] {
                indegree[s] = indegree[s].saturating_sub(1);
                if indegree[s] == 0 && !done[s] {
                    ready.push(Reverse(s));
                }
            }
        }
        order
    }

    /// The animation node an object is bound to and its rest world transform, if it can carry the
    /// object (a rest transform that collapses space cannot be undone, so such objects stay in world
    /// space).
    fn binding(&self, pick: impl Fn(&'a Bindings) -> Option<&'a Option<usize>>) -> Option<(usize, Mat4)> {
        let anim = self.animation?;
        let node = (*pick(&anim.bindings)?)?;
        let rest = anim.nodes.get(node)?.rest_world;
        (rest.determinant().abs() > 1e-12).then_some((node, rest))
    }

    /// Writes every clip, keys and interpolation as they are, and returns the glTF index of the active
    /// one. Clips without channels are left out (glTF requires at least one; they move nothing), so an
    /// empty active clip becomes the first written one.
    fn clips(&self, b: &mut Builder, anim: &SceneAnimation) -> usize {
        let mut active = 0;
        use json::accessor::{ComponentType, Type};
        use json::animation::{Interpolation as JsonInterpolation, Property as JsonProperty};
        for (ci, clip) in anim.clips.iter().enumerate().filter(|(_, c)| !c.channels.is_empty()) {
            if ci == anim.active {
                active = b.root.animations.len();
            }
            let mut channels = Vec::new();
            let mut samplers = Vec::new();
            for ch in &clip.channels {
                let Some(&node) = self.nodes.get(ch.node) else { continue };
                let s = &ch.sampler;
                let (lo, hi) = s.range();
                let input = b.accessor(
                    &le_f32(s.times.iter().copied()),
                    s.times.len(),
                    ComponentType::F32,
                    Type::Scalar,
                    Some((&[lo], &[hi])),
                );
                let (components, type_, path) = match ch.property {
                    Property::Translation => (3, Type::Vec3, JsonProperty::Translation),
                    Property::Rotation => (4, Type::Vec4, JsonProperty::Rotation),
                    Property::Scale => (3, Type::Vec3, JsonProperty::Scale),
                };
                let values = le_f32(s.values.iter().flat_map(|v| v.to_array().into_iter().take(components)));
                let output = b.accessor(&values, s.values.len(), ComponentType::F32, type_, None);
                let interpolation = match s.interpolation {
                    Interpolation::Step => JsonInterpolation::Step,
                    Interpolation::Linear => JsonInterpolation::Linear,
                    Interpolation::CubicSpline => JsonInterpolation::CubicSpline,
                };
                samplers.push(json::animation::Sampler {
                    extensions: None,
                    extras: None,
                    input,
                    interpolation: Checked::Valid(interpolation),
                    output,
                });
                channels.push(json::animation::Channel {
                    sampler: Index::new(samplers.len() as u32 - 1),
                    target: json::animation::Target {
                        extensions: None,
                        extras: None,
                        node,
                        path: Checked::Valid(path),
                    },
                    extensions: None,
                    extras: None,
                });
            }
            b.root.animations.push(json::Animation {
                extensions: None,
                extras: None,
                channels,
                name: non_empty(&clip.name),
                samplers,
            });
        }
        active
    }
}

fn encode_png(t: &super::Texture) -> Result<Vec<u8>, String> {
    use image::ImageEncoder;
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&t.rgba8, t.width, t.height, image::ExtendedColorType::Rgba8)
        .map_err(|e| format!("cannot encode PNG: {e}"))?;
    Ok(png)
}

/// Accumulates the JSON document and the BIN chunk.
#[derive(Default)]
struct Builder {
    root: json::Root,
    bin: Vec<u8>,
}

impl Builder {
    /// Appends `bytes` to the BIN chunk as a new buffer view, 4-byte aligned as accessors require.
    fn view(&mut self, bytes: &[u8], target: Option<json::buffer::Target>) -> Index<json::buffer::View> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.root.push(json::buffer::View {
            buffer: Index::new(0),
            byte_length: USize64(bytes.len() as u64),
            byte_offset: Some(USize64(offset as u64)),
            byte_stride: None,
            name: None,
            target: target.map(Checked::Valid),
            extensions: None,
            extras: None,
        })
    }

    fn accessor(
        &mut self,
        bytes: &[u8],
        count: usize,
        component: json::accessor::ComponentType,
        type_: json::accessor::Type,
        bounds: Option<(&[f32], &[f32])>,
    ) -> Index<json::Accessor> {
        use json::accessor::ComponentType;
        let target = match component {
            ComponentType::U32 => json::buffer::Target::ElementArrayBuffer,
            _ => json::buffer::Target::ArrayBuffer,
        };
        let view = self.view(bytes, Some(target));
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64(count as u64),
            component_type: Checked::Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: None,
            type_: Checked::Valid(type_),
            min: bounds.map(|(lo, _)| json_f32s(lo)),
            max: bounds.map(|(_, hi)| json_f32s(hi)),
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    fn mesh(&mut self, mesh: &super::Mesh) -> Index<json::Mesh> {
        use json::accessor::{ComponentType, Type};
        use json::mesh::Semantic;
        let n = mesh.positions.len();
        let (lo, hi) = mesh
            .positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let mut attributes = BTreeMap::new();
        let pos = self.accessor(
            &le_f32(mesh.positions.iter().flat_map(|v| v.to_array())),
            n,
            ComponentType::F32,
            Type::Vec3,
            Some((&lo.to_array(), &hi.to_array())),
        );
        attributes.insert(Checked::Valid(Semantic::Positions), pos);
        let nrm = self.accessor(
            &le_f32(mesh.normals.iter().flat_map(|v| v.to_array())),
            n,
            ComponentType::F32,
            Type::Vec3,
            None,
        );
        attributes.insert(Checked::Valid(Semantic::Normals), nrm);
        let tan = self.accessor(
            &le_f32(mesh.tangents.iter().flat_map(|v| v.to_array())),
            n,
            ComponentType::F32,
            Type::Vec4,
            None,
        );
        attributes.insert(Checked::Valid(Semantic::Tangents), tan);
        let uv = self.accessor(
            &le_f32(mesh.uvs.iter().flat_map(|v| v.to_array())),
            n,
            ComponentType::F32,
            Type::Vec2,
            None,
        );
        attributes.insert(Checked::Valid(Semantic::TexCoords(0)), uv);
        let indices = self.accessor(
            &mesh.indices.iter().flat_map(|i| i.to_le_bytes()).collect::<Vec<u8>>(),
            mesh.indices.len(),
            ComponentType::U32,
            Type::Scalar,
            None,
        );
        self.root.push(json::Mesh {
            extensions: None,
            extras: None,
            name: non_empty(&mesh.name),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(indices),
                material: Some(Index::new(mesh.material)),
                mode: Checked::Valid(json::mesh::Mode::Triangles),
                targets: None,
            }],
            weights: None,
        })
    }

    fn node(&mut self, node: json::Node) -> Index<json::Node> {
        self.root.push(node)
    }

    /// Serialises the GLB container: 12-byte header, JSON chunk padded with spaces, BIN chunk padded
    /// with zeros (both to 4 bytes, as the spec requires).
    fn finish(mut self) -> Result<Vec<u8>, String> {
        if !self.bin.is_empty() {
            self.root.buffers.push(json::Buffer {
                byte_length: USize64(self.bin.len() as u64),
                name: None,
                uri: None,
                extensions: None,
                extras: None,
            });
        }
        let mut json =
            json::serialize::to_vec(&self.root).map_err(|e| format!("cannot serialise glTF JSON: {e}"))?;
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.bin;
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
        let total =
            u32::try_from(total).map_err(|_| "scene too large for a .glb file (over 4 GiB)".to_string())?;
        let mut out = Vec::with_capacity(total as usize);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&total.to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        if !bin.is_empty() {
            out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
            out.extend_from_slice(b"BIN\0");
            out.extend_from_slice(&bin);
        }
        Ok(out)
    }
}
