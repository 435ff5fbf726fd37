//! The render world: one `gibake_runtime::Renderer` on Bevy's own
//! `RenderDevice` and `RenderQueue`, a gibake view per camera marked
//! [`GibakeCamera`], and the three places of Bevy's render graph (a graph
//! of schedules since Bevy 0.18) where the frame is recorded:
//!
//! - `prepare` (`Render` schedule, after Bevy's view targets and prepass
//!   textures exist): the level's renderer made or given the re-baked
//!   asset (`set_asset`), moving objects synced (`spawn`, `remove`,
//!   `set_visible`), each camera's view sized, its G-buffer taken from
//!   Bevy's prepass (`use_depth_gbuffer`, given again when Bevy's texture
//!   pool hands out other textures), its target set to the camera's HDR
//!   main texture times its exposure (`OutputTarget::AddScaled`), then
//!   `prepare` with every camera's matrices: one update for all views;
//! - `record_update` in the root `RenderGraph` schedule, before Bevy's
//!   `camera_driver` runs the cameras: the once-per-frame passes;
//! - per camera, in its `Core3d` schedule after `main_opaque_pass_3d` (and
//!   the deferred lighting before it) and before the transparent pass: the
//!   albedo unpacked from Bevy's deferred G-buffer, then `record_view`
//!   (rebuild, shade, add into the main texture);
//! - `record_finish` after `camera_driver`: the pass timers resolved.

use std::collections::HashMap;

use bevy::core_pipeline::core_3d::{main_opaque_pass_3d, main_transparent_pass_3d};
use bevy::core_pipeline::prepass::ViewPrepassTextures;
use bevy::prelude::*;
use bevy::render::camera::ExtractedCamera;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::view::{ExtractedView, ViewTarget};
use gibake_runtime::{
    CameraMatrices, DepthGBuffer, FrameInput, Mode, NormalEncoding, ObjectHandle, OutputTarget,
    RenderSettings, Renderer, ViewId, wgpu,
};

use crate::level::ExtractedGibake;
use crate::{GibakeMode, GibakeShared};

/// Marks a 3D camera whose frame gets gibake's light, added into its HDR
/// target between Bevy's opaque and transparent passes.
///
/// It brings what the plugin reads: Bevy's HDR target, the depth and
/// normal prepass and the deferred G-buffer (for the albedo), and MSAA off
/// (an addition into the resolved target would be overwritten by the next
/// MSAA pass). See the crate's README for what else the game must do.
#[derive(Component, Clone, Copy, Debug, Default, ExtractComponent)]
#[extract_app(bevy::render::RenderApp)]
#[require(
    bevy::camera::Hdr,
    Msaa = Msaa::Off,
    bevy::core_pipeline::prepass::DepthPrepass,
    bevy::core_pipeline::prepass::NormalPrepass,
    bevy::core_pipeline::prepass::DeferredPrepass
)]
pub struct GibakeCamera {
    /// Draw gibake's own G-buffer (the level's geometry again) instead of
    /// reading Bevy's prepass: for a camera whose materials are forward
    /// rendered (no albedo in a deferred G-buffer). Costs a second
    /// geometry pass.
    pub own_gbuffer: bool,
}

/// The camera matrices gibake takes from Bevy's view: `clip_from_view`
/// (Bevy's infinite reversed-Z perspective, or its orthographic
/// projection, with any jitter) times the inverse of `world_from_view`;
/// the eye is the view's translation, the forward direction its −Z.
/// Bevy's conventions are gibake's (right-handed, +Y up, the camera
/// looking down its −Z, reversed Z, NDC y up with row 0 at the top):
/// tested in `tests/conventions.rs`, not assumed.
pub fn camera_matrices(world_from_view: &GlobalTransform, clip_from_view: Mat4) -> CameraMatrices {
    let (_, rotation, position) = world_from_view.to_scale_rotation_translation();
    let view_from_world = world_from_view.to_matrix().inverse();
    CameraMatrices {
        view_proj: clip_from_view * view_from_world,
        position,
        forward: rotation * Vec3::NEG_Z,
        orthographic: clip_from_view.w_axis.w == 1.0,
    }
}

/// One camera's gibake view.
struct CameraView {
    id: ViewId,
    size: (u32, u32),
    /// The Bevy textures the view's G-buffer was last built from (depth,
    /// normals, deferred G-buffer).
    sources: Option<[wgpu::Texture; 3]>,
    /// The deferred G-buffer's albedo, unpacked for gibake.
    albedo: Option<Albedo>,
    /// Seen this frame.
    alive: bool,
}

