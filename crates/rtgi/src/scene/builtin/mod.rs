//! Procedural built-in scenes (no asset files), listed by `rtgi list`.
//!
//! Each scene is a function of its validated parameters; generation is deterministic (no RNG: where a
//! scene wants irregularity it hashes integers, see [`shapes::hash`]).

pub mod shapes;

use crate::error::SceneError;
use crate::params::{ParamSpec, ParamValues};
use crate::scene::Scene;

/// A built-in scene: its name, what it is for, its parameters, and its generator.
pub struct BuiltinScene {
    pub name: &'static str,
    pub description: &'static str,
    pub params: &'static [ParamSpec],
    pub build: fn(&ParamValues) -> Scene,
}

/// Every built-in scene, in the order `rtgi list` prints them.
pub fn list() -> &'static [BuiltinScene] {
    &[]
}

/// Builds the built-in scene `name` with `settings` (`key=value` pairs) applied over its defaults.
pub fn build(name: &str, settings: &[(String, String)]) -> Result<Scene, SceneError> {
    let entry = list().iter().find(|s| s.name == name).ok_or_else(|| SceneError::UnknownScene {
        name: name.to_string(),
        available: list().iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
    })?;
    let values = ParamValues::from_settings(name, entry.params, settings)
        .map_err(|message| SceneError::InvalidParameter { scene: name.to_string(), message })?;
    let scene = (entry.build)(&values);
    debug_assert!(scene.validate().is_ok(), "{:?}", scene.validate());
    Ok(scene)
}
