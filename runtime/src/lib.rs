//! gibake's game-facing runtime.
//!
//! A [`Renderer`] owns the GPU resources for one scene on the caller's
//! `wgpu::Device`: scene meshes, the camera G-buffer, the merged primary
//! shadow map and the shading pass. Each frame the caller moves the dynamic
//! objects ([`Renderer::set_time`] samples the scene's animation, or
//! [`Renderer::set_dynamic_transforms`] takes the game's own matrices),
//! records the frame with [`Renderer::encode`], and reads or samples
//! [`Renderer::output`] (linear radiance, `Rgba32Float`).
//!
//! Passes, in order: [`shadow::ShadowPass`] (primary shadow map of static +
//! moving geometry), [`gbuffer::GBufferPass`], [`shade::ShadePass`].

pub mod camera;
pub mod gbuffer;
pub mod shade;
pub mod shadow;

use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::{GpuContext, GpuError, GpuPrimaryLight, LightView};
use gibake_image::Image;
use gibake_scene::Scene;
use glam::Mat4;
use wgpu::util::DeviceExt;

pub use camera::{CameraMatrices, NoCamera};

/// What a frame contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Mode {
    /// Direct light from the primary light only.
    #[default]
    Direct,
}

/// Settings of a [`Renderer`].
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Resolution of the primary shadow map (square).
    pub shadow_map_size: u32,
    /// What to render.
    pub mode: Mode,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings { width: 640, height: 480, shadow_map_size: 2048, mode: Mode::Direct }
    }
}

/// Runtime errors.
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    /// The scene has no camera.
    #[error(transparent)]
    NoCamera(#[from] NoCamera),
    /// A GPU operation failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A bad setting (zero size, size over the device's limits, ...).
    #[error("invalid render setting: {0}")]
    InvalidSetting(String),
}

/// Renders frames of one scene.
pub struct Renderer {
    settings: RenderSettings,
    scene_gpu: SceneGpu,
    shadow: shadow::ShadowPass,
    gbuffer: gbuffer::GBuffer,
    gbuffer_pass: gbuffer::GBufferPass,
    shade: shade::ShadePass,
    output: wgpu::Texture,
    _light_buf: wgpu::Buffer,
    camera: CameraMatrices,
}

impl Renderer {
    /// Creates every GPU resource for `scene`, with moving objects at `time`.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        settings: &RenderSettings,
        time: f32,
    ) -> Result<Renderer, RuntimeError> {
        let limit = device.limits().max_texture_dimension_2d;
        for (what, v) in [("width", settings.width), ("height", settings.height), ("shadow map size", settings.shadow_map_size)] {
            if v == 0 || v > limit {
                return Err(RuntimeError::InvalidSetting(format!("{what} {v} must be in 1..={limit} on this device")));
            }
        }
        let camera = CameraMatrices::new(scene, time, settings.width, settings.height)?;
        let scene_gpu = SceneGpu::new(device, queue, scene, time);
        let view = LightView::new(&scene.light, &scene.full_bounds(), settings.shadow_map_size);
        let shadow = shadow::ShadowPass::new(device, &scene_gpu, view);
        let gbuffer = gbuffer::GBuffer::new(device, settings.width, settings.height);
        let gbuffer_pass = gbuffer::GBufferPass::new(device, &scene_gpu);
        let output = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("radiance"),
            size: wgpu::Extent3d { width: settings.width, height: settings.height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: shade::RADIANCE_FORMAT,
            usage: wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let light_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("primary light"),
            contents: bytemuck::bytes_of(&GpuPrimaryLight::new(&scene.light)),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let out_view = output.create_view(&Default::default());
        let flags = match settings.mode {
            Mode::Direct => shade::FLAG_DIRECT,
        };
        let shade = shade::ShadePass::new(
            device,
            &shade::ShadeInputs {
                gbuffer: &gbuffer,
                shadow_map: &shadow.metric_view,
                light: &light_buf,
                light_view: &shadow.uniform_buf,
                output: &out_view,
            },
            flags,
        );
        queue.write_buffer(&gbuffer_pass.uniform_buf, 0, bytemuck::bytes_of(&camera.to_gpu()));
        Ok(Renderer {
            settings: settings.clone(),
            scene_gpu,
            shadow,
            gbuffer,
            gbuffer_pass,
            shade,
            output,
            _light_buf: light_buf,
            camera,
        })
    }

    /// Moves the dynamic objects and the camera to the scene's animation at `time`.
    pub fn set_time(&mut self, queue: &wgpu::Queue, scene: &Scene, time: f32) -> Result<(), RuntimeError> {
        self.scene_gpu.update_dynamic(queue, scene, time);
        self.camera = CameraMatrices::new(scene, time, self.settings.width, self.settings.height)?;
        queue.write_buffer(&self.gbuffer_pass.uniform_buf, 0, bytemuck::bytes_of(&self.camera.to_gpu()));
        Ok(())
    }

    /// Sets the dynamic objects' world matrices (one per
    /// `Scene::dynamic_objects` entry), as a game would each frame.
    pub fn set_dynamic_transforms(&mut self, queue: &wgpu::Queue, transforms: &[Mat4]) {
        self.scene_gpu.set_dynamic_transforms(queue, transforms);
    }

    /// Sets the camera (world → clip matrix with reversed Z, eye, forward).
    pub fn set_camera(&mut self, queue: &wgpu::Queue, camera: CameraMatrices) {
        self.camera = camera;
        queue.write_buffer(&self.gbuffer_pass.uniform_buf, 0, bytemuck::bytes_of(&camera.to_gpu()));
    }

    /// Records one frame.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        let all = [&self.scene_gpu.static_draws[..], &self.scene_gpu.dynamic_draws[..]];
        self.shadow.encode(encoder, &self.scene_gpu, &all);
        self.gbuffer_pass.encode(encoder, &self.gbuffer, &self.scene_gpu, &all);
        self.shade.encode(encoder);
    }

    /// The frame's linear radiance (`Rgba32Float`, row 0 at the top).
    pub fn output(&self) -> &wgpu::Texture {
        &self.output
    }

    /// The primary light's view.
    pub fn light_view(&self) -> &LightView {
        &self.shadow.view
    }
}

/// Renders one frame at `time` on `ctx` and reads it back. `ssaa` renders at
/// `ssaa ×` the resolution and box-filters down (an unbiased pixel integral,
/// like the reference's jittered samples).
pub fn render_image(
    ctx: &GpuContext,
    scene: &Scene,
    settings: &RenderSettings,
    time: f32,
    ssaa: u32,
) -> Result<Image, RuntimeError> {
    let ssaa = ssaa.max(1);
    let mut hi = settings.clone();
    hi.width = settings.width * ssaa;
    hi.height = settings.height * ssaa;
    let renderer = Renderer::new(&ctx.device, &ctx.queue, scene, &hi, time)?;
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    renderer.encode(&mut enc);
    ctx.queue.submit([enc.finish()]);
    let data = gibake_gpu::readback::read_texture_f32(ctx, renderer.output(), 0, 4)?;
    let img = Image::from_rgba_f32(hi.width, hi.height, &data);
    Ok(gibake_image::box_downsample(&img, ssaa))
}