/// The albedo of Bevy's deferred G-buffer as a float texture (Bevy packs
/// its base colour as 8-bit `rgb^(1/2.2)`; unlit materials have none).
struct Albedo {
    texture: wgpu::Texture,
    group: wgpu::BindGroup,
    size: (u32, u32),
}

/// The level's renderer in the render world (a resource of the render
/// app; read it from a render-world system for tools and tests).
#[derive(Resource, Default)]
pub struct GibakeRender {
    renderer: Option<Renderer>,
    /// The level generation and mode the renderer has.
    generation: u64,
    mode: Option<Mode>,
    interleave: u32,
    /// Per render-world camera entity.
    views: HashMap<Entity, CameraView>,
    /// Per main-world entity of a moving object: its handle and shown state.
    objects: HashMap<Entity, (ObjectHandle, bool)>,
    unpack: Option<wgpu::ComputePipeline>,
    /// This frame is drawn (prepared without error).
    active: bool,
    /// The error last logged (logged once until it changes).
    last_error: Option<String>,
}

impl GibakeRender {
    /// The level's renderer, once made.
    pub fn renderer(&self) -> Option<&Renderer> {
        self.renderer.as_ref()
    }

    /// The gibake view of a render-world camera entity.
    pub fn view_of(&self, camera: Entity) -> Option<ViewId> {
        self.views.get(&camera).map(|v| v.id)
    }

    /// Whether this frame is drawn (prepared without error).
    pub fn active(&self) -> bool {
        self.active
    }
}

/// Logs an error once (until it changes) and reports it.
fn fail(last: &mut Option<String>, shared: &GibakeShared, e: String) {
    if last.as_ref() != Some(&e) {
        error!("gibake: {e}");
        *last = Some(e.clone());
    }
    shared.set(|s| s.error = Some(e));
}

fn settings_mode(m: GibakeMode) -> Mode {
    match m {
        GibakeMode::Indirect => Mode::Indirect,
        GibakeMode::Everything => Mode::Full,
    }
}

type CameraItem<'a> = (
    Entity,
    &'a ExtractedView,
    &'a ExtractedCamera,
    &'a ViewTarget,
    Option<&'a ViewPrepassTextures>,
    &'a GibakeCamera,
);

