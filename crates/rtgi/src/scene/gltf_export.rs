//! Writing a scene as glTF 2.0 binary (.glb).
//!
//! PLACEHOLDER from branch `cli`: this stub only lets the CLI compile against the exporter's signature.
//! The real exporter from branch `gltf` replaces this whole file on merge.

use std::path::Path;

use crate::error::SceneError;
use crate::scene::Scene;

/// Placeholder: always fails (see the module documentation).
pub fn export(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let _ = scene;
    Err(SceneError::file(path, "glTF support is not merged yet"))
}
