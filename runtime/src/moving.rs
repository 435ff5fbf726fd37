//! The per-frame update: every pass moving objects cause (design brief,
//! steps 4–7) as one unit with its own `new` / `prepare` / `record`, built
//! from the [`FramePlan`]:
//!
//! 1. primary merge: moving objects into their own primary shadow map
//!    (shading takes the minimum with the baked static map);
//! 2. dynamic RSM: moving objects at the bake's RSM resolution; texels
//!    where they are nearer the light than the static surface
//!    - occlusion: scale the static VPLs' flux by their lit fraction,
//!    - dynamic VPLs: clustered on the GPU with the bake's rule;
//! 3. VPL maps: only the VPLs whose hemisphere a moving object's bounds
//!    enter get a merge-atlas tile in which the moving objects are
//!    rasterized (`naive`: every map re-rendered from all geometry).
//!
//! The update runs once per frame whatever the number of views; every
//! view's shading reads its results ([`MovingPasses::gi`]). With no moving
//! objects (and not `naive`) none of it exists: no pass, no texture.

use gibake_gpu::LightView;
use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_gpu::passes::shadow::ShadowPass;
use glam::Mat4;

use crate::RuntimeError;
use crate::baked::BakedGpu;
use crate::dynamic_rsm::{DynamicRsmPass, OcclusionPass};
use crate::dynamic_vpl::DynamicVplPass;
use crate::merge::VplMerge;
use crate::plan::{FramePlan, Pass};
use crate::stats::Timer;

/// What the update needs to be built.
pub(crate) struct UpdateInputs<'a> {
    /// The plan that says which passes exist.
    pub plan: &'a FramePlan,
    /// The scene's meshes.
    pub scene_gpu: &'a SceneGpu,
    /// The asset on the GPU (every mode but `direct`).
    pub baked: Option<&'a BakedGpu>,
    /// The primary maps' light view.
    pub primary_view: LightView,
    /// `GpuPrimaryLight` uniform.
    pub light_buf: &'a wgpu::Buffer,
    /// The bake's clustering threshold (for the dynamic VPLs).
    pub threshold: f32,
    /// Most dynamic VPLs per frame.
    pub max_dynamic_vpls: u32,
    /// The scene's diagonal (scales the merge's depth).
    pub scene_diagonal: f32,
}

/// What shading reads from the update (`None`: the pass does not exist).
#[derive(Default)]
pub(crate) struct UpdateOutputs<'a> {
    /// Moving objects' primary shadow map.
    pub primary_dynamic: Option<&'a wgpu::TextureView>,
    /// Per static VPL occluded share.
    pub occlusion: Option<&'a wgpu::Buffer>,
    /// Per static VPL merge-atlas tile.
    pub vpl_tile: Option<&'a wgpu::Buffer>,
    /// The merge atlas.
    pub atlas: Option<&'a wgpu::TextureView>,
    /// Dynamic VPL slots.
    pub dyn_vpls: Option<&'a wgpu::Buffer>,
}

/// The moving objects' passes of one renderer.
pub(crate) struct MovingPasses {
    primary: Option<ShadowPass>,
    rsm: Option<(DynamicRsmPass, OcclusionPass)>,
    vpls: Option<DynamicVplPass>,
    merge: Option<VplMerge>,
    /// Draw calls of this frame's VPL-map merge.
    merge_draws: u32,
    /// Draw calls of the moving objects shown this frame (each of their
    /// passes draws them all).
    moving_draws: u32,
}

