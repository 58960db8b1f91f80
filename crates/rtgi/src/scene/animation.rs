//! Time in the scene: a node hierarchy, keyframed clips (glTF 2.0 animation semantics) and the
//! bindings of meshes, lights, the camera and the sky's sun to nodes.
//!
//! The rest of rtgi works on world-space [`Scene`] data, so an animated scene keeps its meshes, lights
//! and camera in the world-space REST pose (what the loaders produce) and animation is expressed as a
//! per-object delta: a bound object's world transform at time t is `W_node(t) · W_node(rest)⁻¹` applied
//! to its stored data. Objects whose node no channel moves get no delta at all, so their data stays
//! bit-identical in every pose.

use glam::{Mat3, Mat4, Quat, Vec3, Vec4};

use super::{Environment, Light, Mesh, Scene};
use crate::error::SceneError;

/// A node's local transform as translation, rotation and scale (glTF's TRS, applied scale first).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trs {
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
}

impl Default for Trs {
    fn default() -> Self {
        Trs { translation: Vec3::ZERO, rotation: Quat::IDENTITY, scale: Vec3::ONE }
    }
}

impl Trs {
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// The TRS of an affine matrix (exact for matrices built from TRS; shear is lost).
    pub fn from_matrix(m: Mat4) -> Trs {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Trs { translation, rotation: rotation.normalize(), scale }
    }

    /// A rigid transform that places −Z along `forward` with `up` as close to +Y of the frame as
    /// possible: how glTF orients cameras and lights.
    pub fn looking(position: Vec3, forward: Vec3, up: Vec3) -> Trs {
        Trs { translation: position, rotation: look_rotation(forward, up), scale: Vec3::ONE }
    }
}

/// The rotation taking −Z to `forward` and +Y towards `up` (falls back to any perpendicular `up` when
/// the two are parallel).
pub fn look_rotation(forward: Vec3, up: Vec3) -> Quat {
    let forward = forward.normalize_or(Vec3::NEG_Z);
    let right = forward.cross(up).normalize_or(forward.any_orthonormal_vector());
    let up = right.cross(forward);
    Quat::from_mat3(&Mat3::from_cols(right, up, -forward)).normalize()
}

/// A node of the animation hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimNode {
    pub name: String,
    /// Always an index smaller than this node's own (parents come first), so world transforms can be
    /// computed in one forward pass.
    pub parent: Option<usize>,
    /// Local transform in the rest pose; channels override its components.
    pub rest: Trs,
    /// World transform in the rest pose, the pose in which the scene's meshes, lights and camera are
    /// stored. Kept rather than recomputed because a loaded node may have a `matrix` that TRS cannot
    /// represent exactly (shear); it is used as is for nodes that do not move.
    pub rest_world: Mat4,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
}

impl Property {
    pub fn gltf_name(self) -> &'static str {
        match self {
            Property::Translation => "translation",
            Property::Rotation => "rotation",
            Property::Scale => "scale",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Holds each key's value until the next key.
    Step,
    /// Linear; rotations use spherical linear interpolation along the shorter arc.
    Linear,
    /// Cubic Hermite spline with explicit in and out tangents per key.
    CubicSpline,
}

impl Interpolation {
    pub fn gltf_name(self) -> &'static str {
        match self {
            Interpolation::Step => "STEP",
            Interpolation::Linear => "LINEAR",
            Interpolation::CubicSpline => "CUBICSPLINE",
        }
    }
}

/// Keyframes of one property.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampler {
    pub interpolation: Interpolation,
    /// Key times in seconds, strictly increasing, at least one.
    pub times: Vec<f32>,
    /// Key values in glTF's layout: one per key for STEP and LINEAR, three per key for CUBICSPLINE
    /// (in-tangent, value, out-tangent). Translation and scale use xyz (w = 0); rotations are xyzw
    /// quaternions.
    pub values: Vec<Vec4>,
}

impl Sampler {
    pub fn new(interpolation: Interpolation, times: Vec<f32>, values: Vec<Vec4>) -> Sampler {
        Sampler { interpolation, times, values }
    }

    fn values_per_key(&self) -> usize {
        if self.interpolation == Interpolation::CubicSpline { 3 } else { 1 }
    }

    /// The time range covered by the keys.
    pub fn range(&self) -> (f32, f32) {
        (self.times.first().copied().unwrap_or(0.0), self.times.last().copied().unwrap_or(0.0))
    }

