//! Camera G-buffer of all geometry, 16 bytes a sample: the depth attachment
//! itself (`Depth32Float`, reversed Z; the world position is rebuilt from it
//! with the view's inverse view-projection), both normals packed in an
//! `Rg32Uint` (16-bit octahedral each, facing the viewer) and the albedo in
//! an `R32Uint` (√albedo at 1625 levels a channel) (`gbuffer_layout.wgsl` defines the layout for
//! every pass that writes or reads it). One pipeline ([`GBufferPass`])
//! serves every view; each view has its own targets ([`GBuffer`]) and
//! camera ([`Camera`]).

use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_gpu::shaders;
use gibake_gpu::util::{
    cleared_attachments, cleared_depth, draws_and_uniform_group, mesh_pipeline, texture_2d,
};
use wgpu::util::DeviceExt;

use crate::camera::GpuCamera;

/// The G-buffer's textures: depth (the pass's depth attachment, reversed
/// Z: 0 where no surface is), both normals (`x`: `pack2x16snorm` of the
/// octahedral shading normal, `y`: of the geometric normal, both facing the
/// viewer), albedo (√ of the linear albedo rounded to 1625 levels a channel,
/// `r + 1625·(g + 1625·b)`). 4 + 8 + 4 = 16 bytes a sample.
pub const GBUFFER_FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::Depth32Float,
    wgpu::TextureFormat::Rg32Uint,
    wgpu::TextureFormat::R32Uint,
];

/// Bytes a sample of the G-buffer, the depth included.
pub const GBUFFER_BYTES_PER_SAMPLE: u32 = 16;

/// Levels of each albedo channel (`ALBEDO_LEVELS` in the WGSL).
pub const GBUFFER_ALBEDO_LEVELS: u32 = 1625;

/// Linear albedo of a texel of gibake's packed albedo
/// ([`GBUFFER_FORMATS`]`[2]`): the CPU twin of `gbuffer_albedo`.
pub fn unpack_albedo(packed: u32) -> [f32; 3] {
    let n = GBUFFER_ALBEDO_LEVELS;
    [packed % n, (packed / n) % n, packed / (n * n)].map(|q| (q as f32 / (n - 1) as f32).powi(2))
}

/// The shading and geometric normals of a packed normals texel
/// (`Rg32Uint`, `gbuffer_normal` in `gbuffer_layout.wgsl`): its CPU twin.
pub fn unpack_normals(packed: [u32; 2]) -> [glam::Vec3; 2] {
    packed.map(|p| {
        let snorm = |v: u16| (f32::from(v as i16) / 32767.0).max(-1.0);
        let (x, y) = (snorm(p as u16), snorm((p >> 16) as u16));
        let mut n = glam::Vec3::new(x, y, 1.0 - x.abs() - y.abs());
        let t = (-n.z).max(0.0);
        n.x += if n.x >= 0.0 { -t } else { t };
        n.y += if n.y >= 0.0 { -t } else { t };
        n.normalize_or_zero()
    })
}

/// The WGSL of the layout (`gbuffer_layout.wgsl`, needs `common.wgsl`).
pub(crate) const LAYOUT_WGSL: &str = include_str!("gbuffer_layout.wgsl");

/// The G-buffer textures.
pub(crate) struct GBuffer {
    /// Textures in [`GBUFFER_FORMATS`] order (the first is the depth
    /// attachment).
    pub textures: Vec<wgpu::Texture>,
    /// Their views.
    pub views: [wgpu::TextureView; 3],
}

impl GBuffer {
    /// Allocates a `width × height` G-buffer.
    pub(crate) fn new(device: &wgpu::Device, width: u32, height: u32) -> GBuffer {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        // Storage: the normals and albedo rebuilt from an engine's
        // (gbuffer_depth.rs).
        let storage = usage | wgpu::TextureUsages::STORAGE_BINDING;
        let usages = [usage, storage, storage];
        let textures: Vec<_> = GBUFFER_FORMATS
            .iter()
            .zip(usages)
            .zip(["gbuffer depth", "gbuffer normals", "gbuffer albedo"])
            .map(|((f, u), l)| texture_2d(device, l, width, height, *f, u))
            .collect();
        let views = [0, 1, 2].map(|i: usize| textures[i].create_view(&Default::default()));
        GBuffer { textures, views }
    }

