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
//!
//!    the same three for every other light's view whose static RSM the
//!    asset stores (format 4.1: the views moving objects can enter), each
//!    frame only in the views the moving objects' boxes touch
//!    ([`Pass::LightBounce`]); one set of RSM targets, one occluded sum per
//!    static VPL and one slot buffer serve them all (each view's dynamic
//!    VPLs in its own slot range, zeroed when it is not touched);
//! 3. VPL maps: only the VPLs whose hemisphere a moving object's bounds
//!    enter get a merge-atlas tile in which the moving objects are
//!    rasterized (`naive`: every map re-rendered from all geometry).
//!
//! The update runs once per frame whatever the number of views; every
//! view's shading reads its results ([`MovingPasses::gi`]). With no moving
//! objects (and not `naive`) none of it exists: no pass, no texture.

use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_gpu::passes::shadow::ShadowPass;
use gibake_gpu::{GpuPrimaryLight, LightView};
use gibake_scene::{Aabb, Light};
use glam::Mat4;
use wgpu::util::DeviceExt;

use crate::RuntimeError;
use crate::baked::{BakedGpu, RsmGpu};
use crate::dynamic_rsm::{DynamicRsmPass, OcclusionPass, OcclusionView, RsmView, Window, Windows};
use crate::dynamic_vpl::{DynamicVplPass, VplView};
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
    /// The scene's lights (the other views' bounce uses theirs).
    pub lights: &'a [Light],
    /// The bake's clustering threshold (for the dynamic VPLs).
    pub threshold: f32,
    /// Most dynamic VPLs per frame (the primary light's).
    pub max_dynamic_vpls: u32,
    /// Most dynamic VPLs per view of the other lights.
    pub max_dynamic_vpls_per_view: u32,
    /// The scene's diagonal (scales the merge's depth).
    pub scene_diagonal: f32,
    /// [`crate::RenderSettings::split_windows`].
    pub split_windows: bool,
    /// [`crate::RenderSettings::merge_cull_share`].
    pub merge_cull_share: f32,
    /// Per scene material: its mean albedo.
    pub material_albedo: Vec<glam::Vec3>,
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

/// One light view the bounce off moving objects is computed in: its
/// bindings (`None`: the passes' own, made for it), its view, whether it is
/// the primary light's (recorded every frame), whether this frame's moving
/// objects touch it, and the window of its map they cover.
struct BounceView {
    view: LightView,
    rsm: Option<RsmView>,
    occlusion: Option<OcclusionView>,
    vpls: Option<VplView>,
    /// Its light's `GpuPrimaryLight` uniform (bound in `vpls`).
    _light_buf: Option<wgpu::Buffer>,
    primary: bool,
    touched: bool,
    /// The first slot of its range (the views recorded this frame come
    /// first, in order), as its parameters say.
    base: u32,
    /// Where its occlusion test and dynamic VPLs run this frame (the
    /// squares of its map around the moving objects' boxes), as its
    /// parameters say.
    windows: Windows,
    /// This frame's texel rectangles of the boxes it can see (scratch).
    rects: Vec<[u32; 4]>,
    /// The moving draws whose box it can see this frame (only those are
    /// drawn into its RSM: the others' triangles would all be clipped).
    seen: Vec<u32>,
}

