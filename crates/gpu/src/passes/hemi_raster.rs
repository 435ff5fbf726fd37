//! Exact rasterization of meshes into VPL hemisphere maps (see
//! `hemi_raster.wgsl` for why it is exact): the runtime merges moving
//! objects into the affected static VPL maps with it, and `naive` mode
//! re-renders every map from all geometry with it.
//!
//! Maps are tiles of one `R32Float` atlas (distance from the VPL origin;
//! `f32::MAX` = nothing), ordered by a `Depth32Float` atlas. One instanced
//! draw per mesh covers every job (VPL) and the four octahedron faces; the
//! mesh's material texture is bound per draw for the alpha test.

use std::ops::Range;

use gibake_scene::Aabb;
use glam::Vec3;

use crate::mesh::SceneGpu;
use crate::util::texture_2d;
use crate::{hemisphere, shaders};

/// Which of the four octahedron faces (bit `sx + 2·sy`, `s = 1` for +)
/// of the hemisphere map around `normal` at `origin` the box can touch.
/// 0 when the box lies entirely behind the VPL's plane. Conservative.
pub fn face_mask(b: &Aabb, origin: Vec3, normal: Vec3) -> u32 {
    if b.is_empty() {
        return 0;
    }
    let mut l = [Vec3::ZERO; 8];
    for (i, c) in l.iter_mut().enumerate() {
        let p = Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        );
        *c = hemisphere::to_local(normal, p - origin);
    }
    if l.iter().all(|c| c.z < 0.0) {
        return 0;
    }
    let mut mask = 0;
    for face in 0..4u32 {
        let sx = if face & 1 != 0 { 1.0 } else { -1.0 };
        let sy = if face & 2 != 0 { 1.0 } else { -1.0 };
        let out = l.iter().all(|c| sx * c.x < 0.0)
            || l.iter().all(|c| sy * c.y < 0.0)
            || l.iter().all(|c| sx * c.x + sy * c.y + c.z <= 0.0);
        if !out {
            mask |= 1 << face;
        }
    }
    mask
}

/// One VPL to draw into. Must match `Job` in `hemi_raster.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuHemiJob {
    /// xyz map origin (`hemisphere::vpl_origin`).
    pub origin: [f32; 4],
    /// xyz VPL normal.
    pub normal: [f32; 4],
    /// xy tile offset in texels (zw unused).
    pub tile: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuRasterParams {
    atlas_size: [f32; 2],
    tile_size: f32,
    depth_scale: f32,
    pad: [u32; 4],
}

/// A tile atlas of hemisphere maps.
pub struct HemiAtlas {
    /// `R32Float` distances.
    pub texture: wgpu::Texture,
    /// Its view.
    pub view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    /// Tile size in texels.
    pub tile_size: u32,
    /// Tiles per row.
    pub cols: u32,
    /// Number of tiles.
    pub capacity: u32,
}

impl HemiAtlas {
    /// An atlas of `cols × rows` tiles of `tile_size²` (the caller picks
    /// the layout and checks it against the device's limits).
    pub fn new(device: &wgpu::Device, tile_size: u32, cols: u32, rows: u32) -> HemiAtlas {
        let (cols, rows) = (cols.max(1), rows.max(1));
        let (w, h) = (cols * tile_size, rows * tile_size);
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_DST
            | wgpu::TextureUsages::COPY_SRC;
        let texture = texture_2d(
            device,
            "hemisphere atlas",
            w,
            h,
            wgpu::TextureFormat::R32Float,
            usage,
        );
        let depth = texture_2d(
            device,
            "hemisphere depth",
            w,
            h,
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        HemiAtlas {
            view: texture.create_view(&Default::default()),
            texture,
            depth_view: depth.create_view(&Default::default()),
            tile_size,
            cols,
            capacity: cols * rows,
        }
    }

    /// Texel offset of tile `i`.
    pub fn tile_origin(&self, i: u32) -> [u32; 2] {
        [
            (i % self.cols) * self.tile_size,
            (i / self.cols) * self.tile_size,
        ]
    }
}

/// The rasterization pass.
pub struct HemiRasterPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    params_buf: wgpu::Buffer,
    jobs_buf: wgpu::Buffer,
    jobs_capacity: u32,
    inst_buf: wgpu::Buffer,
    inst_capacity: u32,
    n_jobs: u32,
    depth_scale: f32,
    /// The scene's material bind groups (texture, sampler), group 1.
    material_groups: Vec<wgpu::BindGroup>,
    /// Draw id → index into `material_groups`.
    draw_material: Vec<usize>,
    /// Draw id of each instance of the current table.
    inst_draws: Vec<u32>,
}

fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    crate::util::storage_entry(binding, wgpu::ShaderStages::VERTEX_FRAGMENT, true)
}

