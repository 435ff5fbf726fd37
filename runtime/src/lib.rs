//! gibake's game-facing runtime.
//!
//! A [`Renderer`] owns the GPU resources for one scene and (except in
//! `direct` mode) one baked asset, on the caller's `wgpu::Device`. Each
//! frame the caller moves the dynamic objects ([`Renderer::set_time`]
//! samples the scene's animation; [`Renderer::set_dynamic_transforms`] takes
//! the game's own matrices), records the frame with [`Renderer::encode`], and
//! reads or samples [`Renderer::output`] (linear radiance, `Rgba32Float`).
//!
//! Per frame, only what moving objects cause is done (design brief, steps
//! 4–8), all on the GPU, with no read-back:
//! 1. moving objects → their own primary shadow map; shading takes the
//!    minimum with the baked static map (the z-min merge, without copying);
//! 2. moving objects → a small RSM at the bake's RSM resolution; texels where
//!    they are nearer the light than the static surface
//!    - scale the static VPLs' flux by their lit fraction (partial occlusion),
//!    - become dynamic VPLs (quadtree on the GPU);
//! 3. static VPL maps: only the VPLs whose hemisphere a moving object's
//!    bounds enter get a tile in which the moving objects are rasterized
//!    exactly; shading takes the minimum with the baked map. A VPL no longer
//!    affected simply has no tile: its baked map is used as it is.
//! 4. G-buffer, then shading.
//!
//! With no moving objects none of 1–3 exists: no pass, no texture.

pub mod baked;
pub mod camera;
pub mod dynamic_rsm;
pub mod dynamic_vpl;
pub mod gbuffer;
pub mod interleave;
pub mod shade;
pub mod timer;
pub mod transport;

use std::time::Instant;

use gibake_asset::Asset;
use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::passes::hemi_raster::{GpuHemiJob, HemiAtlas, HemiRasterPass, face_mask};
use gibake_gpu::passes::shadow::ShadowPass;
use gibake_gpu::{GpuContext, GpuError, GpuPrimaryLight, LightView, hemisphere};
use gibake_image::Image;
use gibake_scene::{Aabb, Scene};
use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

pub use camera::{CameraMatrices, NoCamera};

/// What a frame contains (the `--mode` of `gibake render`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Mode {
    /// The method: direct + static VPLs with merged maps + dynamic VPLs.
    #[default]
    Full,
    /// Direct light only (needs no asset).
    Direct,
    /// The indirect part of `Full`.
    Indirect,
    /// Dachsbacher's RSM: direct + every VPL, no VPL visibility.
    Rsm,
    /// Like `Full`, but every VPL map is re-rendered from all geometry every
    /// frame (the cost baseline; same image).
    Naive,
}

/// Settings of a [`Renderer`].
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Primary shadow map resolution when no asset is given (direct mode);
    /// with an asset, the baked map's resolution is used.
    pub shadow_map_size: u32,
    /// What to render.
    pub mode: Mode,
    /// Most dynamic VPLs per frame (rounded up to a power of 4; 0: none).
    pub max_dynamic_vpls: u32,
    /// Interleaved VPL sampling: 1 (every pixel sums every VPL), 2, 4 or 8
    /// (each pixel of an N×N block sums a disjoint 1/N² of the VPLs, and a
    /// geometry-aware filter over its neighbours reconstructs the sum; see
    /// [`interleave`]). Other values are [`RuntimeError::InvalidSetting`].
    pub interleave: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            max_dynamic_vpls: 256,
            width: 640,
            height: 480,
            shadow_map_size: 2048,
            mode: Mode::Full,
            interleave: 1,
        }
    }
}

