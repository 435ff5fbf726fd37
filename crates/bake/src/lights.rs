//! The bake's front part for every light (issue 19): each light's views
//! ([`LightView::of_light`]: a spot's one, a sun's fitted one, a point
//! light's six cube faces), one reflective shadow map per view (at a
//! resolution by the view's share of the bounce, [`ViewPlan`]), and one VPL
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
use gibake_gpu::light_fit::LightFit;
use gibake_scene::Scene;

use crate::cluster::{Cluster, ClusterTarget, JointClustering, cluster_joint_keeping};
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
    /// 0 for the view itself; `j ≥ 1` for its outer ring `j`
    /// ([`crate::rings`]: `view` is then the ring's).
    pub ring: u32,
    /// The view at the primary shadow map's resolution (the runtime's).
    pub view: LightView,
    /// The RSM, at the view's planned resolution ([`ViewPlan`]: the bake's
    /// RSM resolution, or less for a view with a small share of the light).
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

    /// VPLs per light on its outer rings (index = light; the last ones of
    /// the light's VPLs, [`gibake_asset::Manifest::ring_vpls`]); empty when
    /// no light has any.
    pub fn ring_vpls_per_light(&self, lights: usize) -> Vec<u32> {
        let mut n = vec![0; lights];
        for (m, c) in self.maps.iter().zip(&self.clusters.maps) {
            if m.ring > 0 {
                n[m.light] += c.vpls.len() as u32;
            }
        }
        if n.iter().all(|&k| k == 0) {
            n.clear();
        }
        n
    }

    /// Per VPL of [`EveryLight::vpl_records`]: whether it lies on an outer
    /// ring.
    pub fn ring_flags(&self) -> Vec<bool> {
        self.maps
            .iter()
            .zip(&self.clusters.maps)
            .flat_map(|(m, c)| std::iter::repeat_n(m.ring > 0, c.vpls.len()))
            .collect()
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
        self.vpl_trees().0
    }

    /// [`EveryLight::vpl_nodes`] and the level-3 nodes' texel coherences
    /// (`gibake_asset::Asset::vpl_coherence`), in the same order
    /// ([`crate::near_field::tree_and_coherence_of`]).
    pub fn vpl_trees(&self) -> (Vec<VplRecord>, Vec<f32>) {
        let (mut nodes, mut coherence) = (Vec::new(), Vec::new());
        for (m, c) in self.maps.iter().zip(&self.clusters.maps) {
            for i in 0..c.vpls.len() {
                let (t, k) = crate::near_field::tree_and_coherence_of(&m.rsm, c, i);
                nodes.extend(t);
                coherence.extend(k);
            }
        }
        (nodes, coherence)
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
    let plan = ViewPlan::new(scene, reach, rsm_size, shadow_map_size);
    every_light_planned(scene, reach, plan, target, leave_out_negligible)
}

