//! [`AssetError`]: every failure of reading or writing an asset, each naming
//! the file concerned.

use std::path::PathBuf;

/// An error reading, verifying or writing a `.gibake` asset. Every variant
/// names the file (or directory) it concerns; `Display` gives one line a
/// user can act on.
#[derive(Debug, thiserror::Error)]
pub enum AssetError {
    /// The operating system refused an operation on `path`.
    #[error("{}: {source}", path.display())]
    Io {
        /// File or directory concerned.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file is damaged, truncated, not a gibake asset, fails its checksum,
    /// or holds inconsistent values (or, when writing, the in-memory asset is
    /// inconsistent).
    #[error("{}: {message}", path.display())]
    Invalid {
        /// File or directory concerned.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A valid asset this version cannot read (another major format version).
    #[error("{}: {message}", path.display())]
    NotSupported {
        /// File concerned (`manifest.bin`).
        path: PathBuf,
        /// What is not supported, naming both versions.
        message: String,
    },
    /// The asset was baked from a different static scene than the one it is
    /// used with.
    #[error(
        "{asset} was baked from a different static scene than {} (asset's static scene hash {asset_hash}, scene's {scene_hash}){hint}",
        scene.display()
    )]
    SceneMismatch {
        /// The asset (its directory, or a description from its manifest).
        asset: String,
        /// The scene file it is used with.
        scene: PathBuf,
        /// Static scene hash stored in the asset (hex, first 16 digits).
        asset_hash: String,
        /// Static scene hash of the scene (hex, first 16 digits).
        scene_hash: String,
        /// What to do, from `; `: re-bake, or load the scene with the scene
        /// options the asset records ([`crate::Manifest::scene_options`]),
        /// which it names.
        hint: String,
    },
    /// Writing the output failed (lock, temporary, swap).
    #[error(transparent)]
    Output(#[from] gibake_output::OutputError),
}

impl AssetError {
    pub(crate) fn invalid(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        AssetError::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }

    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        AssetError::Io {
            path: path.into(),
            source,
        }
    }

    /// The file or directory the error concerns (`None` for
    /// [`AssetError::SceneMismatch`], which names two).
    pub fn path(&self) -> Option<&std::path::Path> {
        match self {
            AssetError::Io { path, .. }
            | AssetError::Invalid { path, .. }
            | AssetError::NotSupported { path, .. } => Some(path),
            AssetError::Output(e) => Some(&e.path),
            AssetError::SceneMismatch { .. } => None,
        }
    }
}
