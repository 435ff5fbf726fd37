//! The bake's front part for every light (issue 19): each light's views
//! ([`LightView::of_light`]: a spot's one, a sun's fitted one, a point
//! light's six cube faces), one reflective shadow map per view, and one VPL
//! budget over all of them ([`cluster_joint`]: a node's share of the light
//! is its part of every light's reaching flux, so VPLs go where the bounce
//! is, whichever light made it).
//!
//! What a scene does not need is left out: a view whose map reflects no
//! light (a point light's face toward the sky, a light beyond its range of
//! everything) keeps no map and no VPL; a view whose reflected light that
//! reaches a surface is under a quarter of one average VPL's
//! ([`NEGLIGIBLE_VPL_FRACTION`] of the total over the VPL count) keeps
//! none either — one VPL would carry less than a quarter of what every
//! other carries; and VPLs whose hemisphere sees nothing are dropped as in
//! the one-light bake. `lights_twin --keep-negligible` measures what
//! leaving them out changes in the image. The bake of several lights
//! ([`crate::bake()`]) takes its VPLs from here; the CPU evaluation
//! (`gibake-eval`'s `lights_twin` example) judges them against the
//! reference without a frame's other errors.

use gibake_asset::VplRecord;
use gibake_gpu::LightView;
use gibake_scene::Scene;

use crate::cluster::{Cluster, ClusterTarget, JointClustering, cluster_joint};
use crate::reach::Reach;

/// A view whose reaching flux is under this fraction of an average VPL's
/// (the total over the VPL count) keeps no VPL (module docs).
pub const NEGLIGIBLE_VPL_FRACTION: f64 = 0.25;
use crate::rsm::{Rsm, render_rsm};

/// One view of one light and its RSM.
pub struct LightMap {
    /// Index into `scene.lights`.
    pub light: usize,
    /// Which of the light's views ([`LightView::of_light`]'s order: a point
    /// light's faces +X, −X, +Y, −Y, +Z, −Z).
    pub face: usize,
    /// The view at the primary shadow map's resolution (the runtime's).
    pub view: LightView,
    /// The RSM, at the bake's RSM resolution.
    pub rsm: Rsm,
}

/// Every light's maps and their VPLs.
pub struct EveryLight {
    /// The views that reflect light, in light order (a point light's faces
    /// +X, −X, +Y, −Y, +Z, −Z).
    pub maps: Vec<LightMap>,
    /// Their joint clustering (`clusters.maps[k]` is `maps[k]`'s), VPLs
    /// whose hemisphere sees nothing removed.
    pub clusters: JointClustering,
    /// How many views were left out because they reflect no light.
    pub unlit_views: usize,
    /// How many views were left out because their light is negligible
    /// ([`NEGLIGIBLE_VPL_FRACTION`]).
    pub negligible_views: usize,
    /// VPLs removed because their hemisphere sees nothing.
    pub dropped_vpls: usize,
}

impl EveryLight {
    /// VPLs per light (index = light).
    pub fn vpls_per_light(&self, lights: usize) -> Vec<usize> {
        let mut n = vec![0; lights];
        for (m, c) in self.maps.iter().zip(&self.clusters.maps) {
            n[m.light] += c.vpls.len();
        }
        n
    }

    /// The VPL records of every map, in map order (no hemisphere maps yet:
    /// `map` is [`gibake_asset::NO_MAP`]).
    pub fn vpl_records(&self) -> Vec<VplRecord> {
        self.clusters
            .maps
            .iter()
            .flat_map(|c| c.vpls.iter())
            .map(Cluster::record)
            .collect()
    }

    /// The VPLs' near-field trees, in [`EveryLight::vpl_records`]' order
    /// ([`crate::near_field::tree_of`] in each VPL's own map).
    pub fn vpl_nodes(&self) -> Vec<VplRecord> {
        self.maps
            .iter()
            .zip(&self.clusters.maps)
            .flat_map(|(m, c)| {
                (0..c.vpls.len()).flat_map(move |i| crate::near_field::tree_of(&m.rsm, c, i))
            })
            .collect()
    }
}

/// Renders every light's RSMs (`rsm_size²`, views fitted at
/// `shadow_map_size` and resized, as the one-light bake does) and clusters
/// them under one `target`.
pub fn every_light(
    scene: &Scene,
    reach: &Reach<'_, '_>,
    rsm_size: u32,
    shadow_map_size: u32,
    target: ClusterTarget,
) -> EveryLight {
    every_light_with(scene, reach, rsm_size, shadow_map_size, target, true)
}

/// [`every_light`], keeping views of negligible light when
/// `leave_out_negligible` is false (to measure what leaving them out
/// changes).
pub fn every_light_with(
    scene: &Scene,
    reach: &Reach<'_, '_>,
    rsm_size: u32,
    shadow_map_size: u32,
    target: ClusterTarget,
    leave_out_negligible: bool,
) -> EveryLight {
    let mut maps = Vec::new();
    let mut unlit_views = 0;
    for (k, light) in scene.lights.iter().enumerate() {
        for (face, view) in LightView::of_light(scene, light, shadow_map_size)
            .into_iter()
            .enumerate()
        {
            let rsm = render_rsm(reach.rays, light, &view.resized(rsm_size), Some(reach));
            if rsm.flux.iter().any(|f| f.max_element() > 0.0) {
                maps.push(LightMap {
                    light: k,
                    face,
                    view,
                    rsm,
                });
            } else {
                unlit_views += 1;
            }
        }
    }
    let refs: Vec<&Rsm> = maps.iter().map(|m| &m.rsm).collect();
    let mut clusters = cluster_joint(&refs, target);
    let mut negligible_views = 0;
    if leave_out_negligible && !maps.is_empty() {
        // The light each view bounces onto a surface (its flux if nothing
        // anywhere reaches one), against an average VPL's share.
        let reaching = |r: &Rsm| -> (f64, f64) {
            r.flux
                .iter()
                .zip(&r.reach)
                .fold((0.0, 0.0), |(a, b), (f, w)| {
                    let f = f.as_dvec3().element_sum();
                    (a + f * f64::from(*w), b + f)
                })
        };
        let per: Vec<(f64, f64)> = maps.iter().map(|m| reaching(&m.rsm)).collect();
        let (tr, tf) = per.iter().fold((0.0, 0.0), |(a, b), (r, f)| (a + r, b + f));
        let by_reach = tr > 0.0;
        let total = if by_reach { tr } else { tf };
        let n = clusters.vpl_count().max(1) as f64;
        let keep: Vec<bool> = per
            .iter()
            .map(|&(r, f)| (if by_reach { r } else { f }) >= NEGLIGIBLE_VPL_FRACTION * total / n)
            .collect();
        if keep.iter().any(|k| !k) {
            negligible_views = keep.iter().filter(|k| !**k).count();
            let mut k = keep.iter();
            maps.retain(|_| *k.next().expect("one per map"));
            let mut k = keep.iter();
            clusters.maps.retain(|_| *k.next().expect("one per map"));
        }
    }
    let mut dropped_vpls = 0;
    for (c, m) in clusters.maps.iter_mut().zip(&maps) {
        let reaching = c.reaching_flux(&m.rsm);
        dropped_vpls += c.retain(|i, v| reach.keeps(v, reaching[i]));
    }
    EveryLight {
        maps,
        clusters,
        unlit_views,
        negligible_views,
        dropped_vpls,
    }
}
