//! gibake's game-facing runtime, in the style of wgpu middleware.
//!
//! ```no_run
//! # fn frame(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<(), Box<dyn std::error::Error>> {
//! use gibake_runtime::{CameraMatrices, FrameInput, RenderSettings, Renderer, glam::Mat4};
//!
//! let asset = gibake_runtime::load_asset(std::path::Path::new("level.gibake"))?;
//! // The level as baked: with the asset's `--sun`, `--dynamic`, ... applied.
//! let scene = gibake_runtime::load_scene_for(std::path::Path::new("level.glb"), &asset, &Default::default())?;
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
//! camera, if any, is not needed: the camera comes with each frame), and
//! [`load_scene_for`] reads it with the scene options its asset was baked
//! with ([`Asset::scene_options`]: a sun added, moving objects marked by
//! name, ...; [`scene_options`]). Moving
//! objects are addressed by [`ObjectHandle`] ([`Renderer::object`] looks one
//! up by name). Per frame, [`Renderer::prepare`] does every upload and
//! growth and returns typed errors ([`RuntimeError`]); [`Renderer::record`]
//! only records. The frame lands in [`Renderer::output`] (linear radiance,
//! [`OUTPUT_FORMAT`], sampleable) or in a texture the caller provides
//! ([`Renderer::set_output`]); [`Renderer::resize`] changes its size.
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
pub mod cascades;
mod composite;
mod dynamic_rsm;
mod dynamic_vpl;
mod error;
mod frame;
mod gbuffer;
mod gbuffer_depth;
mod interleave;
mod later_absorb;
mod later_occlusion;
mod light;
mod map_cells;
mod merge;
mod merge_cull;
mod moving;
mod other_lights;
mod plan;
mod requirements;
pub mod scene_options;
mod settings;
mod shade;
mod stats;
mod view;
mod world;

use glam::Mat4;

/// The runtime's own estimates of what moving objects take from the later
/// bounces, for the CPU twins that judge them (`gibake-eval`'s
/// `absorb_twin`): the same functions the frame calls.
pub mod twin {
    pub use crate::later_absorb::{later_scale, local_keep};
    pub use crate::merge_cull::intercepted_by_area;
}

pub use camera::{CameraMatrices, NoCamera};
pub use cascades::CascadeLayout;
pub use error::RuntimeError;
pub use frame::{FrameInput, ObjectHandle, scene_transforms};
pub use gbuffer::{
    GBUFFER_ALBEDO_LEVELS, GBUFFER_BYTES_PER_SAMPLE, GBUFFER_FORMATS, positions_from_depth,
    unpack_albedo, unpack_normals,
};
pub use gbuffer_depth::{DepthGBuffer, NormalEncoding};
pub use gibake_asset::{
    Asset, AssetError, OptionsConflict, Resolution, SceneOption, SceneOptions, SunOption,
    load as load_asset,
};
pub use gibake_gpu::GpuError;
pub use gibake_image::Image;
pub use gibake_scene::{
    Aabb, Animator, DynamicObject, Light, LightKind, Material, Mesh, Projection, Scene, SceneError,
    Texture,
};
#[cfg(feature = "gltf-import")]
pub use gibake_scene::{LoadOptions, load as load_scene};
pub use light::LightInfo;
pub use plan::{FramePlan, Pass, PassSet, ShadeFlag};
pub use requirements::Requirements;
#[cfg(feature = "gltf-import")]
pub use scene_options::{load_options_for, load_scene_for};
pub use settings::{
    Cascades, DEFAULT_LATER_NEAR_FIELD_DESCENT, DEFAULT_MERGE_CULL_SHARE,
    DEFAULT_NEAR_FIELD_DESCENT, Mode, RenderSettings,
};
pub use stats::{FRAMES_IN_FLIGHT, FrameStats, Timing};
pub use view::{OutputTarget, ViewId};
pub use {glam, wgpu};

use crate::frame::Objects;
use crate::shade::ShadePass;
use crate::stats::Timer;
use crate::view::View;
use crate::world::World;

/// Format of the renderer's output: linear radiance.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = shade::RADIANCE_FORMAT;

