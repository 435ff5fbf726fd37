//! The runtime's errors: none of them is a panic.

use crate::{AssetError, GpuError, NoCamera, ObjectHandle, OptionsConflict, SceneError, ViewId};

/// Runtime errors. None of them is a panic; the messages name no command
/// line (a tool adds its own wording).
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    /// The scene has no camera (only [`crate::CameraMatrices::from_scene`]
    /// and [`crate::Renderer::prepare_at_time`] need one).
    #[error(transparent)]
    NoCamera(#[from] NoCamera),
    /// A GPU operation failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The asset does not fit the scene.
    #[error(transparent)]
    Asset(#[from] AssetError),
    /// The scene file cannot be loaded ([`crate::load_scene_for`]).
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// Scene options given for loading a level differ from the ones its
    /// asset was baked with ([`crate::load_scene_for`]).
    #[error(transparent)]
    SceneOptions(#[from] OptionsConflict),
    /// A bad setting (zero size, unknown interleave factor, ...).
    #[error("invalid render setting: {0}")]
    InvalidSetting(String),
    /// Something would exceed a limit of the caller's device.
    #[error("{what} needs {needed}; this device allows {limit}")]
    DeviceLimit {
        /// What was to be created.
        what: String,
        /// The size it needs (texels, bytes).
        needed: u64,
        /// The device's limit.
        limit: u64,
    },
    /// The mode needs a baked asset.
    #[error("mode `{0}` needs a baked asset")]
    NeedsAsset(&'static str),
    /// A frame's transform list does not have one matrix per moving object.
    #[error("{got} transforms given for {expected} moving objects")]
    TransformCount {
        /// Moving objects of the scene.
        expected: usize,
        /// Transforms given.
        got: usize,
    },
    /// [`crate::Renderer::spawn`] past [`crate::RenderSettings::max_spawned`].
    #[error("no room to spawn another moving object ({max} spawned at most; raise max_spawned)")]
    TooManyObjects {
        /// The settings' `max_spawned`.
        max: u32,
    },
    /// A handle that is not one of this renderer's moving objects.
    #[error("{0:?} is not a moving object of this renderer")]
    UnknownObject(ObjectHandle),
    /// A view that is not one of this renderer's.
    #[error("{0:?} is not a view of this renderer")]
    UnknownView(ViewId),
    /// A caller-provided output texture does not fit.
    #[error("output target: {0}")]
    OutputTarget(String),
}
