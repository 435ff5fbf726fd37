//! Scene meshes on the GPU: one vertex/index buffer pair for all meshes,
//! a per-draw storage buffer (model matrix, albedo, alpha test) indexed by
//! `instance_index`, and one bind group per material texture.
//!
//! Static draws have identity transforms and never change; the world
//! matrices of dynamic draws are rewritten by [`SceneGpu::set_dynamic_transforms`].

use std::ops::Range;

use gibake_scene::Scene;
use glam::Mat4;
use wgpu::util::DeviceExt;

/// One interleaved vertex. Must match `VertexIn` in the passes' WGSL.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuVertex {
    /// Position (world for static meshes, local for dynamic ones).
    pub position: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// TEXCOORD_0 (0 when untextured).
    pub uv: [f32; 2],
}

impl GpuVertex {
    /// Vertex buffer layout: locations 0 position, 1 normal, 2 uv.
    pub const LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<GpuVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2],
    };
}

/// Per-draw data. Must match `DrawData` in `wgsl/mesh.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuDrawData {
    /// Object → world.
    pub model: [[f32; 4]; 4],
    /// Inverse-transpose of the model's upper 3×3 (columns padded).
    pub normal_matrix: [[f32; 4]; 4],
    /// rgb baseColorFactor, w = 1 if textured.
    pub albedo: [f32; 4],
    /// The alpha test (`alpha_keeps` in `wgsl/mesh.wgsl`): x alpha cutoff,
    /// y baseColorFactor's alpha, z = 1 if the material is masked, w unused.
    pub alpha: [f32; 4],
    /// x: base vertex (for vertex pulling), y: first index, z: triangle count, w: unused.
    pub extra: [u32; 4],
}

impl GpuDrawData {
    fn new(
        model: Mat4,
        material: &gibake_scene::Material,
        textured: bool,
        extra: [u32; 4],
    ) -> Self {
        let n = Mat4::from_mat3(glam::Mat3::from_mat4(model).inverse().transpose());
        let alpha = match material.cutoff() {
            Some(c) => [c, material.alpha, 1.0, 0.0],
            None => [0.0, 1.0, 0.0, 0.0],
        };
        GpuDrawData {
            model: model.to_cols_array_2d(),
            normal_matrix: n.to_cols_array_2d(),
            albedo: material
                .base_color
                .extend(if textured { 1.0 } else { 0.0 })
                .to_array(),
            alpha,
            extra,
        }
    }

    /// The same draw moved to `model`.
    fn moved(&self, model: Mat4) -> Self {
        let n = Mat4::from_mat3(glam::Mat3::from_mat4(model).inverse().transpose());
        GpuDrawData {
            model: model.to_cols_array_2d(),
            normal_matrix: n.to_cols_array_2d(),
            ..*self
        }
    }
}

/// One draw call: a mesh with its material.
#[derive(Clone, Debug)]
pub struct Draw {
    /// Range in the index buffer.
    pub indices: Range<u32>,
    /// Added to every index.
    pub base_vertex: i32,
    /// Index in the draw-data buffer (passed as `first_instance`).
    pub id: u32,
    /// Index into [`SceneGpu::material_groups`].
    pub material: usize,
    /// The mesh's material in the scene (`gibake_scene::Scene::materials`;
    /// [`Draw::material`] is the default group for an untextured one).
    pub scene_material: usize,
    /// The mesh's surface area in the space of [`Draw::bounds`] (local for
    /// a moving one): a quarter of it is a convex mesh's mean projected
    /// area, what it takes of the light round it.
    pub area: f32,
    /// Dynamic object index, `None` for static draws.
    pub object: Option<usize>,
    /// Bounds of the mesh: world space for static draws, local for dynamic.
    pub bounds: gibake_scene::Aabb,
    /// Index ranges of the levels of detail, finest first (`lods[0] ==
    /// indices`). Only moving meshes get coarser levels: they are drawn
    /// into low-resolution VPL maps every frame (see [`lod_for`]).
    pub lods: Vec<Range<u32>>,
}

