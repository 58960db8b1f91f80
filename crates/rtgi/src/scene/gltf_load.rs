//! glTF 2.0 loading.
//!
//! PLACEHOLDER from branch `cli`: this stub only lets the CLI compile against the loader's signature.
//! The real loader from branch `gltf` replaces this whole file on merge.

use std::path::Path;

use crate::error::SceneError;
use crate::scene::Scene;

/// Placeholder: always fails (see the module documentation).
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    Err(SceneError::file(path, "glTF support is not merged yet"))
}
