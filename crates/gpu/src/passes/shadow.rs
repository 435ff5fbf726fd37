//! Primary-light shadow map (the bake's static map and the runtime's merged
//! one): every mesh drawn from the light's view
//! ([`gibake_gpu::LightView`]), storing the projection's metric in an
//! `R32Float` texture (the depth buffer only orders fragments). Surfaces are
//! two-sided, so nothing is culled.

use crate::mesh::{Draw, GpuVertex, MESH_WGSL, SceneGpu};
use crate::{LightView, shaders};
use wgpu::util::DeviceExt;

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
        let src = format!("{MESH_WGSL}\n{}", include_str!("shadow.wgsl"));
        let module = shaders::module(device, "shadow.wgsl", &src);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let uniform_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("light view"),
            contents: bytemuck::bytes_of(&view.to_gpu()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow"),
            layout: &layout,
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
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow"),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(GpuVertex::LAYOUT)],
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(METRIC_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let size = wgpu::Extent3d {
            width: view.size,
            height: view.size,
            depth_or_array_layers: 1,
        };
        let metric = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadow metric"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: METRIC_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let depth = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadow depth"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
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

    /// Records the pass: clears to "infinitely far" and draws `draws`.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_gpu: &SceneGpu,
        draws: &[&[Draw]],
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadow"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.metric_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: f32::MAX as f64,
                        g: 0.0,
                        b: 0.0,
                        a: 0.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(0.0),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: ts,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        for d in draws {
            scene_gpu.draw(&mut pass, d, false);
        }
    }
}