/// Coarser index lists of a moving mesh (meshoptimizer's simplifier, same
/// vertices): about 1/4 and 1/16 of the triangles, each kept only if it
/// really is coarser. Deterministic.
fn simplified_lods(mesh: &gibake_scene::Mesh) -> Vec<Vec<u32>> {
    let tris = mesh.indices.len() / 3;
    if tris < 64 || mesh.positions.is_empty() {
        return Vec::new();
    }
    let pos: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
    let bytes: &[u8] = bytemuck::cast_slice(&pos);
    let Ok(adapter) = meshopt::VertexDataAdapter::new(bytes, 12, 0) else {
        return Vec::new();
    };
    let mut out: Vec<Vec<u32>> = Vec::new();
    let mut prev = mesh.indices.len();
    for ratio in [4usize, 16] {
        let target = ((tris / ratio).max(16)) * 3;
        let lod = meshopt::simplify(
            &mesh.indices,
            &adapter,
            target,
            0.25,
            meshopt::SimplifyOptions::None,
            None,
        );
        if !lod.is_empty() && lod.len() < prev * 3 / 4 {
            prev = lod.len();
            out.push(lod);
        }
    }
    out
}

/// The level of detail to draw a mesh with world bounds `b` into a
/// `map_size²` hemisphere map seen from `origin`: its angular size in map
/// texels (the map spans about π radians over `map_size` texels) picks
/// level 0 from 24 texels across, level 1 from 6, else level 2 (clamped to
/// the levels the mesh has).
pub fn lod_for(b: &gibake_scene::Aabb, origin: glam::Vec3, map_size: u32, levels: usize) -> usize {
    let r = (b.max - b.min).length() * 0.5;
    let d = (b.center() - origin).length();
    if levels <= 1 || d <= r {
        return 0;
    }
    let texels = 2.0 * (r / d).atan() * map_size as f32 / std::f32::consts::PI;
    let level = if texels >= 24.0 {
        0
    } else if texels >= 6.0 {
        1
    } else {
        2
    };
    level.min(levels - 1)
}

/// All scene geometry on the GPU.
pub struct SceneGpu {
    /// Interleaved vertices of every mesh.
    pub vertices: wgpu::Buffer,
    /// Indices of every mesh.
    pub indices: wgpu::Buffer,
    /// Per-draw data, indexed by `instance_index`.
    pub draw_data: wgpu::Buffer,
    /// Static draws.
    pub static_draws: Vec<Draw>,
    /// Dynamic draws.
    pub dynamic_draws: Vec<Draw>,
    /// Layout of group 0 of mesh passes: the draw-data buffer (binding 0),
    /// the pass uniform (binding 1, owned by the pass).
    pub material_layout: wgpu::BindGroupLayout,
    /// One bind group per material: texture (binding 0), sampler (binding 1).
    pub material_groups: Vec<wgpu::BindGroup>,
    cpu_draw_data: Vec<GpuDrawData>,
    /// The first draw-data slot of the spare room (draws below it are the
    /// scene's own).
    first_spare: u32,
    /// Draw-data slots still free for [`SceneGpu::add_instance`].
    spare: Range<u32>,
}