/// [`every_light_with`] on views whose RSM resolutions are already chosen
/// ([`ViewPlan`]; the bake checks its memory budget in between).
pub fn every_light_planned(
    scene: &Scene,
    reach: &Reach<'_, '_>,
    plan: ViewPlan,
    target: ClusterTarget,
    leave_out_negligible: bool,
) -> EveryLight {
    let mut maps = Vec::new();
    let mut unlit_views = 0;
    for ((((k, face, view), size), probe), rings) in plan
        .views
        .into_iter()
        .zip(plan.sizes)
        .zip(plan.probes)
        .zip(plan.rings)
    {
        let light = &scene.lights[k];
        let rsm = match probe {
            Some(rsm) if rsm.size == size => rsm,
            _ => render_rsm(reach.rays, light, &view.resized(size), Some(reach)),
        };
        // A sun whose view cut a ground: its outer rings after the view
        // (its VPLs stay consecutive, the rings' last).
        let rings = match rings {
            Some(fit) => crate::rings::ring_rsms(reach, light, &fit, rsm.size, view.size),
            None => Vec::new(),
        };
        if rsm.flux.iter().any(|f| f.max_element() > 0.0) {
            maps.push(LightMap {
                light: k,
                face,
                ring: 0,
                view,
                rsm,
            });
        } else {
            unlit_views += 1;
        }
        for (j, rsm) in rings.into_iter().enumerate() {
            if rsm.flux.iter().any(|f| f.max_element() > 0.0) {
                let view = rsm.view.resized(view.size);
                maps.push(LightMap {
                    light: k,
                    face,
                    ring: j as u32 + 1,
                    view,
                    rsm,
                });
            } else {
                unlit_views += 1;
            }
        }
    }
    // Views of negligible light keep no VPL (module docs): under a
    // `Count(n)` budget judged before the clustering against n VPLs, so that
    // the budget goes to the views that keep theirs; under a threshold,
    // after it, against the VPLs it made.
    let mut negligible_views = 0;
    if let (true, ClusterTarget::Count(n)) = (leave_out_negligible, target) {
        let keep = significant_views(&maps, f64::from(n.max(1)));
        negligible_views = keep.iter().filter(|k| !**k).count();
        let mut k = keep.iter();
        maps.retain(|_| *k.next().expect("one per map"));
    }
    // What the bake keeps of a VPL (crate::reach: its light reaches
    // something, or its origin sees something; a ring VPL seen from its
    // inner edge, crate::rings): a `Count` budget counts exactly those.
    let ring: Vec<bool> = maps.iter().map(|m| m.ring > 0).collect();
    let keep = |k: usize, rsm: &Rsm, texels: &[usize], c: &Cluster, reaching: f64| {
        let mut c = *c;
        if ring[k]
            && let Some(t) = crate::rings::anchor_texel(rsm, texels)
        {
            c.anchor = rsm.position[t];
        }
        reach.keeps(&c, reaching, ring[k])
    };
    let refs: Vec<&Rsm> = maps.iter().map(|m| &m.rsm).collect();
    let mut clusters = cluster_joint_keeping(&refs, target, &keep);
    if let (true, ClusterTarget::Threshold(_)) = (leave_out_negligible, target)
        && !maps.is_empty()
    {
        let keep = significant_views(&maps, clusters.vpl_count().max(1) as f64);
        if keep.iter().any(|k| !*k) {
            negligible_views = keep.iter().filter(|k| !**k).count();
            let mut k = keep.iter();
            maps.retain(|_| *k.next().expect("one per map"));
            let mut k = keep.iter();
            clusters.maps.retain(|_| *k.next().expect("one per map"));
        }
    }
    // A ring VPL is seen from its texel nearest the view (crate::rings).
    for (c, m) in clusters.maps.iter_mut().zip(&maps) {
        if m.ring > 0 {
            crate::rings::anchor_near_centre(&m.rsm, c);
        }
    }
    let mut dropped_vpls = 0;
    for (c, m) in clusters.maps.iter_mut().zip(&maps) {
        let reaching = c.reaching_flux(&m.rsm);
        dropped_vpls += reach.retain(c, &reaching, m.ring > 0);
    }
    EveryLight {
        maps,
        clusters,
        unlit_views,
        negligible_views,
        dropped_vpls,
    }
}

/// Per map, whether its view keeps VPLs: its reaching light (its flux if
/// nothing in any map reaches a surface) is at least
/// [`NEGLIGIBLE_VPL_FRACTION`] of an average VPL's, the total over `n`.
fn significant_views(maps: &[LightMap], n: f64) -> Vec<bool> {
    let per: Vec<(f64, f64)> = maps.iter().map(|m| reaching_and_flux(&m.rsm)).collect();
    let (tr, tf) = per.iter().fold((0.0, 0.0), |(a, b), (r, f)| (a + r, b + f));
    let by_reach = tr > 0.0;
    let total = if by_reach { tr } else { tf };
    per.iter()
        .map(|&(r, f)| (if by_reach { r } else { f }) >= NEGLIGIBLE_VPL_FRACTION * total / n)
        .collect()
}

