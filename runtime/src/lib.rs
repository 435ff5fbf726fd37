//! gibake's game-facing runtime, in the style of wgpu middleware.
//!
//! ```no_run
//! # fn frame(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<(), Box<dyn std::error::Error>> {
//! use gibake_runtime::{CameraMatrices, FrameInput, RenderSettings, Renderer, glam::Mat4};
//!
//! let scene = gibake_runtime::load_scene(std::path::Path::new("level.glb"), &Default::default())?;
//! let asset = gibake_runtime::load_asset(std::path::Path::new("level.gibake"))?;
//! let mut renderer = Renderer::new(device, queue, &scene, Some(&asset), &RenderSettings::default())?;
//! let door = renderer.object("door").ok_or("no door")?;
//!
//! // Every frame: the game's camera and moved objects, then one encoder.
//! let camera = CameraMatrices::perspective(Mat4::IDENTITY, 1.0, 640.0 / 480.0, 0.1);
//! let moved = [(door, Mat4::from_translation([0.0, 1.0, 0.0].into()))];
//! renderer.prepare(device, queue, &FrameInput::new(camera).moving(&moved))?;
//! let mut encoder = device.create_command_encoder(&Default::default());
//! renderer.record(&mut encoder);
//! // ... sample `renderer.output()` (linear radiance) in the game's own pass ...
//! queue.submit([encoder.finish()]);
//! # Ok(()) }
//! ```
//!
//! A [`Renderer`] owns the GPU resources for one [`Scene`] and (except in
//! `direct` mode) one baked [`Asset`], on the caller's `wgpu::Device`. The
//! scene is plain data an engine can fill from its own meshes; with the
//! default `gltf` feature [`load_scene`] reads one from a glTF file (its
//! camera, if any, is not needed: the camera comes with each frame). Moving
//! objects are addressed by [`ObjectHandle`] ([`Renderer::object`] looks one
//! up by name). Per frame, [`Renderer::prepare`] does every upload and
//! growth and returns typed errors ([`RuntimeError`]); [`Renderer::record`]
//! only records. The frame lands in [`Renderer::output`] (linear radiance,
//! [`OUTPUT_FORMAT`], sampleable) or in a texture the caller provides
//! ([`Renderer::set_output_target`]); [`Renderer::resize`] changes its size.
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

mod atlas;
mod baked;
mod camera;
mod dynamic_rsm;
mod dynamic_vpl;
mod error;
mod frame;
mod gbuffer;
mod interleave;
mod light;
mod merge;
mod moving;
mod plan;
mod settings;
mod shade;
mod stats;
mod view;

use std::sync::atomic::{AtomicU32, Ordering};

use gibake_gpu::mesh::SceneGpu;
use glam::Mat4;

pub use camera::{CameraMatrices, NoCamera};
pub use error::RuntimeError;
pub use frame::{FrameInput, ObjectHandle, scene_transforms};
pub use gbuffer::GBUFFER_FORMATS;
pub use gibake_asset::{Asset, AssetError, load as load_asset};
pub use gibake_gpu::GpuError;
pub use gibake_image::Image;
pub use gibake_scene::{
    Aabb, Animator, DynamicObject, Light, LightKind, Material, Mesh, Projection, Scene, SceneError,
    Texture,
};
#[cfg(feature = "gltf")]
pub use gibake_scene::{LoadOptions, load as load_scene};
pub use plan::{FramePlan, Pass, PassSet, ShadeFlag};
pub use settings::{Mode, RenderSettings};
pub use stats::{FRAMES_IN_FLIGHT, FrameStats, Timing};
pub use {glam, wgpu};

use crate::baked::BakedGpu;
use crate::gbuffer::GBufferPass;
use crate::light::PrimaryLight;
use crate::moving::{MovingPasses, UpdateInputs};
use crate::shade::{GiSources, ShadeGi, ShadePass};
use crate::stats::Timer;
use crate::view::View;

/// Format of the renderer's output: linear radiance.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = shade::RADIANCE_FORMAT;