/// Runtime errors.
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    /// The scene has no camera.
    #[error(transparent)]
    NoCamera(#[from] NoCamera),
    /// A GPU operation failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The asset does not fit the scene.
    #[error(transparent)]
    Asset(#[from] gibake_asset::AssetError),
    /// A bad setting (zero size, size over the device's limits, ...).
    #[error("invalid render setting: {0}")]
    InvalidSetting(String),
    /// The mode needs a baked asset.
    #[error("--mode {0} needs a baked asset (--bake OUT.gibake); run `gibake bake` first")]
    NeedsAsset(&'static str),
}

/// Per-frame counts and times.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    /// "gpu timestamps" or "wall (no timestamp queries on this adapter)".
    pub timing: String,
    /// Per pass `(name, milliseconds)`, in order.
    pub passes: Vec<(String, f64)>,
    /// Static VPLs shaded.
    pub static_vpls: u32,
    /// Dynamic VPL slots shaded.
    pub dynamic_vpl_slots: u32,
    /// VPL maps into which moving objects were rasterized this frame.
    pub affected_maps: u32,
    /// Draw calls recorded by the per-frame update (merge passes).
    pub update_draw_calls: u32,
    /// Draw calls in total.
    pub draw_calls: u32,
}

impl FrameStats {
    /// Sum of the update passes (everything but G-buffer, shading and its
    /// interleave filter).
    pub fn update_ms(&self) -> f64 {
        self.passes
            .iter()
            .filter(|(n, _)| n != "gbuffer" && n != "shade" && n != "interleave")
            .map(|(_, t)| t)
            .sum()
    }
}

/// What the frame bind group needs besides the G-buffer.
struct FrameViews {
    primary_static: wgpu::TextureView,
    primary_dynamic: wgpu::TextureView,
    light_view_buf: wgpu::Buffer,
    /// What the shade pass writes: the final output, or interleaved, the
    /// filter's input.
    output: wgpu::TextureView,
    /// The renderer's output.
    final_output: wgpu::TextureView,
}

impl FrameViews {
    fn group(
        &self,
        device: &wgpu::Device,
        shade: &shade::ShadePass,
        gbuffer: [&wgpu::TextureView; 3],
        light: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        shade.frame_group(
            device,
            &shade::FrameInputs {
                gbuffer,
                primary_static: &self.primary_static,
                primary_dynamic: &self.primary_dynamic,
                light,
                light_view: &self.light_view_buf,
                output: &self.output,
            },
        )
    }
}

struct HemiState {
    /// Per static VPL: (map origin, normal), computed once.
    frames: std::sync::Arc<[(Vec3, Vec3)]>,
    pass: HemiRasterPass,
    atlas: HemiAtlas,
    tile_buf: wgpu::Buffer,
    jobs: Vec<GpuHemiJob>,
    tiles: Vec<u32>,
}

/// Renders frames of one scene.
pub struct Renderer {
    settings: RenderSettings,
    scene_gpu: SceneGpu,
    baked: Option<baked::BakedGpu>,
    _own_static: Option<ShadowPass>,
    dyn_primary: Option<ShadowPass>,
    dyn_rsm: Option<dynamic_rsm::DynamicRsmPass>,
    occlusion: Option<dynamic_rsm::OcclusionPass>,
    hemi: Option<HemiState>,
    gbuffer: gbuffer::GBuffer,
    gbuffer_pass: gbuffer::GBufferPass,
    shade: shade::ShadePass,
    /// The interleave filter (interleave > 1 only).
    interleave: Option<interleave::InterleavePass>,
    frame_group: wgpu::BindGroup,
    /// Built right after construction (it needs the renderer's resources).
    gi_group: Option<wgpu::BindGroup>,
    frame_views: FrameViews,
    external_gbuffer: bool,
    params: shade::GpuShadeParams,
    output: wgpu::Texture,
    _light_buf: wgpu::Buffer,
    dummy_buf: wgpu::Buffer,
    dyn_vpl_buf: wgpu::Buffer,
    dyn_vpls: Option<dynamic_vpl::DynamicVplPass>,
    camera: CameraMatrices,
    transforms: Vec<Mat4>,
    timer: Option<timer::Timer>,
    stats: FrameStats,
    wall_start: Option<Instant>,
}

fn mode_name(m: Mode) -> &'static str {
    match m {
        Mode::Full => "full",
        Mode::Direct => "direct",
        Mode::Indirect => "indirect",
        Mode::Rsm => "rsm",
        Mode::Naive => "naive",
    }
}