/// A view's RSM is at least this many texels wide ([`ViewPlan`]), and
/// this is the resolution its share of the light is measured at first.
pub const MIN_VIEW_RSM_SIZE: u32 = 64;

/// A view that is not the leading light's gets this many times its share
/// of all views' reaching flux in RSM texels ([`ViewPlan`]): a light that
/// bounces a sixteenth of the level's light or more keeps the full
/// resolution. Measured on the 97-spot store (`lights_twin`, 24²
/// receivers, 64² samples each; docs/method.md): 4, 8 and 16 give a
/// blurred error of 0.024, 0.024 and 0.025 against 0.021 at full size,
/// and a bias of +1.1, +0.9 and +0.1% against +0.3%.
pub const VIEW_RSM_TEXEL_FACTOR: f64 = 16.0;

/// Every view of every light ([`LightView::of_light`], in light order)
/// and the resolution of its RSM.
///
/// The leading light's views and the views whose static RSM the asset
/// stores ([`crate::bake::moving_views`]; the format stores them at
/// `rsm_size`) get `rsm_size`: a bake of one light is unchanged. Every
/// other view is first rendered at [`MIN_VIEW_RSM_SIZE`] (its *probe*)
/// and gets `VIEW_RSM_TEXEL_FACTOR · share · rsm_size²` texels (rounded up
/// to a multiple of 8 wide, at least the probe's, at most `rsm_size`),
/// `share` its part of all views' reaching flux (the flux when nothing
/// reaches anything) measured on the probes (a share does not depend on
/// the resolution, `cluster.rs`). One budget spreads the VPLs by the same
/// share, so a view keeps about `VIEW_RSM_TEXEL_FACTOR` times the texels
/// per VPL that one light alone gets (or more), while a level of a hundred
/// lamps no longer renders and holds a hundred full-size RSMs for a few
/// VPLs each (docs/method.md, "One VPL budget over every light").
pub struct ViewPlan {
    /// (light, face, view) of every view.
    views: Vec<(usize, usize, LightView)>,
    /// The RSM resolution of each view.
    sizes: Vec<u32>,
    /// Each view's probe RSM where it is the view's RSM (its resolution
    /// is the probe's).
    probes: Vec<Option<Rsm>>,
    /// Each view's fit when it has outer rings ([`crate::rings::ring_fit`]),
    /// each ring at the view's resolution.
    rings: Vec<Option<LightFit>>,
}

impl ViewPlan {
    /// Plans every view of `scene`'s lights (see the type's docs).
    pub fn new(scene: &Scene, reach: &Reach<'_, '_>, rsm_size: u32, shadow_map_size: u32) -> Self {
        let views = all_views(scene, shadow_map_size);
        let full = full_size_views(scene, shadow_map_size, &views);
        let rings = view_rings(scene, &views);
        let probe_size = MIN_VIEW_RSM_SIZE.min(rsm_size);
        if probe_size == rsm_size || full.iter().all(|f| *f) {
            return ViewPlan {
                sizes: vec![rsm_size; views.len()],
                probes: views.iter().map(|_| None).collect(),
                views,
                rings,
            };
        }
        let probes: Vec<Rsm> = views
            .iter()
            .map(|(k, _, view)| {
                render_rsm(
                    reach.rays,
                    &scene.lights[*k],
                    &view.resized(probe_size),
                    Some(reach),
                )
            })
            .collect();
        let totals: Vec<(f64, f64)> = probes.iter().map(reaching_and_flux).collect();
        let (tr, tf) = totals
            .iter()
            .fold((0.0, 0.0), |(a, b), (r, f)| (a + r, b + f));
        let (by_reach, total) = if tr > 0.0 { (true, tr) } else { (false, tf) };
        let sizes = totals
            .iter()
            .zip(&full)
            .map(|(&(r, f), &full)| {
                if full || total.is_nan() || total <= 0.0 {
                    return rsm_size;
                }
                let share = (if by_reach { r } else { f }) / total;
                let texels = VIEW_RSM_TEXEL_FACTOR * share * f64::from(rsm_size).powi(2);
                let wide = (texels.sqrt().ceil().min(f64::from(rsm_size)) as u32).div_ceil(8) * 8;
                wide.clamp(probe_size, rsm_size)
            })
            .collect::<Vec<u32>>();
        // Only the probes that are already their view's RSM are kept.
        let probes = probes
            .into_iter()
            .zip(&sizes)
            .map(|(p, &size)| (p.size == size).then_some(p))
            .collect();
        ViewPlan {
            views,
            sizes,
            probes,
            rings,
        }
    }