    /// Checks what sampling relies on; the message says what is wrong.
    pub fn check(&self) -> Result<(), String> {
        if self.times.is_empty() {
            return Err("a sampler needs at least one key".into());
        }
        if let Some(bad) = self.times.iter().find(|t| !t.is_finite() || **t < 0.0) {
            return Err(format!("key time {bad} is not a finite, non-negative number of seconds"));
        }
        if let Some(k) = self.times.windows(2).position(|w| w[1] <= w[0]) {
            return Err(format!(
                "key times must increase strictly, but key {} ({}) follows key {k} ({})",
                k + 1,
                self.times[k + 1],
                self.times[k]
            ));
        }
        let expected = self.times.len() * self.values_per_key();
        if self.values.len() != expected {
            return Err(format!(
                "{} keys need {expected} {} output values, but there are {}",
                self.times.len(),
                self.interpolation.gltf_name(),
                self.values.len()
            ));
        }
        if self.values.iter().any(|v| !v.is_finite()) {
            return Err("non-finite output value".into());
        }
        Ok(())
    }

    /// The value of key `k` (the spline vertex for CUBICSPLINE).
    fn key(&self, k: usize) -> Vec4 {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        }
    }

    /// The value at time `t`, held constant before the first and after the last key (glTF semantics).
    /// Rotations come back as unit quaternions.
    pub fn sample(&self, t: f32, property: Property) -> Vec4 {
        let n = self.times.len();
        let finish = |v: Vec4| if property == Property::Rotation { v.normalize_or(Vec4::W) } else { v };
        if n == 0 {
            return finish(Vec4::ZERO);
        }
        if t.is_nan() || t <= self.times[0] {
            return finish(self.key(0));
        }
        if t >= self.times[n - 1] {
            return finish(self.key(n - 1));
        }
        // times[k] <= t < times[k + 1]
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let dt = self.times[k + 1] - self.times[k];
        let s = (t - self.times[k]) / dt;
        let (a, b) = (self.key(k), self.key(k + 1));
        finish(match self.interpolation {
            Interpolation::Step => a,
            Interpolation::Linear if property == Property::Rotation => slerp(a, b, s),
            Interpolation::Linear => a.lerp(b, s),
            Interpolation::CubicSpline => {
                // Tangents are stored per second; the spline runs over s in [0, 1], so scale by dt.
                let (out_a, in_b) = (self.values[3 * k + 2] * dt, self.values[3 * (k + 1)] * dt);
                let (s2, s3) = (s * s, s * s * s);
                a * (2.0 * s3 - 3.0 * s2 + 1.0)
                    + out_a * (s3 - 2.0 * s2 + s)
                    + b * (-2.0 * s3 + 3.0 * s2)
                    + in_b * (s3 - s2)
            }
        })
    }
}

/// Spherical linear interpolation of unit quaternions (xyzw) along the shorter arc, as the glTF
/// specification defines it for LINEAR rotation channels.
pub fn slerp(a: Vec4, b: Vec4, s: f32) -> Vec4 {
    let d = a.dot(b);
    let (b, d) = if d < 0.0 { (-b, -d) } else { (b, d) };
    // Nearly equal rotations: sin(angle) → 0, and the chord is the arc to float precision.
    if d > 0.9995 {
        return a.lerp(b, s).normalize_or(a);
    }
    let angle = d.min(1.0).acos();
    let sin = angle.sin();
    (a * ((1.0 - s) * angle).sin() + b * (s * angle).sin()) / sin
}

/// One animated property of one node.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// Index into [`SceneAnimation::nodes`].
    pub node: usize,
    pub property: Property,
    pub sampler: Sampler,
}

/// A named set of channels played together (a glTF animation).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct AnimationClip {
    pub name: String,
    pub channels: Vec<Channel>,
}

impl AnimationClip {
    /// First and last key time over all channels; (0, 0) without channels.
    pub fn range(&self) -> (f32, f32) {
        let mut ranges = self.channels.iter().map(|c| c.sampler.range());
        let Some(first) = ranges.next() else { return (0.0, 0.0) };
        ranges.fold(first, |(lo, hi), (a, b)| (lo.min(a), hi.max(b)))
    }
}

