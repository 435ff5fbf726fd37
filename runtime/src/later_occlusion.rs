//! The later bounces' VPLs under moving objects that cover the lights
//! (`later_occlusion.wgsl`): after the frame's occlusion passes, each later
//! VPL (format 4.6) gets the flux-weighted mean of the first bounce's
//! occluded shares, so that a light a moving object covers darkens the
//! later bounces as it darkens the first. Only built when the asset has
//! later VPLs and the scene has the occlusion pass.

use gibake_gpu::shaders;
use wgpu::util::DeviceExt;

/// The pass's WGSL.
pub(crate) const LATER_OCCLUSION_WGSL: &str = include_str!("later_occlusion.wgsl");

/// `LaterParams` in `later_occlusion.wgsl` (must match).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuLaterParams {
    first_later: u32,
    n_static: u32,
    _pad: [u32; 2],
}

/// The pass: its pipeline and its one bind group.
pub(crate) struct LaterOcclusionPass {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    _weight: wgpu::Buffer,
    _params: wgpu::Buffer,
}

impl LaterOcclusionPass {
    /// For static VPLs of flux `fluxes` (linear RGB, every static VPL in
    /// order, the last `later` the later bounces') and the occluded sums
    /// `occluded`; `None` without later VPLs or without a first bounce.
    pub(crate) fn new(
        device: &wgpu::Device,
        fluxes: &[[f32; 3]],
        later: u32,
        occluded: &wgpu::Buffer,
    ) -> Option<LaterOcclusionPass> {
        let n = fluxes.len() as u32;
        let first_later = n.checked_sub(later)?;
        if later == 0 || first_later == 0 {
            return None;
        }
        let weight: Vec<f32> = fluxes[..first_later as usize]
            .iter()
            .map(|f| (0.2126 * f[0] + 0.7152 * f[1] + 0.0722 * f[2]).max(0.0))
            .collect();
        let weight_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("later occlusion weights"),
            contents: bytemuck::cast_slice(&weight),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("later occlusion params"),
            contents: bytemuck::bytes_of(&GpuLaterParams {
                first_later,
                n_static: n,
                _pad: [0; 2],
            }),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let module = shaders::module(device, "later_occlusion.wgsl", LATER_OCCLUSION_WGSL);
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("later occlusion"),
            layout: None,
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("later occlusion"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: weight_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: occluded.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: params.as_entire_binding(),
                },
            ],
        });
        Some(LaterOcclusionPass {
            pipeline,
            group,
            _weight: weight_buf,
            _params: params,
        })
    }

    /// Records the pass (after every occlusion pass of the frame, before
    /// shading): one workgroup.
    pub(crate) fn encode(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("later occlusion"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
}