    /// The RSM resolution of each view, in light order.
    pub fn sizes(&self) -> &[u32] {
        &self.sizes
    }

    /// The RSM texels of every view and outer ring together (what the
    /// bake holds; a ring has its view's resolution).
    pub fn texels(&self) -> u64 {
        self.sizes
            .iter()
            .zip(&self.rings)
            .map(|(&s, r)| u64::from(s) * u64::from(s) * (1 + u64::from(ring_count(r))))
            .sum()
    }

    /// The fewest RSM texels a plan of `scene` can have, known before any
    /// RSM is made: the full-size views at `rsm_size²`, every other at the
    /// probe's (the bake's first memory check, [`crate::budget`]).
    pub fn least_texels(scene: &Scene, rsm_size: u32, shadow_map_size: u32) -> (u64, u64) {
        let views = all_views(scene, shadow_map_size);
        let full = full_size_views(scene, shadow_map_size, &views);
        let probe = u64::from(MIN_VIEW_RSM_SIZE.min(rsm_size));
        let rings = view_rings(scene, &views);
        let texels = full
            .iter()
            .zip(&rings)
            .map(|(&f, r)| {
                let one = if f {
                    u64::from(rsm_size).pow(2)
                } else {
                    probe * probe
                };
                one * (1 + u64::from(ring_count(r)))
            })
            .sum();
        (views.len() as u64, texels)
    }
}

/// Each view's fit when it has outer rings ([`crate::rings::ring_fit`]): a
/// directional light's one view may, every other has none.
fn view_rings(scene: &Scene, views: &[(usize, usize, LightView)]) -> Vec<Option<LightFit>> {
    views
        .iter()
        .map(|(k, _, _)| crate::rings::ring_fit(scene, &scene.lights[*k]))
        .collect()
}

/// How many outer rings a view of [`view_rings`] has.
fn ring_count(fit: &Option<LightFit>) -> u32 {
    fit.as_ref().map_or(0, LightFit::rings)
}

/// (light, face, view) of every view of `scene`'s lights, in light order.
fn all_views(scene: &Scene, shadow_map_size: u32) -> Vec<(usize, usize, LightView)> {
    scene
        .lights
        .iter()
        .enumerate()
        .flat_map(|(k, light)| {
            LightView::of_light(scene, light, shadow_map_size)
                .into_iter()
                .enumerate()
                .map(move |(face, view)| (k, face, view))
        })
        .collect()
}

/// Which views keep the full RSM resolution ([`ViewPlan`]).
fn full_size_views(
    scene: &Scene,
    shadow_map_size: u32,
    views: &[(usize, usize, LightView)],
) -> Vec<bool> {
    let stored = crate::bake::moving_views(scene, shadow_map_size);
    // `moving_views` counts the views from the first light with shadow-map
    // views of its own (the second, unless the first is a point light).
    let first = gibake_gpu::passes::light_maps::first_viewed_light(scene);
    let skipped = views.iter().filter(|(k, _, _)| *k < first).count();
    views
        .iter()
        .enumerate()
        .map(|(i, (k, _, _))| *k == 0 || (i >= skipped && stored.contains(&((i - skipped) as u32))))
        .collect()
}

/// A map's reaching flux (`Σ flux · reach`) and flux, channels summed.
fn reaching_and_flux(r: &Rsm) -> (f64, f64) {
    r.flux
        .iter()
        .zip(&r.reach)
        .fold((0.0, 0.0), |(a, b), (f, w)| {
            let f = f.as_dvec3().element_sum();
            (a + f * f64::from(*w), b + f)
        })
}
