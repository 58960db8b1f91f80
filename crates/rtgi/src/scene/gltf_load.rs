//! glTF 2.0 loading (`.gltf` with external or embedded buffers, and `.glb`).
//!
//! The loader works on the raw JSON document (`gltf::json`) rather than the `gltf` crate's wrapper
//! API: that API (and the crate's own validator) index arrays with `unwrap()` on the assumption that
//! the document is valid, so a single bad index in a downloaded file would crash rtgi. Here every
//! reference, byte range and index value is checked, and every failure becomes a
//! [`SceneError::File`] naming the file and what is wrong with it.
//!
//! Anything rtgi reads but cannot render (optional extensions, occlusion maps, morph targets, skins,
//! morph-target weight animation, …) is reported in [`Scene::warnings`] rather than dropped silently.

mod accessor;
#[cfg(test)]
mod animation_tests;
mod container;
#[cfg(test)]
mod tests;

use std::borrow::Cow;
use std::cell::OnceCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::json;
use gltf::json::mesh::{Mode, Semantic};
use gltf::json::validation::Checked;
use serde_json::Value;

use super::animation::{AnimNode, AnimationClip, Channel, Interpolation, Property, Sampler, Trs};
use super::gltf_export::{
    ACTIVE_ANIMATION_KEY, ENVIRONMENT_KEY, ENVIRONMENT_NODE_KEY, ENVIRONMENT_ROTATION_KEY, EnvironmentJson,
    SUBSURFACE_KEY, SUN_NODE_KEY, SubsurfaceJson, TARGET_DISTANCE_KEY,
};
use super::{
    Aabb, AlphaMode, Camera, Environment, EnvironmentMap, Light, Material, Mesh, Scene, SceneAnimation,
    Texture, TextureRef, generate_tangents,
};
use crate::error::SceneError;

/// glTF extensions rtgi implements. Files that *require* anything else are refused; files that merely
/// *use* something else load with a warning.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_mesh_quantization",
];

/// Material-level extensions that are read (others are reported per material).
const MATERIAL_EXTENSIONS: &[&str] = &["KHR_materials_emissive_strength", "KHR_materials_specular"];

/// Loads a `.gltf` or `.glb` file into a world-space [`Scene`].
///
/// The default scene (or the first one, or else every root node) is flattened: node transforms are
/// baked into the vertices, lights and the first camera are placed in world space. Files with
/// animations also keep the node hierarchy, every animation's translation, rotation and scale
/// channels (the first animation active) and which node each mesh, light and the camera follow, in
/// [`Scene::animation`]; the flattened data is the rest pose.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    load_inner(path).map_err(|message| SceneError::file(path, message))
}

fn load_inner(path: &Path) -> Result<Scene, String> {
    let bytes = std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => "file not found".to_string(),
        _ => format!("cannot read file: {e}"),
    })?;
    let (json_bytes, bin) = if container::is_glb(&bytes) {
        let glb = container::parse_glb(&bytes)?;
        (glb.json, glb.bin)
    } else {
        (&bytes[..], None)
    };
    let json_bytes = json_bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(json_bytes);
    if json_bytes.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
        return Err("not a glTF file: neither binary glTF (no 'glTF' magic) nor a JSON object".into());
    }
    let raw: Value = serde_json::from_slice(json_bytes).map_err(|e| format!("malformed glTF JSON: {e}"))?;
    let root: json::Root = json::deserialize::from_slice(json_bytes)
        .map_err(|e| format!("not a valid glTF 2.0 document: {e}"))?;
    check_version(&root)?;
    check_required_extensions(&root)?;

    let base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let buffers = (0..root.buffers.len()).map(|_| OnceCell::new()).collect();
    let loader = Loader { root, raw, base_dir, bin, buffers };
    let mut out = Output::default();
    out.scene.name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    loader.run(&mut out)?;
    let mut scene = out.scene;
    scene.warnings = out.warnings.finish();
    scene.validate().map_err(|e| format!("invalid scene data: {e}"))?;
    Ok(scene)
}

fn check_version(root: &json::Root) -> Result<(), String> {
    let major = |v: &str| v.split('.').next().and_then(|m| m.trim().parse::<u32>().ok());
    let version = &root.asset.version;
    if major(version) != Some(2) {
        return Err(format!("glTF version '{version}' is not supported (rtgi reads glTF 2.0)"));
    }
    if let Some(min) = &root.asset.min_version
        && min.trim() != "2.0"
    {
        return Err(format!("file requires glTF minVersion '{min}', rtgi reads glTF 2.0"));
    }
    Ok(())
}

fn check_required_extensions(root: &json::Root) -> Result<(), String> {
    let unsupported: Vec<String> = root
        .extensions_required
        .iter()
        .filter(|e| !SUPPORTED_EXTENSIONS.contains(&e.as_str()))
        .map(|e| format!("'{e}'"))
        .collect();
    if unsupported.is_empty() {
        return Ok(());
    }
    let noun = if unsupported.len() == 1 { "extension" } else { "extensions" };
    Err(format!(
        "requires glTF {noun} {}, which rtgi does not support (supported: {})",
        unsupported.join(", "),
        SUPPORTED_EXTENSIONS.join(", ")
    ))
}

/// Read-only view of the document and its buffers.
struct Loader<'a> {
    root: json::Root,
    /// The same JSON as a tree, for what `gltf::json` does not keep: unknown extension names and extras.
    raw: Value,
    base_dir: PathBuf,
    bin: Option<&'a [u8]>,
    buffers: Vec<OnceCell<Cow<'a, [u8]>>>,
}

