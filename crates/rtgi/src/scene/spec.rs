//! A scene named as on rtgi's command line (`--scene`) and in bench suites: a built-in scene with
//! optional parameters (`NAME:key=value,...`), or a glTF file.

use std::path::PathBuf;

use super::{Scene, builtin, gltf_load};
use crate::error::SceneError;
use crate::params::{ParamValues, parse_setting};

/// What `--scene` names.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneSpec {
    /// A `.gltf` or `.glb` file.
    File(PathBuf),
    /// `NAME` or `NAME:key=value,key=value`.
    Builtin { name: String, settings: Vec<(String, String)> },
}

fn is_gltf_path(text: &str) -> bool {
    let lower = text.to_ascii_lowercase();
    lower.ends_with(".gltf") || lower.ends_with(".glb")
}

impl SceneSpec {
    /// Parses the syntax only; errors start with the quoted text so callers can prefix the flag.
    pub fn parse(text: &str) -> Result<SceneSpec, String> {
        let text = text.trim();
        if text.is_empty() {
            return Err(
                "'' is empty; give a built-in scene name (see `rtgi list`) or a .gltf/.glb file".into()
            );
        }
        // The extension test comes first so that paths with colons (C:\scenes\a.glb) stay paths.
        if is_gltf_path(text) {
            return Ok(SceneSpec::File(PathBuf::from(text)));
        }
        let (name, params) = text.split_once(':').unwrap_or((text, ""));
        let name = name.trim();
        if is_gltf_path(name) {
            return Err(format!("'{text}': parameters after ':' apply only to built-in scenes"));
        }
        if name.contains(['/', '\\', '.']) {
            return Err(format!(
                "'{text}' is not a built-in scene name, and scene files must be .gltf or .glb"
            ));
        }
        let settings = params
            .split(',')
            .filter(|p| !p.trim().is_empty())
            .map(|p| parse_setting(p).map_err(|e| format!("'{text}': {e}")))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SceneSpec::Builtin { name: name.to_string(), settings })
    }

    /// Checks a built-in scene's name and parameters without building it, so that mistakes are reported
    /// before slow work (loading, GPU start-up). Files are only checked when loaded.
    pub fn validate(&self) -> Result<(), SceneError> {
        let SceneSpec::Builtin { name, settings } = self else { return Ok(()) };
        let entry =
            builtin::list().iter().find(|s| s.name == name).ok_or_else(|| SceneError::UnknownScene {
                name: name.clone(),
                available: builtin::list().iter().map(|s| s.name).collect::<Vec<_>>().join(", "),
            })?;
        ParamValues::from_settings(name, entry.params, settings)
            .map(|_| ())
            .map_err(|message| SceneError::InvalidParameter { scene: name.clone(), message })
    }

    pub fn load(&self) -> Result<Scene, SceneError> {
        match self {
            SceneSpec::File(path) => gltf_load::load(path),
            SceneSpec::Builtin { name, settings } => builtin::build(name, settings),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn builtin(name: &str, settings: &[(&str, &str)]) -> SceneSpec {
        SceneSpec::Builtin {
            name: name.into(),
            settings: settings.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect(),
        }
    }

    #[test]
    fn parses_names_parameters_and_files() {
        assert_eq!(SceneSpec::parse("cornell"), Ok(builtin("cornell", &[])));
        assert_eq!(SceneSpec::parse("atrium:"), Ok(builtin("atrium", &[])));
        assert_eq!(
            SceneSpec::parse("atrium:detail=3, lights = 2"),
            Ok(builtin("atrium", &[("detail", "3"), ("lights", "2")]))
        );
        assert_eq!(SceneSpec::parse("a/b.GLB"), Ok(SceneSpec::File("a/b.GLB".into())));
        assert_eq!(SceneSpec::parse(r"C:\s\a.gltf"), Ok(SceneSpec::File(r"C:\s\a.gltf".into())));
    }

    #[test]
    fn rejects_malformed_specs() {
        for (text, needle) in [
            ("", "empty"),
            ("atrium:detail", "key=value"),
            ("a.glb:x=1", "only to built-in"),
            ("model.obj", ".gltf or .glb"),
        ] {
            let e = SceneSpec::parse(text).unwrap_err();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }
}
