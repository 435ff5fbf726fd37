//! `gibake view`: the runtime ([`gibake_runtime::Renderer`]) in a window of
//! its own (winit), as a game would use it and nothing more.
//!
//! - Fly with W A S D (Q/E down/up, Shift faster) and the mouse (right
//!   button held, or C to capture it); R goes back to the scene's camera.
//! - Space or P plays/pauses the scene's animation.
//! - 1–5: mode full / direct / indirect / rsm / naive; I cycles the
//!   interleave 1, 2, 4, 8. X re-measures the automatic exposure.
//! - The window's title shows the mode and the per-pass GPU times
//!   ([`gibake_runtime::Renderer::poll_stats`], never waiting).
//! - Hot reload: the asset's manifest is polled once a second ([`watch`]);
//!   a re-baked asset replaces the old one with
//!   [`gibake_runtime::Renderer::set_asset`] (a failed load keeps the old
//!   one, with a warning). One re-baked with other scene options (another
//!   `--sun`, other moving props) comes with the level loaded again with
//!   them ([`Reimport`]).
//! - Headless ([`ViewOptions::frames`]): N frames are rendered and
//!   presented to a real window and the last one is returned
//!   ([`Screenshot`]) for the caller to write; frame `f` is at
//!   `time + f / fps`, as `gibake render --frames` renders it.
//!
//! [`gpu_report`] says, without a window, whether the adapter can run a
//! level.

mod app;
mod error;
pub mod fly;
mod gpu;
mod level;
pub mod present;
pub mod watch;

use std::path::PathBuf;

pub use error::ViewerError;
pub use gpu::GpuReport;
pub use level::Reimport;

use gibake_runtime::{Asset, RenderSettings, Requirements, Scene};

/// What to show and how.
pub struct ViewOptions {
    /// The scene (loaded by the caller, with its level flags and the
    /// asset's recorded scene options).
    pub scene: Scene,
    /// How the scene was loaded, to load it again for a hot-reloaded asset
    /// baked with other scene options (`None`: never loaded again; such an
    /// asset is then refused).
    pub reimport: Option<Reimport>,
    /// The baked asset (`None`: only `direct` mode can be shown).
    pub asset: Option<Asset>,
    /// Where the asset lives (watched for hot reload).
    pub asset_dir: Option<PathBuf>,
    /// Decoded-size budget of a reloaded asset
    /// (`gibake_asset::load_with_limit`).
    pub max_decoded_bytes: u64,
    /// The renderer's settings; `width × height` is the window's first
    /// size (and the size of every headless frame).
    pub settings: RenderSettings,
    /// Animation time of the first frame, seconds.
    pub time: f32,
    /// Headless frames are `1 / fps` apart.
    pub fps: f32,
    /// Exposure of the tone curve; `None`: the first frame's automatic one
    /// (`gibake_image::Image::auto_exposure`), as `gibake render` does.
    pub exposure: Option<f32>,
    /// Headless: render this many frames, then stop and return the last.
    pub frames: Option<u32>,
    /// Adapter name (substring); default `GIBAKE_ADAPTER` or the first
    /// real GPU that can present to the window.
    pub adapter: Option<String>,
}

/// The last frame of a headless run.
pub struct Screenshot {
    /// Linear radiance, as the runtime rendered it.
    pub image: gibake_runtime::Image,
    /// The exposure the window used for it.
    pub exposure: f32,
    /// The adapter it was rendered on.
    pub adapter: gibake_gpu::AdapterRecord,
    /// What the window showed: the surface texture's pixels after the
    /// present pass, 8-bit sRGB RGB rows top to bottom, with its width and
    /// height; `None` when the surface does not allow copies from it.
    pub presented: Option<(u32, u32, Vec<u8>)>,
}

/// Opens the window and runs until it is closed (or, headless, until the
/// frames are done: then the last one is returned).
pub fn run(options: ViewOptions) -> Result<Option<Screenshot>, ViewerError> {
    app::run(options)
}

/// The `--gpu-report`: the adapter the viewer would use (no window needed),
/// the limits the level needs against the adapter's, the GPU memory.
pub fn gpu_report(
    scene: &Scene,
    asset: Option<&Asset>,
    settings: &RenderSettings,
    adapter: Option<&str>,
) -> Result<GpuReport, ViewerError> {
    let needs = Requirements::of(scene, asset, settings)?;
    gpu::report(&needs, adapter)
}
