//! Error types of the library, one per layer. The CLI maps them to one-line messages.

use std::path::PathBuf;

/// Errors while producing a [`crate::scene::Scene`].
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A problem with a scene file: the message names what is wrong.
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    #[error("unknown scene '{name}'; built-in scenes: {available}")]
    UnknownScene { name: String, available: String },
    #[error("scene '{scene}': {message}")]
    InvalidParameter { scene: String, message: String },
}

impl SceneError {
    pub fn file(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        SceneError::File { path: path.into(), message: message.into() }
    }
}