impl Renderer {
    /// Creates every GPU resource for `scene` (and `asset`, needed by every
    /// mode but `Direct`), with moving objects at `time`. The asset must
    /// have been baked from this scene's static part.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        asset: Option<&Asset>,
        settings: &RenderSettings,
        time: f32,
    ) -> Result<Renderer, RuntimeError> {
        let limit = device.limits().max_texture_dimension_2d;
        for (what, v) in [
            ("width", settings.width),
            ("height", settings.height),
            ("shadow map size", settings.shadow_map_size),
        ] {
            if v == 0 || v > limit {
                return Err(RuntimeError::InvalidSetting(format!(
                    "{what} {v} must be in 1..={limit} on this device"
                )));
            }
        }
        if !interleave::VALID.contains(&settings.interleave) {
            return Err(RuntimeError::InvalidSetting(format!(
                "interleave {} must be 1, 2, 4 or 8",
                settings.interleave
            )));
        }
        let mode = settings.mode;
        if asset.is_none() && mode != Mode::Direct {
            return Err(RuntimeError::NeedsAsset(mode_name(mode)));
        }
        if let Some(a) = asset {
            gibake_asset::check_scene_hash(
                &a.manifest,
                &gibake_scene::static_scene_hash(scene),
                &scene.source,
            )?;
        }
        let camera = CameraMatrices::new(scene, time, settings.width, settings.height)?;
        let scene_gpu = SceneGpu::new(device, queue, scene, time);
        let has_dynamic = !scene.dynamic_objects.is_empty();
        let indirect = mode != Mode::Direct;

        let baked = match asset {
            Some(a) => Some(baked::BakedGpu::new(device, queue, a)?),
            None => None,
        };
        // Primary shadow map: baked static map, or rendered once here.
        let (view, own_static) = match &baked {
            Some(b) => (b.view, None),
            None => {
                let view =
                    LightView::new(&scene.light, &scene.full_bounds(), settings.shadow_map_size);
                let pass = ShadowPass::new(device, &scene_gpu, view);
                let mut enc = device.create_command_encoder(&Default::default());
                pass.encode(&mut enc, &scene_gpu, &[&scene_gpu.static_draws], None);
                queue.submit([enc.finish()]);
                (view, Some(pass))
            }
        };
        let primary_static = match (&baked, &own_static) {
            (Some(b), _) => b.primary.clone(),
            (None, Some(p)) => p.metric_view.clone(),
            (None, None) => unreachable!("one of the two exists"),
        };
        let dyn_primary = has_dynamic.then(|| ShadowPass::new(device, &scene_gpu, view));
        let light_view_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("primary light view"),
            contents: bytemuck::bytes_of(&view.to_gpu()),
            usage: wgpu::BufferUsages::UNIFORM,
        });

        // Moving objects' RSM and partial occlusion.
        let (dyn_rsm, occlusion) = match (&baked, has_dynamic && indirect) {
            (Some(b), true) => match &b.rsm {
                Some(r) => {
                    let pass = dynamic_rsm::DynamicRsmPass::new(device, &scene_gpu, &r.view);
                    let occ = dynamic_rsm::OcclusionPass::new(
                        device,
                        &r.static_metric,
                        &pass,
                        &r.texel_info,
                        b.vpls.len() as u32,
                    );
                    (Some(pass), Some(occ))
                }
                None => (None, None),
            },
            _ => (None, None),
        };

        // Hemisphere-map merge (full/indirect with moving objects) or
        // re-render (naive).
        let needs_hemi = match mode {
            Mode::Naive => true,
            Mode::Full | Mode::Indirect => has_dynamic,
            _ => false,
        };
        let hemi = match (&baked, needs_hemi) {
            (Some(b), true) => {
                let n = b.vpls.len() as u32;
                let capacity = if mode == Mode::Naive { n } else { n.min(64) };
                let atlas = HemiAtlas::new(device, b.map_size, capacity);
                let diag = scene.full_bounds().diagonal().max(f32::MIN_POSITIVE);
                let pass = HemiRasterPass::new(device, &scene_gpu, 1.0 / (4.0 * diag));
                let tile_buf = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("VPL tiles"),
                    size: 4 * n.max(1) as u64,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let frames = b
                    .vpls
                    .iter()
                    .map(|v| {
                        let n = Vec3::from_array(v.normal);
                        (
                            hemisphere::vpl_origin(Vec3::from_array(v.position), n, v.area),
                            n,
                        )
                    })
                    .collect();
                Some(HemiState {
                    frames,
                    pass,
                    atlas,
                    tile_buf,
                    jobs: Vec::new(),
                    tiles: vec![u32::MAX; n as usize],
                })
            }
            _ => None,
        };

        let gbuffer = gbuffer::GBuffer::new(device, settings.width, settings.height);
        let gbuffer_pass = gbuffer::GBufferPass::new(device, &scene_gpu);
        let output = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("radiance"),
            size: wgpu::Extent3d {
                width: settings.width,
                height: settings.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: shade::RADIANCE_FORMAT,
            usage: wgpu::TextureUsages::STORAGE_BINDING
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let light_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("primary light"),
            contents: bytemuck::bytes_of(&GpuPrimaryLight::new(&scene.light)),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let out_view = output.create_view(&Default::default());
        let shade = shade::ShadePass::new(device);
        let size = [settings.width, settings.height];
        let mut interleave = (settings.interleave > 1)
            .then(|| interleave::InterleavePass::new(device, queue, size, settings.interleave));
        if let Some(il) = &mut interleave {
            il.bind(
                device,
                [&gbuffer.views[0], &gbuffer.views[1], &gbuffer.views[2]],
                &out_view,
            );
        }
        // Interleaved, the shade pass writes the filter's input instead.
        let shade_out = match &interleave {
            Some(il) => il.shaded.clone(),
            None => out_view.clone(),
        };
        let dyn_primary_view = dyn_primary
            .as_ref()
            .map(|p| p.metric_view.clone())
            .unwrap_or_else(|| primary_static.clone());
        let frame_views = FrameViews {
            primary_static,
            primary_dynamic: dyn_primary_view,
            light_view_buf,
            output: shade_out,
            final_output: out_view,
        };
        let frame_group = frame_views.group(
            device,
            &shade,
            [&gbuffer.views[0], &gbuffer.views[1], &gbuffer.views[2]],
            &light_buf,
        );
        let dummy_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("dummy"),
            size: 64,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let dyn_vpl_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("no dynamic VPLs"),
            size: 48,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        // Dynamic VPLs: moving surfaces of the dynamic RSM, clustered on the
        // GPU with the bake's rule and threshold.
        let dyn_vpls = match (&dyn_rsm, &baked, asset) {
            (Some(r), Some(b), Some(a)) if settings.max_dynamic_vpls > 0 => {
                b.rsm.as_ref().map(|rg| {
                    dynamic_vpl::DynamicVplPass::new(
                        device,
                        r,
                        &rg.static_metric,
                        &light_buf,
                        a.manifest.settings.threshold,
                        settings.max_dynamic_vpls,
                    )
                })
            }
            _ => None,
        };

        let mut flags = match mode {
            Mode::Direct => shade::FLAG_DIRECT,
            Mode::Full | Mode::Naive => {
                shade::FLAG_DIRECT | shade::FLAG_STATIC_VPL | shade::FLAG_VISIBILITY
            }
            Mode::Indirect => shade::FLAG_STATIC_VPL | shade::FLAG_VISIBILITY,
            Mode::Rsm => shade::FLAG_DIRECT | shade::FLAG_STATIC_VPL,
        };
        if mode == Mode::Naive {
            flags |= shade::FLAG_ATLAS_ONLY;
        }
        if dyn_primary.is_some() {
            flags |= shade::FLAG_DYN_PRIMARY;
        }
        if occlusion.is_some() {
            flags |= shade::FLAG_OCCLUSION;
        }
        // Without a merge atlas there is no tile buffer: every VPL uses its
        // baked map alone (a static scene, or rsm mode).
        if hemi.is_some() {
            flags |= shade::FLAG_TILES;
        }
        if dyn_vpls.is_some() && mode != Mode::Direct {
            flags |= shade::FLAG_DYNAMIC_VPL;
        }
        let params = shade::GpuShadeParams {
            size: [settings.width, settings.height],
            flags,
            n_static: baked.as_ref().map(|b| b.vpls.len() as u32).unwrap_or(0),
            map_size: baked.as_ref().map(|b| b.map_size).unwrap_or(1),
            atlas_cols: hemi.as_ref().map(|h| h.atlas.cols).unwrap_or(1),
            n_dynamic: dyn_vpls.as_ref().map(|d| d.slots()).unwrap_or(0),
            static_cols: baked.as_ref().map(|b| b.static_cols).unwrap_or(1),
            interleave: settings.interleave,
            _pad: [0; 3],
        };
        queue.write_buffer(&shade.uniform_buf, 0, bytemuck::bytes_of(&params));
        queue.write_buffer(
            &gbuffer_pass.uniform_buf,
            0,
            bytemuck::bytes_of(&camera.to_gpu()),
        );

        let transforms = (0..scene.dynamic_objects.len())
            .map(|i| scene.dynamic_transform(i, time))
            .collect();
        let mut r = Renderer {
            settings: settings.clone(),
            scene_gpu,
            baked,
            _own_static: own_static,
            dyn_primary,
            dyn_rsm,
            occlusion,
            hemi,
            gbuffer,
            gbuffer_pass,
            shade,
            interleave,
            frame_group,
            gi_group: None,
            frame_views,
            external_gbuffer: false,
            params,
            output,
            _light_buf: light_buf,
            dummy_buf,
            dyn_vpl_buf,
            dyn_vpls,
            camera,
            transforms,
            timer: timer::Timer::new(device, queue, 9),
            stats: FrameStats::default(),
            wall_start: None,
        };
        r.gi_group = Some(r.make_gi_group(device));
        Ok(r)
    }

    fn make_gi_group(&self, device: &wgpu::Device) -> wgpu::BindGroup {
        let fallback_maps;
        let static_maps = match &self.baked {
            Some(b) => &b.static_maps,
            None => {
                fallback_maps = tiny_texture(device);
                &fallback_maps
            }
        };
        let fallback_atlas;
        let atlas = match &self.hemi {
            Some(h) => &h.atlas.view,
            None => {
                fallback_atlas = tiny_texture(device);
                &fallback_atlas
            }
        };
        self.shade.gi_group(
            device,
            &shade::GiInputs {
                vpls: self
                    .baked
                    .as_ref()
                    .map(|b| &b.vpl_buf)
                    .unwrap_or(&self.dummy_buf),
                occlusion: self
                    .occlusion
                    .as_ref()
                    .map(|o| &o.occluded)
                    .unwrap_or(&self.dummy_buf),
                vpl_tile: self
                    .hemi
                    .as_ref()
                    .map(|h| &h.tile_buf)
                    .unwrap_or(&self.dummy_buf),
                static_maps,
                atlas,
                dyn_vpls: self
                    .dyn_vpls
                    .as_ref()
                    .map(|d| &d.vpls)
                    .unwrap_or(&self.dyn_vpl_buf),
                vpl_nodes: self
                    .baked
                    .as_ref()
                    .map(|b| &b.node_buf)
                    .unwrap_or(&self.dummy_buf),
            },
        )
    }

    /// Moves the dynamic objects and the camera to the scene's animation at `time`.
    pub fn set_time(
        &mut self,
        queue: &wgpu::Queue,
        scene: &Scene,
        time: f32,
    ) -> Result<(), RuntimeError> {
        let transforms: Vec<Mat4> = (0..scene.dynamic_objects.len())
            .map(|i| scene.dynamic_transform(i, time))
            .collect();
        self.set_dynamic_transforms(queue, &transforms);
        self.set_camera(
            queue,
            CameraMatrices::new(scene, time, self.settings.width, self.settings.height)?,
        );
        Ok(())
    }

    /// Sets the dynamic objects' world matrices (one per
    /// `Scene::dynamic_objects` entry), as a game would each frame.
    pub fn set_dynamic_transforms(&mut self, queue: &wgpu::Queue, transforms: &[Mat4]) {
        for (t, m) in self.transforms.iter_mut().zip(transforms) {
            *t = *m;
        }
        self.scene_gpu.set_dynamic_transforms(queue, transforms);
    }

    /// Sets the camera.
    pub fn set_camera(&mut self, queue: &wgpu::Queue, camera: CameraMatrices) {
        self.camera = camera;
        queue.write_buffer(
            &self.gbuffer_pass.uniform_buf,
            0,
            bytemuck::bytes_of(&camera.to_gpu()),
        );
    }

    /// Records one frame. Needs the device to grow the merge atlas when
    /// more VPL maps are affected than ever before.
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
    ) {
        self.wall_start = Some(Instant::now());
        let mut stats = FrameStats {
            static_vpls: self.params.n_static,
            ..Default::default()
        };
        if let Some(t) = self.timer.as_mut() {
            t.reset();
        }
        let mut calls = 0u32;
        // 1. Moving objects into their primary shadow map.
        if let Some(p) = &self.dyn_primary {
            let ts = self.timer.as_mut().and_then(|t| t.render("primary merge"));
            p.encode(
                encoder,
                &self.scene_gpu,
                &[&self.scene_gpu.dynamic_draws],
                ts,
            );
            calls += self.scene_gpu.dynamic_draws.len() as u32;
        }
        // 2. Moving objects' RSM, partial occlusion.
        if let (Some(r), Some(o)) = (&self.dyn_rsm, &self.occlusion) {
            let ts = self.timer.as_mut().and_then(|t| t.render("dynamic rsm"));
            calls += r.encode(encoder, &self.scene_gpu, ts);
            let ts = self.timer.as_mut().and_then(|t| t.compute("occlusion"));
            o.encode(encoder, ts);
            if let Some(d) = &self.dyn_vpls {
                d.encode(encoder, self.timer.as_mut());
            }
        }
        // 3. VPL maps: per (draw, VPL, octahedron face) instances, only where
        // the draw's bounds can reach.
        if let (Some(b), Some(capacity)) =
            (&self.baked, self.hemi.as_ref().map(|h| h.atlas.capacity))
        {
            let naive = self.settings.mode == Mode::Naive;
            let draws: Vec<&gibake_gpu::mesh::Draw> = if naive {
                self.scene_gpu
                    .static_draws
                    .iter()
                    .chain(&self.scene_gpu.dynamic_draws)
                    .collect()
            } else {
                self.scene_gpu.dynamic_draws.iter().collect()
            };
            let boxes: Vec<Aabb> = draws
                .iter()
                .map(|d| match d.object {
                    Some(o) => d.bounds.transformed(self.transforms[o]),
                    None => d.bounds,
                })
                .collect();
            // masks[v][k]: faces of VPL v's map that draw k can touch.
            let frames = self
                .hemi
                .as_ref()
                .map(|h| h.frames.clone())
                .unwrap_or_default();
            let masks: Vec<Vec<u32>> = frames
                .iter()
                .map(|(o, n)| boxes.iter().map(|bx| face_mask(bx, *o, *n)).collect())
                .collect();
            // Full: only VPLs some moving object reaches get a tile.
            let chosen: Vec<u32> = (0..b.vpls.len() as u32)
                .filter(|&v| naive || masks[v as usize].iter().any(|&m| m != 0))
                .collect();
            let map_size = b.map_size;
            if chosen.len() as u32 > capacity {
                let cap = (chosen.len() as u32)
                    .next_power_of_two()
                    .min(b.vpls.len() as u32);
                if let Some(h) = self.hemi.as_mut() {
                    h.atlas = HemiAtlas::new(device, map_size, cap);
                    self.params.atlas_cols = h.atlas.cols;
                }
                queue.write_buffer(&self.shade.uniform_buf, 0, bytemuck::bytes_of(&self.params));
                self.gi_group = Some(self.make_gi_group(device));
            }
            let Some(h) = self.hemi.as_mut() else {
                unreachable!("checked above")
            };
            h.jobs.clear();
            h.tiles.iter_mut().for_each(|t| *t = u32::MAX);
            for (slot, &v) in chosen.iter().enumerate() {
                let (o, n) = frames[v as usize];
                let t = h.atlas.tile_origin(slot as u32);
                h.jobs.push(GpuHemiJob {
                    origin: o.extend(0.0).to_array(),
                    normal: n.extend(0.0).to_array(),
                    tile: [t[0], t[1], 0, 0],
                });
                h.tiles[v as usize] = slot as u32;
            }
            // Moving meshes use the level of detail matched to their size in
            // each map; instances are grouped per (draw, level).
            let mut instances: Vec<[u32; 4]> = Vec::new();
            let mut ranges = Vec::with_capacity(draws.len());
            for (k, d) in draws.iter().enumerate() {
                let levels: Vec<usize> = chosen
                    .iter()
                    .map(|&v| {
                        if d.object.is_some() {
                            gibake_gpu::mesh::lod_for(
                                &boxes[k],
                                frames[v as usize].0,
                                map_size,
                                d.lods.len(),
                            )
                        } else {
                            0
                        }
                    })
                    .collect();
                for (level, lod) in d.lods.iter().enumerate() {
                    let start = instances.len() as u32;
                    for (slot, &v) in chosen.iter().enumerate() {
                        let m = masks[v as usize][k];
                        if levels[slot] != level || m == 0 {
                            continue;
                        }
                        for face in 0..4 {
                            if m & (1 << face) != 0 {
                                instances.push([d.id, slot as u32, face, 0]);
                            }
                        }
                    }
                    ranges.push((lod.clone(), start..instances.len() as u32));
                }
            }
            queue.write_buffer(&h.tile_buf, 0, bytemuck::cast_slice(&h.tiles));
            h.pass.set_work(
                device,
                queue,
                &self.scene_gpu,
                &h.atlas,
                &h.jobs,
                &instances,
            );
            stats.affected_maps = chosen.len() as u32;
            if !chosen.is_empty() {
                let ts = self.timer.as_mut().and_then(|t| t.render("vpl maps"));
                calls += h.pass.encode(encoder, &h.atlas, &ranges, true, ts);
            }
        }
        stats.update_draw_calls = calls;
        // 4. G-buffer and shading.
        let all = [
            &self.scene_gpu.static_draws[..],
            &self.scene_gpu.dynamic_draws[..],
        ];
        if !self.external_gbuffer {
            let ts = self.timer.as_mut().and_then(|t| t.render("gbuffer"));
            self.gbuffer_pass
                .encode(encoder, &self.gbuffer, &self.scene_gpu, &all, ts);
            calls += (all[0].len() + all[1].len()) as u32;
        }
        let ts = self.timer.as_mut().and_then(|t| t.compute("shade"));
        self.shade.encode(
            encoder,
            &self.frame_group,
            self.gi_group.as_ref().expect("built in Renderer::new"),
            [self.settings.width, self.settings.height],
            ts,
        );
        if let Some(il) = &self.interleave {
            let ts = self.timer.as_mut().and_then(|t| t.compute("interleave"));
            il.encode(encoder, ts);
        }
        if let Some(t) = &self.timer {
            t.resolve(encoder);
        }
        stats.draw_calls = calls;
        stats.dynamic_vpl_slots = self.params.n_dynamic;
        self.stats = stats;
    }

    /// Stats of the last frame: waits for the GPU, reads the timestamps.
    pub fn stats(&mut self, device: &wgpu::Device) -> FrameStats {
        let mut s = self.stats.clone();
        match &self.timer {
            Some(t) => {
                s.timing = "gpu timestamps".into();
                s.passes = t
                    .read(device)
                    .into_iter()
                    .map(|(n, ms)| (n.to_string(), ms))
                    .collect();
            }
            None => {
                let _ = device.poll(wgpu::PollType::wait_indefinitely());
                s.timing = "wall (no timestamp queries on this adapter)".into();
                let ms = self
                    .wall_start
                    .map(|w| w.elapsed().as_secs_f64() * 1e3)
                    .unwrap_or(0.0);
                s.passes = vec![("frame".into(), ms)];
            }
        }
        s
    }

    /// The renderer's own G-buffer (what a game replaces with
    /// [`Renderer::use_external_gbuffer`]).
    pub fn gbuffer(&self) -> &gbuffer::GBuffer {
        &self.gbuffer
    }

    /// The frame's linear radiance (`Rgba32Float`, row 0 at the top).
    pub fn output(&self) -> &wgpu::Texture {
        &self.output
    }

    /// Shades the game's own G-buffer instead of rendering one: three views
    /// of `width × height` textures in [`gbuffer::GBUFFER_FORMATS`] with
    /// `TEXTURE_BINDING` usage — 0: world position (xyz) and coverage (w = 1
    /// where a surface is, 0 elsewhere), 1: octahedral-encoded shading
    /// normal (xy) and geometric normal (zw), both facing the viewer (see
    /// `oct_encode` in the shared `common.wgsl`), 2: linear albedo (rgb).
    /// After this call [`Renderer::encode`] skips its G-buffer pass.
    pub fn use_external_gbuffer(&mut self, device: &wgpu::Device, views: [&wgpu::TextureView; 3]) {
        self.frame_group = self
            .frame_views
            .group(device, &self.shade, views, &self._light_buf);
        if let Some(il) = &mut self.interleave {
            il.bind(device, views, &self.frame_views.final_output);
        }
        self.external_gbuffer = true;
    }

    /// Whether any resource for moving objects exists (merge maps, dynamic
    /// RSM, occlusion sums, merge atlas, dynamic VPLs). False for a scene
    /// without moving objects: nothing is allocated for them.
    pub fn has_dynamic_resources(&self) -> bool {
        self.dyn_primary.is_some()
            || self.dyn_rsm.is_some()
            || self.occlusion.is_some()
            || self.hemi.is_some()
            || self.dyn_vpls.is_some()
    }

    /// GPU bytes uploaded from the asset.
    pub fn asset_bytes(&self) -> u64 {
        self.baked.as_ref().map(|b| b.bytes).unwrap_or(0)
    }
}

