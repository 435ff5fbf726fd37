//! Scene import errors. Every variant names the file; none is a panic.

use std::path::PathBuf;

/// Why a scene could not be loaded. All of these are bad input (exit code 2).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        #[source]
        source: std::io::Error,
    },
    /// The glTF could not be parsed or failed glTF validation.
    #[cfg(feature = "gltf")]
    #[error("{path}: not a valid glTF 2.0 file: {source}")]
    Gltf {
        /// The file.
        path: PathBuf,
        /// The parser's error.
        #[source]
        source: gltf::Error,
    },
    /// The file is valid glTF but breaks one of gibake's conventions, or its
    /// data is unusable (non-finite vertices, indices out of range, ...).
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the node/mesh/accessor.
        message: String,
    },
    /// The file uses something gibake does not support in a way that cannot
    /// be skipped (e.g. only point lights).
    #[error("{path}: not supported: {message}")]
    NotSupported {
        /// The file.
        path: PathBuf,
        /// What is not supported.
        message: String,
    },
}
