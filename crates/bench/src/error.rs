//! The benchmarks' error: what failed, with its cause kept as the source.

use std::path::PathBuf;

/// Why a benchmark could not run or finish.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A bad option or a result that makes no sense (non-finite pixels, a
    /// bake that was not skipped, ...).
    #[error("{0}")]
    Invalid(String),
    /// A file could not be written.
    #[error("{}: {what}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done.
        what: &'static str,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A GPU operation failed.
    #[error(transparent)]
    Gpu(#[from] gibake_gpu::GpuError),
    /// A scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] gibake_scene::SceneError),
    /// A bake failed.
    #[error(transparent)]
    Bake(#[from] gibake_bake::BakeError),
    /// An asset could not be written or read.
    #[error(transparent)]
    Asset(#[from] gibake_asset::AssetError),
    /// The runtime refused a setting or failed.
    #[error(transparent)]
    Runtime(#[from] gibake_runtime::RuntimeError),
    /// The CPU reference failed.
    #[error(transparent)]
    Reference(#[from] gibake_reference::ReferenceError),
    /// The judge failed.
    #[error(transparent)]
    Eval(#[from] gibake_eval::EvalError),
    /// An image could not be written.
    #[error(transparent)]
    Image(#[from] gibake_image::ImageError),
    /// A file operation failed (wrapped in [`BenchError::Context`] naming the file).
    #[error(transparent)]
    StdIo(#[from] std::io::Error),
    /// FLIP could not be computed.
    #[error(transparent)]
    Flip(#[from] gibake_eval::flip::FlipError),
    /// JSON could not be encoded.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A step failed; `what` says which.
    #[error("{what}: {source}")]
    Context {
        /// The step.
        what: String,
        /// The cause.
        #[source]
        source: Box<BenchError>,
    },
}

/// `Result` with [`BenchError`].
pub type Result<T, E = BenchError> = std::result::Result<T, E>;

/// Names the step that failed (as `anyhow::Context` does, typed).
pub(crate) trait Context<T> {
    /// Wraps the error with the text `f` makes.
    fn with_context(self, f: impl FnOnce() -> String) -> Result<T>;
}

impl<T, E: Into<BenchError>> Context<T> for std::result::Result<T, E> {
    fn with_context(self, f: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| BenchError::Context {
            what: f(),
            source: Box::new(e.into()),
        })
    }
}

/// Returns [`BenchError::Invalid`] with a formatted message.
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::error::BenchError::Invalid(format!($($arg)*)))
    };
}
pub(crate) use bail;
