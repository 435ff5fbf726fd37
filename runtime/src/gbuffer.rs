//! Camera G-buffer of all geometry: world position, shading and geometric
//! normals (octahedral, facing the viewer), albedo. 32 bytes per pixel.
//! One pipeline ([`GBufferPass`]) serves every view; each view has its own
//! targets ([`GBuffer`]) and camera ([`Camera`]).

use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_gpu::shaders;
use gibake_gpu::util::{
    cleared_attachments, cleared_depth, draws_and_uniform_group, mesh_pipeline, texture_2d,
};
use wgpu::util::DeviceExt;

use crate::camera::GpuCamera;

/// G-buffer target formats, in location order.
pub const GBUFFER_FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba16Float,
    wgpu::TextureFormat::Rgba16Float,
];

/// The G-buffer textures.
pub(crate) struct GBuffer {
    /// Textures in [`GBUFFER_FORMATS`] order.
    pub textures: Vec<wgpu::Texture>,
    /// Their views.
    pub views: [wgpu::TextureView; 3],
    /// The depth buffer (`Depth32Float`, reversed Z, `TEXTURE_BINDING`).
    pub depth: wgpu::Texture,
    depth_view: wgpu::TextureView,
}

impl GBuffer {
    /// Allocates a `width × height` G-buffer.
    pub(crate) fn new(device: &wgpu::Device, width: u32, height: u32) -> GBuffer {
        // Storage: rebuilt from the engine's depth instead (gbuffer_depth.rs).
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let textures: Vec<_> = GBUFFER_FORMATS
            .iter()
            .zip(["gbuffer position", "gbuffer normals", "gbuffer albedo"])
            .map(|(f, l)| texture_2d(device, l, width, height, *f, usage))
            .collect();
        let views = [0, 1, 2].map(|i: usize| textures[i].create_view(&Default::default()));
        let depth = texture_2d(
            device,
            "gbuffer depth",
            width,
            height,
            gibake_gpu::passes::shadow::DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        GBuffer {
            textures,
            views,
            depth_view: depth.create_view(&Default::default()),
            depth,
        }
    }
}

/// A view's camera: its uniform and the pass's group 0 over it.
pub(crate) struct Camera {
    /// `GpuCamera` uniform.
    pub uniform_buf: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

/// The G-buffer pass: pipeline and layout, shared by every view.
pub(crate) struct GBufferPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl GBufferPass {
    /// Creates the pass for the meshes of `scene_gpu`.
    pub(crate) fn new(device: &wgpu::Device, scene_gpu: &SceneGpu) -> GBufferPass {
        let module = shaders::mesh_module(device, "gbuffer.wgsl", include_str!("gbuffer.wgsl"));
        let probe = zeroed_camera(device);
        let (layout, _) = draws_and_uniform_group(device, "gbuffer", &scene_gpu.draw_data, &probe);
        let targets: Vec<Option<wgpu::ColorTargetState>> =
            GBUFFER_FORMATS.iter().map(|f| Some((*f).into())).collect();
        let pipeline = mesh_pipeline(
            device,
            "gbuffer",
            &module,
            &[&layout, &scene_gpu.material_layout],
            &targets,
            wgpu::CompareFunction::Greater,
        );
        GBufferPass { pipeline, layout }
    }

    /// A camera for one view.
    pub(crate) fn camera(&self, device: &wgpu::Device, scene_gpu: &SceneGpu) -> Camera {
        let uniform_buf = zeroed_camera(device);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gbuffer"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: scene_gpu.draw_data.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: uniform_buf.as_entire_binding(),
                },
            ],
        });
        Camera {
            uniform_buf,
            bind_group,
        }
    }

    /// Records the pass into `target`, seen by `camera`.
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &GBuffer,
        camera: &Camera,
        scene_gpu: &SceneGpu,
        draws: &[&[Draw]],
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("gbuffer"),
            color_attachments: &cleared_attachments(
                target.views.iter().map(|v| (v, wgpu::Color::TRANSPARENT)),
            ),
            depth_stencil_attachment: Some(cleared_depth(&target.depth_view, 0.0)),
            timestamp_writes: ts,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &camera.bind_group, &[]);
        for d in draws {
            scene_gpu.draw(&mut pass, d.iter(), true);
        }
    }
}

fn zeroed_camera(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("camera"),
        contents: bytemuck::bytes_of(&<GpuCamera as bytemuck::Zeroable>::zeroed()),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    })
}