/// What the loader builds; kept apart from [`Loader`] so that buffer bytes borrowed from the loader
/// can be used while the output is mutated.
#[derive(Default)]
struct Output {
    scene: Scene,
    warnings: Warnings,
    /// (glTF image, sRGB?) → index in `scene.textures`.
    textures: HashMap<(usize, bool), u32>,
    /// glTF image → first texture decoded from it (to copy rather than decode it twice).
    decoded: HashMap<usize, u32>,
    default_material: Option<u32>,
    /// Unsupported extensions already named in a more specific warning.
    reported_extensions: Vec<String>,
}

impl Output {
    /// glTF's default material (white, fully metallic, fully rough per the spec), appended on demand.
    fn default_material(&mut self) -> u32 {
        *self.default_material.get_or_insert_with(|| {
            self.scene.materials.push(Material {
                name: "glTF default material".into(),
                metallic: 1.0,
                roughness: 1.0,
                ..Default::default()
            });
            (self.scene.materials.len() - 1) as u32
        })
    }
}

/// Warnings, grouped by problem so that a file with 500 materials using the same unsupported feature
/// yields one line, not 500.
#[derive(Default)]
struct Warnings {
    entries: Vec<(String, Vec<String>)>,
}

impl Warnings {
    fn note(&mut self, message: String) {
        if !self.entries.iter().any(|(m, s)| *m == message && s.is_empty()) {
            self.entries.push((message, Vec::new()));
        }
    }

    fn about(&mut self, problem: &str, subject: String) {
        match self.entries.iter_mut().find(|(m, s)| m == problem && !s.is_empty()) {
            Some((_, subjects)) => {
                if !subjects.contains(&subject) {
                    subjects.push(subject);
                }
            }
            None => self.entries.push((problem.to_string(), vec![subject])),
        }
    }

    fn finish(self) -> Vec<String> {
        const SHOWN: usize = 6;
        self.entries
            .into_iter()
            .map(|(problem, subjects)| {
                if subjects.is_empty() {
                    return problem;
                }
                let mut list = subjects.iter().take(SHOWN).cloned().collect::<Vec<_>>().join(", ");
                if subjects.len() > SHOWN {
                    list += &format!(" and {} more", subjects.len() - SHOWN);
                }
                format!("{list}: {problem}")
            })
            .collect()
    }
}

fn quoted_name(kind: &str, index: usize, name: &Option<String>) -> String {
    match name {
        Some(n) => format!("{kind} {index} '{n}'"),
        None => format!("{kind} {index}"),
    }
}