/// Renders frames of one scene.
pub struct Renderer {
    id: u32,
    settings: RenderSettings,
    plan: FramePlan,
    object_names: Vec<String>,
    transforms: Vec<Mat4>,
    scene_gpu: SceneGpu,
    baked: Option<BakedGpu>,
    light: PrimaryLight,
    moving: MovingPasses,
    gbuffer: GBufferPass,
    shade: ShadePass,
    gi: ShadeGi,
    view: View,
    timer: Timer,
}

static NEXT_RENDERER: AtomicU32 = AtomicU32::new(0);

/// Refuses material textures larger than the device's 2D limit.
fn check_textures(device: &wgpu::Device, scene: &Scene) -> Result<(), RuntimeError> {
    let limit = device.limits().max_texture_dimension_2d;
    match scene
        .textures
        .iter()
        .find(|t| t.width.max(t.height) > limit)
    {
        Some(t) => Err(RuntimeError::DeviceLimit {
            what: format!("a {}×{} material texture", t.width, t.height),
            needed: u64::from(t.width.max(t.height)),
            limit: u64::from(limit),
        }),
        None => Ok(()),
    }
}

impl Renderer {
    /// Creates every GPU resource for `scene` (and `asset`, needed by every
    /// mode but `Direct`) on the caller's device. The asset must have been
    /// baked from this scene's static part. Moving objects start at their
    /// animation's time 0; the camera comes with the first
    /// [`Renderer::prepare`].
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        asset: Option<&Asset>,
        settings: &RenderSettings,
    ) -> Result<Renderer, RuntimeError> {
        settings.check(device, asset.is_some())?;
        let plan = FramePlan::new(settings, scene, asset)?;
        if let Some(a) = asset {
            let hash = gibake_scene::static_scene_hash(scene);
            gibake_asset::check_scene_hash(&a.manifest, &hash, &scene.source)?;
        }
        check_textures(device, scene)?;
        // The asset first: its limits are checked before any other upload.
        let baked = asset.map(|a| BakedGpu::new(device, queue, a)).transpose()?;
        let scene_gpu = SceneGpu::new(device, queue, scene, 0.0);
        let light = PrimaryLight::new(
            device,
            queue,
            scene,
            &scene_gpu,
            baked.as_ref(),
            settings.shadow_map_size,
        );
        let moving = MovingPasses::new(
            device,
            &UpdateInputs {
                plan: &plan,
                scene_gpu: &scene_gpu,
                baked: baked.as_ref(),
                primary_view: light.view,
                light_buf: &light.light_buf,
                threshold: asset.map_or(0.0, |a| a.manifest.settings.threshold),
                max_dynamic_vpls: settings.max_dynamic_vpls,
                scene_diagonal: scene.full_bounds().diagonal(),
            },
        )?;
        let gbuffer = GBufferPass::new(device, &scene_gpu);
        let shade = ShadePass::new(device);
        let gi = ShadeGi::new(
            device,
            &shade,
            &GiSources {
                plan: &plan,
                baked: baked.as_ref(),
                light: &light,
                moving: &moving,
            },
        );
        let view = View::new(
            device,
            queue,
            (&shade, &gbuffer, &scene_gpu),
            [settings.width, settings.height],
            settings.interleave,
        );
        Ok(Renderer {
            id: NEXT_RENDERER.fetch_add(1, Ordering::Relaxed),
            settings: settings.clone(),
            plan,
            object_names: scene
                .dynamic_objects
                .iter()
                .map(|o| o.name.clone())
                .collect(),
            transforms: scene_transforms(scene, 0.0),
            scene_gpu,
            baked,
            light,
            moving,
            gbuffer,
            shade,
            gi,
            view,
            timer: Timer::new(device, queue),
        })
    }

    /// The frame plan: which passes this renderer's frames have.
    pub fn plan(&self) -> &FramePlan {
        &self.plan
    }

    /// The moving objects: handle and name, in the scene's order.
    pub fn objects(&self) -> impl Iterator<Item = (ObjectHandle, &str)> + '_ {
        self.object_names.iter().enumerate().map(|(i, n)| {
            (
                ObjectHandle {
                    renderer: self.id,
                    index: i as u32,
                },
                n.as_str(),
            )
        })
    }

    /// The first moving object named `name`.
    pub fn object(&self, name: &str) -> Option<ObjectHandle> {
        self.objects().find(|(_, n)| *n == name).map(|(h, _)| h)
    }

    /// The current world matrix of a moving object.
    pub fn transform(&self, object: ObjectHandle) -> Result<Mat4, RuntimeError> {
        Ok(self.transforms[self.check_handle(object)?])
    }

    fn check_handle(&self, h: ObjectHandle) -> Result<usize, RuntimeError> {
        if h.renderer != self.id || h.index() >= self.transforms.len() {
            return Err(RuntimeError::UnknownObject(h));
        }
        Ok(h.index())
    }

    /// The output size in pixels.
    pub fn size(&self) -> (u32, u32) {
        self.view.size()
    }

    /// The interleave factor in use (1, 2, 4 or 8; resolves
    /// [`RenderSettings::interleave`] = 0 for the current size).
    pub fn interleave(&self) -> u32 {
        self.view.interleave()
    }

    /// Changes the output size: a new G-buffer and output (the renderer's
    /// own again, and its own G-buffer: a caller that provided either
    /// provides it again at the new size). The camera's aspect ratio is the
    /// caller's to change.
    pub fn resize(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        width: u32,
        height: u32,
    ) -> Result<(), RuntimeError> {
        view::check_size(device, width, height)?;
        self.settings.width = width;
        self.settings.height = height;
        self.view
            .resize(device, queue, &self.shade, [width, height]);
        Ok(())
    }

    /// Renders into the caller's `texture` from now on (`None`: the
    /// renderer's own output again). It must be a 2D [`OUTPUT_FORMAT`]
    /// texture of the output size with `STORAGE_BINDING` usage.
    pub fn set_output_target(
        &mut self,
        device: &wgpu::Device,
        texture: Option<&wgpu::Texture>,
    ) -> Result<(), RuntimeError> {
        self.view.set_output(device, &self.shade, texture)
    }

    /// Prepares one frame: applies the camera and the moving objects'
    /// matrices, and uploads every table and grows every buffer the frame
    /// needs (the merge atlas included). On an error nothing of the frame is
    /// recorded differently from the last successful prepare's, except the
    /// matrices.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &FrameInput<'_>,
    ) -> Result<(), RuntimeError> {
        // Validate everything before changing anything.
        let n = self.transforms.len();
        if !frame.transforms.is_empty() && frame.transforms.len() != n {
            return Err(RuntimeError::TransformCount {
                expected: n,
                got: frame.transforms.len(),
            });
        }
        for (h, _) in frame.moved {
            self.check_handle(*h)?;
        }
        if !frame.transforms.is_empty() {
            self.transforms.copy_from_slice(frame.transforms);
        }
        for (h, m) in frame.moved {
            self.transforms[h.index()] = *m;
        }
        if n > 0 {
            self.scene_gpu
                .set_dynamic_transforms(queue, &self.transforms);
        }
        self.view.set_camera(queue, &frame.camera);
        let atlas_grown = self
            .moving
            .prepare(device, queue, &self.scene_gpu, &self.transforms)?;
        if atlas_grown {
            let sources = GiSources {
                plan: &self.plan,
                baked: self.baked.as_ref(),
                light: &self.light,
                moving: &self.moving,
            };
            self.gi.atlas_changed(device, queue, &self.shade, &sources);
        }
        let affected = self.moving.affected();
        let passes = self.plan.recorded(affected > 0, &[self.view.passes()]);
        let update_draw_calls = self.moving.draw_calls();
        let view_draws = if passes.has(Pass::GBuffer) {
            (self.scene_gpu.static_draws.len() + self.scene_gpu.dynamic_draws.len()) as u32
        } else {
            0
        };
        let stats = FrameStats {
            static_vpls: self.gi.static_vpls(),
            dynamic_vpl_slots: self.moving.dynamic_vpl_slots(),
            affected_maps: affected,
            update_draw_calls,
            draw_calls: update_draw_calls + view_draws,
            ..Default::default()
        };
        self.timer.begin(stats, passes);
        Ok(())
    }

    /// [`Renderer::prepare`] for the frame of `scene`'s own animation at
    /// `time`, seen by its camera ([`RuntimeError::NoCamera`] without one):
    /// what tools and tests render.
    pub fn prepare_at_time(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        time: f32,
    ) -> Result<(), RuntimeError> {
        let (w, h) = self.size();
        let camera = CameraMatrices::from_scene(scene, time, w, h)?;
        let transforms = scene_transforms(scene, time);
        self.prepare(
            device,
            queue,
            &FrameInput::new(camera).transforms(&transforms),
        )
    }

    /// Records the frame last prepared into `encoder`; uploads nothing:
    /// the per-frame update once, then the view's G-buffer and shading.
    /// Submit it before the next [`Renderer::prepare`].
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        self.moving.record(encoder, &self.scene_gpu, &self.timer);
        self.view.record(
            encoder,
            (&self.shade, &self.gbuffer, &self.scene_gpu),
            &self.gi.group,
            &self.timer,
        );
        self.timer.finish(encoder);
    }

    /// Stats of the last frame recorded: waits for the GPU (tools, tests;
    /// a game polls [`Renderer::poll_stats`]).
    pub fn stats(&mut self, device: &wgpu::Device) -> FrameStats {
        self.timer.wait(device)
    }

    /// Stats of the newest frame the GPU has finished (at most
    /// [`FRAMES_IN_FLIGHT`] frames old when polled every frame; its
    /// [`FrameStats::frame`] says which), without waiting: `None` until a
    /// frame has finished.
    pub fn poll_stats(&mut self, device: &wgpu::Device) -> Option<FrameStats> {
        self.timer.poll(device)
    }

    /// The renderer's own G-buffer textures, in [`GBUFFER_FORMATS`] order.
    pub fn gbuffer_textures(&self) -> &[wgpu::Texture] {
        &self.view.gbuffer().textures
    }

    /// The renderer's own G-buffer views, in [`GBUFFER_FORMATS`] order.
    pub fn gbuffer_views(&self) -> &[wgpu::TextureView; 3] {
        &self.view.gbuffer().views
    }

    /// The frame's linear radiance ([`OUTPUT_FORMAT`], row 0 at the top,
    /// `TEXTURE_BINDING` usage): the renderer's own texture, or the one given
    /// to [`Renderer::set_output_target`].
    pub fn output(&self) -> &wgpu::Texture {
        self.view.output()
    }

    /// A view of [`Renderer::output`].
    pub fn output_view(&self) -> &wgpu::TextureView {
        self.view.output_view()
    }

    /// Shades the game's own G-buffer instead of rendering one: three views
    /// of output-sized textures in [`GBUFFER_FORMATS`] with
    /// `TEXTURE_BINDING` usage — 0: world position (xyz) and coverage (w = 1
    /// where a surface is, 0 elsewhere), 1: octahedral-encoded shading
    /// normal (xy) and geometric normal (zw), both facing the viewer (see
    /// `oct_encode` in the shared `common.wgsl`), 2: linear albedo (rgb).
    /// After this call [`Renderer::record`] skips its G-buffer pass, until
    /// [`Renderer::resize`], after which the caller provides its G-buffer
    /// again.
    pub fn use_external_gbuffer(&mut self, device: &wgpu::Device, views: [&wgpu::TextureView; 3]) {
        self.view.use_external_gbuffer(device, &self.shade, views);
    }

    /// Whether any resource for moving objects exists (merge maps, dynamic
    /// RSM, occlusion sums, merge atlas, dynamic VPLs). False for a scene
    /// without moving objects: nothing is allocated for them.
    pub fn has_dynamic_resources(&self) -> bool {
        self.moving.exists()
    }

    /// GPU bytes uploaded from the asset.
    pub fn asset_bytes(&self) -> u64 {
        self.baked.as_ref().map_or(0, |b| b.bytes)
    }
}
