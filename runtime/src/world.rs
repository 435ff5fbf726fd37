//! What a renderer builds from its scene and asset, shared by every view:
//! the frame plan, the meshes, the baked data, the primary light, the
//! per-frame update of the moving objects, the G-buffer pipeline and the
//! light and GI data shading reads. [`World::new`] checks everything before
//! creating anything, so a failed [`crate::Renderer::set_asset`] leaves the
//! renderer as it was.

use gibake_asset::Asset;
use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_scene::Scene;
use glam::Mat4;

use crate::CameraMatrices;
use crate::baked::BakedGpu;
use crate::cascades::CascadePasses;
use crate::gbuffer::GBufferPass;
use crate::light::PrimaryLight;
use crate::moving::{MovingPasses, UpdateInputs};
use crate::other_lights::OtherLights;
use crate::plan::FramePlan;
use crate::shade::{GiSources, ShadeGi, ShadePass};
use crate::stats::Timer;
use crate::{RenderSettings, RuntimeError};

/// The scene- and asset-dependent part of a renderer.
pub(crate) struct World {
    pub plan: FramePlan,
    pub scene_gpu: SceneGpu,
    pub baked: Option<BakedGpu>,
    pub light: PrimaryLight,
    /// The scene's primary lights, as the API reports them.
    pub lights: Vec<crate::LightInfo>,
    pub moving: MovingPasses,
    pub gbuffer: GBufferPass,
    pub gi: ShadeGi,
    /// Cascaded shadow maps of the direct light (when planned).
    pub cascades: Option<CascadePasses>,
    /// The lights after the first (a scene with several).
    pub other_lights: Option<OtherLights>,
    /// The draws of the moving objects that are shown (hidden and removed
    /// ones are left out of every pass).
    pub moving_draws: Vec<Draw>,
}

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