impl Loader<'_> {
    fn run(&self, out: &mut Output) -> Result<(), String> {
        for i in 0..self.root.materials.len() {
            let material = self.material(i, out)?;
            out.scene.materials.push(material);
        }

        let (scene_index, roots) = self.root_nodes(out)?;
        let mut camera = None;
        let mut cameras_seen = 0usize;
        let mut visited = vec![false; self.root.nodes.len()];
        // The hierarchy is kept for animation; the depth-first order puts parents before children.
        let mut anim = SceneAnimation::default();
        let mut anim_index: Vec<Option<usize>> = vec![None; self.root.nodes.len()];
        let mut stack: Vec<(usize, Mat4, Option<usize>)> =
            roots.iter().rev().map(|&n| (n, Mat4::IDENTITY, None)).collect();
        while let Some((ni, parent, parent_anim)) = stack.pop() {
            let node = self.root.nodes.get(ni).ok_or_else(|| {
                format!("node {ni} does not exist (the file has {} nodes)", self.root.nodes.len())
            })?;
            let label = quoted_name("node", ni, &node.name);
            match visited.get_mut(ni) {
                Some(seen) if *seen => {
                    return Err(format!(
                        "{label} is reached twice in the node hierarchy (a cycle, or a node with two parents)"
                    ));
                }
                Some(seen) => *seen = true,
                None => return Err(format!("node {ni} does not exist")),
            }
            let local = local_transform(node).map_err(|e| format!("{label}: {e}"))?;
            let world = parent * local;
            let rest = match node.matrix {
                Some(_) => Trs::from_matrix(local),
                None => rest_trs(node).map_err(|e| format!("{label}: {e}"))?,
            };
            let name = node.name.clone().unwrap_or_else(|| format!("node {ni}"));
            anim.nodes.push(AnimNode { name, parent: parent_anim, rest, rest_world: world });
            let this = anim.nodes.len() - 1;
            anim_index[ni] = Some(this);
            // A node whose rest transform collapses space cannot be undone to place its objects at
            // another time; they stay static.
            let bindable = world.determinant().abs() > 1e-12;
            let (meshes_before, lights_before) = (out.scene.meshes.len(), out.scene.lights.len());

            if let Some(mesh) = node.mesh {
                let mesh_world = if node.skin.is_some() {
                    out.warnings
                        .about("skin ignored; mesh drawn in its bind pose, not animated", label.clone());
                    // The spec says a skinned mesh ignores its node's transform (joints place it).
                    Mat4::IDENTITY
                } else {
                    world
                };
                self.mesh(mesh.value(), &label, mesh_world, out)?;
                if node.skin.is_none() && bindable {
                    anim.bindings.meshes.resize(meshes_before, None);
                    anim.bindings.meshes.resize(out.scene.meshes.len(), Some(this));
                }
            }
            if let Some(cam) = node.camera {
                cameras_seen += 1;
                if cameras_seen == 1 {
                    camera = self.camera(cam.value(), ni, &label, world, out)?;
                    if camera.is_some() && bindable {
                        anim.bindings.camera = Some(this);
                    }
                }
            }
            if let Some(light) = node.extensions.as_ref().and_then(|e| e.khr_lights_punctual.as_ref()) {
                self.light(light.light.value(), &label, world, out)?;
                if out.scene.lights.len() > lights_before && bindable {
                    anim.bindings.lights.resize(lights_before, None);
                    anim.bindings.lights.push(Some(this));
                }
            }
            if let Some(children) = &node.children {
                stack.extend(children.iter().rev().map(|c| (c.value(), world, Some(this))));
            }
        }
        // Extensions already reported per material are not repeated here.
        for ext in &self.root.extensions_used {
            if !SUPPORTED_EXTENSIONS.contains(&ext.as_str()) && !out.reported_extensions.contains(ext) {
                out.warnings
                    .note(format!("optional glTF extension '{ext}' is not supported by rtgi and is ignored"));
            }
        }
        if cameras_seen > 1 {
            out.warnings.note(format!("{cameras_seen} camera nodes; rtgi uses the first one"));
        }
        out.scene.camera = camera.unwrap_or_else(|| framing_camera(out.scene.bounds()));
        out.scene.environment = self.environment(scene_index, out)?;
        out.scene.environment_rotation = self.environment_rotation(scene_index, out);
        if !self.root.animations.is_empty() {
            anim.clips = self.animations(&anim_index, out)?;
            anim.bindings.sun = self.bound_node(scene_index, SUN_NODE_KEY, &anim_index, out);
            anim.bindings.environment = self.bound_node(scene_index, ENVIRONMENT_NODE_KEY, &anim_index, out);
            anim.active = self.active_animation(scene_index, anim.clips.len(), out);
            out.scene.animation = Some(anim);
        }
        Ok(())
    }

    /// Every animation as a clip. Channels rtgi cannot play are named in warnings; malformed ones
    /// are errors.
    fn animations(
        &self,
        anim_index: &[Option<usize>],
        out: &mut Output,
    ) -> Result<Vec<AnimationClip>, String> {
        use json::animation::{Interpolation as JsonInterpolation, Property as JsonProperty};
        let mut clips = Vec::new();
        for (ai, animation) in self.root.animations.iter().enumerate() {
            let label = quoted_name("animation", ai, &animation.name);
            let mut channels: Vec<Channel> = Vec::new();
            for (ci, channel) in animation.channels.iter().enumerate() {
                let ctx = format!("{label} channel {ci}");
                let node = channel.target.node.value();
                if node >= self.root.nodes.len() {
                    return Err(format!(
                        "{ctx} targets node {node}, which does not exist (the file has {} nodes)",
                        self.root.nodes.len()
                    ));
                }
                let property = match channel.target.path {
                    Checked::Valid(JsonProperty::Translation) => Property::Translation,
                    Checked::Valid(JsonProperty::Rotation) => Property::Rotation,
                    Checked::Valid(JsonProperty::Scale) => Property::Scale,
                    Checked::Valid(JsonProperty::MorphTargetWeights) => {
                        out.warnings.about(
                            "morph-target 'weights' channels ignored (rtgi has no morph targets)",
                            label.clone(),
                        );
                        continue;
                    }
                    Checked::Invalid => return Err(format!("{ctx}: invalid target path")),
                };
                let sampler_index = channel.sampler.value();
                let sampler = animation.samplers.get(sampler_index).ok_or_else(|| {
                    format!(
                        "{ctx} refers to sampler {sampler_index}, which does not exist (the animation has {} samplers)",
                        animation.samplers.len()
                    )
                })?;
                let interpolation = match sampler.interpolation {
                    Checked::Valid(JsonInterpolation::Step) => Interpolation::Step,
                    Checked::Valid(JsonInterpolation::Linear) => Interpolation::Linear,
                    Checked::Valid(JsonInterpolation::CubicSpline) => Interpolation::CubicSpline,
                    Checked::Invalid => {
                        return Err(format!("{ctx}: sampler {sampler_index} has an invalid interpolation"));
                    }
                };
                let times = self.read_times(sampler.input.value(), &format!("{ctx} input"))?;
                let what = format!("{ctx} {} output", property.gltf_name());
                let values = match property {
                    Property::Rotation => self.read_vec4(sampler.output.value(), &what)?,
                    _ => self
                        .read_vec3(sampler.output.value(), &what)?
                        .into_iter()
                        .map(|v| v.extend(0.0))
                        .collect(),
                };
                let keys = Sampler::new(interpolation, times, values);
                keys.check().map_err(|e| format!("{ctx} (sampler {sampler_index}): {e}"))?;
                let Some(target) = anim_index[node] else {
                    out.warnings
                        .about("channels targeting nodes outside the loaded scene ignored", label.clone());
                    continue;
                };
                if let Some(k) = channels.iter().position(|c| c.node == target && c.property == property) {
                    return Err(format!(
                        "{ctx} animates the {} of node {node} again (an earlier channel, {k}, already does)",
                        property.gltf_name()
                    ));
                }
                channels.push(Channel { node: target, property, sampler: keys });
            }
            clips.push(AnimationClip {
                name: animation.name.clone().unwrap_or_else(|| format!("animation {ai}")),
                channels,
            });
        }
        Ok(clips)
    }

    /// The animation to play: the one rtgi's exporter recorded in the scene extras, else the first.
    fn active_animation(&self, scene_index: Option<usize>, clips: usize, out: &mut Output) -> usize {
        let Some(value) = scene_index.map(|i| &self.raw["scenes"][i]["extras"][ACTIVE_ANIMATION_KEY]) else {
            return 0;
        };
        if value.is_null() {
            return 0;
        }
        match value.as_u64().and_then(|a| usize::try_from(a).ok()).filter(|&a| a < clips) {
            Some(a) => a,
            None => {
                out.warnings.note(format!(
                    "'{ACTIVE_ANIMATION_KEY}' extras ignored: {value} is not one of the {clips} animations"
                ));
                0
            }
        }
    }

    /// The node recorded by rtgi's exporter under `key` in the scene extras (the one that turns the
    /// sky's sun, or the environment).
    fn bound_node(
        &self,
        scene_index: Option<usize>,
        key: &str,
        anim_index: &[Option<usize>],
        out: &mut Output,
    ) -> Option<usize> {
        let value = &self.raw["scenes"][scene_index?]["extras"][key];
        if value.is_null() {
            return None;
        }
        let node = value.as_u64().and_then(|n| anim_index.get(usize::try_from(n).ok()?).copied().flatten());
        if node.is_none() {
            out.warnings.note(format!("'{key}' extras ignored: {value} is not a node of the loaded scene"));
        }
        node
    }

    /// The environment's turn recorded by rtgi's exporter in the scene extras (identity if none).
    fn environment_rotation(&self, scene_index: Option<usize>, out: &mut Output) -> glam::Quat {
        let Some(value) = scene_index.map(|i| &self.raw["scenes"][i]["extras"][ENVIRONMENT_ROTATION_KEY])
        else {
            return glam::Quat::IDENTITY;
        };
        if value.is_null() {
            return glam::Quat::IDENTITY;
        }
        let parsed = serde_json::from_value::<[f32; 4]>(value.clone())
            .ok()
            .map(glam::Quat::from_array)
            .filter(|q| q.is_finite() && (q.length() - 1.0).abs() < 1e-3);
        parsed.map(glam::Quat::normalize).unwrap_or_else(|| {
            out.warnings.note(format!(
                "'{ENVIRONMENT_ROTATION_KEY}' extras ignored: {value} is not a unit quaternion [x, y, z, w]"
            ));
            glam::Quat::IDENTITY
        })
    }

    /// The nodes to draw: the default scene's, else the first scene's, else every node that is nobody's
    /// child.
    fn root_nodes(&self, out: &mut Output) -> Result<(Option<usize>, Vec<usize>), String> {
        let scenes = &self.root.scenes;
        let index = match self.root.scene {
            Some(i) => Some(i.value()),
            None if !scenes.is_empty() => Some(0),
            None => None,
        };
        if let Some(i) = index {
            let scene = scenes.get(i).ok_or_else(|| {
                format!("default scene {i} does not exist (the file has {} scenes)", scenes.len())
            })?;
            if scenes.len() > 1 {
                out.warnings.note(format!(
                    "the file has {} scenes; rtgi loads only {}",
                    scenes.len(),
                    quoted_name("scene", i, &scene.name)
                ));
            }
            return Ok((Some(i), scene.nodes.iter().map(|n| n.value()).collect()));
        }
        let mut is_child = vec![false; self.root.nodes.len()];
        for node in &self.root.nodes {
            for c in node.children.iter().flatten() {
                if let Some(flag) = is_child.get_mut(c.value()) {
                    *flag = true;
                }
            }
        }
        let roots: Vec<usize> = (0..self.root.nodes.len()).filter(|&i| !is_child[i]).collect();
        // glTF allows a file without scenes and leaves what to show to the application ("when scene is
        // undefined, runtime is not required to render anything"): drawing every root node is rtgi's
        // choice, so it says so rather than guessing silently.
        if !roots.is_empty() {
            out.warnings.note(format!(
                "the file defines no scenes; rtgi draws all {} root node{} (those that are nobody's child)",
                roots.len(),
                if roots.len() == 1 { "" } else { "s" }
            ));
        }
        Ok((None, roots))
    }

    fn mesh(&self, mesh_index: usize, node_label: &str, world: Mat4, out: &mut Output) -> Result<(), String> {
        let mesh = self
            .root
            .meshes
            .get(mesh_index)
            .ok_or_else(|| format!("{node_label} refers to mesh {mesh_index}, which does not exist"))?;
        let mesh_name = mesh.name.clone().unwrap_or_else(|| format!("mesh {mesh_index}"));
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let ctx = format!("mesh {mesh_index} '{mesh_name}' primitive {pi}");
            let subject = format!("mesh '{mesh_name}'");
            let mode = match prim.mode {
                Checked::Valid(m) => m,
                Checked::Invalid => return Err(format!("{ctx}: invalid primitive mode")),
            };
            if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
                out.warnings.about("point and line primitives skipped (rtgi renders triangles)", subject);
                continue;
            }
            let attr = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|i| i.value());
            let Some(pos_index) = attr(Semantic::Positions) else {
                out.warnings.about("primitives without POSITION skipped", subject);
                continue;
            };
            if prim.attributes.keys().any(|k| matches!(k, Checked::Valid(Semantic::Colors(_)))) {
                out.warnings.about("vertex colours (COLOR_n) ignored", subject.clone());
            }
            if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) {
                out.warnings.about("morph targets ignored (base geometry used)", subject.clone());
            }

            let mut positions = self.read_vec3(pos_index, &format!("{ctx} POSITION"))?;
            let n = positions.len();
            let same_count = |what: &str, index: usize| -> Result<(), String> {
                match self.accessor_count(index) {
                    Some(c) if c as usize == n => Ok(()),
                    Some(c) => Err(format!("{ctx}: {what} has {c} elements but POSITION has {n}")),
                    None => Ok(()), // reported by the read itself
                }
            };
            let normals = match attr(Semantic::Normals) {
                Some(i) => {
                    same_count("NORMAL", i)?;
                    Some(self.read_vec3(i, &format!("{ctx} NORMAL"))?)
                }
                None => None,
            };
            // The spec: without normals, tangents are meaningless and must be ignored.
            let tangents = match attr(Semantic::Tangents).filter(|_| normals.is_some()) {
                Some(i) => {
                    same_count("TANGENT", i)?;
                    Some(self.read_vec4(i, &format!("{ctx} TANGENT"))?)
                }
                None => None,
            };
            let uvs = match attr(Semantic::TexCoords(0)) {
                Some(i) => {
                    same_count("TEXCOORD_0", i)?;
                    self.read_vec2(i, &format!("{ctx} TEXCOORD_0"))?
                }
                None => vec![Vec2::ZERO; n],
            };
            let indices = match prim.indices {
                Some(i) => self.read_indices(i.value(), &format!("{ctx} indices"))?,
                None => (0..n as u32).collect(),
            };
            if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
                return Err(format!("{ctx}: index {bad} out of range ({n} vertices)"));
            }
            let mut indices = match mode {
                Mode::TriangleStrip => strip_to_list(&indices),
                Mode::TriangleFan => fan_to_list(&indices),
                _ => indices,
            };
            if !indices.len().is_multiple_of(3) {
                out.warnings
                    .about("index count not a multiple of 3; trailing indices dropped", subject.clone());
                indices.truncate(indices.len() / 3 * 3);
            }
            let material = match prim.material {
                Some(m) if m.value() < self.root.materials.len() => m.value() as u32,
                Some(m) => {
                    return Err(format!(
                        "{ctx}: material {} does not exist (the file has {} materials)",
                        m.value(),
                        self.root.materials.len()
                    ));
                }
                None => out.default_material(),
            };

            let mut normals = normals;
            let mut tangents = tangents;
            super::transform_vertices(
                world,
                &mut positions,
                normals.as_deref_mut().unwrap_or_default(),
                tangents.as_deref_mut().unwrap_or_default(),
                &mut indices,
            );

            let (positions, normals, uvs, indices) = match normals {
                Some(normals) => {
                    let normals = normals.into_iter().map(|v| v.normalize_or(Vec3::Z)).collect();
                    (positions, normals, uvs, indices)
                }
                None => {
                    tangents = None;
                    flat_shade(&positions, &uvs, &indices)
                }
            };
            let tangents = match tangents {
                Some(t) => t
                    .into_iter()
                    .zip(&normals)
                    .map(|(t, n)| {
                        let xyz = t.truncate().normalize_or(n.any_orthonormal_vector());
                        xyz.extend(if t.w < 0.0 { -1.0 } else { 1.0 })
                    })
                    .collect(),
                None => generate_tangents(&positions, &normals, &uvs, &indices),
            };
            let name =
                if mesh.primitives.len() > 1 { format!("{mesh_name}#{pi}") } else { mesh_name.clone() };
            out.scene.meshes.push(Mesh { name, positions, normals, tangents, uvs, indices, material });
        }
        Ok(())
    }

    fn material(&self, index: usize, out: &mut Output) -> Result<Material, String> {
        let m = self.root.materials.get(index).ok_or_else(|| format!("material {index} does not exist"))?;
        let name = m.name.clone().unwrap_or_else(|| format!("material {index}"));
        let label = format!("material '{name}'");
        let pbr = &m.pbr_metallic_roughness;
        let info = |t: &Option<json::texture::Info>| t.as_ref().map(|t| (t.index.value(), t.tex_coord));

        let base_color_texture =
            self.texture_ref(info(&pbr.base_color_texture), true, &label, "baseColorTexture", out)?;
        let metallic_roughness_texture = self.texture_ref(
            info(&pbr.metallic_roughness_texture),
            false,
            &label,
            "metallicRoughnessTexture",
            out,
        )?;
        let emissive_texture =
            self.texture_ref(info(&m.emissive_texture), true, &label, "emissiveTexture", out)?;
        let normal_texture = self.texture_ref(
            m.normal_texture.as_ref().map(|t| (t.index.value(), t.tex_coord)),
            false,
            &label,
            "normalTexture",
            out,
        )?;
        if m.occlusion_texture.is_some() {
            out.warnings.about("occlusion texture ignored (rtgi computes occlusion itself)", label.clone());
        }
        let strength = m
            .extensions
            .as_ref()
            .and_then(|e| e.emissive_strength.as_ref())
            .map_or(1.0, |s| s.emissive_strength.0);
        // KHR_materials_specular: rtgi models the factor (the strength of the dielectric specular layer);
        // a coloured or textured specular is reported, not silently approximated.
        let specular_ext = m.extensions.as_ref().and_then(|e| e.specular.as_ref());
        let specular = specular_ext.map_or(1.0, |s| s.specular_factor.0);
        if let Some(s) = specular_ext
            && (s.specular_texture.is_some()
                || s.specular_color_texture.is_some()
                || s.specular_color_factor.0 != [1.0; 3])
        {
            out.warnings.about(
                "KHR_materials_specular colour and textures ignored (only specularFactor is used)",
                label.clone(),
            );
        }
        let alpha_mode = match m.alpha_mode {
            Checked::Valid(json::material::AlphaMode::Opaque) => AlphaMode::Opaque,
            Checked::Valid(json::material::AlphaMode::Mask) => {
                AlphaMode::Mask { cutoff: m.alpha_cutoff.map_or(0.5, |c| c.0) }
            }
            Checked::Valid(json::material::AlphaMode::Blend) => {
                out.warnings
                    .about("alphaMode BLEND rendered opaque (rtgi has no transparency)", label.clone());
                AlphaMode::Blend
            }
            Checked::Invalid => return Err(format!("{label}: invalid alphaMode")),
        };

        // Extensions that `gltf::json` does not model are only visible in the raw tree.
        let raw = &self.raw["materials"][index];
        for key in object_keys(&raw["extensions"]) {
            if !MATERIAL_EXTENSIONS.contains(&key) {
                out.warnings.about(&format!("glTF extension '{key}' ignored"), label.clone());
                out.reported_extensions.push(key.to_string());
            }
        }
        let texture_infos = [
            &raw["pbrMetallicRoughness"]["baseColorTexture"],
            &raw["pbrMetallicRoughness"]["metallicRoughnessTexture"],
            &raw["normalTexture"],
            &raw["emissiveTexture"],
        ];
        for info in texture_infos {
            for key in object_keys(&info["extensions"]) {
                out.warnings.about(&format!("glTF extension '{key}' ignored"), label.clone());
                out.reported_extensions.push(key.to_string());
            }
        }

        Ok(Material {
            name,
            base_color: Vec4::from(pbr.base_color_factor.0),
            base_color_texture,
            metallic: pbr.metallic_factor.0,
            roughness: pbr.roughness_factor.0,
            metallic_roughness_texture,
            emissive: Vec3::from(m.emissive_factor.0) * strength,
            emissive_texture,
            normal_texture,
            normal_scale: m.normal_texture.as_ref().map_or(1.0, |t| t.scale),
            specular,
            alpha_mode,
            double_sided: m.double_sided,
            subsurface: self.subsurface(index, &label)?,
        })
    }

    /// The translucent medium rtgi's exporter recorded in material `index`'s extras, if any; a malformed
    /// one is an error naming the material.
    fn subsurface(&self, index: usize, label: &str) -> Result<Option<crate::scene::Subsurface>, String> {
        let value = &self.raw["materials"][index]["extras"][SUBSURFACE_KEY];
        if value.is_null() {
            return Ok(None);
        }
        let medium = serde_json::from_value::<SubsurfaceJson>(value.clone())
            .map_err(|e| format!("{label}: '{SUBSURFACE_KEY}' extras: {e}"))?
            .medium();
        medium.check().map_err(|e| format!("{label}: '{SUBSURFACE_KEY}' extras: {e}"))?;
        Ok(Some(medium))
    }

    /// Resolves a material's texture slot to an rtgi texture, decoding the image on first use.
    /// Textures are keyed by (image, colour space): the same image used as sRGB colour and as linear
    /// data must become two GPU textures.
    fn texture_ref(
        &self,
        info: Option<(usize, u32)>,
        srgb: bool,
        label: &str,
        slot: &str,
        out: &mut Output,
    ) -> Result<Option<TextureRef>, String> {
        let Some((ti, tex_coord)) = info else { return Ok(None) };
        if tex_coord != 0 {
            out.warnings.about(
                &format!("textures using TEXCOORD_{tex_coord} dropped (rtgi meshes carry only TEXCOORD_0)"),
                format!("{label} {slot}"),
            );
            return Ok(None);
        }
        let texture = self
            .root
            .textures
            .get(ti)
            .ok_or_else(|| format!("{label}: {slot} refers to texture {ti}, which does not exist"))?;
        let image_index = texture.source.value();
        if image_index >= self.root.images.len() {
            return Err(format!(
                "{label}: texture {ti} has no usable image source (image {image_index} does not exist; \
                 extension-only sources such as EXT_texture_webp are not supported)"
            ));
        }
        if let Some(si) = texture.sampler {
            let sampler = self.root.samplers.get(si.value()).ok_or_else(|| {
                format!("texture {ti} refers to sampler {}, which does not exist", si.value())
            })?;
            let repeat = Checked::Valid(json::texture::WrappingMode::Repeat);
            if sampler.wrap_s != repeat || sampler.wrap_t != repeat {
                out.warnings.about(
                    "texture wrap mode other than REPEAT ignored (rtgi always repeats)",
                    quoted_name("texture", ti, &texture.name),
                );
            }
        }
        if let Some(&t) = out.textures.get(&(image_index, srgb)) {
            return Ok(Some(TextureRef::new(t)));
        }
        let texture = match out.decoded.get(&image_index).and_then(|&t| out.scene.textures.get(t as usize)) {
            Some(other) => Texture { srgb, ..other.clone() },
            None => {
                let (width, height, rgba8) = self.decode_image(image_index)?;
                let img = &self.root.images[image_index];
                let name = img
                    .name
                    .clone()
                    .or_else(|| img.uri.clone().filter(|u| !u.starts_with("data:")))
                    .unwrap_or_else(|| format!("image {image_index}"));
                Texture { name, width, height, rgba8, srgb }
            }
        };
        let index = out.scene.textures.len() as u32;
        out.scene.textures.push(texture);
        out.textures.insert((image_index, srgb), index);
        out.decoded.entry(image_index).or_insert(index);
        Ok(Some(TextureRef::new(index)))
    }

    /// Decodes a PNG or JPEG image to RGBA8, from a file, a data URI or a buffer view.
    fn decode_image(&self, index: usize) -> Result<(u32, u32, Vec<u8>), String> {
        let img = self.root.images.get(index).ok_or_else(|| format!("image {index} does not exist"))?;
        let label = match (&img.name, &img.uri) {
            (Some(n), _) => format!("image {index} '{n}'"),
            (None, Some(u)) if !u.starts_with("data:") => format!("image {index} '{u}'"),
            _ => format!("image {index}"),
        };
        let declared = img.mime_type.as_ref().map(|m| m.0.clone());
        let (bytes, mime): (Cow<[u8]>, Option<String>) = match (&img.uri, img.buffer_view) {
            (Some(uri), _) => match container::resolve_uri(uri, &self.base_dir)
                .map_err(|e| format!("{label}: {e}"))?
            {
                container::UriTarget::Data { bytes, mime } => (Cow::Owned(bytes), Some(mime)),
                container::UriTarget::File(file) => {
                    // Without a declared type, the file extension is the best hint.
                    let by_extension =
                        match file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase) {
                            Some(e) if e == "png" => Some("image/png".to_string()),
                            Some(e) if e == "jpg" || e == "jpeg" => Some("image/jpeg".to_string()),
                            _ => None,
                        };
                    let bytes = container::read_uri_file(uri, &file).map_err(|e| format!("{label}: {e}"))?;
                    (Cow::Owned(bytes), declared.or(by_extension))
                }
            },
            (None, Some(view)) => {
                (Cow::Borrowed(self.view_bytes(view.value()).map_err(|e| format!("{label}: {e}"))?), declared)
            }
            (None, None) => return Err(format!("{label} has neither a URI nor a buffer view")),
        };
        use image::ImageFormat;
        // Trust the bytes over the declared type: mislabelled JPEGs are common in the wild.
        let format = match image::guess_format(&bytes) {
            Ok(f @ (ImageFormat::Png | ImageFormat::Jpeg)) => f,
            Ok(other) => {
                return Err(format!("{label}: unsupported image type {other:?} (rtgi decodes PNG and JPEG)"));
            }
            Err(_) => match mime.as_deref() {
                Some("image/png") => ImageFormat::Png,
                Some("image/jpeg") => ImageFormat::Jpeg,
                Some(m) => {
                    return Err(format!("{label}: unsupported image type '{m}' (rtgi decodes PNG and JPEG)"));
                }
                None => {
                    return Err(format!("{label}: unrecognised image type (rtgi decodes PNG and JPEG)"));
                }
            },
        };
        let decoded = image::load_from_memory_with_format(&bytes, format)
            .map_err(|e| format!("{label}: cannot decode {format:?} image: {e}"))?;
        let rgba = decoded.into_rgba8();
        Ok((rgba.width(), rgba.height(), rgba.into_raw()))
    }

    fn light(&self, index: usize, node_label: &str, world: Mat4, out: &mut Output) -> Result<(), String> {
        use json::extensions::scene::khr_lights_punctual::Type;
        let lights = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map_or(&[][..], |l| &l.lights[..]);
        let light = lights.get(index).ok_or_else(|| {
            format!(
                "{node_label} refers to light {index}, but KHR_lights_punctual defines {} lights",
                lights.len()
            )
        })?;
        let label = match &light.name {
            Some(n) => format!("light '{n}'"),
            None => format!("light {index}"),
        };
        if light.range.is_some() {
            out.warnings
                .about("light range ignored (rtgi uses physical inverse-square falloff)", label.clone());
        }
        let intensity = Vec3::from(light.color) * light.intensity;
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        if !intensity.is_finite() || !position.is_finite() {
            return Err(format!("{label}: non-finite intensity or position"));
        }
        let needs_direction = !matches!(light.type_, Checked::Valid(Type::Point));
        if needs_direction && direction == Vec3::ZERO {
            out.warnings.about("light skipped: its node transform has no direction (zero scale)", label);
            return Ok(());
        }
        let light = match light.type_ {
            Checked::Valid(Type::Point) => Light::Point { position, intensity },
            Checked::Valid(Type::Spot) => {
                let spot = light
                    .spot
                    .as_ref()
                    .ok_or_else(|| format!("{label}: spot light without 'spot' properties"))?;
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    inner_angle: spot.inner_cone_angle,
                    outer_angle: spot.outer_cone_angle,
                }
            }
            Checked::Valid(Type::Directional) => Light::Directional { direction, irradiance: intensity },
            Checked::Invalid => return Err(format!("{label}: invalid light type")),
        };
        out.scene.lights.push(light);
        Ok(())
    }

    fn camera(
        &self,
        index: usize,
        node_index: usize,
        node_label: &str,
        world: Mat4,
        out: &mut Output,
    ) -> Result<Option<Camera>, String> {
        let cam = self
            .root
            .cameras
            .get(index)
            .ok_or_else(|| format!("{node_label} refers to camera {index}, which does not exist"))?;
        let label = quoted_name("camera", index, &cam.name);
        let p = match cam.type_ {
            Checked::Valid(json::camera::Type::Perspective) => {
                cam.perspective.as_ref().ok_or_else(|| format!("{label}: no 'perspective' properties"))?
            }
            Checked::Valid(json::camera::Type::Orthographic) => {
                out.warnings.note(format!(
                    "{label} is orthographic; rtgi uses a default perspective camera framing the scene"
                ));
                return Ok(None);
            }
            Checked::Invalid => return Err(format!("{label}: invalid camera type")),
        };
        let valid_fov = p.yfov.is_finite() && p.yfov > 0.0 && p.yfov < std::f32::consts::PI;
        if !(valid_fov && p.znear.is_finite() && p.znear > 0.0) {
            return Err(format!("{label}: invalid yfov {} or znear {}", p.yfov, p.znear));
        }
        let zfar = match p.zfar {
            Some(z) if z.is_finite() && z > p.znear => z,
            Some(z) => return Err(format!("{label}: zfar {z} is not beyond znear {}", p.znear)),
            // Infinite projection: rtgi's projection is finite, so pick a far plane well beyond near.
            None => 1000f32.max(p.znear * 1.0e4),
        };
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
        if forward == Vec3::ZERO || up == Vec3::ZERO || !position.is_finite() {
            out.warnings.note(format!("{label}: degenerate node transform; using a default camera"));
            return Ok(None);
        }
        // glTF cameras have no target; rtgi's exporter records the look-at distance in the node extras.
        let distance = self.raw["nodes"][node_index]["extras"][TARGET_DISTANCE_KEY]
            .as_f64()
            .filter(|d| d.is_finite() && *d > 0.0)
            .map_or(1.0, |d| d as f32);
        Ok(Some(Camera {
            position,
            target: position + forward * distance,
            up,
            yfov: p.yfov,
            znear: p.znear,
            zfar,
        }))
    }

    fn environment(&self, scene_index: Option<usize>, out: &mut Output) -> Result<Environment, String> {
        let from_scene = scene_index.map(|i| &self.raw["scenes"][i]["extras"][ENVIRONMENT_KEY]);
        let value =
            from_scene.filter(|v| !v.is_null()).unwrap_or(&self.raw["asset"]["extras"][ENVIRONMENT_KEY]);
        if value.is_null() {
            return Ok(Environment::None);
        }
        let parsed: EnvironmentJson = match serde_json::from_value(value.clone()) {
            Ok(p) => p,
            Err(e) => {
                out.warnings.note(format!("malformed '{ENVIRONMENT_KEY}' extras ignored: {e}"));
                return Ok(Environment::None);
            }
        };
        Ok(match parsed {
            EnvironmentJson::None => Environment::None,
            EnvironmentJson::Uniform { radiance } => Environment::Uniform(Vec3::from(radiance)),
            EnvironmentJson::Sky { sun_direction, sun_radiance, sky_radiance, ground_radiance } => {
                Environment::Sky {
                    sun_direction: Vec3::from(sun_direction),
                    sun_radiance: Vec3::from(sun_radiance),
                    sky_radiance: Vec3::from(sky_radiance),
                    ground_radiance: Vec3::from(ground_radiance),
                }
            }
            EnvironmentJson::Map { path, intensity } => self.environment_map(path, intensity, out)?,
        })
    }

    /// Loads the equirectangular map named in the extras: absolute, else relative to the glTF file,
    /// else relative to the working directory. A missing map is a warning (the scene is still usable).
    fn environment_map(&self, path: String, intensity: f32, out: &mut Output) -> Result<Environment, String> {
        let p = Path::new(&path);
        let candidates = if p.is_absolute() {
            vec![p.to_path_buf()]
        } else {
            vec![self.base_dir.join(p), p.to_path_buf()]
        };
        let Some(file) = candidates.iter().find(|c| c.is_file()) else {
            out.warnings.note(format!("environment map '{path}' not found; environment set to none"));
            return Ok(Environment::None);
        };
        let is_exr = file.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        if is_exr {
            return Err(format!(
                "environment map '{path}': OpenEXR maps are not supported yet (use Radiance .hdr)"
            ));
        }
        let reader = image::ImageReader::open(file)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| format!("environment map '{path}': {e}"))?;
        if reader.format() != Some(image::ImageFormat::Hdr) {
            return Err(format!("environment map '{path}': only Radiance .hdr maps are supported"));
        }
        let img = reader.decode().map_err(|e| format!("environment map '{path}': cannot decode: {e}"))?;
        let rgb = img.into_rgb32f();
        Ok(Environment::Map(EnvironmentMap {
            path,
            width: rgb.width(),
            height: rgb.height(),
            rgb: rgb.into_raw(),
            intensity,
        }))
    }
}

