//! What a renderer needs of a device, known before one is made
//! ([`Requirements::of`]): the limits (from `wgpu::Limits::downlevel_defaults`
//! up to what the asset and settings need), optional features, and the GPU
//! memory the renderer allocates. [`Requirements::check`] compares them
//! with a device's limits and names the first that is too small;
//! [`crate::Renderer::new`] runs it first, so a device that cannot take the
//! asset is refused with the reason before anything is created.

use gibake_asset::{Asset, atlas_grid};
use gibake_scene::Scene;

use crate::plan::{FramePlan, Pass};
use crate::{RenderSettings, RuntimeError, interleave};

/// Storage buffers one shader stage binds: shading's four (VPLs and their
/// trees, occlusion, tiles, dynamic VPLs) ...
const SHADE_STORAGE_BUFFERS: u32 = 4;
/// ... and two more in a scene with other lights (the lights, their views).
const OTHER_LIGHT_STORAGE_BUFFERS: u32 = 2;
/// Sampled textures shading binds in a scene with other lights: the
/// G-buffer (3), the VPL maps and merge atlas (2), the primary maps (2),
/// the cascades (8) and the other lights' static and moving maps (2); 15
/// with one light, as `downlevel_defaults` allow (16).
const OTHER_LIGHT_SAMPLED_TEXTURES: u32 = 17;
/// The VPL-map merge's rasterizer binds five (draws, vertices, indices,
/// jobs, instances) in its vertex and fragment stages.
const MERGE_STORAGE_BUFFERS: u32 = 5;
/// Bytes of one static VPL or node on the GPU.
const VPL_BYTES: u64 = 48;

/// What a renderer of one scene, asset and settings needs of a device.
#[derive(Clone, Debug, PartialEq)]
pub struct Requirements {
    /// Limits a device must have: `wgpu::Limits::downlevel_defaults()`,
    /// raised where this renderer needs more (request these when creating
    /// the device).
    pub limits: wgpu::Limits,
    /// Features used when present (per-pass GPU times); none is required.
    pub optional_features: wgpu::Features,
    /// Bytes uploaded from the asset (what [`crate::Renderer::asset_bytes`]
    /// reports once created).
    pub asset_bytes: u64,
    /// GPU memory the renderer allocates at creation, asset included
    /// (from the formats and sizes; the driver's own overhead is not
    /// counted). The merge atlas and its tables grow later with the number
    /// of VPL maps moving objects reach.
    pub gpu_bytes: u64,
    /// What needs the most of each raised limit, for messages.
    reasons: Vec<(Limit, String, u64)>,
}

/// A limit [`Requirements`] raises.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Limit {
    Texture2d,
    StorageBinding,
    StorageBuffersPerStage,
    SampledTexturesPerStage,
}

impl Limit {
    fn of(self, l: &wgpu::Limits) -> u64 {
        match self {
            Limit::Texture2d => u64::from(l.max_texture_dimension_2d),
            Limit::StorageBinding => l.max_storage_buffer_binding_size,
            Limit::StorageBuffersPerStage => u64::from(l.max_storage_buffers_per_shader_stage),
            Limit::SampledTexturesPerStage => u64::from(l.max_sampled_textures_per_shader_stage),
        }
    }
}

fn sq(n: u32) -> u64 {
    u64::from(n) * u64::from(n)
}

