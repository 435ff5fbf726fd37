//! A view's G-buffer from the engine's own. Shading and the interleave
//! filter read the engine's depth directly (with the frame camera's inverse
//! view-projection it gives the world position, as gibake's own depth
//! does): no copy. The normals and albedo are packed each frame into the
//! view's own textures, in place of the G-buffer pass
//! (`gbuffer_depth.wgsl`; the normals turned to face the viewer) — unless
//! they already are in gibake's layout ([`NormalEncoding::Packed`]), when
//! no pass runs at all.
//!
//! Its two pipelines (a `Depth32Float` or an `R32Float` depth) are made once
//! per renderer ([`Pipelines`]): an engine whose textures come from a pool
//! that may hand out other ones from frame to frame gives them again with
//! `use_depth_gbuffer` and pays for three bind groups (this pass's,
//! shading's and the filter's).

use gibake_gpu::shaders;

use crate::gbuffer::GBuffer;
use crate::{CameraMatrices, RuntimeError};

/// How the engine's normal buffer stores a normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalEncoding {
    /// gibake's own G-buffer layout ([`crate::GBUFFER_FORMATS`]`[1]`, an
    /// `Rg32Uint`: `pack2x16snorm` of the octahedral shading normal in x,
    /// of the geometric normal in y, both facing the viewer), with the
    /// albedo in gibake's layout too (`GBUFFER_FORMATS[2]`, an `R32Uint`):
    /// both read as they are, no rebuild pass.
    Packed,
    /// Octahedral shading normal (xy) and geometric normal (zw) in a float
    /// or unorm format, both facing the viewer (`oct_encode` in the shared
    /// `common.wgsl`).
    Octahedral,
    /// World-space unit normal in rgb, components in [−1, 1].
    World,
    /// World-space unit normal in rgb as `n · 0.5 + 0.5` (an unorm target).
    WorldUnorm,
}

/// The engine's G-buffer, which gibake shades with each frame: the depth as
/// it is, the normals and albedo packed into gibake's layout.
/// Every texture has the view's size, is single-sampled and 2D, and has
/// `TEXTURE_BINDING` usage; it must stay alive while the view uses it.
#[derive(Clone, Copy, Debug)]
pub struct DepthGBuffer<'a> {
    /// Depth (`Depth32Float`, or the depth value in an `R32Float`) written
    /// with the `view_proj` of the frame's [`CameraMatrices`]; a sample's
    /// world position is rebuilt from it at the pixel's centre.
    pub depth: &'a wgpu::Texture,
    /// Depth of a pixel with no surface (0 with reversed Z, as gibake's own
    /// cameras; 1 with standard Z).
    pub far_depth: f32,
    /// Normals (a float or unorm format; `Rg32Uint` for
    /// [`NormalEncoding::Packed`]), stored as `encoding` says.
    pub normals: &'a wgpu::Texture,
    /// How `normals` stores a normal.
    pub encoding: NormalEncoding,
    /// Linear albedo in rgb (a float or unorm format; an sRGB format
    /// decodes to linear when read); gibake's packed `R32Uint` with
    /// [`NormalEncoding::Packed`].
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
        self.inv_view_proj = camera.inv_view_proj().to_cols_array_2d();
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
                let own = own_wgsl(decl, load);
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

/// The pass's WGSL for a depth texture declared as `decl`, loaded by `load`.
fn own_wgsl(decl: &str, load: &str) -> String {
    let own = include_str!("gbuffer_depth.wgsl")
        .replace("DEPTH_TEXTURE", decl)
        .replace("DEPTH_LOAD", load);
    format!("{}\n{own}", crate::gbuffer::LAYOUT_WGSL)
}

/// A view's G-buffer from the engine's: the views shading reads and, unless
/// the normals are packed already, the pass that repacks them.
pub(crate) struct DepthGBufferPass {
    /// The engine's depth, normals and albedo (the last two used only when
    /// packed).
    views: [wgpu::TextureView; 3],
    /// The engine's depth texture (what shading rebuilds positions from).
    depth: wgpu::Texture,
    far_depth: f32,
    rebuild: Option<Rebuild>,
}