fn object_keys(v: &Value) -> impl Iterator<Item = &str> {
    v.as_object().into_iter().flat_map(|o| o.keys().map(String::as_str))
}

/// A node's local matrix from `matrix` or TRS.
fn local_transform(node: &json::Node) -> Result<Mat4, String> {
    match node.matrix {
        Some(m) => Ok(Mat4::from_cols_array(&m)),
        None => Ok(rest_trs(node)?.matrix()),
    }
}

/// A node's TRS properties, with the rotation normalised.
fn rest_trs(node: &json::Node) -> Result<Trs, String> {
    let t = node.translation.map_or(Vec3::ZERO, Vec3::from);
    let s = node.scale.map_or(Vec3::ONE, Vec3::from);
    let r = match node.rotation {
        None => Quat::IDENTITY,
        Some(q) => {
            let q = Quat::from_array(q.0);
            let len = q.length();
            if !len.is_finite() || len < 1e-6 {
                return Err(format!("rotation {:?} is not a unit quaternion", q.to_array()));
            }
            q / len
        }
    };
    Ok(Trs { translation: t, rotation: r, scale: s })
}

/// glTF strip order: triangle i is (i, i+1, i+2) for even i and (i, i+2, i+1) for odd i, which keeps
/// every triangle counter-clockwise.
fn strip_to_list(strip: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(strip.len().saturating_sub(2) * 3);
    for (i, w) in strip.windows(3).enumerate() {
        if i % 2 == 0 {
            out.extend_from_slice(&[w[0], w[1], w[2]]);
        } else {
            out.extend_from_slice(&[w[0], w[2], w[1]]);
        }
    }
    out
}

