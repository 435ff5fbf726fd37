//! Tool helpers around the runtime (kept out of the game's crate): render
//! one frame of a scene's own animation and camera and read it back, or
//! read back what a [`Renderer`] rendered. Used by `gibake render`, the
//! benchmarks, this crate's judge and the tests.

use gibake_asset::Asset;
use gibake_image::Image;
use gibake_runtime::{CameraMatrices, RenderSettings, Renderer, RuntimeError};
use gibake_scene::Scene;

/// Reads `renderer`'s output back (waits for the GPU), box-filtered by
/// `ssaa` (1: as rendered).
pub fn read_output(
    renderer: &Renderer,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    ssaa: u32,
) -> Result<Image, RuntimeError> {
    let out = renderer.output();
    let data = gibake_gpu::readback::read_texture_f32_on(device, queue, out, 0, 4)?;
    let img = Image::from_rgba_f32(out.width(), out.height(), &data);
    Ok(gibake_image::box_downsample(&img, ssaa.max(1)))
}

/// Renders one frame of `scene`'s animation at `time`, seen by its camera,
/// and reads it back. `ssaa` renders at `ssaa ×` the resolution and
/// box-filters down (an unbiased pixel integral, like the reference's
/// jittered samples).
pub fn render_image(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    asset: Option<&Asset>,
    settings: &RenderSettings,
    time: f32,
    ssaa: u32,
) -> Result<Image, RuntimeError> {
    let ssaa = ssaa.max(1);
    let mut hi = settings.clone();
    hi.width = settings.width * ssaa;
    hi.height = settings.height * ssaa;
    // The camera first: no GPU work for a scene without one.
    CameraMatrices::from_scene(scene, time, hi.width, hi.height)?;
    let mut renderer = Renderer::new(device, queue, scene, asset, &hi)?;
    renderer.prepare_at_time(device, queue, scene, time)?;
    let mut enc = device.create_command_encoder(&Default::default());
    renderer.record(&mut enc);
    queue.submit([enc.finish()]);
    read_output(&renderer, device, queue, ssaa)
}
