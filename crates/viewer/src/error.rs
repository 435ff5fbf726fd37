//! The viewer's errors: one enum, each naming what failed (the display, the
//! adapter, the asset's directory) and keeping wgpu's or winit's error as
//! its source.

use std::path::PathBuf;

/// Why the viewer could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    /// Neither a Wayland nor an X11 display is named in the environment.
    #[error(
        "no display to open a window on: neither WAYLAND_DISPLAY nor DISPLAY is set \
         (run inside a desktop session, or under a virtual X server: `xvfb-run gibake view …`; \
         `--gpu-report` needs no display)"
    )]
    NoDisplay,
    /// The display is named but cannot be reached.
    #[error("cannot open a window on the display ({display}): {source}")]
    EventLoop {
        /// `DISPLAY` / `WAYLAND_DISPLAY` as found.
        display: String,
        /// winit's error.
        #[source]
        source: winit::error::EventLoopError,
    },
    /// The window system refused the window.
    #[error("cannot create the window: {0}")]
    Window(#[source] winit::error::OsError),
    /// wgpu cannot make a surface of the window.
    #[error("cannot create a GPU surface for the window: {0}")]
    Surface(#[source] wgpu::CreateSurfaceError),
    /// No adapter at all, or none matching `--adapter`.
    #[error(transparent)]
    Gpu(#[from] gibake_gpu::GpuError),
    /// Adapters exist, but none can present to the window.
    #[error("no GPU adapter can present to this window (found: {0})")]
    NoPresentAdapter(String),
    /// The surface offers no 8-bit colour format the viewer can write.
    #[error("the window's surface on {0} offers no usable colour format")]
    SurfaceFormat(String),
    /// The adapter refused to create a device.
    #[error("cannot create a device on {adapter}: {source}")]
    Device {
        /// Adapter name.
        adapter: String,
        /// wgpu's error.
        #[source]
        source: wgpu::RequestDeviceError,
    },
    /// The adapter lacks a limit the level needs.
    #[error("{adapter} cannot run this level: {source}")]
    Unsupported {
        /// Adapter name.
        adapter: String,
        /// The runtime's check.
        #[source]
        source: Box<gibake_runtime::RuntimeError>,
    },
    /// The runtime refused the scene, the asset or a frame.
    #[error(transparent)]
    Runtime(Box<gibake_runtime::RuntimeError>),
    /// The scene has no camera and no bounds to place one at.
    #[error("{0}: the scene has no camera and no geometry to place one at")]
    NoCamera(PathBuf),
    /// The surface was lost for good, or acquiring a frame failed.
    #[error("the window's surface failed: {0}")]
    SurfaceLost(String),
}

impl From<gibake_runtime::RuntimeError> for ViewerError {
    fn from(e: gibake_runtime::RuntimeError) -> Self {
        ViewerError::Runtime(Box::new(e))
    }
}