impl Requirements {
    /// The requirements of a renderer of `scene` with `asset` and
    /// `settings` (the errors of [`crate::FramePlan::new`]: a mode that
    /// needs an asset without one).
    pub fn of(
        scene: &Scene,
        asset: Option<&Asset>,
        settings: &RenderSettings,
    ) -> Result<Requirements, RuntimeError> {
        let plan = FramePlan::new(settings, scene, asset)?;
        let mut r = Requirements {
            limits: wgpu::Limits::downlevel_defaults(),
            optional_features: wgpu::Features::TIMESTAMP_QUERY,
            asset_bytes: 0,
            gpu_bytes: 0,
            reasons: Vec::new(),
        };
        let (w, h) = (settings.width, settings.height);
        let il = interleave::effective(settings.interleave, w, h);
        r.need(Limit::Texture2d, "an output width", u64::from(w));
        r.need(Limit::Texture2d, "an output height", u64::from(h));
        if il > 1 {
            r.need(
                Limit::Texture2d,
                "the interleaved shading target (twice the output width)",
                2 * u64::from(w),
            );
        }
        for t in &scene.textures {
            r.need(
                Limit::Texture2d,
                "a material texture",
                u64::from(t.width.max(t.height)),
            );
            r.gpu_bytes += 4 * u64::from(t.width) * u64::from(t.height);
        }
        let vertices: usize = scene
            .static_meshes
            .iter()
            .chain(&scene.dynamic_meshes)
            .map(|m| m.positions.len())
            .sum();
        let indices: usize = scene
            .static_meshes
            .iter()
            .chain(&scene.dynamic_meshes)
            .map(|m| m.indices.len())
            .sum();
        r.gpu_bytes += 32 * vertices as u64 + 4 * indices as u64;
        // A view: G-buffer (32 B), depth (4), radiance (16) per pixel, and
        // the interleaved shading target (2 × 16).
        let pixels = u64::from(w) * u64::from(h);
        r.gpu_bytes += pixels * (32 + 4 + 16 + if il > 1 { 32 } else { 0 });
        r.need(
            Limit::StorageBuffersPerStage,
            "shading",
            u64::from(SHADE_STORAGE_BUFFERS),
        );
        if gibake_gpu::passes::light_maps::view_count(scene) > 0 {
            r.need(
                Limit::StorageBuffersPerStage,
                "shading the other lights",
                u64::from(SHADE_STORAGE_BUFFERS + OTHER_LIGHT_STORAGE_BUFFERS),
            );
            r.need(
                Limit::SampledTexturesPerStage,
                "shading the other lights",
                u64::from(OTHER_LIGHT_SAMPLED_TEXTURES),
            );
        }
        let shadow = match asset {
            Some(a) => a.primary_depth.size,
            None => settings.shadow_map_size,
        };
        r.need(
            Limit::Texture2d,
            "the primary shadow map",
            u64::from(shadow),
        );
        if asset.is_none() {
            r.gpu_bytes += 8 * sq(shadow);
            // The lights after the first: their maps, rendered here.
            let views = gibake_gpu::passes::light_maps::view_count(scene);
            if views > 0 {
                let max = u32::MAX;
                let (size, _) = gibake_gpu::passes::light_maps::light_map_size(shadow, views, max);
                let (c, rw) = atlas_grid(views as u32);
                r.need(
                    Limit::Texture2d,
                    "the other lights' shadow maps",
                    u64::from(c.max(rw)) * u64::from(size),
                );
                r.gpu_bytes += 4 * u64::from(c) * u64::from(rw) * sq(size);
            }
        }
        if plan.has(Pass::PrimaryMerge) {
            r.gpu_bytes += 8 * sq(shadow);
        }
        if plan.has(Pass::LightMerge) {
            // Moving objects in the other lights' views they can enter: a
            // pass (metric and depth) and an atlas tile per view.
            let (views, size) =
                crate::other_lights::views_of(scene, asset, settings.shadow_map_size);
            let n = crate::other_lights::movable(&views, &scene.dynamic_swept_bounds()).len();
            let (c, rw) = atlas_grid(n as u32);
            r.need(
                Limit::Texture2d,
                "the moving objects' maps of the other lights",
                u64::from(c.max(rw)) * u64::from(size),
            );
            r.gpu_bytes += 8 * n as u64 * sq(size) + 4 * u64::from(c) * u64::from(rw) * sq(size);
        }
        if let Some(c) = plan.cascades() {
            r.need(Limit::Texture2d, "the shadow cascades", u64::from(c.size));
            // Metric and ordering depth per texel, a static map per cascade
            // and, with moving objects, a map of them.
            let maps = if plan.has(Pass::PrimaryMerge) { 2 } else { 1 };
            r.gpu_bytes += maps * u64::from(c.count) * 8 * sq(c.size);
        }
        if let Some(a) = asset {
            r.asset(
                a,
                &plan,
                (
                    settings.max_dynamic_vpls,
                    settings.max_dynamic_vpls_per_view,
                ),
            );
        }
        Ok(r)
    }