/// The frame's preparation (see the module docs).
#[allow(clippy::too_many_arguments)]
pub(crate) fn prepare(
    mut state: ResMut<GibakeRender>,
    frame: Res<ExtractedGibake>,
    shared: Res<GibakeShared>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    cameras: Query<CameraItem>,
) {
    let state = &mut *state;
    state.active = false;
    let device = device.wgpu_device();
    let queue: &wgpu::Queue = &queue;
    if let Some(r) = &mut state.renderer
        && let Some(stats) = r.poll_stats(device)
    {
        shared.set(|s| s.stats = Some(stats));
    }
    let Some(level) = &frame.level else {
        return;
    };
    if !frame.settings.enabled {
        return;
    }
    let mut cams: Vec<CameraItem> = cameras.iter().collect();
    // Cameras in their render order: the first is the renderer's main view.
    cams.sort_by_key(|c| (c.2.order, c.0));
    let mode = settings_mode(frame.settings.mode);
    let interleave = frame.settings.interleave;
    // A new renderer for a new mode (the frame plan changes), or the first.
    if state.renderer.is_none() || state.mode != Some(mode) || state.interleave != interleave {
        let (w, h) = cams
            .first()
            .and_then(|c| c.2.physical_target_size)
            .map_or((1, 1), |s| (s.x.max(1), s.y.max(1)));
        let settings = RenderSettings {
            width: w,
            height: h,
            mode,
            interleave,
            ..Default::default()
        };
        match Renderer::new(device, queue, &level.scene, Some(&level.asset), &settings) {
            Ok(r) => {
                state.renderer = Some(r);
                state.generation = level.generation;
                state.mode = Some(mode);
                state.interleave = interleave;
                state.views.clear();
                state.objects.clear();
            }
            Err(e) => {
                state.renderer = None;
                state.mode = Some(mode);
                state.interleave = interleave;
                return fail(&mut state.last_error, &shared, e.to_string());
            }
        }
    }
    let Some(r) = state.renderer.as_mut() else {
        return;
    };
    // A re-bake: the same renderer, views and (same names) handles.
    if level.generation != state.generation {
        match r.set_asset(device, queue, &level.scene, Some(&level.asset)) {
            Ok(reload) => {
                state.generation = level.generation;
                shared.set(|s| {
                    s.reloads += 1;
                    s.handles_kept = Some(reload == gibake_runtime::Reload::HandlesKept);
                });
                if reload == gibake_runtime::Reload::HandlesRenewed {
                    state.objects.clear();
                }
                info!("gibake: the re-baked asset is in use ({reload:?})");
            }
            Err(e) => {
                // The old asset stays.
                state.generation = level.generation;
                let e = format!("the re-baked asset was not taken: {e}");
                fail(&mut state.last_error, &shared, e);
            }
        }
    }

    // Moving objects: the level's own by name, copies spawned, gone ones
    // removed, visibility as Bevy's.
    let mut moved = Vec::with_capacity(frame.objects.len());
    let mut seen = Vec::with_capacity(frame.objects.len());
    for o in frame.objects.iter().filter(|o| o.declared) {
        let handle = match state.objects.get(&o.entity) {
            Some((h, _)) => Some(*h),
            None => r.object(&o.name).inspect(|h| {
                state.objects.insert(o.entity, (*h, true));
            }),
        };
        if let Some(h) = handle {
            moved.push((h, o.matrix));
            seen.push((o.entity, o.visible));
        }
    }
    for o in frame.objects.iter().filter(|o| !o.declared) {
        let handle = match state.objects.get(&o.entity) {
            Some((h, _)) => Some(*h),
            None => match r.object(&o.name) {
                Some(like) => match r.spawn(queue, like, o.matrix) {
                    Ok(h) => {
                        state.objects.insert(o.entity, (h, true));
                        Some(h)
                    }
                    Err(e) => {
                        fail(&mut state.last_error, &shared, format!("{}: {e}", o.name));
                        None
                    }
                },
                None => {
                    warn_once!(
                        "gibake: GibakeObject::copy_of({:?}): the level has no moving object of that name",
                        o.name
                    );
                    None
                }
            },
        };
        if let Some(h) = handle {
            moved.push((h, o.matrix));
            seen.push((o.entity, o.visible));
        }
    }
    let gone: Vec<Entity> = state
        .objects
        .keys()
        .filter(|e| !seen.iter().any(|(s, _)| s == *e))
        .copied()
        .collect();
    for e in gone {
        if let Some((h, _)) = state.objects.remove(&e) {
            let _ = r.remove(h);
        }
    }
    for (e, visible) in seen {
        if let Some((h, shown)) = state.objects.get_mut(&e)
            && *shown != visible
        {
            *shown = visible;
            let _ = r.set_visible(*h, visible);
        }
    }

    // Views: the first camera is the main view, the others added.
    for v in state.views.values_mut() {
        v.alive = false;
    }
    let mut cameras_in = Vec::new();
    let mut main_camera = None;
    for (entity, view, camera, target, prepass, gcam) in &cams {
        let t = target.main_texture();
        let size = (t.width(), t.height());
        if !state.views.contains_key(entity) {
            let taken = state.views.values().any(|v| v.id == ViewId::MAIN);
            let id = if taken {
                match r.add_view(device, queue, size.0, size.1, interleave) {
                    Ok(id) => id,
                    Err(e) => {
                        fail(&mut state.last_error, &shared, e.to_string());
                        continue;
                    }
                }
            } else {
                ViewId::MAIN
            };
            state.views.insert(
                *entity,
                CameraView {
                    id,
                    size: r.view_size(id).unwrap_or((0, 0)),
                    sources: None,
                    albedo: None,
                    alive: true,
                },
            );
        }
        let v = state.views.get_mut(entity).expect("inserted above");
        v.alive = true;
        if v.size != size {
            if let Err(e) = r.resize_view(device, queue, v.id, size.0, size.1) {
                fail(&mut state.last_error, &shared, e.to_string());
                continue;
            }
            v.size = size;
            v.sources = None;
        }
        if camera.viewport.is_some() {
            warn_once!(
                "gibake: a GibakeCamera with a viewport is shaded over its whole target (viewports are not supported)"
            );
        }
        // The G-buffer: Bevy's prepass, unless the camera asks for gibake's own.
        let bevy_gbuffer = prepass.and_then(|p| {
            Some([
                (*p.depth.as_ref()?.texture.texture).clone(),
                (*p.normal.as_ref()?.texture.texture).clone(),
                (*p.deferred.as_ref()?.texture.texture).clone(),
            ])
        });
        match (bevy_gbuffer, gcam.own_gbuffer) {
            (Some(src), false) => {
                if v.sources.as_ref() != Some(&src) {
                    let pipeline = state
                        .unpack
                        .get_or_insert_with(|| unpack_pipeline(device))
                        .clone();
                    let albedo = Albedo::new(device, &pipeline, &src[2], size);
                    let result = r.use_depth_gbuffer(
                        device,
                        v.id,
                        &DepthGBuffer {
                            depth: &src[0],
                            far_depth: 0.0,
                            normals: &src[1],
                            encoding: NormalEncoding::WorldUnorm,
                            albedo: &albedo.texture,
                        },
                    );
                    if let Err(e) = result {
                        fail(
                            &mut state.last_error,
                            &shared,
                            format!("Bevy's G-buffer: {e}"),
                        );
                        continue;
                    }
                    v.albedo = Some(albedo);
                    v.sources = Some(src);
                }
            }
            (None, false) => {
                warn_once!(
                    "gibake: a GibakeCamera without Bevy's depth, normal and deferred prepass textures: gibake draws its own G-buffer"
                );
            }
            _ => {}
        }
        if let Err(e) = r.set_output(device, v.id, OutputTarget::AddScaled(t, camera.exposure)) {
            fail(
                &mut state.last_error,
                &shared,
                format!("the camera's target: {e}"),
            );
            continue;
        }
        let m = camera_matrices(&view.world_from_view, view.clip_from_view);
        if v.id == ViewId::MAIN {
            main_camera = Some(m);
        } else {
            cameras_in.push((v.id, m));
        }
    }
    // Cameras gone: their views too (the main one stays, unused).
    let gone: Vec<Entity> = state
        .views
        .iter()
        .filter(|(_, v)| !v.alive)
        .map(|(e, _)| *e)
        .collect();
    for e in gone {
        if let Some(v) = state.views.remove(&e)
            && v.id != ViewId::MAIN
        {
            let _ = r.remove_view(v.id);
        }
    }
    let Some(main) = main_camera.or_else(|| cameras_in.first().map(|(_, m)| *m)) else {
        return; // no camera: nothing to draw
    };
    let input = FrameInput::new(main).moving(&moved).views(&cameras_in);
    match r.prepare(device, queue, &input) {
        Ok(()) => {
            state.active = true;
            shared.set(|s| s.frames += 1);
        }
        Err(e) => fail(&mut state.last_error, &shared, e.to_string()),
    }
}