/// Which node each scene object follows; `None` (or a missing entry) means static.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Bindings {
    /// Per [`Scene::meshes`] entry.
    pub meshes: Vec<Option<usize>>,
    /// Per [`Scene::lights`] entry.
    pub lights: Vec<Option<usize>>,
    pub camera: Option<usize>,
    /// The node whose rotation turns the sun of an [`Environment::Sky`] (usually the directional
    /// light's node).
    pub sun: Option<usize>,
    /// The node whose rotation turns the environment ([`Scene::environment_rotation`]).
    pub environment: Option<usize>,
}

/// The animation of a scene. See the module documentation for how it applies to the scene's data.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SceneAnimation {
    pub nodes: Vec<AnimNode>,
    pub clips: Vec<AnimationClip>,
    /// Index into `clips` of the clip that [`Scene::pose_at`] plays.
    pub active: usize,
    pub bindings: Bindings,
}

impl SceneAnimation {
    /// Appends a node with rest transform `rest` under `parent` and returns its index.
    pub fn add_node(&mut self, name: &str, parent: Option<usize>, rest: Trs) -> usize {
        let parent_world = parent.and_then(|p| self.nodes.get(p)).map_or(Mat4::IDENTITY, |p| p.rest_world);
        self.nodes.push(AnimNode {
            name: name.into(),
            parent,
            rest,
            rest_world: parent_world * rest.matrix(),
        });
        self.nodes.len() - 1
    }

    pub fn active_clip(&self) -> Option<&AnimationClip> {
        self.clips.get(self.active)
    }

    /// Checks the invariants that posing relies on, against a scene with `meshes` meshes and `lights`
    /// lights.
    pub fn validate(&self, meshes: usize, lights: usize) -> Result<(), String> {
        for (i, node) in self.nodes.iter().enumerate() {
            if node.parent.is_some_and(|p| p >= i) {
                return Err(format!("animation node {i} '{}': its parent must come before it", node.name));
            }
            let r = node.rest;
            if !(r.translation.is_finite()
                && r.rotation.is_finite()
                && r.scale.is_finite()
                && node.rest_world.is_finite())
            {
                return Err(format!("animation node {i} '{}': non-finite rest transform", node.name));
            }
        }
        let node_ok = |n: &Option<usize>| n.is_none_or(|n| n < self.nodes.len());
        let b = &self.bindings;
        if b.meshes.len() > meshes || b.lights.len() > lights {
            return Err(format!(
                "animation binds {} meshes and {} lights, but the scene has {meshes} and {lights}",
                b.meshes.len(),
                b.lights.len()
            ));
        }
        if !(b.meshes.iter().all(node_ok)
            && b.lights.iter().all(node_ok)
            && node_ok(&b.camera)
            && node_ok(&b.sun)
            && node_ok(&b.environment))
        {
            return Err(format!("animation binding to a node out of range ({} nodes)", self.nodes.len()));
        }
        if !self.clips.is_empty() && self.active >= self.clips.len() {
            return Err(format!("active clip {} out of range ({} clips)", self.active, self.clips.len()));
        }
        for (ci, clip) in self.clips.iter().enumerate() {
            for (k, ch) in clip.channels.iter().enumerate() {
                let label = format!("animation '{}' (clip {ci}) channel {k}", clip.name);
                if ch.node >= self.nodes.len() {
                    return Err(format!("{label}: node {} out of range", ch.node));
                }
                ch.sampler.check().map_err(|e| format!("{label}: {e}"))?;
            }
        }
        Ok(())
    }

    /// Per node: whether the active clip moves it (a channel targets it or one of its ancestors).
    pub fn moving_nodes(&self) -> Vec<bool> {
        let mut moving = vec![false; self.nodes.len()];
        for ch in self.active_clip().into_iter().flat_map(|c| &c.channels) {
            if let Some(m) = moving.get_mut(ch.node) {
                *m = true;
            }
        }
        for i in 0..self.nodes.len() {
            if let Some(p) = self.nodes[i].parent.filter(|&p| p < i) {
                moving[i] |= moving[p];
            }
        }
        moving
    }

