//! Techniques: each folder holds one technique (or family), its host code and its WGSL side by side.
//!
//! Adding a technique touches its own folder plus one line in [`registry`].

use crate::params::{ParamSpec, ParamValues};

/// A registered technique: what `rtgi list` prints and how to instantiate it.
pub struct TechniqueInfo {
    pub name: &'static str,
    pub description: &'static str,
    pub params: &'static [ParamSpec],
}

/// Every technique, in the order `rtgi list` prints them.
pub fn registry() -> &'static [TechniqueInfo] {
    &[]
}

/// Finds a technique and validates `settings` against its parameters.
pub fn resolve(
    name: &str,
    settings: &[(String, String)],
) -> Result<(&'static TechniqueInfo, ParamValues), String> {
    let info = registry().iter().find(|t| t.name == name).ok_or_else(|| {
        format!(
            "unknown technique '{name}'; techniques: {}",
            registry().iter().map(|t| t.name).collect::<Vec<_>>().join(", ")
        )
    })?;
    let values = ParamValues::from_settings(name, info.params, settings)?;
    Ok((info, values))
}
