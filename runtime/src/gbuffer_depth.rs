//! A view's G-buffer rebuilt from the engine's own (`gbuffer_depth.wgsl`):
//! its depth buffer and the frame camera's inverse view-projection give the
//! world position, its normal buffer the normals, its albedo buffer the
//! albedo. Recorded in place of the G-buffer pass, every frame.
//!
//! Its two pipelines (a `Depth32Float` or an `R32Float` depth) are made once
//! per renderer ([`Pipelines`]): an engine whose depth and normal textures
//! come from a pool that may hand out other ones from frame to frame gives
//! them again with `use_depth_gbuffer` and pays for a bind group.

use gibake_gpu::shaders;

use crate::gbuffer::GBuffer;
use crate::{CameraMatrices, RuntimeError};

/// How the engine's normal buffer stores a normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalEncoding {
    /// gibake's: octahedral shading normal (xy) and geometric normal (zw),
    /// both facing the viewer (`oct_encode` in the shared `common.wgsl`).
    Octahedral,
    /// World-space unit normal in rgb, components in [−1, 1].
    World,
    /// World-space unit normal in rgb as `n · 0.5 + 0.5` (an unorm target).
    WorldUnorm,
}

/// The engine's G-buffer, from which gibake rebuilds its own each frame.
/// Every texture has the view's size and `TEXTURE_BINDING` usage.
#[derive(Clone, Copy, Debug)]
pub struct DepthGBuffer<'a> {
    /// Depth (`Depth32Float`, or the depth value in an `R32Float`) written
    /// with the `view_proj` of the frame's [`CameraMatrices`].
    pub depth: &'a wgpu::Texture,
    /// Depth of a pixel with no surface (0 with reversed Z, as gibake's own
    /// cameras; 1 with standard Z).
    pub far_depth: f32,
    /// Normals (a float or unorm format), stored as `encoding` says.
    pub normals: &'a wgpu::Texture,
    /// How `normals` stores a normal.
    pub encoding: NormalEncoding,
    /// Linear albedo in rgb (a float or unorm format).
    pub albedo: &'a wgpu::Texture,
}

/// `DepthParams` in the WGSL.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuDepthParams {
    inv_view_proj: [[f32; 4]; 4],
    position: [f32; 4],
    forward: [f32; 4],
    size: [u32; 2],
    far_depth: f32,
    normals: u32,
}

impl GpuDepthParams {
    fn set_camera(&mut self, camera: &CameraMatrices) {
        let gpu = camera.to_gpu();
        self.inv_view_proj = camera.view_proj.inverse().to_cols_array_2d();
        self.position = gpu.position;
        self.forward = gpu.forward;
    }
}

/// The rebuild pipelines of one renderer, made when first needed: for a
/// `Depth32Float` depth, for an `R32Float` one.
#[derive(Default)]
pub(crate) struct Pipelines([std::sync::OnceLock<wgpu::ComputePipeline>; 2]);

impl Pipelines {
    fn get(&self, device: &wgpu::Device, depth: wgpu::TextureFormat) -> wgpu::ComputePipeline {
        let float = depth != wgpu::TextureFormat::Depth32Float;
        self.0[usize::from(float)]
            .get_or_init(|| {
                let (decl, load) = if float {
                    ("texture_2d<f32>", "textureLoad(depth_tex, px, 0).r")
                } else {
                    ("texture_depth_2d", "textureLoad(depth_tex, px, 0)")
                };
                let own = include_str!("gbuffer_depth.wgsl")
                    .replace("DEPTH_TEXTURE", decl)
                    .replace("DEPTH_LOAD", load);
                let module = shaders::module(device, "gbuffer_depth.wgsl", &own);
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some("gbuffer from depth"),
                    layout: None,
                    module: &module,
                    entry_point: Some("cs_main"),
                    compilation_options: Default::default(),
                    cache: None,
                })
            })
            .clone()
    }
}

/// The rebuild pass of one view.
pub(crate) struct DepthGBufferPass {
    pipeline: wgpu::ComputePipeline,
    group: wgpu::BindGroup,
    params: GpuDepthParams,
    params_buf: wgpu::Buffer,
}