impl SceneGpu {
    /// Uploads every static and dynamic mesh of `scene`, dynamic objects
    /// placed at time `time`.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene, time: f32) -> SceneGpu {
        SceneGpu::with_spare_draws(device, queue, scene, time, 0)
    }

    /// [`SceneGpu::new`] with room for `spare_draws` more draws of moving
    /// objects ([`SceneGpu::add_instance`]).
    pub fn with_spare_draws(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        time: f32,
        spare_draws: u32,
    ) -> SceneGpu {
        let mut vertices: Vec<GpuVertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut draw_data = Vec::new();
        let mut static_draws = Vec::new();
        let mut dynamic_draws = Vec::new();
        let mut push = |mesh: &gibake_scene::Mesh, model: Mat4, object: Option<usize>| {
            let base_vertex = vertices.len() as i32;
            let uvs = mesh.uvs.as_deref();
            for (i, (p, n)) in mesh.positions.iter().zip(&mesh.normals).enumerate() {
                let uv = uvs.map(|u| u[i].to_array()).unwrap_or([0.0; 2]);
                vertices.push(GpuVertex {
                    position: p.to_array(),
                    normal: n.to_array(),
                    uv,
                });
            }
            let start = indices.len() as u32;
            indices.extend_from_slice(&mesh.indices);
            let m = &scene.materials[mesh.material];
            let textured = m.texture.is_some() && mesh.uvs.is_some();
            let id = draw_data.len() as u32;
            let tris = (indices.len() as u32 - start) / 3;
            draw_data.push(GpuDrawData::new(
                model,
                m,
                textured,
                [base_vertex as u32, start, tris, 0],
            ));
            let mut bounds = gibake_scene::Aabb::EMPTY;
            for p in &mesh.positions {
                bounds.grow(*p);
            }
            let lod0 = start..indices.len() as u32;
            let mut lods = vec![lod0.clone()];
            if object.is_some() {
                for level in simplified_lods(mesh) {
                    let s = indices.len() as u32;
                    indices.extend_from_slice(&level);
                    lods.push(s..indices.len() as u32);
                }
            }
            let d = Draw {
                indices: lod0,
                lods,
                base_vertex,
                id,
                material: if textured {
                    mesh.material
                } else {
                    scene.materials.len()
                },
                scene_material: mesh.material,
                area: mesh
                    .indices
                    .chunks_exact(3)
                    .map(|t| {
                        let p = |i: u32| {
                            mesh.positions
                                .get(i as usize)
                                .copied()
                                .unwrap_or(glam::Vec3::ZERO)
                        };
                        let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
                        0.5 * (b - a).cross(c - a).length()
                    })
                    .filter(|a| a.is_finite())
                    .sum(),
                object,
                bounds,
            };
            if object.is_some() {
                dynamic_draws.push(d)
            } else {
                static_draws.push(d)
            }
        };
        for m in &scene.static_meshes {
            push(m, Mat4::IDENTITY, None);
        }
        for (oi, o) in scene.dynamic_objects.iter().enumerate() {
            let model = scene.dynamic_transform(oi, time);
            for &mi in &o.meshes {
                push(&scene.dynamic_meshes[mi], model, Some(oi));
            }
        }
        if vertices.is_empty() {
            vertices.push(GpuVertex {
                position: [0.0; 3],
                normal: [0.0, 1.0, 0.0],
                uv: [0.0; 2],
            });
        }
        if indices.is_empty() {
            indices.extend_from_slice(&[0, 0, 0]);
        }
        let first_spare = draw_data.len() as u32;
        draw_data.extend(std::iter::repeat_n(
            <GpuDrawData as bytemuck::Zeroable>::zeroed(),
            spare_draws as usize,
        ));
        if draw_data.is_empty() {
            draw_data.push(GpuDrawData::new(
                Mat4::IDENTITY,
                &gibake_scene::Material::opaque("none", glam::Vec3::ONE, None),
                false,
                [0; 4],
            ));
        }
        let vb = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene vertices"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
        });
        let ib = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE,
        });
        let db = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("draw data"),
            contents: bytemuck::cast_slice(&draw_data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let material_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("material"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: true },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                    count: None,
                },
            ],
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("albedo"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            // Trilinear over the mip chain (crate::mips).
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let max_side = device.limits().max_texture_dimension_2d;
        let make_group = |tex: &gibake_scene::Texture| {
            // A texture over the device's limit (the import already keeps
            // sides ≤ --max-texture-size) is downscaled, never a wgpu panic.
            let fitted = gibake_scene::limits::downscale_to_fit(tex, max_side);
            if let Some(f) = &fitted {
                tracing::warn!(
                    "texture {}x{} exceeds the GPU's limit of {max_side}; downscaled to {}x{}",
                    tex.width,
                    tex.height,
                    f.width,
                    f.height
                );
            }
            let tex = fitted.as_ref().unwrap_or(tex);
            let (w, h) = (tex.width.max(1), tex.height.max(1));
            let t = device.create_texture_with_data(
                queue,
                &wgpu::TextureDescriptor {
                    label: Some("albedo texture"),
                    size: wgpu::Extent3d {
                        width: w,
                        height: h,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: crate::mips::level_count(w, h),
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba8UnormSrgb,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                &crate::mips::chain(w, h, &tex.rgba8_srgb),
            );
            let view = t.create_view(&Default::default());
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("material"),
                layout: &material_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::Sampler(&sampler),
                    },
                ],
            })
        };
        // Group per material (untextured ones reuse the white texture at the end).
        let white = gibake_scene::Texture {
            width: 1,
            height: 1,
            rgba8_srgb: vec![255; 4],
        };
        let mut material_groups = Vec::with_capacity(scene.materials.len() + 1);
        for m in &scene.materials {
            match m.texture {
                Some(t) => material_groups.push(make_group(&scene.textures[t])),
                None => material_groups.push(make_group(&white)),
            }
        }
        material_groups.push(make_group(&white));
        SceneGpu {
            vertices: vb,
            indices: ib,
            draw_data: db,
            static_draws,
            dynamic_draws,
            material_layout,
            material_groups,
            cpu_draw_data: draw_data,
            first_spare,
            spare: first_spare..first_spare + spare_draws,
        }
    }

    /// Draws moving object `template`'s meshes once more, as moving object
    /// `object` at `model` (its later matrices come with
    /// [`SceneGpu::set_dynamic_transforms`]), in the spare draw-data room of
    /// [`SceneGpu::with_spare_draws`]. Returns `false` and changes nothing
    /// when the room is too small or `template` has no draws.
    pub fn add_instance(
        &mut self,
        queue: &wgpu::Queue,
        template: usize,
        object: usize,
        model: Mat4,
    ) -> bool {
        let originals: Vec<Draw> = self
            .dynamic_draws
            .iter()
            .filter(|d| d.object == Some(template) && d.id < self.first_spare)
            .cloned()
            .collect();
        let n = originals.len() as u32;
        if n == 0 || self.spare.len() < n as usize {
            return false;
        }
        let start = self.spare.start;
        for (k, d) in originals.into_iter().enumerate() {
            let id = start + k as u32;
            self.cpu_draw_data[id as usize] = self.cpu_draw_data[d.id as usize].moved(model);
            self.dynamic_draws.push(Draw {
                id,
                object: Some(object),
                ..d
            });
        }
        self.spare.start += n;
        let range = &self.cpu_draw_data[start as usize..self.spare.start as usize];
        queue.write_buffer(
            &self.draw_data,
            (start as usize * std::mem::size_of::<GpuDrawData>()) as u64,
            bytemuck::cast_slice(range),
        );
        true
    }

    /// Rewrites the world matrices of the dynamic draws from one matrix per
    /// dynamic object (the game-facing way to move objects).
    pub fn set_dynamic_transforms(&mut self, queue: &wgpu::Queue, transforms: &[Mat4]) {
        let Some(first) = self.dynamic_draws.first().map(|d| d.id as usize) else {
            return;
        };
        for d in &self.dynamic_draws {
            let o = d.object.expect("dynamic draw has an object");
            let Some(&model) = transforms.get(o) else {
                continue;
            };
            let old = self.cpu_draw_data[d.id as usize];
            self.cpu_draw_data[d.id as usize] = old.moved(model);
        }
        let range = &self.cpu_draw_data[first..];
        queue.write_buffer(
            &self.draw_data,
            (first * std::mem::size_of::<GpuDrawData>()) as u64,
            bytemuck::cast_slice(range),
        );
    }

    /// Records the draws (static, dynamic or both) into a render pass whose
    /// pipeline uses group 1 for the material (if `materials`).
    pub fn draw<'d>(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        draws: impl IntoIterator<Item = &'d Draw>,
        materials: bool,
    ) {
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        for d in draws {
            if materials {
                pass.set_bind_group(1, &self.material_groups[d.material], &[]);
            }
            pass.draw_indexed(d.indices.clone(), d.base_vertex, d.id..d.id + 1);
        }
    }
}

/// WGSL for mesh passes: vertex input and per-draw data. Must match
/// [`GpuVertex`] and [`GpuDrawData`].
pub const MESH_WGSL: &str = include_str!("wgsl/mesh.wgsl");