/// A 1×1 `R32Float` texture bound where a feature is absent.
fn tiny_texture(device: &wgpu::Device) -> wgpu::TextureView {
    gibake_gpu::util::texture_2d(
        device,
        "unused",
        1,
        1,
        wgpu::TextureFormat::R32Float,
        wgpu::TextureUsages::TEXTURE_BINDING,
    )
    .create_view(&Default::default())
}

/// Renders one frame at `time` on `ctx` and reads it back. `ssaa` renders at
/// `ssaa ×` the resolution and box-filters down (an unbiased pixel integral,
/// like the reference's jittered samples).
pub fn render_image(
    ctx: &GpuContext,
    scene: &Scene,
    asset: Option<&Asset>,
    settings: &RenderSettings,
    time: f32,
    ssaa: u32,
) -> Result<Image, RuntimeError> {
    let ssaa = ssaa.max(1);
    let mut hi = settings.clone();
    hi.width = settings.width * ssaa;
    hi.height = settings.height * ssaa;
    let mut renderer = Renderer::new(&ctx.device, &ctx.queue, scene, asset, &hi, time)?;
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    renderer.encode(&ctx.device, &ctx.queue, &mut enc);
    ctx.queue.submit([enc.finish()]);
    read_output(ctx, &renderer, ssaa)
}

/// Reads a renderer's output back (box-filtered by `ssaa`).
pub fn read_output(
    ctx: &GpuContext,
    renderer: &Renderer,
    ssaa: u32,
) -> Result<Image, RuntimeError> {
    let out = renderer.output();
    let data = gibake_gpu::readback::read_texture_f32(ctx, out, 0, 4)?;
    let img = Image::from_rgba_f32(out.width(), out.height(), &data);
    Ok(gibake_image::box_downsample(&img, ssaa.max(1)))
}