/// The normals' rebuild pass.
struct Rebuild {
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
        let packed = src.encoding == NormalEncoding::Packed;
        if packed {
            check_packed(src.normals, "normals", 1, size)?;
            check_packed(src.albedo, "albedo", 2, size)?;
        } else {
            check(src.normals, "normals", size, &[])?;
            check(src.albedo, "albedo", size, &[])?;
        }
        if !src.far_depth.is_finite() {
            return Err(RuntimeError::InvalidSetting(
                "the far depth of an external G-buffer must be finite".into(),
            ));
        }
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let views = [view(src.depth), view(src.normals), view(src.albedo)];
        let rebuild =
            (!packed).then(|| Rebuild::new(device, pipelines, src, &views, target, size, camera));
        Ok(DepthGBufferPass {
            views,
            depth: src.depth.clone(),
            far_depth: src.far_depth,
            rebuild,
        })
    }

    /// The views shading reads: the engine's depth, the normals and albedo
    /// (the engine's if packed, else the view's own, rebuilt).
    pub(crate) fn views<'a>(&'a self, own: &'a GBuffer) -> [&'a wgpu::TextureView; 3] {
        let packed = match self.rebuild {
            Some(_) => &own.views,
            None => &self.views,
        };
        [&self.views[0], &packed[1], &packed[2]]
    }

    /// The engine's depth texture.
    pub(crate) fn depth(&self) -> &wgpu::Texture {
        &self.depth
    }

    /// The depth of a sample with no surface.
    pub(crate) fn far_depth(&self) -> f32 {
        self.far_depth
    }

    /// Whether a pass runs each frame (the engine's layout is not gibake's).
    pub(crate) fn has_pass(&self) -> bool {
        self.rebuild.is_some()
    }

    /// The frame's camera (its inverse view-projection rebuilds positions).
    pub(crate) fn set_camera(&mut self, queue: &wgpu::Queue, camera: &CameraMatrices) {
        if let Some(r) = &mut self.rebuild {
            r.params.set_camera(camera);
            queue.write_buffer(&r.params_buf, 0, bytemuck::bytes_of(&r.params));
        }
    }

    /// Records the pass (nothing if the engine's layout is gibake's).
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        ts: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let Some(r) = &self.rebuild else {
            return;
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("gbuffer normals from the engine's"),
            timestamp_writes: ts,
        });
        pass.set_pipeline(&r.pipeline);
        pass.set_bind_group(0, &r.group, &[]);
        let [w, h] = r.params.size;
        pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
    }
}

/// Checks a texture in gibake's packed layout: `GBUFFER_FORMATS[k]` of the
/// view's size.
fn check_packed(
    t: &wgpu::Texture,
    what: &str,
    k: usize,
    size: (u32, u32),
) -> Result<(), RuntimeError> {
    let f = crate::GBUFFER_FORMATS[k];
    if t.format() != f {
        return Err(RuntimeError::OutputTarget(format!(
            "{what}: format {:?}, gibake's packed layout needs {f:?}",
            t.format()
        )));
    }
    if !t.usage().contains(wgpu::TextureUsages::TEXTURE_BINDING) {
        return Err(RuntimeError::OutputTarget(format!(
            "{what}: needs TEXTURE_BINDING usage"
        )));
    }
    if t.dimension() != wgpu::TextureDimension::D2 || t.sample_count() != 1 {
        return Err(RuntimeError::OutputTarget(format!(
            "{what}: needs a single-sampled 2D texture"
        )));
    }
    if (t.width(), t.height()) != size {
        return Err(RuntimeError::OutputTarget(format!(
            "{what}: {}×{}, the view is {}×{} (resize first)",
            t.width(),
            t.height(),
            size.0,
            size.1
        )));
    }
    Ok(())
}

impl Rebuild {
    fn new(
        device: &wgpu::Device,
        pipelines: &Pipelines,
        src: &DepthGBuffer<'_>,
        views: &[wgpu::TextureView; 3],
        target: &GBuffer,
        size: (u32, u32),
        camera: Option<&CameraMatrices>,
    ) -> Rebuild {
        let pipeline = pipelines.get(device, src.depth.format());
        let mut params = GpuDepthParams {
            inv_view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            position: [0.0; 4],
            forward: [0.0, 0.0, -1.0, 0.0],
            size: [size.0, size.1],
            far_depth: src.far_depth,
            normals: match src.encoding {
                NormalEncoding::Packed | NormalEncoding::Octahedral => 0,
                NormalEncoding::World => 1,
                NormalEncoding::WorldUnorm => 2,
            },
        };
        // A source given again between `prepare` and `record` keeps the
        // prepared frame's camera.
        if let Some(camera) = camera {
            params.set_camera(camera);
        }
        let params_buf = crate::shade::uniform(device, "gbuffer normals", &params);
        let tv = wgpu::BindingResource::TextureView;
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gbuffer normals from the engine's"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                (0, tv(&views[0])),
                (1, tv(&views[1])),
                (2, tv(&views[2])),
                (3, params_buf.as_entire_binding()),
                (5, tv(&target.views[1])),
                (6, tv(&target.views[2])),
            ]
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource }),
        });
        Rebuild {
            pipeline,
            group,
            params,
            params_buf,
        }
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
            if let Err(e) = validate(&compose(&super::own_wgsl(decl, load))) {
                panic!("gbuffer_depth.wgsl ({decl}) does not validate:\n{e}");
            }
        }
    }
}