    /// Per node: `W(t) · W(rest)⁻¹` for nodes that move, `None` for the others.
    pub fn node_deltas(&self, t: f32) -> Vec<Option<Mat4>> {
        let moving = self.moving_nodes();
        let Some(clip) = self.active_clip() else { return vec![None; self.nodes.len()] };
        let mut local: Vec<Option<Trs>> = vec![None; self.nodes.len()];
        for ch in &clip.channels {
            let Some(trs) = local.get_mut(ch.node) else { continue };
            let trs = trs.get_or_insert(self.nodes[ch.node].rest);
            let v = ch.sampler.sample(t, ch.property);
            match ch.property {
                Property::Translation => trs.translation = v.truncate(),
                Property::Rotation => trs.rotation = Quat::from_vec4(v),
                Property::Scale => trs.scale = v.truncate(),
            }
        }
        let mut world = Vec::with_capacity(self.nodes.len());
        for (i, node) in self.nodes.iter().enumerate() {
            let w = if moving[i] {
                let parent = node.parent.filter(|&p| p < i).map_or(Mat4::IDENTITY, |p| world[p]);
                parent * local[i].unwrap_or(node.rest).matrix()
            } else {
                node.rest_world
            };
            world.push(w);
        }
        world
            .iter()
            .zip(&self.nodes)
            .zip(moving)
            .map(|((w, node), m)| m.then(|| *w * node.rest_world.inverse()))
            .collect()
    }
}

/// The time-dependent part of a scene at one instant.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    pub camera: super::Camera,
    pub lights: Vec<Light>,
    /// One per mesh: maps the mesh's stored (rest) world-space geometry to its world space at t;
    /// IDENTITY for static meshes.
    pub mesh_transforms: Vec<Mat4>,
    /// The sun direction (towards the sun) of an [`Environment::Sky`] at t; `None` for other
    /// environments.
    pub environment_sun: Option<Vec3>,
    /// The environment's rotation at t ([`Scene::environment_rotation`]).
    pub environment_rotation: Quat,
}

fn transform_light(light: &Light, m: Mat4) -> Light {
    let dir = |d: Vec3| m.transform_vector3(d).normalize_or(d);
    match *light {
        Light::Point { position, intensity } => {
            Light::Point { position: m.transform_point3(position), intensity }
        }
        Light::Spot { position, direction, intensity, inner_angle, outer_angle } => Light::Spot {
            position: m.transform_point3(position),
            direction: dir(direction),
            intensity,
            inner_angle,
            outer_angle,
        },
        Light::Directional { direction, irradiance } => {
            Light::Directional { direction: dir(direction), irradiance }
        }
    }
}

impl Scene {
    /// Whether the active clip has at least one channel.
    pub fn is_animated(&self) -> bool {
        self.animation.as_ref().and_then(SceneAnimation::active_clip).is_some_and(|c| !c.channels.is_empty())
    }

    /// Length of the active clip in seconds: its last key time (glTF clips start at time 0); 0 for
    /// static scenes.
    pub fn animation_duration(&self) -> f32 {
        self.animation.as_ref().and_then(SceneAnimation::active_clip).map_or(0.0, |c| c.range().1)
    }

    /// The camera, lights, mesh transforms and sun at time `t` (seconds), clamped to the active clip's
    /// first and last keys.
    pub fn pose_at(&self, t: f32) -> Pose {
        let static_pose = || Pose {
            camera: self.camera,
            lights: self.lights.clone(),
            mesh_transforms: vec![Mat4::IDENTITY; self.meshes.len()],
            environment_sun: match self.environment {
                Environment::Sky { sun_direction, .. } => Some(sun_direction),
                _ => None,
            },
            environment_rotation: self.environment_rotation,
        };
        let Some(anim) = self.animation.as_ref().filter(|_| self.is_animated()) else { return static_pose() };
        let (start, end) = anim.active_clip().map_or((0.0, 0.0), AnimationClip::range);
        let t = if t.is_nan() { start } else { t.clamp(start, end) };
        let deltas = anim.node_deltas(t);
        let delta = |node: Option<&Option<usize>>| {
            node.copied().flatten().and_then(|n| deltas.get(n).copied().flatten())
        };
        let b = &anim.bindings;
        let mut pose = static_pose();
        for (i, m) in pose.mesh_transforms.iter_mut().enumerate() {
            if let Some(d) = delta(b.meshes.get(i)) {
                *m = d;
            }
        }
        for (i, light) in pose.lights.iter_mut().enumerate() {
            if let Some(d) = delta(b.lights.get(i)) {
                *light = transform_light(light, d);
            }
        }
        if let Some(d) = delta(Some(&b.camera)) {
            let c = &mut pose.camera;
            c.position = d.transform_point3(c.position);
            c.target = d.transform_point3(c.target);
            c.up = d.transform_vector3(c.up).normalize_or(c.up);
        }
        if let (Some(d), Some(sun)) = (delta(Some(&b.sun)), pose.environment_sun.as_mut()) {
            *sun = d.transform_vector3(*sun).normalize_or(*sun);
        }
        if let Some(d) = delta(Some(&b.environment)) {
            let (_, turn, _) = d.to_scale_rotation_translation();
            pose.environment_rotation = (turn * pose.environment_rotation).normalize();
        }
        pose
    }

