//! Moving objects drawn from the primary light at the RSM resolution
//! (`dynamic_rsm.wgsl`), and the partial-occlusion pass that reads it
//! (`occlusion.wgsl`). Only built when the scene has moving objects.

use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_gpu::util::{
    cleared_attachments, cleared_depth, draws_and_uniform_group, mesh_pipeline, texture_2d,
};
use gibake_gpu::{LightView, shaders};
use wgpu::util::DeviceExt;

/// The occlusion pass's WGSL: the shared in-front test, then its own.
pub(crate) const OCCLUSION_WGSL: &str = concat!(
    include_str!("moving.wgsl"),
    "\n",
    include_str!("occlusion.wgsl")
);

/// Target formats of the dynamic RSM.
pub(crate) const DYN_RSM_FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba16Float,
    wgpu::TextureFormat::Rgba16Float,
];

/// The dynamic RSM pass and its targets.
pub(crate) struct DynamicRsmPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// Targets in [`DYN_RSM_FORMATS`] order (read back by tests).
    #[cfg_attr(not(test), expect(dead_code))]
    pub(crate) textures: Vec<wgpu::Texture>,
    /// Their views.
    pub(crate) views: Vec<wgpu::TextureView>,
    depth_view: wgpu::TextureView,
    /// The light view (RSM size) uniform.
    pub(crate) view_buf: wgpu::Buffer,
    /// Size.
    pub(crate) size: u32,
}

impl DynamicRsmPass {
    /// Creates the pass for `view` (RSM resolution).
    pub(crate) fn new(
        device: &wgpu::Device,
        scene_gpu: &SceneGpu,
        view: &LightView,
    ) -> DynamicRsmPass {
        let module =
            shaders::mesh_module(device, "dynamic_rsm.wgsl", include_str!("dynamic_rsm.wgsl"));
        let view_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("rsm light view"),
            contents: bytemuck::bytes_of(&view.to_gpu()),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let (layout, bind_group) =
            draws_and_uniform_group(device, "dynamic rsm", &scene_gpu.draw_data, &view_buf);
        let targets: Vec<Option<wgpu::ColorTargetState>> =
            DYN_RSM_FORMATS.iter().map(|f| Some((*f).into())).collect();
        let pipeline = mesh_pipeline(
            device,
            "dynamic rsm",
            &module,
            &[&layout, &scene_gpu.material_layout],
            &targets,
            wgpu::CompareFunction::Greater,
        );
        let size = view.size;
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let textures: Vec<_> = DYN_RSM_FORMATS
            .iter()
            .map(|f| texture_2d(device, "dynamic rsm", size, size, *f, usage))
            .collect();
        let views = textures
            .iter()
            .map(|t| t.create_view(&Default::default()))
            .collect();
        let depth = texture_2d(
            device,
            "dynamic rsm depth",
            size,
            size,
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        DynamicRsmPass {
            pipeline,
            bind_group,
            textures,
            views,
            depth_view: depth.create_view(&Default::default()),
            view_buf,
            size,
        }
    }

    /// Records the pass (the moving objects' `draws`).
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_gpu: &SceneGpu,
        draws: &[Draw],
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) -> u32 {
        let clears = [
            wgpu::Color {
                r: 0.0,
                g: 0.0,
                b: 0.0,
                a: 3.0e38,
            },
            wgpu::Color::TRANSPARENT,
            wgpu::Color::TRANSPARENT,
        ];
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("dynamic rsm"),
            color_attachments: &cleared_attachments(self.views.iter().zip(clears)),
            depth_stencil_attachment: Some(cleared_depth(&self.depth_view, 0.0)),
            timestamp_writes: ts,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        scene_gpu.draw(&mut pass, draws, true);
        draws.len() as u32
    }
}

/// The partial-occlusion pass.
pub(crate) struct OcclusionPass {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
    /// Per static VPL occluded share (u32, fixed point 2^24).
    pub(crate) occluded: wgpu::Buffer,
    size: u32,
}

impl OcclusionPass {
    /// Creates the pass. `texel_info` holds `(vpl, share)` per RSM texel.
    pub(crate) fn new(
        device: &wgpu::Device,
        static_metric: &wgpu::TextureView,
        rsm: &DynamicRsmPass,
        texel_info: &wgpu::Buffer,
        vpl_count: u32,
    ) -> OcclusionPass {
        let module = shaders::module(device, "occlusion.wgsl", OCCLUSION_WGSL);
        let occluded = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("occluded shares"),
            size: 4 * vpl_count.max(1) as u64,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("occlusion"),
            layout: None,
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        let layout = pipeline.get_bind_group_layout(0);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("occlusion"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(static_metric),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&rsm.views[0]),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: texel_info.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: occluded.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: rsm.view_buf.as_entire_binding(),
                },
            ],
        });
        OcclusionPass {
            pipeline,
            bind_group,
            occluded,
            size: rsm.size,
        }
    }

    /// Records: clear the sums, then one invocation per texel.
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        ts: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        encoder.clear_buffer(&self.occluded, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("occlusion"),
            timestamp_writes: ts,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(self.size.div_ceil(8), self.size.div_ceil(8), 1);
    }
}