/// The moving objects' passes of one renderer.
pub(crate) struct MovingPasses {
    /// The later VPLs' own factors last written to the occlusion buffer's
    /// tail ([`MovingPasses::write_later_factors`]).
    later_factors: Vec<f32>,
    primary: Option<ShadowPass>,
    rsm: Option<(DynamicRsmPass, OcclusionPass)>,
    /// The later bounces' VPLs' share of the occlusion (an asset with
    /// later VPLs, format 4.6).
    later_occlusion: Option<crate::later_occlusion::LaterOcclusionPass>,
    vpls: Option<DynamicVplPass>,
    /// Every view the bounce is computed in, the primary light's first (the
    /// order of the dynamic VPLs' slot ranges).
    bounce: Vec<BounceView>,
    merge: Option<VplMerge>,
    /// Draw calls of this frame's VPL-map merge.
    merge_draws: u32,
    /// Draw calls of the moving objects shown this frame (each of their
    /// passes draws them all).
    moving_draws: u32,
    /// Dynamic VPL slots of the views recorded this frame (shading reads
    /// those).
    dynamic_slots: u32,
    /// [`crate::RenderSettings::split_windows`].
    split_windows: bool,
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
        // The views of the bounce: the primary light's RSM (DynamicRsm,
        // Occlusion, DynamicVpls), then the other lights' stored ones
        // (LightBounce).
        let mut sources: Vec<(&RsmGpu, bool)> = Vec::new();
        if let Some(r) = i.baked.and_then(|b| b.rsm.as_ref())
            && plan.has(Pass::DynamicRsm)
        {
            sources.push((r, true));
        }
        if plan.has(Pass::LightBounce) {
            sources.extend(
                i.baked
                    .into_iter()
                    .flat_map(|b| &b.view_rsms)
                    .map(|r| (r, false)),
            );
        }
        // The first light's dynamic VPLs, then each other view's (fewer:
        // `max_dynamic_vpls_per_view`); 0 turns them off.
        let most = |primary: bool| {
            if primary {
                i.max_dynamic_vpls
            } else {
                i.max_dynamic_vpls_per_view.min(i.max_dynamic_vpls)
            }
        };
        let (rsm, vpls, bounce) = match sources.first() {
            Some(&(first, _)) => {
                let pass = DynamicRsmPass::new(device, i.scene_gpu, &first.view);
                let vpl_count = i.baked.map_or(0, |b| b.vpls.len() as u32);
                let occ = OcclusionPass::new(
                    device,
                    &first.static_metric,
                    &pass,
                    &first.texel_info,
                    (vpl_count, i.baked.map_or(0, |b| b.later)),
                );
                let light_of = |r: &RsmGpu, primary: bool| -> Option<wgpu::Buffer> {
                    (!primary).then(|| {
                        let light = i.lights.get(r.light).unwrap_or(&i.lights[0]);
                        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some("bounce light"),
                            contents: bytemuck::bytes_of(&GpuPrimaryLight::new(light)),
                            usage: wgpu::BufferUsages::UNIFORM,
                        })
                    })
                };
                let first_light = light_of(first, sources[0].1);
                let others_most = most(false);
                let more_slots = if others_most > 0 {
                    (sources.len() as u32 - 1) * DynamicVplPass::slots_for(pass.size, others_most)
                } else {
                    0
                };
                let dyn_vpls = (most(sources[0].1) > 0
                    && (plan.has(Pass::DynamicVpls) || plan.has(Pass::LightBounce)))
                .then(|| {
                    DynamicVplPass::new(
                        device,
                        &pass,
                        &first.static_metric,
                        first_light.as_ref().unwrap_or(i.light_buf),
                        i.threshold,
                        most(sources[0].1),
                        more_slots,
                    )
                });
                let mut bounce = vec![BounceView {
                    view: first.view,
                    rsm: None,
                    occlusion: None,
                    vpls: None,
                    _light_buf: first_light,
                    primary: sources[0].1,
                    touched: sources[0].1,
                    base: 0,
                    windows: Windows::one(Window::whole(pass.size)),
                    rects: Vec::new(),
                    seen: Vec::new(),
                }];
                for &(r, primary) in sources.iter().skip(1) {
                    let view = pass.bind(device, i.scene_gpu, &r.view);
                    let occlusion = occ.bind(device, &r.static_metric, &pass, &view, &r.texel_info);
                    let light_buf = light_of(r, primary);
                    let vpls = dyn_vpls.as_ref().filter(|_| most(primary) > 0).map(|d| {
                        d.bind(
                            device,
                            &pass,
                            &view,
                            &r.static_metric,
                            light_buf.as_ref().unwrap_or(i.light_buf),
                            most(primary),
                        )
                    });
                    bounce.push(BounceView {
                        view: r.view,
                        rsm: Some(view),
                        occlusion: Some(occlusion),
                        vpls,
                        _light_buf: light_buf,
                        primary,
                        touched: primary,
                        // Set when it is first recorded.
                        base: u32::MAX,
                        windows: Windows::one(Window::whole(pass.size)),
                        rects: Vec::new(),
                        seen: Vec::new(),
                    });
                }
                (Some((pass, occ)), dyn_vpls, bounce)
            }
            None => (None, None, Vec::new()),
        };
        let merge = match i.baked {
            Some(b) if plan.has(Pass::VplMaps) => Some(VplMerge::new(
                device,
                i.scene_gpu,
                b,
                i.scene_diagonal,
                plan.mode() == crate::Mode::Naive,
                i.merge_cull_share,
                i.material_albedo.clone(),
            )?),
            _ => None,
        };
        let later_occlusion = match (i.baked, &rsm) {
            (Some(b), Some((_, occ))) => {
                let fluxes: Vec<[f32; 3]> = b.vpls.iter().map(|v| v.flux).collect();
                crate::later_occlusion::LaterOcclusionPass::new(
                    device,
                    &fluxes,
                    b.later,
                    b.later_sources.as_ref(),
                    &occ.occluded,
                )
            }
            _ => None,
        };
        Ok(MovingPasses {
            later_factors: Vec::new(),
            primary,
            rsm,
            later_occlusion,
            vpls,
            bounce,
            merge,
            merge_draws: 0,
            moving_draws: i.scene_gpu.dynamic_draws.len() as u32,
            dynamic_slots: 0,
            split_windows: i.split_windows,
        })
    }

    /// Whether any of the passes exists.
    pub(crate) fn exists(&self) -> bool {
        self.primary.is_some() || self.rsm.is_some() || self.vpls.is_some() || self.merge.is_some()
    }

    /// Uploads this frame's merge tables for the moving objects' `draws`
    /// shown, at `transforms` (their draw data is already on the GPU), and
    /// picks the other lights' views their world `boxes` touch. Returns
    /// whether the merge atlas was re-created (shading rebinds it); on an
    /// error the last frame's tables stay.
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene_gpu: &SceneGpu,
        draws: &[Draw],
        transforms: &[Mat4],
        boxes: &[Aabb],
    ) -> Result<bool, RuntimeError> {
        self.moving_draws = draws.len() as u32;
        // Per view: the boxes it can see, the window they cover (none seen:
        // one texel, for the primary view that is recorded anyway), and,
        // for the views recorded this frame, the next slot range in order
        // (shading reads only those, `dynamic_vpl_slots`). Parameters are
        // written only where the window or the range moved.
        let mut next = 0;
        for b in &mut self.bounce {
            b.seen.clear();
            b.rects.clear();
            for (k, x) in boxes.iter().enumerate() {
                if let Some(c) = b.view.texel_rect(x) {
                    b.seen.push(k as u32);
                    b.rects.push(c);
                }
            }
            if !b.primary {
                b.touched = !b.rects.is_empty();
            }
            if !b.touched {
                continue;
            }
            // No box seen: one texel (the primary view is recorded anyway).
            let mut windows = Windows::around(&b.rects, b.view.size);
            if !self.split_windows {
                windows = Windows::one(windows.union);
            }
            if let Some((_, occlusion)) = &self.rsm
                && b.windows != windows
            {
                let v = b.occlusion.as_ref().unwrap_or(occlusion.own_view());
                occlusion.set_window(queue, v, &windows);
            }
            if let Some(d) = &self.vpls {
                let v = match &b.rsm {
                    None => Some(d.own_view()),
                    Some(_) => b.vpls.as_ref(),
                };
                if let Some(v) = v {
                    if b.base != next || b.windows != windows {
                        d.set_frame(queue, v, next, &windows);
                        b.base = next;
                    }
                    next += DynamicVplPass::slots_of(v);
                }
            }
            b.windows = windows;
        }
        self.dynamic_slots = next;
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

    /// Per moving object, the VPL maps it is merged into this frame.
    pub(crate) fn merge_maps_per_object(&self) -> Vec<u32> {
        self.merge
            .as_ref()
            .map_or_else(Vec::new, |m| m.per_object().to_vec())
    }

    /// The merge's rasterization instances this frame.
    pub(crate) fn merge_instances(&self) -> u32 {
        self.merge.as_ref().map_or(0, VplMerge::instances)
    }

    /// What the moving objects absorb of the later bounces this frame
    /// (none without a merge).
    pub(crate) fn later_absorbed(&self) -> Option<&crate::later_absorb::Absorbed> {
        self.merge.as_ref().map(VplMerge::later_absorbed)
    }

    /// Writes the later VPLs' own factors (what the moving objects near
    /// each take of the light that reaches it) after the occluded shares,
    /// where the occlusion buffer exists.
    /// Written only when they change (the tail is never cleared).
    pub(crate) fn write_later_factors(&mut self, queue: &wgpu::Queue, factors: &[glam::Vec3]) {
        if let Some((_, occ)) = &self.rsm
            && !factors.is_empty()
        {
            let data: Vec<f32> = factors.iter().flat_map(|f| [f.x, f.y, f.z, 1.0]).collect();
            if data != self.later_factors {
                queue.write_buffer(
                    &occ.occluded,
                    4 * u64::from(occ.vpl_count),
                    bytemuck::cast_slice(&data),
                );
                self.later_factors = data;
            }
        }
    }

    /// Whether the later VPLs' own factors are bound ([`Self::write_later_factors`]).
    pub(crate) fn has_later_factors(&self) -> bool {
        self.rsm.is_some()
    }

    /// (Map, draw) pairs the merge left out as faint this frame.
    pub(crate) fn merge_faint_pairs(&self) -> u32 {
        self.merge.as_ref().map_or(0, VplMerge::faint)
    }

    /// VPL maps a moving object reaches that their baked map hides.
    pub(crate) fn hidden_maps(&self) -> u32 {
        self.merge.as_ref().map_or(0, VplMerge::hidden)
    }

    /// The other lights' views whose bounce this frame computes.
    pub(crate) fn light_views_bounced(&self) -> u32 {
        self.bounce
            .iter()
            .filter(|b| !b.primary && b.touched)
            .count() as u32
    }

    /// RSM texels this frame's occlusion tests and dynamic-VPL clustering
    /// cover: the windows' areas over the views whose bounce is computed.
    pub(crate) fn bounce_texels(&self) -> u64 {
        if self.rsm.is_none() {
            return 0;
        }
        self.bounce
            .iter()
            .filter(|b| b.touched)
            .flat_map(|b| {
                let size = u64::from(b.view.size.max(1));
                b.windows
                    .as_slice()
                    .iter()
                    .map(move |w| (1u64 << w.levels.min(31)).min(size).pow(2))
            })
            .sum()
    }

    /// Draw calls [`MovingPasses::record`] records.
    pub(crate) fn draw_calls(&self) -> u32 {
        let primary = self.primary.as_ref().map_or(0, |_| self.moving_draws);
        let rsm: u32 = self
            .bounce
            .iter()
            .filter(|b| b.touched)
            .map(|b| b.seen.len() as u32)
            .sum();
        primary + rsm + self.merge_draws
    }

    /// Dynamic VPL slots shading reads this frame: those of the views
    /// whose bounce is computed (the primary light's, and the other views
    /// the moving objects touch).
    pub(crate) fn dynamic_vpl_slots(&self) -> u32 {
        self.dynamic_slots
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
            p.encode(encoder, scene_gpu, draws, ts);
        }
        if let Some((rsm, occlusion)) = &self.rsm {
            // The occluded shares; the later VPLs' factors after them are
            // the CPU's (written at prepare).
            let shares = 4 * u64::from(occlusion.vpl_count);
            encoder.clear_buffer(&occlusion.occluded, 0, Some(shares.max(4)));
            let others: Vec<usize> = (0..self.bounce.len())
                .filter(|&j| !self.bounce[j].primary && self.bounce[j].touched)
                .collect();
            for (j, b) in self.bounce.iter().enumerate() {
                if !b.touched {
                    continue;
                }
                // The primary's passes are timed apart; the other views'
                // together, from the first one's RSM to the last one's end.
                let (first, last) = match others.iter().position(|&k| k == j) {
                    Some(n) => (n == 0, n + 1 == others.len()),
                    None => (false, false),
                };
                // Its clustering: the pass's own view's, or its own binding
                // (none when the other views have no dynamic VPLs).
                let vpl_view = self.vpls.as_ref().and_then(|d| {
                    let v = match &b.rsm {
                        None => Some(d.own_view()),
                        Some(_) => b.vpls.as_ref(),
                    };
                    v.map(|v| (d, v))
                });
                let has_vpls = vpl_view.is_some();
                let rsm_ts = if b.primary {
                    timer.render(Pass::DynamicRsm, None)
                } else {
                    timer.render_span(Pass::LightBounce, first, false)
                };
                let own = b.rsm.as_ref().unwrap_or(&rsm.own);
                let seen = b.seen.iter().filter_map(|&k| draws.get(k as usize));
                rsm.encode_from(encoder, scene_gpu, own, seen, rsm_ts);
                let occ_ts = if b.primary {
                    timer.compute(Pass::Occlusion, None)
                } else {
                    timer.compute_span(Pass::LightBounce, false, last && !has_vpls)
                };
                occlusion.encode_from(
                    encoder,
                    b.occlusion.as_ref().unwrap_or(occlusion.own_view()),
                    &b.windows,
                    occ_ts,
                );
                if let Some((d, v)) = &vpl_view {
                    let ts = if b.primary {
                        timer.compute(Pass::DynamicVpls, None)
                    } else {
                        timer.compute_span(Pass::LightBounce, false, last)
                    };
                    d.encode_from(encoder, v, &b.windows, ts);
                }
            }
            // Every view's occlusion is summed: the later VPLs' share.
            if let Some(l) = &self.later_occlusion {
                l.encode(encoder);
            }
        }
        if let Some(m) = &self.merge {
            m.record(encoder, timer.render(Pass::VplMaps, None));
        }
    }
}
