//! Camera G-buffer of all geometry: world position, shading and geometric
//! normals (octahedral, facing the viewer), albedo. 32 bytes per pixel.

use gibake_gpu::mesh::{Draw, GpuVertex, MESH_WGSL, SceneGpu};
use gibake_gpu::shaders;
use wgpu::util::DeviceExt;

use crate::camera::GpuCamera;

/// G-buffer target formats, in location order.
pub const GBUFFER_FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba16Float,
    wgpu::TextureFormat::Rgba16Float,
];

/// The G-buffer textures.
pub struct GBuffer {
    /// Textures in [`GBUFFER_FORMATS`] order.
    pub textures: Vec<wgpu::Texture>,
    /// Their views.
    pub views: Vec<wgpu::TextureView>,
    depth_view: wgpu::TextureView,
    /// Size in pixels.
    pub width: u32,
    /// Size in pixels.
    pub height: u32,
}

impl GBuffer {
    /// Allocates a `width × height` G-buffer.
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> GBuffer {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let make = |format, label| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        let textures: Vec<_> = GBUFFER_FORMATS
            .iter()
            .zip(["gbuffer position", "gbuffer normals", "gbuffer albedo"])
            .map(|(f, l)| make(*f, l))
            .collect();
        let views = textures
            .iter()
            .map(|t| t.create_view(&Default::default()))
            .collect();
        let depth = make(gibake_gpu::passes::shadow::DEPTH_FORMAT, "gbuffer depth");
        GBuffer {
            textures,
            views,
            depth_view: depth.create_view(&Default::default()),
            width,
            height,
        }
    }
}

/// The G-buffer pass: pipeline, bind group, camera uniform.
pub struct GBufferPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// Camera uniform (`GpuCamera`).
    pub uniform_buf: wgpu::Buffer,
}

impl GBufferPass {
    /// Creates the pass for the meshes of `scene_gpu`.
    pub fn new(device: &wgpu::Device, scene_gpu: &SceneGpu) -> GBufferPass {
        let src = format!("{MESH_WGSL}\n{}", include_str!("gbuffer.wgsl"));
        let module = shaders::module(device, "gbuffer.wgsl", &src);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gbuffer"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
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
            label: Some("camera"),
            contents: bytemuck::bytes_of(&<GpuCamera as bytemuck::Zeroable>::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gbuffer"),
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
            label: Some("gbuffer"),
            bind_group_layouts: &[Some(&layout), Some(&scene_gpu.material_layout)],
            immediate_size: 0,
        });
        let targets: Vec<Option<wgpu::ColorTargetState>> =
            GBUFFER_FORMATS.iter().map(|f| Some((*f).into())).collect();
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("gbuffer"),
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
                format: gibake_gpu::passes::shadow::DEPTH_FORMAT,
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
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        });
        GBufferPass {
            pipeline,
            bind_group,
            uniform_buf,
        }
    }

    /// Records the pass into `target`.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &GBuffer,
        scene_gpu: &SceneGpu,
        draws: &[&[Draw]],
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let attachments: Vec<Option<wgpu::RenderPassColorAttachment>> = target
            .views
            .iter()
            .map(|v| {
                Some(wgpu::RenderPassColorAttachment {
                    view: v,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })
            })
            .collect();
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("gbuffer"),
            color_attachments: &attachments,
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &target.depth_view,
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
            scene_gpu.draw(&mut pass, d, true);
        }
    }
}