/// The once-per-frame passes, before Bevy runs the cameras.
pub(crate) fn record_update(state: Res<GibakeRender>, mut ctx: RenderContext) {
    if let (true, Some(r)) = (state.active, &state.renderer) {
        r.record_update(ctx.command_encoder());
    }
}

/// The pass timers, after every camera.
pub(crate) fn record_finish(state: Res<GibakeRender>, mut ctx: RenderContext) {
    if let (true, Some(r)) = (state.active, &state.renderer) {
        r.record_finish(ctx.command_encoder());
    }
}

/// One camera's gibake light: Bevy's albedo unpacked, then the view's
/// rebuild, shading and addition into the camera's main texture.
pub(crate) fn record_view(
    view: ViewQuery<Entity, With<GibakeCamera>>,
    state: Res<GibakeRender>,
    mut ctx: RenderContext,
) {
    let entity = view.into_inner();
    let (true, Some(r)) = (state.active, &state.renderer) else {
        return;
    };
    let Some(v) = state.views.get(&entity) else {
        return;
    };
    let encoder = ctx.command_encoder();
    if let (Some(a), Some(pipeline)) = (&v.albedo, &state.unpack) {
        a.encode(encoder, pipeline);
    }
    let _ = r.record_view(encoder, v.id);
}

/// The schedule order of the per-camera system.
pub(crate) fn view_system_config()
-> bevy::ecs::schedule::ScheduleConfigs<bevy::ecs::system::ScheduleSystem> {
    record_view
        .after(main_opaque_pass_3d)
        .before(main_transparent_pass_3d)
        .into_configs()
}

const UNPACK_WGSL: &str = include_str!("unpack_albedo.wgsl");

fn unpack_pipeline(device: &wgpu::Device) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("gibake-bevy unpack_albedo.wgsl"),
        source: wgpu::ShaderSource::Wgsl(UNPACK_WGSL.into()),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("gibake-bevy unpack albedo"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    })
}

impl Albedo {
    fn new(
        device: &wgpu::Device,
        pipeline: &wgpu::ComputePipeline,
        gbuffer: &wgpu::Texture,
        size: (u32, u32),
    ) -> Albedo {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("gibake-bevy albedo"),
            size: wgpu::Extent3d {
                width: size.0,
                height: size.1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba16Float,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("gibake-bevy unpack albedo"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(
                        &gbuffer.create_view(&Default::default()),
                    ),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(
                        &texture.create_view(&Default::default()),
                    ),
                },
            ],
        });
        Albedo {
            texture,
            group,
            size,
        }
    }

    fn encode(&self, encoder: &mut wgpu::CommandEncoder, pipeline: &wgpu::ComputePipeline) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("gibake-bevy unpack albedo"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        pass.dispatch_workgroups(self.size.0.div_ceil(8), self.size.1.div_ceil(8), 1);
    }
}