impl HemiRasterPass {
    /// Creates the pass. `depth_scale` = 1 / the largest distance to order
    /// (e.g. the inverse of four times the scene diagonal). Tiles hold the
    /// drawn geometry only; the runtime takes the minimum with the baked
    /// maps where it reads them.
    pub fn new(device: &wgpu::Device, scene_gpu: &SceneGpu, depth_scale: f32) -> HemiRasterPass {
        let module =
            shaders::mesh_module(device, "hemi_raster.wgsl", include_str!("hemi_raster.wgsl"));
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hemi raster"),
            entries: &[
                storage_entry(0),
                storage_entry(1),
                storage_entry(2),
                storage_entry(3),
                crate::util::uniform_entry(4, wgpu::ShaderStages::VERTEX_FRAGMENT),
                storage_entry(5),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hemi raster"),
            bind_group_layouts: &[Some(&layout), Some(&scene_gpu.material_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("hemi raster"),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::TextureFormat::R32Float.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let params_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hemi raster params"),
            size: std::mem::size_of::<GpuRasterParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let jobs_capacity = 1;
        let jobs_buf = Self::buffer(device, "hemi jobs", jobs_capacity as u64 * 48);
        let inst_capacity = 1;
        let inst_buf = Self::buffer(device, "hemi instances", inst_capacity as u64 * 16);
        let bind_group = Self::bind(
            device,
            &layout,
            scene_gpu,
            &jobs_buf,
            &params_buf,
            &inst_buf,
        );
        let mut draw_material = Vec::new();
        for d in scene_gpu
            .static_draws
            .iter()
            .chain(&scene_gpu.dynamic_draws)
        {
            let id = d.id as usize;
            if draw_material.len() <= id {
                draw_material.resize(id + 1, 0);
            }
            draw_material[id] = d.material;
        }
        HemiRasterPass {
            pipeline,
            layout,
            bind_group,
            params_buf,
            jobs_buf,
            jobs_capacity,
            inst_buf,
            inst_capacity,
            n_jobs: 0,
            depth_scale,
            material_groups: scene_gpu.material_groups.clone(),
            draw_material,
            inst_draws: Vec::new(),
        }
    }

    fn buffer(device: &wgpu::Device, label: &str, bytes: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    fn bind(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        scene_gpu: &SceneGpu,
        jobs: &wgpu::Buffer,
        params: &wgpu::Buffer,
        instances: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("hemi raster"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: scene_gpu.draw_data.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: scene_gpu.vertices.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: scene_gpu.indices.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: jobs.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: instances.as_entire_binding(),
                },
            ],
        })
    }

    /// Uploads this frame's jobs and instance table `(draw, job, face, 0)`
    /// (growing the buffers if needed).
    #[allow(clippy::too_many_arguments)]
    pub fn set_work(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene_gpu: &SceneGpu,
        atlas: &HemiAtlas,
        jobs: &[GpuHemiJob],
        instances: &[[u32; 4]],
    ) {
        let mut rebind = false;
        if jobs.len() as u32 > self.jobs_capacity {
            self.jobs_capacity = (jobs.len() as u32).next_power_of_two();
            self.jobs_buf = Self::buffer(device, "hemi jobs", self.jobs_capacity as u64 * 48);
            rebind = true;
        }
        if instances.len() as u32 > self.inst_capacity {
            self.inst_capacity = (instances.len() as u32).next_power_of_two();
            self.inst_buf = Self::buffer(device, "hemi instances", self.inst_capacity as u64 * 16);
            rebind = true;
        }
        if rebind {
            self.bind_group = Self::bind(
                device,
                &self.layout,
                scene_gpu,
                &self.jobs_buf,
                &self.params_buf,
                &self.inst_buf,
            );
        }
        if !jobs.is_empty() {
            queue.write_buffer(&self.jobs_buf, 0, bytemuck::cast_slice(jobs));
        }
        if !instances.is_empty() {
            queue.write_buffer(&self.inst_buf, 0, bytemuck::cast_slice(instances));
        }
        self.n_jobs = jobs.len() as u32;
        self.inst_draws.clear();
        self.inst_draws.extend(instances.iter().map(|i| i[0]));
        let size = atlas.texture.size();
        let params = GpuRasterParams {
            atlas_size: [size.width as f32, size.height as f32],
            tile_size: atlas.tile_size as f32,
            depth_scale: self.depth_scale,
            pad: [0; 4],
        };
        queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&params));
    }

    /// Draws each `(index range, instance range)` pair: a mesh's indices (a
    /// level of detail of a [`Draw`]) for the instances of the table given
    /// to [`HemiRasterPass::set_work`]. `clear`: start every tile at
    /// "nothing"; otherwise keep the atlas contents. Returns the number of
    /// draw calls.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        atlas: &HemiAtlas,
        draws: &[(Range<u32>, Range<u32>)],
        clear: bool,
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) -> u32 {
        if self.n_jobs == 0 {
            return 0;
        }
        let load = if clear {
            wgpu::LoadOp::Clear(wgpu::Color {
                r: f32::MAX as f64,
                g: 0.0,
                b: 0.0,
                a: 0.0,
            })
        } else {
            wgpu::LoadOp::Load
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("hemi raster"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &atlas.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &atlas.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: ts,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        let mut calls = 0;
        let mut bound = None;
        for (indices, range) in draws {
            if !range.is_empty() {
                // Every instance of a range draws the same mesh: its material.
                let material = self
                    .inst_draws
                    .get(range.start as usize)
                    .and_then(|&d| self.draw_material.get(d as usize))
                    .copied()
                    .unwrap_or(self.material_groups.len() - 1)
                    .min(self.material_groups.len() - 1);
                if bound != Some(material) {
                    pass.set_bind_group(1, &self.material_groups[material], &[]);
                    bound = Some(material);
                }
                pass.draw(indices.clone(), range.clone());
                calls += 1;
            }
        }
        calls
    }
}
