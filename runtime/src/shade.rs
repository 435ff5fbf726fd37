//! Deferred shading pass (compute, `shade.wgsl`): direct light with the
//! merged primary shadow map, static VPLs with merged hemisphere maps and
//! partial occlusion, dynamic VPLs. Writes linear radiance (`Rgba32Float`),
//! or, interleaved, direct radiance and an irradiance estimate side by side
//! for [`crate::interleave::InterleavePass`] to filter.

use gibake_gpu::shaders;

/// The pass's WGSL: the dynamic VPL slot layout it reads, then its own.
const SHADE_WGSL: &str = concat!(
    include_str!("dyn_vpl.wgsl"),
    "\n",
    include_str!("shade.wgsl")
);

/// Output format of shading.
pub const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// Must match `ShadeParams` in `shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuShadeParams {
    /// Output size.
    pub size: [u32; 2],
    /// `FLAG_*` bits.
    pub flags: u32,
    /// Number of static VPLs.
    pub n_static: u32,
    /// Hemisphere map size.
    pub map_size: u32,
    /// Tiles per atlas row.
    pub atlas_cols: u32,
    /// Number of dynamic VPL slots.
    pub n_dynamic: u32,
    /// Tiles per row of the baked map atlas.
    pub static_cols: u32,
    /// Interleave N: 1 shades every VPL at every pixel; N > 1 shades the
    /// VPLs `i ≡ k (mod N²)` at pixel `k = x mod N + N·(y mod N)` and writes
    /// direct radiance | irradiance side by side (see `interleave.rs`).
    pub interleave: u32,
    /// Padding (16-byte struct size).
    pub _pad: [u32; 3],
}

/// Direct light.
pub const FLAG_DIRECT: u32 = 1;
/// Static VPLs.
pub const FLAG_STATIC_VPL: u32 = 2;
/// Dynamic VPLs.
pub const FLAG_DYNAMIC_VPL: u32 = 4;
/// VPL visibility from hemisphere maps (off in `rsm` mode).
pub const FLAG_VISIBILITY: u32 = 8;
/// Every VPL map is an atlas tile (`naive`).
pub const FLAG_ATLAS_ONLY: u32 = 16;
/// Moving objects drawn into the primary map.
pub const FLAG_DYN_PRIMARY: u32 = 32;
/// Partial occlusion of static VPLs.
pub const FLAG_OCCLUSION: u32 = 64;
/// Moving objects are merged into VPL map tiles (`vpl_tile` is bound).
pub const FLAG_TILES: u32 = 128;

/// The shading pass: pipeline, bind group layouts, uniform, and what is
/// bound where a feature is absent (its fallbacks).
pub struct ShadePass {
    pipeline: wgpu::ComputePipeline,
    /// Bound for absent storage inputs.
    fallback_buf: wgpu::Buffer,
    /// Bound when there are no dynamic VPLs (one empty slot).
    fallback_dyn_vpls: wgpu::Buffer,
    /// A 1×1 `R32Float` texture bound for absent maps.
    fallback_map: wgpu::TextureView,
    /// Layout of group 0 (G-buffer, primary maps, light, params, output).
    pub frame_layout: wgpu::BindGroupLayout,
    /// Layout of group 1 (VPL data and maps).
    pub gi_layout: wgpu::BindGroupLayout,
    /// `GpuShadeParams` uniform.
    pub uniform_buf: wgpu::Buffer,
}

const COMPUTE: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

fn tex_entry(binding: u32, dim: wgpu::TextureViewDimension) -> wgpu::BindGroupLayoutEntry {
    gibake_gpu::util::texture_entry(binding, COMPUTE, dim)
}

fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    gibake_gpu::util::uniform_entry(binding, COMPUTE)
}

fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    gibake_gpu::util::storage_entry(binding, COMPUTE, true)
}

/// Frame inputs (group 0).
pub struct FrameInputs<'a> {
    /// The camera G-buffer's three views (see [`crate::gbuffer::GBUFFER_FORMATS`]).
    pub gbuffer: [&'a wgpu::TextureView; 3],
    /// Static primary shadow map (metric).
    pub primary_static: &'a wgpu::TextureView,
    /// Moving objects' primary shadow map (or any R32Float view when none).
    pub primary_dynamic: &'a wgpu::TextureView,
    /// `GpuPrimaryLight` uniform.
    pub light: &'a wgpu::Buffer,
    /// `GpuLightView` uniform of the primary maps.
    pub light_view: &'a wgpu::Buffer,
    /// Output radiance view (`Rgba32Float`, storage binding).
    pub output: &'a wgpu::TextureView,
}