fn check(
    t: &wgpu::Texture,
    what: &str,
    size: (u32, u32),
    formats: &[wgpu::TextureFormat],
) -> Result<(), RuntimeError> {
    let problem = if !formats.is_empty() && !formats.contains(&t.format()) {
        Some(format!(
            "{what}: format {:?}, needs one of {formats:?}",
            t.format()
        ))
    } else if !t.usage().contains(wgpu::TextureUsages::TEXTURE_BINDING) {
        Some(format!("{what}: needs TEXTURE_BINDING usage"))
    } else if t.dimension() != wgpu::TextureDimension::D2 || t.sample_count() != 1 {
        Some(format!("{what}: needs a single-sampled 2D texture"))
    } else if (t.width(), t.height()) != size {
        Some(format!(
            "{what}: {}×{}, the view is {}×{} (resize first)",
            t.width(),
            t.height(),
            size.0,
            size.1
        ))
    } else if t.format().sample_type(None, None).is_some_and(|s| {
        matches!(
            s,
            wgpu::TextureSampleType::Sint | wgpu::TextureSampleType::Uint
        )
    }) {
        Some(format!("{what}: an integer format cannot be read as float"))
    } else {
        None
    };
    match problem {
        Some(p) => Err(RuntimeError::OutputTarget(p)),
        None => Ok(()),
    }
}

impl DepthGBufferPass {
    /// The pass from `src` into `target` (both of `size`).
    pub(crate) fn new(
        device: &wgpu::Device,
        pipelines: &Pipelines,
        src: &DepthGBuffer<'_>,
        target: &GBuffer,
        size: (u32, u32),
        camera: Option<&CameraMatrices>,
    ) -> Result<DepthGBufferPass, RuntimeError> {
        use wgpu::TextureFormat as F;
        check(src.depth, "depth", size, &[F::Depth32Float, F::R32Float])?;
        check(src.normals, "normals", size, &[])?;
        check(src.albedo, "albedo", size, &[])?;
        if !src.far_depth.is_finite() {
            return Err(RuntimeError::InvalidSetting(
                "the far depth of an external G-buffer must be finite".into(),
            ));
        }
        let pipeline = pipelines.get(device, src.depth.format());
        let mut params = GpuDepthParams {
            inv_view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            position: [0.0; 4],
            forward: [0.0, 0.0, -1.0, 0.0],
            size: [size.0, size.1],
            far_depth: src.far_depth,
            normals: match src.encoding {
                NormalEncoding::Octahedral => 0,
                NormalEncoding::World => 1,
                NormalEncoding::WorldUnorm => 2,
            },
        };
        // A source given again between `prepare` and `record` keeps the
        // prepared frame's camera.
        if let Some(camera) = camera {
            params.set_camera(camera);
        }
        let params_buf = crate::shade::uniform(device, "gbuffer from depth", &params);
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (d, n, a) = (view(src.depth), view(src.normals), view(src.albedo));
        let tv = wgpu::BindingResource::TextureView;
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gbuffer from depth"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                (0, tv(&d)),
                (1, tv(&n)),
                (2, tv(&a)),
                (3, params_buf.as_entire_binding()),
                (4, tv(&target.views[0])),
                (5, tv(&target.views[1])),
                (6, tv(&target.views[2])),
            ]
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource }),
        });
        Ok(DepthGBufferPass {
            pipeline,
            group,
            params,
            params_buf,
        })
    }

    /// The frame's camera (its inverse view-projection rebuilds positions).
    pub(crate) fn set_camera(&mut self, queue: &wgpu::Queue, camera: &CameraMatrices) {
        self.params.set_camera(camera);
        queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
    }

    /// Records the pass.
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        ts: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("gbuffer from depth"),
            timestamp_writes: ts,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        let [w, h] = self.params.size;
        pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn gbuffer_depth_shader_validates_for_both_depth_formats() {
        use gibake_gpu::shaders::{compose, validate};
        for (decl, load) in [
            ("texture_depth_2d", "textureLoad(depth_tex, px, 0)"),
            ("texture_2d<f32>", "textureLoad(depth_tex, px, 0).r"),
        ] {
            let src = include_str!("gbuffer_depth.wgsl")
                .replace("DEPTH_TEXTURE", decl)
                .replace("DEPTH_LOAD", load);
            if let Err(e) = validate(&compose(&src)) {
                panic!("gbuffer_depth.wgsl ({decl}) does not validate:\n{e}");
            }
        }
    }
}