    /// The asset's share: its upload and what the planned update allocates.
    fn asset(
        &mut self,
        a: &Asset,
        plan: &FramePlan,
        (max_dynamic_vpls, max_dynamic_vpls_per_view): (u32, u32),
    ) {
        let m = &a.manifest;
        let s = m.settings.vpl_map_size;
        let (cols, rows) = atlas_grid(m.map_count.max(1));
        let side = u64::from(cols.max(rows)) * u64::from(s);
        self.need(Limit::Texture2d, "the asset's VPL map atlas", side);
        let mut atlas = u64::from(cols) * u64::from(rows) * sq(s);
        // The second maps' atlas, below the first in the same texture.
        if m.lower_map_count > 0 {
            let (lc, lr) = atlas_grid(m.lower_map_count);
            let side = u64::from(lc.max(lr)) * u64::from(s);
            self.need(Limit::Texture2d, "the asset's second VPL map atlas", side);
            let height = u64::from(rows + lr) * u64::from(s);
            self.need(
                Limit::Texture2d,
                "the asset's VPL maps and second maps in one texture",
                height,
            );
            atlas += u64::from(lc) * u64::from(lr) * sq(s);
        }
        // The VPLs, their near-field trees, their far-field records, their
        // nodes' facing records and their second maps' records (baked.rs).
        let per_vpl = 2 + gibake_asset::FACINGS_PER_VPL;
        let records = (per_vpl * a.vpls.len() + a.vpl_nodes.len()) as u64 * VPL_BYTES;
        self.need(
            Limit::StorageBinding,
            "the asset's VPLs, near-field nodes, far-field and facing records",
            records,
        );
        let mut upload = 4 * atlas + 4 * sq(a.primary_depth.size) + records;
        if !m.views.is_empty() {
            // The lights after the first: their stored maps (one +inf
            // texel when none is stored).
            let lm = &a.light_maps;
            let (w, h) = if lm.count() == 0 {
                (1, 1)
            } else {
                (lm.width(), lm.height())
            };
            self.need(
                Limit::Texture2d,
                "the other lights' shadow maps",
                u64::from(w.max(h)),
            );
            upload += 4 * u64::from(w) * u64::from(h);
        }
        // The stored RSMs: the primary light's, then the other lights'
        // views' (format 4.1), all `rsm_size`².
        let rsms: Vec<&gibake_asset::RsmData> = a.rsm.iter().chain(&a.view_rsms).collect();
        for rsm in &rsms {
            self.need(Limit::Texture2d, "the baked RSM", u64::from(rsm.size));
            let texels = sq(rsm.size);
            self.need(Limit::StorageBinding, "the RSM texel shares", 8 * texels);
            upload += 12 * texels;
        }
        // One set of dynamic RSM targets and one pyramid serve every view.
        let bounce = plan.has(Pass::DynamicRsm) || plan.has(Pass::LightBounce);
        if let Some(rsm) = rsms.first().filter(|_| bounce) {
            let texels = sq(rsm.size);
            // Targets (16 + 8 + 8) and depth (4); occlusion sums.
            self.gpu_bytes += 36 * texels + 4 * a.vpls.len() as u64;
            if max_dynamic_vpls > 0 {
                let levels = rsm.size.max(1).next_power_of_two().trailing_zeros();
                let nodes = match levels {
                    0 => 1,
                    l => u64::from(crate::dynamic_vpl::slot_count(l - 1)),
                };
                self.need(Limit::StorageBinding, "the dynamic VPL pyramid", 80 * nodes);
                // The pyramid, and 48 bytes per slot of every view (the
                // other views' fewer).
                let slots_for = crate::dynamic_vpl::DynamicVplPass::slots_for;
                let slots = u64::from(slots_for(rsm.size, max_dynamic_vpls))
                    + u64::from(slots_for(rsm.size, max_dynamic_vpls_per_view))
                        * (rsms.len() as u64 - 1);
                self.gpu_bytes += 80 * nodes + 48 * slots;
            }
        }
        if plan.has(Pass::VplMaps) {
            self.need(
                Limit::StorageBuffersPerStage,
                "the VPL-map merge (full, indirect and naive modes with moving objects)",
                u64::from(MERGE_STORAGE_BUFFERS),
            );
            let n = a.vpls.len() as u32;
            let capacity = if plan.mode() == crate::Mode::Naive {
                n
            } else {
                n.min(64)
            };
            let (c, r) = atlas_grid(capacity.max(1));
            self.need(
                Limit::Texture2d,
                "the merge atlas",
                u64::from(c.max(r)) * u64::from(s),
            );
            // Distances and depth per texel, a tile index per VPL.
            self.gpu_bytes += 8 * u64::from(c) * u64::from(r) * sq(s) + 4 * u64::from(n);
        }
        self.asset_bytes = upload;
        self.gpu_bytes += upload;
    }

    /// Records that `what` needs `value` of `limit`, raising it.
    fn need(&mut self, limit: Limit, what: &str, value: u64) {
        let l = &mut self.limits;
        match limit {
            Limit::Texture2d => {
                let v = u32::try_from(value).unwrap_or(u32::MAX);
                l.max_texture_dimension_2d = l.max_texture_dimension_2d.max(v);
            }
            Limit::StorageBinding => {
                l.max_storage_buffer_binding_size = l.max_storage_buffer_binding_size.max(value);
                l.max_buffer_size = l.max_buffer_size.max(value);
            }
            Limit::StorageBuffersPerStage => {
                let v = u32::try_from(value).unwrap_or(u32::MAX);
                l.max_storage_buffers_per_shader_stage =
                    l.max_storage_buffers_per_shader_stage.max(v);
            }
            Limit::SampledTexturesPerStage => {
                let v = u32::try_from(value).unwrap_or(u32::MAX);
                l.max_sampled_textures_per_shader_stage =
                    l.max_sampled_textures_per_shader_stage.max(v);
            }
        }
        match self.reasons.iter_mut().find(|(k, _, _)| *k == limit) {
            Some(r) if r.2 >= value => {}
            Some(r) => *r = (limit, what.to_string(), value),
            None => self.reasons.push((limit, what.to_string(), value)),
        }
    }

    /// Whether a device with `limits` can run the renderer: the first limit
    /// that is too small, as [`RuntimeError::DeviceLimit`] naming what
    /// needs it.
    pub fn check(&self, limits: &wgpu::Limits) -> Result<(), RuntimeError> {
        for (limit, what, needed) in &self.reasons {
            let have = limit.of(limits);
            if *needed > have {
                let unit = match limit {
                    Limit::Texture2d => "texels along a 2D texture side",
                    Limit::StorageBinding => "bytes in one storage binding",
                    Limit::StorageBuffersPerStage => "storage buffers in one shader stage",
                    Limit::SampledTexturesPerStage => "sampled textures in one shader stage",
                };
                return Err(RuntimeError::DeviceLimit {
                    what: format!("{what} ({unit})"),
                    needed: *needed,
                    limit: have,
                });
            }
        }
        Ok(())
    }
}