impl MovingPasses {
    /// Creates the passes `i.plan` has.
    pub(crate) fn new(
        device: &wgpu::Device,
        i: &UpdateInputs<'_>,
    ) -> Result<MovingPasses, RuntimeError> {
        let plan = i.plan;
        let primary = plan
            .has(Pass::PrimaryMerge)
            .then(|| ShadowPass::new(device, i.scene_gpu, i.primary_view));
        let rsm_data = i.baked.and_then(|b| b.rsm.as_ref());
        let rsm = match rsm_data {
            Some(r) if plan.has(Pass::DynamicRsm) => {
                let pass = DynamicRsmPass::new(device, i.scene_gpu, &r.view);
                let vpl_count = i.baked.map_or(0, |b| b.vpls.len() as u32);
                let occ =
                    OcclusionPass::new(device, &r.static_metric, &pass, &r.texel_info, vpl_count);
                Some((pass, occ))
            }
            _ => None,
        };
        let vpls = match (&rsm, rsm_data) {
            (Some((pass, _)), Some(r)) if plan.has(Pass::DynamicVpls) => Some(DynamicVplPass::new(
                device,
                pass,
                &r.static_metric,
                i.light_buf,
                i.threshold,
                i.max_dynamic_vpls,
            )),
            _ => None,
        };
        let merge = match i.baked {
            Some(b) if plan.has(Pass::VplMaps) => Some(VplMerge::new(
                device,
                i.scene_gpu,
                b,
                i.scene_diagonal,
                plan.mode() == crate::Mode::Naive,
            )?),
            _ => None,
        };
        Ok(MovingPasses {
            primary,
            rsm,
            vpls,
            merge,
            merge_draws: 0,
            moving_draws: i.scene_gpu.dynamic_draws.len() as u32,
        })
    }

    /// Whether any of the passes exists.
    pub(crate) fn exists(&self) -> bool {
        self.primary.is_some() || self.rsm.is_some() || self.vpls.is_some() || self.merge.is_some()
    }

    /// Uploads this frame's merge tables for the moving objects' `draws`
    /// shown, at `transforms` (their draw data is already on the GPU).
    /// Returns whether the merge atlas was re-created (shading rebinds it);
    /// on an error the last frame's tables stay.
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene_gpu: &SceneGpu,
        draws: &[Draw],
        transforms: &[Mat4],
    ) -> Result<bool, RuntimeError> {
        self.moving_draws = draws.len() as u32;
        let grown = match self.merge.as_mut() {
            Some(m) => m.prepare(device, queue, scene_gpu, draws, transforms)?,
            None => false,
        };
        self.merge_draws = self.merge.as_ref().map_or(0, VplMerge::draw_calls);
        Ok(grown)
    }

    /// VPL maps that get a merge tile this frame.
    pub(crate) fn affected(&self) -> u32 {
        self.merge.as_ref().map_or(0, VplMerge::affected)
    }

    /// Draw calls [`MovingPasses::record`] records.
    pub(crate) fn draw_calls(&self) -> u32 {
        let primary = self.primary.as_ref().map_or(0, |_| self.moving_draws);
        let rsm = self.rsm.as_ref().map_or(0, |_| self.moving_draws);
        primary + rsm + self.merge_draws
    }

    /// Dynamic VPL slots shading reads.
    pub(crate) fn dynamic_vpl_slots(&self) -> u32 {
        self.vpls.as_ref().map_or(0, DynamicVplPass::slots)
    }

    /// Tiles per merge-atlas row (1 without a merge).
    pub(crate) fn atlas_cols(&self) -> u32 {
        self.merge.as_ref().map_or(1, VplMerge::atlas_cols)
    }

    /// What shading binds.
    pub(crate) fn outputs(&self) -> UpdateOutputs<'_> {
        UpdateOutputs {
            primary_dynamic: self.primary.as_ref().map(|p| &p.metric_view),
            occlusion: self.rsm.as_ref().map(|(_, o)| &o.occluded),
            vpl_tile: self.merge.as_ref().map(VplMerge::tile_buf),
            atlas: self.merge.as_ref().map(VplMerge::atlas_view),
            dyn_vpls: self.vpls.as_ref().map(|d| &d.vpls),
        }
    }

    /// Records the frame's update (the VPL maps only when some map is
    /// affected).
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_gpu: &SceneGpu,
        draws: &[Draw],
        timer: &Timer,
    ) {
        if let Some(p) = &self.primary {
            let ts = timer.render(Pass::PrimaryMerge, None);
            p.encode(encoder, scene_gpu, &[draws], ts);
        }
        if let Some((rsm, occlusion)) = &self.rsm {
            rsm.encode(
                encoder,
                scene_gpu,
                draws,
                timer.render(Pass::DynamicRsm, None),
            );
            occlusion.encode(encoder, timer.compute(Pass::Occlusion, None));
            if let Some(d) = &self.vpls {
                d.encode(encoder, timer.compute(Pass::DynamicVpls, None));
            }
        }
        if let Some(m) = &self.merge {
            m.record(encoder, timer.render(Pass::VplMaps, None));
        }
    }
}