    /// The depth attachment.
    pub(crate) fn depth(&self) -> &wgpu::Texture {
        &self.textures[0]
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
        let own = format!("{LAYOUT_WGSL}\n{}", include_str!("gbuffer.wgsl"));
        let module = shaders::mesh_module(device, "gbuffer.wgsl", &own);
        let probe = zeroed_camera(device);
        let (layout, _) = draws_and_uniform_group(device, "gbuffer", &scene_gpu.draw_data, &probe);
        let targets: Vec<Option<wgpu::ColorTargetState>> = GBUFFER_FORMATS[1..]
            .iter()
            .map(|f| Some((*f).into()))
            .collect();
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
                target.views[1..]
                    .iter()
                    .map(|v| (v, wgpu::Color::TRANSPARENT)),
            ),
            depth_stencil_attachment: Some(cleared_depth(&target.views[0], 0.0)),
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

/// World positions rebuilt from a `width × height` depth image (row 0 at
/// the top) drawn with `camera`: `[x, y, z, 1]` at every sample with a
/// surface, `[0, 0, 0, 0]` where the depth is `far_depth`. The CPU twin of
/// `gbuffer_position` in `gbuffer_layout.wgsl` (in f64).
pub fn positions_from_depth(
    depth: &[f32],
    width: u32,
    height: u32,
    camera: &crate::CameraMatrices,
    far_depth: f32,
) -> Vec<[f32; 4]> {
    let inv = camera.view_proj.as_dmat4().inverse();
    let (w, h) = (width.max(1) as usize, height.max(1) as usize);
    depth
        .iter()
        .enumerate()
        .map(|(i, &d)| {
            if d == far_depth {
                return [0.0; 4];
            }
            let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let ndc = glam::DVec4::new(
                x / w as f64 * 2.0 - 1.0,
                1.0 - y / h as f64 * 2.0,
                f64::from(d),
                1.0,
            );
            let p = inv * ndc;
            let p = p.truncate() / p.w;
            [p.x as f32, p.y as f32, p.z as f32, 1.0]
        })
        .collect()
}

fn zeroed_camera(device: &wgpu::Device) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("camera"),
        contents: bytemuck::bytes_of(&<GpuCamera as bytemuck::Zeroable>::zeroed()),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    })
}

#[cfg(test)]
mod tests {
    use glam::{Mat4, Vec3, Vec4};

    use crate::CameraMatrices;

    /// `gbuffer_position` of `gbuffer_layout.wgsl`, in f32 as the GPU runs it.
    fn rebuild(inv: Mat4, size: [u32; 2], px: [u32; 2], depth: f32) -> Vec3 {
        let uv = [
            (px[0] as f32 + 0.5) / size[0] as f32,
            (px[1] as f32 + 0.5) / size[1] as f32,
        ];
        let w = inv * Vec4::new(uv[0] * 2.0 - 1.0, 1.0 - uv[1] * 2.0, depth, 1.0);
        w.truncate() / w.w
    }

    /// The worst error of a position rebuilt from a reversed-Z f32 depth,
    /// in pixel footprints at the point, over surfaces from 2 to 500 scene
    /// units of `scale` away (the camera itself 300 units off the origin).
    fn worst_error(scale: f32, orthographic: bool) -> f32 {
        let size = [480u32, 270];
        let eye = Vec3::new(300.0, 40.0, -120.0) * scale;
        let turn = glam::Quat::from_euler(glam::EulerRot::YXZ, 1.2, -0.2, 0.0);
        let to_world = Mat4::from_rotation_translation(turn, eye);
        let aspect = size[0] as f32 / size[1] as f32;
        let cam = if orthographic {
            CameraMatrices::orthographic(to_world, 50.0 * scale, aspect, 0.1 * scale, 600.0 * scale)
        } else {
            CameraMatrices::perspective(to_world, 1.0, aspect, 0.05 * scale)
        };
        let inv = cam.inv_view_proj();
        let vp64 = cam.view_proj.as_dmat4();
        let inv64 = vp64.inverse();
        let mut worst = 0f32;
        for k in 0..400u32 {
            let px = [(k * 37) % size[0], (k * 53) % size[1]];
            let dist = (2.0 + 498.0 * (k as f64 / 399.0).powi(2)) * f64::from(scale);
            // The exact point at this pixel's centre and distance.
            let ndc = |z: f64| {
                let p = inv64
                    * glam::DVec4::new(
                        (px[0] as f64 + 0.5) / size[0] as f64 * 2.0 - 1.0,
                        1.0 - (px[1] as f64 + 0.5) / size[1] as f64 * 2.0,
                        z,
                        1.0,
                    );
                p.truncate() / p.w
            };
            let (near, far) = (ndc(1.0), ndc(if orthographic { 0.0 } else { 1e-9 }));
            let dir = (far - near).normalize();
            let x = eye.as_dvec3() + dir * dist;
            let x = if orthographic { near + dir * dist } else { x };
            // Its depth as the rasterizer stores it (f32), then rebuilt.
            let c = vp64 * x.extend(1.0);
            let depth = (c.z / c.w) as f32;
            let got = rebuild(inv, size, px, depth).as_dvec3();
            let footprint = if orthographic {
                100.0 * f64::from(scale) / size[1] as f64
            } else {
                (x - eye.as_dvec3()).length() / size[1] as f64
            };
            worst = worst.max(((got - x).length() / footprint) as f32);
        }
        worst
    }

    /// Reversed-Z f32 depth rebuilds positions to a small fraction of a
    /// pixel at every scene scale (no scale-dependent constant), for
    /// perspective and orthographic cameras: the interleave filter's plane
    /// test and the maps' receiver-plane tests see the surface the raster
    /// saw.
    #[test]
    fn positions_from_depth_hold_at_a_millimetre_and_a_kilometre() {
        for orthographic in [false, true] {
            let e: Vec<f32> = [1e-3, 1.0, 1e3]
                .iter()
                .map(|&s| worst_error(s, orthographic))
                .collect();
            eprintln!(
                "orthographic {orthographic}: worst error in pixel footprints at 1e-3, 1, 1e3: {e:?}"
            );
            for w in e {
                assert!(w < 0.03, "{w} pixel footprints");
            }
        }
    }
}
