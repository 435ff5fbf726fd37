//! glTF → [`Scene`].

use std::path::Path;

use crate::{Scene, SceneError};

/// Options for [`load`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Pick the primary light by name when the file has several candidates.
    pub light: Option<String>,
}

/// Loads a `.gltf` (with its external buffers/images) or `.glb` file.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let _ = (path, options);
    todo!()
}

/// Loads a glTF held in memory. `path` is used for messages and to resolve
/// relative URIs of external buffers and images.
pub fn load_from_slice(bytes: &[u8], path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let _ = (bytes, path, options);
    todo!()
}