    /// Per mesh: whether the active clip moves it.
    pub fn moving_meshes(&self) -> Vec<bool> {
        let Some(anim) = self.animation.as_ref().filter(|_| self.is_animated()) else {
            return vec![false; self.meshes.len()];
        };
        let moving = anim.moving_nodes();
        (0..self.meshes.len())
            .map(|i| {
                anim.bindings.meshes.get(i).copied().flatten().is_some_and(|n| moving.get(n) == Some(&true))
            })
            .collect()
    }

    /// A static world-space copy of the scene at time `t`: meshes, lights, camera and sky sun posed,
    /// no animation.
    pub fn posed(&self, t: f32) -> Scene {
        self.posed_with(self.pose_at(t))
    }

    /// [`Scene::posed`] for a pose already computed with [`Scene::pose_at`].
    pub fn posed_with(&self, pose: Pose) -> Scene {
        let meshes = self.meshes.iter().zip(&pose.mesh_transforms).map(|(m, &xf)| m.posed(xf)).collect();
        let mut posed = Scene {
            meshes,
            lights: Vec::new(),
            camera: self.camera,
            environment: self.environment.clone(),
            environment_rotation: self.environment_rotation,
            animation: None,
            name: self.name.clone(),
            materials: self.materials.clone(),
            textures: self.textures.clone(),
            warnings: self.warnings.clone(),
        };
        posed.place_lights_and_camera(pose);
        posed
    }

    /// Sets the lights, camera and sky sun of a posed scene to `pose`'s, leaving the geometry as it is:
    /// a pose whose meshes did not move needs nothing else (no copy of the meshes).
    pub fn place_lights_and_camera(&mut self, pose: Pose) {
        self.lights = pose.lights;
        self.camera = pose.camera;
        self.environment_rotation = pose.environment_rotation;
        if let (Environment::Sky { sun_direction, .. }, Some(sun)) =
            (&mut self.environment, pose.environment_sun)
        {
            *sun_direction = sun;
        }
    }

    /// Makes the clip named `name_or_index` (a clip name, else a clip index) the active one.
    pub fn select_animation(&mut self, name_or_index: &str) -> Result<(), SceneError> {
        let error = |message: String| SceneError::InvalidParameter { scene: self.name.clone(), message };
        let Some(anim) = self.animation.as_ref().filter(|a| !a.clips.is_empty()) else {
            return Err(error(format!("no animation '{name_or_index}': the scene has no animations")));
        };
        let wanted = name_or_index.trim();
        let found = anim
            .clips
            .iter()
            .position(|c| c.name == wanted)
            .or_else(|| wanted.parse::<usize>().ok().filter(|&i| i < anim.clips.len()));
        match found {
            Some(i) => {
                if let Some(anim) = self.animation.as_mut() {
                    anim.active = i;
                }
                Ok(())
            }
            None => {
                let available: Vec<String> =
                    anim.clips.iter().enumerate().map(|(i, c)| format!("{i} '{}'", c.name)).collect();
                Err(error(format!("no animation '{wanted}'; available: {}", available.join(", "))))
            }
        }
    }
}

impl Mesh {
    /// This mesh where the pose transform `m` puts it: as stored under the identity (no
    /// renormalisation), else [`Mesh::transformed`].
    pub fn posed(&self, m: Mat4) -> Mesh {
        if m == Mat4::IDENTITY { self.clone() } else { self.transformed(m) }
    }

    /// This mesh under the affine transform `m`: positions by `m`, normals by its inverse transpose,
    /// tangents by its linear part (all renormalised), winding and tangent handedness flipped when `m`
    /// mirrors.
    pub fn transformed(&self, m: Mat4) -> Mesh {
        let mut out = self.clone();
        super::transform_vertices(
            m,
            &mut out.positions,
            &mut out.normals,
            &mut out.tangents,
            &mut out.indices,
        );
        for n in &mut out.normals {
            *n = n.normalize_or(Vec3::Z);
        }
        for (t, n) in out.tangents.iter_mut().zip(&out.normals) {
            *t = t.truncate().normalize_or(n.any_orthonormal_vector()).extend(t.w);
        }
        out
    }
}

#[cfg(test)]
pub(crate) mod tests;