/// GI inputs (group 1); `None`: the feature is absent and the pass binds
/// its fallback.
#[derive(Default)]
pub struct GiInputs<'a> {
    /// Static VPL records.
    pub vpls: Option<&'a wgpu::Buffer>,
    /// Per static VPL occluded fraction (fixed point 2^24).
    pub occlusion: Option<&'a wgpu::Buffer>,
    /// Per static VPL atlas tile or `u32::MAX`.
    pub vpl_tile: Option<&'a wgpu::Buffer>,
    /// Baked maps (2D atlas).
    pub static_maps: Option<&'a wgpu::TextureView>,
    /// Atlas of merged/re-rendered maps.
    pub atlas: Option<&'a wgpu::TextureView>,
    /// Dynamic VPL slots.
    pub dyn_vpls: Option<&'a wgpu::Buffer>,
    /// Near-field trees of the static VPLs.
    pub vpl_nodes: Option<&'a wgpu::Buffer>,
}

impl ShadePass {
    /// Creates the pass.
    pub fn new(device: &wgpu::Device) -> ShadePass {
        let module = shaders::module(device, "shade.wgsl", SHADE_WGSL);
        use wgpu::TextureViewDimension::D2;
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shade frame"),
            entries: &[
                tex_entry(0, D2),
                tex_entry(1, D2),
                tex_entry(2, D2),
                tex_entry(3, D2),
                tex_entry(4, D2),
                uniform_entry(5),
                uniform_entry(6),
                uniform_entry(7),
                wgpu::BindGroupLayoutEntry {
                    binding: 8,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: RADIANCE_FORMAT,
                        view_dimension: D2,
                    },
                    count: None,
                },
            ],
        });
        let gi_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shade gi"),
            entries: &[
                storage_entry(0),
                storage_entry(1),
                storage_entry(2),
                tex_entry(3, D2),
                tex_entry(4, D2),
                storage_entry(5),
                storage_entry(6),
            ],
        });
        let uniform_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shade params"),
            size: std::mem::size_of::<GpuShadeParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shade"),
            bind_group_layouts: &[Some(&frame_layout), Some(&gi_layout)],
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
        let storage = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        };
        ShadePass {
            pipeline,
            fallback_buf: storage("absent GI input", 64),
            fallback_dyn_vpls: storage("no dynamic VPLs", 48),
            fallback_map: gibake_gpu::util::texture_2d(
                device,
                "absent map",
                1,
                1,
                wgpu::TextureFormat::R32Float,
                wgpu::TextureUsages::TEXTURE_BINDING,
            )
            .create_view(&Default::default()),
            frame_layout,
            gi_layout,
            uniform_buf,
        }
    }

    /// Bind group 0.
    pub fn frame_group(&self, device: &wgpu::Device, i: &FrameInputs<'_>) -> wgpu::BindGroup {
        let g = i.gbuffer;
        let tv = wgpu::BindingResource::TextureView;
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade frame"),
            layout: &self.frame_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: tv(g[0]),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: tv(g[1]),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: tv(g[2]),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: tv(i.primary_static),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: tv(i.primary_dynamic),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: i.light.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: i.light_view.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: self.uniform_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 8,
                    resource: tv(i.output),
                },
            ],
        })
    }

    /// Bind group 1, with fallbacks for what `i` lacks.
    pub fn gi_group<'a>(&'a self, device: &wgpu::Device, i: &GiInputs<'a>) -> wgpu::BindGroup {
        let fb = &self.fallback_buf;
        let fm = &self.fallback_map;
        let buf = |b: Option<&'a wgpu::Buffer>| b.unwrap_or(fb).as_entire_binding();
        let map =
            |m: Option<&'a wgpu::TextureView>| wgpu::BindingResource::TextureView(m.unwrap_or(fm));
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade gi"),
            layout: &self.gi_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buf(i.vpls),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: buf(i.occlusion),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: buf(i.vpl_tile),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: map(i.static_maps),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: buf(i.vpl_nodes),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: map(i.atlas),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: i
                        .dyn_vpls
                        .unwrap_or(&self.fallback_dyn_vpls)
                        .as_entire_binding(),
                },
            ],
        })
    }

    /// Records the pass.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &wgpu::BindGroup,
        gi: &wgpu::BindGroup,
        size: [u32; 2],
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("shade"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, frame, &[]);
        pass.set_bind_group(1, gi, &[]);
        pass.dispatch_workgroups(size[0].div_ceil(8), size[1].div_ceil(8), 1);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn runtime_shaders_validate() {
        use gibake_gpu::shaders::{compose, compose_mesh, validate};
        for (name, src) in [
            ("shade.wgsl", compose(super::SHADE_WGSL)),
            ("gbuffer.wgsl", compose_mesh(include_str!("gbuffer.wgsl"))),
            (
                "dynamic_rsm.wgsl",
                compose_mesh(include_str!("dynamic_rsm.wgsl")),
            ),
            (
                "occlusion.wgsl",
                compose(crate::dynamic_rsm::OCCLUSION_WGSL),
            ),
            ("interleave.wgsl", compose(include_str!("interleave.wgsl"))),
        ] {
            if let Err(e) = validate(&src) {
                panic!("{name} does not validate:\n{e}");
            }
        }
    }
}