/// glTF fan order: triangle i is (i+1, i+2, 0).
fn fan_to_list(fan: &[u32]) -> Vec<u32> {
    let Some((&first, rest)) = fan.split_first() else { return Vec::new() };
    rest.windows(2).flat_map(|w| [w[0], w[1], first]).collect()
}

/// The spec asks for flat normals when a primitive has none, which means unwelding: each triangle gets
/// its own three vertices.
fn flat_shade(
    positions: &[Vec3],
    uvs: &[Vec2],
    indices: &[u32],
) -> (Vec<Vec3>, Vec<Vec3>, Vec<Vec2>, Vec<u32>) {
    let mut p = Vec::with_capacity(indices.len());
    let mut n = Vec::with_capacity(indices.len());
    let mut t = Vec::with_capacity(indices.len());
    for tri in indices.chunks_exact(3) {
        let corners: Vec<(Vec3, Vec2)> = tri
            .iter()
            .map(|&i| {
                let i = i as usize;
                (positions.get(i).copied().unwrap_or(Vec3::ZERO), uvs.get(i).copied().unwrap_or(Vec2::ZERO))
            })
            .collect();
        let [(a, _), (b, _), (c, _)] = corners[..] else { continue };
        let normal = (b - a).cross(c - a).normalize_or(Vec3::Z);
        for (pos, uv) in corners {
            p.push(pos);
            n.push(normal);
            t.push(uv);
        }
    }
    let indices = (0..p.len() as u32).collect();
    (p, n, t, indices)
}

/// A camera that frames `bounds`, looking at their centre from the front and a little above, for
/// files that bring no camera.
fn framing_camera(bounds: Aabb) -> Camera {
    if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
        return Camera::default();
    }
    let yfov = 45f32.to_radians();
    let center = bounds.center();
    let radius = bounds.bounding_radius();
    let distance = radius / (yfov * 0.5).sin();
    let position = center + Vec3::new(0.0, 0.35, 1.0).normalize() * distance;
    Camera {
        position,
        target: center,
        up: Vec3::Y,
        yfov,
        znear: (radius * 0.01).max(1e-4),
        zfar: (distance + radius) * 10.0,
    }
}
