//! Deferred shading pass (compute): reads the G-buffer and the merged
//! primary shadow map, writes linear radiance (`Rgba32Float`).

use gibake_gpu::shaders;
use wgpu::util::DeviceExt;

use crate::gbuffer::GBuffer;

/// Output format of shading.
pub const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// Must match `ShadeParams` in `shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuShadeParams {
    /// Output size.
    pub size: [u32; 2],
    /// Bit 0: direct.
    pub flags: u32,
    /// Padding.
    pub pad: u32,
}

/// Flag bit: add direct light.
pub const FLAG_DIRECT: u32 = 1;

/// The shading pass: pipeline, bind group, uniforms.
pub struct ShadePass {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// `GpuShadeParams` uniform.
    pub uniform_buf: wgpu::Buffer,
    size: [u32; 2],
}

fn tex_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

/// Inputs of [`ShadePass::new`].
pub struct ShadeInputs<'a> {
    /// The camera G-buffer.
    pub gbuffer: &'a GBuffer,
    /// Merged primary shadow map (metric).
    pub shadow_map: &'a wgpu::TextureView,
    /// `GpuPrimaryLight` uniform.
    pub light: &'a wgpu::Buffer,
    /// `GpuLightView` uniform of the shadow map.
    pub light_view: &'a wgpu::Buffer,
    /// Output radiance view (`Rgba32Float`, storage binding).
    pub output: &'a wgpu::TextureView,
}

impl ShadePass {
    /// Creates the pass.
    pub fn new(device: &wgpu::Device, inputs: &ShadeInputs<'_>, flags: u32) -> ShadePass {
        let module = shaders::module(device, "shade.wgsl", include_str!("shade.wgsl"));
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shade"),
            entries: &[
                tex_entry(0),
                tex_entry(1),
                tex_entry(2),
                tex_entry(3),
                uniform_entry(4),
                uniform_entry(5),
                uniform_entry(6),
                wgpu::BindGroupLayoutEntry {
                    binding: 7,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: RADIANCE_FORMAT,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
            ],
        });
        let size = [inputs.gbuffer.width, inputs.gbuffer.height];
        let uniform_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("shade params"),
            contents: bytemuck::bytes_of(&GpuShadeParams { size, flags, pad: 0 }),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let g = &inputs.gbuffer.views;
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&g[0]) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&g[1]) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&g[2]) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(inputs.shadow_map) },
                wgpu::BindGroupEntry { binding: 4, resource: inputs.light.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: inputs.light_view.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 6, resource: uniform_buf.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(inputs.output) },
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shade"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("shade"),
            layout: Some(&pl),
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        ShadePass { pipeline, bind_group, uniform_buf, size }
    }

    /// Records the pass.
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("shade"), timestamp_writes: None });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(self.size[0].div_ceil(8), self.size[1].div_ceil(8), 1);
    }
}