/// What [`Renderer::set_asset`] did to the [`ObjectHandle`]s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reload {
    /// The new scene has the same moving objects (names, in order): every
    /// handle, matrix and visibility is kept.
    HandlesKept,
    /// The moving objects differ: old handles are refused from now on
    /// ([`RuntimeError::UnknownObject`]); the objects start at time 0.
    HandlesRenewed,
}

/// Renders frames of one scene, from one or more views.
pub struct Renderer {
    settings: RenderSettings,
    objects: Objects,
    world: World,
    shade: ShadePass,
    /// By [`ViewId`]; `None`: removed.
    views: Vec<Option<View>>,
    timer: Timer,
}

impl Renderer {
    /// Creates every GPU resource for `scene` (and `asset`, needed by every
    /// mode but `Direct`) on the caller's device, with one view
    /// ([`ViewId::MAIN`]) of the settings' size. The asset must have been
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
        Requirements::of(scene, asset, settings)?.check(&device.limits())?;
        let shade = ShadePass::new(device);
        let world = World::new(device, queue, &shade, scene, asset, settings)?;
        let main = View::new(
            device,
            (&shade, &world.gbuffer, &world.scene_gpu),
            [settings.width, settings.height],
            settings.interleave,
        );
        Ok(Renderer {
            settings: settings.clone(),
            objects: Objects::of(scene),
            world,
            shade,
            views: vec![Some(main)],
            timer: Timer::new(device, queue),
        })
    }

    /// Replaces the scene and its asset (a re-bake, hot-reloaded) without
    /// a new renderer: the views, their sizes and outputs stay; the frame
    /// plan is made again. Everything is checked (and uploaded) before the
    /// old data is let go: on an error the renderer is unchanged. While
    /// both exist the GPU holds the old and the new asset.
    pub fn set_asset(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        asset: Option<&Asset>,
    ) -> Result<Reload, RuntimeError> {
        Requirements::of(scene, asset, &self.settings)?.check(&device.limits())?;
        let world = World::new(device, queue, &self.shade, scene, asset, &self.settings)?;
        self.world = world;
        let same = scene
            .dynamic_objects
            .iter()
            .map(|o| &o.name)
            .eq(self.objects.names[..self.objects.declared].iter());
        let reload = if same {
            // The spawned copies again, in the new meshes.
            let o = &self.objects;
            for i in o.declared..o.names.len() {
                self.world
                    .scene_gpu
                    .add_instance(queue, o.template[i], i, o.transforms[i]);
            }
            Reload::HandlesKept
        } else {
            self.objects = Objects::of(scene);
            Reload::HandlesRenewed
        };
        self.world.show(&self.objects.shown);
        for v in self.views.iter_mut().flatten() {
            v.set_scene(device, &self.world.gbuffer, &self.world.scene_gpu);
        }
        Ok(reload)
    }

    /// The frame plan: which passes this renderer's frames have.
    pub fn plan(&self) -> &FramePlan {
        &self.world.plan
    }

    /// The scene's primary lights: kind, radiometry, placement, their VPLs
    /// (the budget share the asset records) and whether this renderer
    /// shades them. Lights are fixed: moving one is a re-bake.
    pub fn lights(&self) -> &[LightInfo] {
        &self.world.lights
    }

    /// The moving objects: handle and name, in the scene's order (removed
    /// ones left out).
    pub fn objects(&self) -> impl Iterator<Item = (ObjectHandle, &str)> + '_ {
        let o = &self.objects;
        o.names
            .iter()
            .enumerate()
            .filter(|(i, _)| !o.removed[*i])
            .map(|(i, n)| {
                (
                    ObjectHandle {
                        renderer: o.id,
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
        Ok(self.objects.transforms[self.objects.index(object)?])
    }

    /// Shows or hides a moving object: a hidden one is in no pass (no
    /// shadow, no bounce, not seen) until shown again.
    pub fn set_visible(&mut self, object: ObjectHandle, visible: bool) -> Result<(), RuntimeError> {
        let i = self.objects.index(object)?;
        self.objects.shown[i] = visible;
        self.world.show(&self.objects.shown);
        Ok(())
    }

    /// Whether a moving object is shown.
    pub fn is_visible(&self, object: ObjectHandle) -> Result<bool, RuntimeError> {
        Ok(self.objects.shown[self.objects.index(object)?])
    }

    /// Adds a copy of the moving object `like` (one of the scene's declared
    /// ones, or a copy of one) at `transform`: a new moving object, shown,
    /// with its own handle, name and matrix. At most
    /// [`RenderSettings::max_spawned`] over the renderer's life
    /// ([`RuntimeError::TooManyObjects`] past them).
    pub fn spawn(
        &mut self,
        queue: &wgpu::Queue,
        like: ObjectHandle,
        transform: Mat4,
    ) -> Result<ObjectHandle, RuntimeError> {
        let o = &mut self.objects;
        let template = o.template[o.index(like)?];
        let index = o.names.len();
        if index - o.declared >= self.settings.max_spawned as usize
            || !self
                .world
                .scene_gpu
                .add_instance(queue, template, index, transform)
        {
            return Err(RuntimeError::TooManyObjects {
                max: self.settings.max_spawned,
            });
        }
        o.names.push(o.names[template].clone());
        o.template.push(template);
        o.transforms.push(transform);
        o.shown.push(true);
        o.removed.push(false);
        self.world.show(&o.shown);
        Ok(ObjectHandle {
            renderer: o.id,
            index: index as u32,
        })
    }

    /// Removes a moving object: it is in no pass any more and its handle is
    /// refused from now on ([`RuntimeError::UnknownObject`]).
    pub fn remove(&mut self, object: ObjectHandle) -> Result<(), RuntimeError> {
        let i = self.objects.index(object)?;
        self.objects.removed[i] = true;
        self.objects.shown[i] = false;
        self.world.show(&self.objects.shown);
        Ok(())
    }

    fn view(&self, id: ViewId) -> Result<&View, RuntimeError> {
        self.views
            .get(id.0 as usize)
            .and_then(Option::as_ref)
            .ok_or(RuntimeError::UnknownView(id))
    }

    fn view_mut(&mut self, id: ViewId) -> Result<&mut View, RuntimeError> {
        self.views
            .get_mut(id.0 as usize)
            .and_then(Option::as_mut)
            .ok_or(RuntimeError::UnknownView(id))
    }

    fn main(&self) -> &View {
        self.views[0]
            .as_ref()
            .expect("the main view is never removed")
    }

    /// Adds a view of `width × height` with `interleave` (as
    /// [`RenderSettings::interleave`]): its own G-buffer, shading and
    /// output, over the renderer's one copy of the asset and one per-frame
    /// update. Its camera comes with [`FrameInput::views`].
    pub fn add_view(
        &mut self,
        device: &wgpu::Device,
        _queue: &wgpu::Queue,
        width: u32,
        height: u32,
        interleave: u32,
    ) -> Result<ViewId, RuntimeError> {
        settings::check_interleave(interleave)?;
        view::check_size(device, width, height, interleave)?;
        let v = View::new(
            device,
            (&self.shade, &self.world.gbuffer, &self.world.scene_gpu),
            [width, height],
            interleave,
        );
        let id = ViewId(self.views.len() as u32);
        self.views.push(Some(v));
        Ok(id)
    }

    /// Removes a view added with [`Renderer::add_view`] (not the main one).
    pub fn remove_view(&mut self, id: ViewId) -> Result<(), RuntimeError> {
        self.view(id)?;
        if id == ViewId::MAIN {
            return Err(RuntimeError::InvalidSetting(
                "the main view cannot be removed".into(),
            ));
        }
        self.views[id.0 as usize] = None;
        Ok(())
    }

    /// The main view's output size in pixels.
    pub fn size(&self) -> (u32, u32) {
        self.main().size()
    }

    /// A view's output size in pixels.
    pub fn view_size(&self, id: ViewId) -> Result<(u32, u32), RuntimeError> {
        Ok(self.view(id)?.size())
    }

    /// The main view's interleave factor (1, 2, 4 or 8; resolves
    /// [`RenderSettings::interleave`] = 0 for the current size).
    pub fn interleave(&self) -> u32 {
        self.main().interleave()
    }

    /// Changes the main view's size ([`Renderer::resize_view`]).
    pub fn resize(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        width: u32,
        height: u32,
    ) -> Result<(), RuntimeError> {
        self.resize_view(device, queue, ViewId::MAIN, width, height)?;
        self.settings.width = width;
        self.settings.height = height;
        Ok(())
    }

    /// Changes a view's size: a new G-buffer and output (the view's own
    /// again, and its own G-buffer: a caller that provided either provides
    /// it again at the new size). The camera's aspect ratio is the caller's
    /// to change.
    pub fn resize_view(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        id: ViewId,
        width: u32,
        height: u32,
    ) -> Result<(), RuntimeError> {
        let v = self.view(id)?;
        view::check_size(device, width, height, v.interleave_setting())?;
        let shade = &self.shade;
        let v = self
            .views
            .get_mut(id.0 as usize)
            .and_then(Option::as_mut)
            .ok_or(RuntimeError::UnknownView(id))?;
        v.resize(device, queue, shade, [width, height]);
        Ok(())
    }

    /// Sends a view's frame to `target` from now on (checked first: on an
    /// error nothing changes).
    pub fn set_output(
        &mut self,
        device: &wgpu::Device,
        id: ViewId,
        target: OutputTarget<'_>,
    ) -> Result<(), RuntimeError> {
        let shade = &self.shade;
        let v = self
            .views
            .get_mut(id.0 as usize)
            .and_then(Option::as_mut)
            .ok_or(RuntimeError::UnknownView(id))?;
        v.set_output(device, shade, target)
    }

    /// Prepares one frame: applies the cameras and the moving objects'
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
        let (n, declared) = (self.objects.transforms.len(), self.objects.declared);
        let t = frame.transforms.len();
        if t != 0 && t != n && t != declared {
            return Err(RuntimeError::TransformCount {
                expected: n,
                got: t,
            });
        }
        for (h, _) in frame.moved {
            self.objects.index(*h)?;
        }
        for (id, _) in frame.views {
            self.view(*id)?;
        }
        let o = &mut self.objects;
        o.transforms[..t].copy_from_slice(frame.transforms);
        for (h, m) in frame.moved {
            o.transforms[h.index()] = *m;
        }
        let main = std::iter::once((ViewId::MAIN, frame.camera));
        for (id, camera) in main.chain(frame.views.iter().copied()) {
            self.view_mut(id)?.set_camera(queue, &camera);
        }
        let later = self.world.gi.has_later() && !self.settings.later_full_resolution;
        let mut later_half_views = 0;
        for v in self.views.iter_mut().flatten() {
            later_half_views += u32::from(v.set_later(device, queue, &self.shade, later));
        }
        if later_half_views > 0 {
            self.shade.prepare_later(device, &self.world.gi);
        }
        let affected = self.world.prepare(
            device,
            queue,
            &self.shade,
            &self.objects.transforms,
            &frame.camera,
        )?;
        let views: Vec<_> = self.views.iter().flatten().map(View::passes).collect();
        let mut passes = self.world.plan.recorded(affected > 0, &views);
        if !self.world.cascades_draw() {
            passes.retain(|(p, _)| *p != Pass::Cascades);
        }
        let light_views = self.world.light_views_touched();
        if light_views == 0 {
            passes.retain(|(p, _)| *p != Pass::LightMerge);
        }
        let light_views_bounced = self.world.moving.light_views_bounced();
        if light_views_bounced == 0 {
            passes.retain(|(p, _)| *p != Pass::LightBounce);
        }
        let update_draw_calls = self.world.moving.draw_calls()
            + self.world.cascade_draw_calls()
            + self.world.light_merge_draw_calls();
        let view_draws: u32 = self
            .views
            .iter()
            .flatten()
            .filter(|v| v.draws_gbuffer())
            .map(|_| self.world.gbuffer_draw_calls())
            .sum();
        let stats = FrameStats {
            static_vpls: self.world.gi.static_vpls(),
            dynamic_vpl_slots: self.world.moving.dynamic_vpl_slots(),
            affected_maps: affected,
            hidden_maps: self.world.moving.hidden_maps(),
            later_half_views,
            later_scale: self.world.gi.later_scale(),
            merge_faint_pairs: self.world.moving.merge_faint_pairs(),
            merge_maps_per_object: self.world.moving.merge_maps_per_object(),
            merge_instances: self.world.moving.merge_instances(),
            light_views_merged: light_views,
            light_views_bounced,
            bounce_texels: self.world.moving.bounce_texels(),
            update_draw_calls,
            draw_calls: update_draw_calls + view_draws,
            views: views.len() as u32,
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
    /// the per-frame update once, then each view's G-buffer and shading.
    /// Submit it before the next [`Renderer::prepare`]. The same as
    /// [`Renderer::record_update`], [`Renderer::record_view`] of every view
    /// and [`Renderer::record_finish`], in that order.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        self.record_update(encoder);
        let w = &self.world;
        for (k, v) in self.views.iter().flatten().enumerate() {
            v.record(
                encoder,
                (&self.shade, &w.gbuffer, &w.scene_gpu),
                &w.moving_draws,
                &w.gi,
                &self.timer,
                k as u32,
            );
        }
        self.record_finish(encoder);
    }

    /// Records the frame's update alone: the passes that run once per
    /// frame however many views there are (merges, dynamic VPLs, VPL maps,
    /// cascades; nothing without moving objects). For an engine that
    /// records each camera in its own pass (a render graph): this first,
    /// then [`Renderer::record_view`] per view (in any encoders submitted
    /// after this one, in the same submission or later ones of the frame),
    /// then [`Renderer::record_finish`] after them all.
    pub fn record_update(&self, encoder: &mut wgpu::CommandEncoder) {
        self.world.record_update(encoder, &self.timer);
    }

    /// Records one view of the frame: its G-buffer (or the rebuild from the
    /// engine's), shading, interleave filter and composite into its target
    /// ([`Renderer::set_output`]). After [`Renderer::record_update`] of the
    /// same frame; [`RuntimeError::UnknownView`] (nothing recorded) for a
    /// view this renderer does not have. A view prepared but not recorded
    /// in a frame is simply not drawn (its pass times that frame are
    /// meaningless).
    pub fn record_view(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        id: ViewId,
    ) -> Result<(), RuntimeError> {
        let v = self.view(id)?;
        // The view's rank among the live views keys its timers.
        let k = self.views[..id.0 as usize].iter().flatten().count();
        let w = &self.world;
        v.record(
            encoder,
            (&self.shade, &w.gbuffer, &w.scene_gpu),
            &w.moving_draws,
            &w.gi,
            &self.timer,
            k as u32,
        );
        Ok(())
    }

    /// Ends the frame's commands: resolves its pass timers (read later by
    /// [`Renderer::poll_stats`]). Record it after every other pass of the
    /// frame, in the last encoder submitted for it.
    pub fn record_finish(&self, encoder: &mut wgpu::CommandEncoder) {
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

    /// The main view's own G-buffer textures, in [`GBUFFER_FORMATS`] order.
    pub fn gbuffer_textures(&self) -> &[wgpu::Texture] {
        &self.main().gbuffer().textures
    }

    /// The world positions the main view shades, rebuilt on the CPU from
    /// the depth it reads — its own G-buffer's, or the engine's given to
    /// [`Renderer::use_depth_gbuffer`] — with the last prepared camera (row
    /// 0 at the top; `[x, y, z, 1]` where a surface is, zeros elsewhere):
    /// the position target that the G-buffer no longer stores (see
    /// [`positions_from_depth`]). Waits for the GPU. An engine's depth
    /// without `COPY_SRC` usage (Bevy's prepass depth) cannot be read back:
    /// [`RuntimeError::InvalidSetting`].
    pub fn gbuffer_positions(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<Vec<[f32; 4]>, RuntimeError> {
        let v = self.main();
        let (depth, far) = v.shaded_depth();
        let camera = v.last_camera().ok_or_else(|| {
            RuntimeError::InvalidSetting("no frame prepared: no camera to rebuild positions".into())
        })?;
        if !depth.usage().contains(wgpu::TextureUsages::COPY_SRC) {
            return Err(RuntimeError::InvalidSetting(format!(
                "the depth this view shades ({:?}) has no COPY_SRC usage: its positions cannot \
                 be read back (create the engine's depth texture with COPY_SRC, or rebuild them \
                 from it with positions_from_depth)",
                depth.format()
            )));
        }
        let d = gibake_gpu::readback::read_texture_f32_on(device, queue, depth, 0, 1)?;
        Ok(gbuffer::positions_from_depth(
            &d,
            depth.width(),
            depth.height(),
            camera,
            far,
        ))
    }

    /// The main view's own G-buffer views, in [`GBUFFER_FORMATS`] order.
    pub fn gbuffer_views(&self) -> &[wgpu::TextureView; 3] {
        &self.main().gbuffer().views
    }

    /// The main view's own G-buffer depth (`Depth32Float`, reversed Z,
    /// `TEXTURE_BINDING` usage; the first of [`Renderer::gbuffer_textures`]):
    /// what a game can depth-test its own draws against.
    pub fn gbuffer_depth(&self) -> &wgpu::Texture {
        self.main().gbuffer().depth()
    }

    /// The main view's linear radiance ([`OUTPUT_FORMAT`], row 0 at the
    /// top, `TEXTURE_BINDING` usage): its own texture, or the storage
    /// texture given to [`Renderer::set_output`].
    pub fn output(&self) -> &wgpu::Texture {
        self.main().output()
    }

    /// A view of [`Renderer::output`].
    pub fn output_view(&self) -> &wgpu::TextureView {
        self.main().output_view()
    }

    /// A view's linear radiance (as [`Renderer::output`]).
    pub fn view_output(&self, id: ViewId) -> Result<&wgpu::Texture, RuntimeError> {
        Ok(self.view(id)?.output())
    }

    /// Shades the game's own G-buffer in the main view instead of rendering
    /// one: three views of output-sized textures with `TEXTURE_BINDING`
    /// usage in gibake's layout ([`GBUFFER_FORMATS`]) — 0: depth
    /// (`Depth32Float` or `R32Float`, reversed Z, 0 where no surface is)
    /// drawn with the frame camera's `view_proj` (the world position is
    /// rebuilt from it), 1: both normals packed in an `Rg32Uint`
    /// (`pack2x16snorm` of the octahedral shading normal in x, of the
    /// geometric normal in y, both facing the viewer; `gbuffer_pack_normals`
    /// in the runtime's `gbuffer_layout.wgsl`), 2: albedo in an `R32Uint`
    /// (√ of the linear albedo rounded to [`GBUFFER_ALBEDO_LEVELS`] levels
    /// a channel, `r + 1625·(g + 1625·b)`; [`unpack_albedo`] reads one).
    /// After this call [`Renderer::record`] skips its G-buffer pass, until
    /// [`Renderer::resize`], after which the caller provides its G-buffer
    /// again.
    pub fn use_external_gbuffer(&mut self, device: &wgpu::Device, views: [&wgpu::TextureView; 3]) {
        let shade = &self.shade;
        if let Some(v) = self.views[0].as_mut() {
            v.use_gbuffer_views(device, shade, views);
        }
    }

    /// Rebuilds a view's G-buffer every frame from the engine's own depth,
    /// normals and albedo ([`DepthGBuffer`]) and the frame camera's inverse
    /// view-projection, instead of drawing the scene again; until the
    /// view is resized.
    pub fn use_depth_gbuffer(
        &mut self,
        device: &wgpu::Device,
        id: ViewId,
        src: &DepthGBuffer<'_>,
    ) -> Result<(), RuntimeError> {
        let shade = &self.shade;
        let v = self
            .views
            .get_mut(id.0 as usize)
            .and_then(Option::as_mut)
            .ok_or(RuntimeError::UnknownView(id))?;
        v.use_depth_gbuffer(device, shade, src)
    }

    /// Whether any resource for moving objects exists (merge maps, dynamic
    /// RSM, occlusion sums, merge atlas, dynamic VPLs). False for a scene
    /// without moving objects: nothing is allocated for them.
    pub fn has_dynamic_resources(&self) -> bool {
        self.world.moving.exists()
    }

    /// GPU bytes uploaded from the asset (the lights after the first's
    /// shadow maps included).
    pub fn asset_bytes(&self) -> u64 {
        self.world.baked.as_ref().map_or(0, |b| b.bytes) + self.other_light_bytes()
    }

    /// GPU bytes of the lights after the first's shadow maps (0 for a scene
    /// with one light: nothing is allocated for them).
    pub fn other_light_bytes(&self) -> u64 {
        self.world.other_lights.as_ref().map_or(0, |o| o.bytes)
    }
}