impl World {
    /// Plans the frame and uploads `scene` (and `asset`, which every mode
    /// but `direct` needs); moving objects at their animation's time 0.
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        shade: &ShadePass,
        scene: &Scene,
        asset: Option<&Asset>,
        settings: &RenderSettings,
    ) -> Result<World, RuntimeError> {
        let plan = FramePlan::new(settings, scene, asset)?;
        if let Some(a) = asset {
            let hash = gibake_scene::static_scene_hash(scene);
            gibake_asset::check_scene_hash(&a.manifest, &hash, &scene.source)?;
        }
        check_textures(device, scene)?;
        // The asset first: its limits are checked before any other upload.
        let mut baked = asset.map(|a| BakedGpu::new(device, queue, a)).transpose()?;
        // The merge's culling of the moving objects its maps hide
        // (map_cells.rs), only where there is a merge to cull.
        if let (Some(b), Some(a)) = (baked.as_mut(), asset)
            && plan.has(crate::Pass::VplMaps)
            && plan.mode() != crate::Mode::Naive
        {
            b.map_cells = Some(crate::map_cells::MapCells::new(a, b));
        }
        // Room for the draws of spawned copies of the biggest object.
        let most_meshes = scene.dynamic_objects.iter().map(|o| o.meshes.len()).max();
        let spare = settings
            .max_spawned
            .saturating_mul(most_meshes.unwrap_or(0) as u32);
        let scene_gpu = SceneGpu::with_spare_draws(device, queue, scene, 0.0, spare);
        let light = PrimaryLight::new(
            device,
            queue,
            scene,
            &scene_gpu,
            baked.as_ref(),
            settings.shadow_map_size,
        );
        let other_lights = OtherLights::new(
            device,
            queue,
            scene,
            &scene_gpu,
            asset,
            settings.shadow_map_size,
            plan.has(crate::Pass::LightMerge),
        )?;
        let moving = MovingPasses::new(
            device,
            &UpdateInputs {
                plan: &plan,
                scene_gpu: &scene_gpu,
                baked: baked.as_ref(),
                primary_view: light.view,
                light_buf: &light.light_buf,
                lights: &scene.lights,
                threshold: asset.map_or(0.0, |a| a.manifest.settings.threshold),
                max_dynamic_vpls: settings.max_dynamic_vpls,
                max_dynamic_vpls_per_view: settings.max_dynamic_vpls_per_view,
                scene_diagonal: scene.full_bounds().diagonal(),
                split_windows: settings.split_windows,
                merge_cull_share: settings.merge_cull_share,
                material_albedo: material_albedo(scene),
            },
        )?;
        let gbuffer = GBufferPass::new(device, &scene_gpu);
        let cascades = plan.cascades().map(|layout| {
            CascadePasses::new(
                device,
                &scene_gpu,
                &light.view,
                layout,
                plan.has(crate::Pass::PrimaryMerge),
            )
        });
        let gi = ShadeGi::new(
            device,
            shade,
            &GiSources {
                plan: &plan,
                baked: baked.as_ref(),
                light: &light,
                moving: &moving,
                cascades: cascades.as_ref(),
                other_lights: other_lights.as_ref(),
            },
        );
        let moving_draws = scene_gpu.dynamic_draws.clone();
        Ok(World {
            plan,
            scene_gpu,
            baked,
            light,
            lights: crate::LightInfo::of(scene, asset),
            moving,
            gbuffer,
            gi,
            cascades,
            other_lights,
            moving_draws,
        })
    }

    /// Shows only the moving objects `shown` says (by object index).
    pub(crate) fn show(&mut self, shown: &[bool]) {
        self.moving_draws = self
            .scene_gpu
            .dynamic_draws
            .iter()
            .filter(|d| {
                d.object
                    .is_some_and(|o| shown.get(o).copied().unwrap_or(true))
            })
            .cloned()
            .collect();
    }

    /// Uploads the moving objects' matrices and this frame's merge tables;
    /// returns the VPL maps affected.
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        shade: &ShadePass,
        transforms: &[Mat4],
        camera: &CameraMatrices,
    ) -> Result<u32, RuntimeError> {
        if let Some(c) = self.cascades.as_mut() {
            c.prepare(queue, camera);
        }
        if !transforms.is_empty() {
            self.scene_gpu.set_dynamic_transforms(queue, transforms);
        }
        // The moving objects' world boxes: which light views they touch.
        let boxes: Vec<gibake_scene::Aabb> = self
            .moving_draws
            .iter()
            .map(|d| match d.object.and_then(|k| transforms.get(k)) {
                Some(m) => d.bounds.transformed(*m),
                None => d.bounds,
            })
            .collect();
        if let Some(o) = self.other_lights.as_mut().filter(|o| o.merges()) {
            o.prepare(queue, &boxes);
        }
        let grown = self.moving.prepare(
            device,
            queue,
            &self.scene_gpu,
            &self.moving_draws,
            transforms,
            &boxes,
        )?;
        self.gi
            .set_dynamic_slots(queue, self.moving.dynamic_vpl_slots());
        if let Some((per_bounce, tail)) = self.baked.as_ref().and_then(|b| b.later_series.as_ref())
        {
            let none = crate::later_absorb::Absorbed::default();
            let a = self.moving.later_absorbed().unwrap_or(&none);
            // Each later VPL's own factor where the occlusion buffer
            // carries it: every transfer into it loses what the objects
            // its map sees take (later_absorb::local_keep); else the
            // level-wide means, in one factor for all.
            let own = self.moving.has_later_factors();
            let n_later = self.baked.as_ref().map_or(0, |b| b.later as usize);
            let (s, keep) = if own {
                let keep: Vec<glam::Vec3> = (0..n_later)
                    .map(|j| {
                        let l = a.local.get(j).copied().unwrap_or(glam::Vec3::ZERO);
                        crate::later_absorb::local_keep(per_bounce, *tail, l)
                    })
                    .collect();
                (glam::Vec3::ONE, keep)
            } else {
                let s = crate::later_absorb::later_scale(per_bounce, *tail, a.first, a.later)
                    * (glam::Vec3::ONE - a.later);
                (s, vec![glam::Vec3::ONE; n_later])
            };
            let reported = s * crate::later_absorb::weighted_mean(&keep, &a.local_weight);
            self.moving.write_later_factors(queue, &keep);
            self.gi.set_later_scale(queue, s, reported);
        }
        if grown {
            let sources = GiSources {
                plan: &self.plan,
                baked: self.baked.as_ref(),
                light: &self.light,
                moving: &self.moving,
                cascades: self.cascades.as_ref(),
                other_lights: self.other_lights.as_ref(),
            };
            self.gi.atlas_changed(device, queue, shade, &sources);
        }
        Ok(self.moving.affected())
    }

    /// Records the frame's update (once, whatever the number of views).
    pub(crate) fn record_update(&self, encoder: &mut wgpu::CommandEncoder, timer: &Timer) {
        if let Some(c) = self.cascades.as_ref().filter(|c| c.draws()) {
            let ts = timer.render(crate::Pass::Cascades, None);
            c.record(encoder, &self.scene_gpu, &self.moving_draws, ts);
        }
        self.moving
            .record(encoder, &self.scene_gpu, &self.moving_draws, timer);
        if let Some(o) = &self.other_lights {
            o.record(encoder, &self.scene_gpu, &self.moving_draws, timer);
        }
    }

    /// Views of the lights after the first that moving objects touch this
    /// frame (each gets a light-merge pass).
    pub(crate) fn light_views_touched(&self) -> u32 {
        self.other_lights.as_ref().map_or(0, OtherLights::touched)
    }

    /// Draw calls of this frame's light merge.
    pub(crate) fn light_merge_draw_calls(&self) -> u32 {
        self.other_lights.as_ref().map_or(0, |o| o.draw_calls())
    }

    /// Draw calls of this frame's cascade passes.
    pub(crate) fn cascade_draw_calls(&self) -> u32 {
        self.cascades.as_ref().filter(|c| c.draws()).map_or(0, |c| {
            c.draw_calls(
                self.scene_gpu.static_draws.len() as u32,
                self.moving_draws.len() as u32,
            )
        })
    }

    /// Whether this frame records the cascade pass.
    pub(crate) fn cascades_draw(&self) -> bool {
        self.cascades.as_ref().is_some_and(CascadePasses::draws)
    }

    /// Draw calls of one view's G-buffer pass.
    pub(crate) fn gbuffer_draw_calls(&self) -> u32 {
        (self.scene_gpu.static_draws.len() + self.moving_draws.len()) as u32
    }
}

/// Each material's mean albedo (linear RGB, its texture averaged over an
/// 8×8 grid of its coordinates), then white for the scene's default
/// material: what a moving object absorbs of the later bounces.
fn material_albedo(scene: &Scene) -> Vec<glam::Vec3> {
    (0..scene.materials.len())
        .map(|m| {
            let mut sum = glam::Vec3::ZERO;
            for j in 0..8 {
                for i in 0..8 {
                    let uv = glam::Vec2::new(i as f32 + 0.5, j as f32 + 0.5) / 8.0;
                    sum += scene.albedo(m, Some(uv));
                }
            }
            sum / 64.0
        })
        .chain(std::iter::once(glam::Vec3::ONE))
        .collect()
}
