//! Primary-light shadow map (the bake's static map and the runtime's map of
//! moving objects): meshes drawn from the light's view
//! ([`crate::LightView`]), storing the projection's metric in an `R32Float`
//! texture (the depth buffer only orders fragments). Surfaces are
//! two-sided, so nothing is culled; alpha-masked materials cut holes (their
//! texture is bound as group 1 and tested with `alpha_keeps`).

use wgpu::util::DeviceExt;

use crate::mesh::{Draw, SceneGpu};
use crate::util::{
    cleared_attachments, cleared_depth, draws_and_uniform_group, mesh_pipeline, texture_2d,
};
use crate::{LightView, shaders};

/// Format of metric maps.
pub const METRIC_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// Format of the ordering depth buffer.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The shadow-map pass: pipeline, bind group, uniform, targets.
pub struct ShadowPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// The light view uniform (`GpuLightView`).
    pub uniform_buf: wgpu::Buffer,
    /// The metric map (`R32Float`, `size × size`).
    pub metric: wgpu::Texture,
    /// View of [`ShadowPass::metric`].
    pub metric_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    /// The light view this pass renders.
    pub view: LightView,
}

impl ShadowPass {
    /// Creates the pass for `view` over the meshes of `scene_gpu`.
    pub fn new(device: &wgpu::Device, scene_gpu: &SceneGpu, view: LightView) -> ShadowPass {
        let module = shaders::mesh_module(device, "shadow.wgsl", include_str!("shadow.wgsl"));
        let uniform_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("light view"),
            contents: bytemuck::bytes_of(&view.to_gpu()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let (layout, bind_group) =
            draws_and_uniform_group(device, "shadow", &scene_gpu.draw_data, &uniform_buf);
        let pipeline = mesh_pipeline(
            device,
            "shadow",
            &module,
            &[&layout, &scene_gpu.material_layout],
            &[Some(METRIC_FORMAT.into())],
            wgpu::CompareFunction::Greater,
        );
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let metric = texture_2d(
            device,
            "shadow metric",
            view.size,
            view.size,
            METRIC_FORMAT,
            usage,
        );
        let depth = texture_2d(
            device,
            "shadow depth",
            view.size,
            view.size,
            DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        ShadowPass {
            pipeline,
            bind_group,
            uniform_buf,
            metric_view: metric.create_view(&Default::default()),
            metric,
            depth_view: depth.create_view(&Default::default()),
            view,
        }
    }

    /// Points the pass at another view of the same size (its uniform is
    /// written through `queue`; the next [`ShadowPass::encode`] renders it).
    pub fn set_view(&mut self, queue: &wgpu::Queue, view: LightView) {
        debug_assert_eq!(view.size, self.view.size);
        queue.write_buffer(&self.uniform_buf, 0, bytemuck::bytes_of(&view.to_gpu()));
        self.view = view;
    }

    /// Records the pass: clears to "infinitely far" and draws `draws`.
    pub fn encode<'d>(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_gpu: &SceneGpu,
        draws: impl IntoIterator<Item = &'d Draw>,
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let far = wgpu::Color {
            r: f32::MAX as f64,
            g: 0.0,
            b: 0.0,
            a: 0.0,
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadow"),
            color_attachments: &cleared_attachments([(&self.metric_view, far)]),
            depth_stencil_attachment: Some(cleared_depth(&self.depth_view, 0.0)),
            timestamp_writes: ts,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        scene_gpu.draw(&mut pass, draws, true);
    }
}
