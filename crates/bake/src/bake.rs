//! The bake pipeline: static BVH → primary shadow map (GPU) → RSM (rays) →
//! quadtree VPLs → hemisphere maps (rays) → [`gibake_asset::Asset`].

use std::time::Instant;

use crate::lights::ViewPlan;
use gibake_asset::{
    Asset, BakeSettings, LEVEL3_NODES, MAX_SHARDS, Manifest, Map, MapAtlas, NO_MAP, NODES_PER_VPL,
    Provenance, RsmData, ShardMaps, ShardPart, VplRecord, assign_lower_tiles, assign_map_tiles,
    shard_range,
};
use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::passes::light_maps::{self, LightMaps};
use gibake_gpu::passes::shadow::ShadowPass;
use gibake_gpu::{GpuContext, LightView, readback};
use gibake_raycast::RayScene;
use gibake_scene::Scene;

use crate::cluster::{Cluster, ClusterTarget, NO_VPL, cluster_keeping};
use crate::reach::Reach;
use crate::rsm::{Rsm, render_rsm};

/// What to bake.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeOptions {
    /// RSM resolution (square), default 512.
    pub rsm_size: u32,
    /// Hemisphere map resolution per VPL, default 128.
    pub vpl_map_size: u32,
    /// Primary shadow map resolution, default 2048.
    pub shadow_map_size: u32,
    /// VPL count or clustering threshold (the first bounce's VPLs).
    pub target: ClusterTarget,
    /// How many bounces the asset carries ([`crate::later`]): every one
    /// that matters (the default), or `Count(n)` in all; `Count(1)` is the
    /// paper's method, the first bounce alone.
    pub bounces: crate::later::Bounces,
    /// The later bounces' VPLs (default: a quarter of the first bounce's,
    /// [`crate::later::LATER_VPL_FRACTION`]).
    pub later_vpls: Option<u32>,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions {
            rsm_size: 512,
            vpl_map_size: 128,
            shadow_map_size: 2048,
            target: ClusterTarget::Count(256),
            bounces: crate::later::Bounces::Every,
            later_vpls: None,
        }
    }
}

/// Progress reporting, per stage.
pub trait BakeProgress: Sync {
    /// A stage starts with `total` steps (0: unknown).
    fn begin(&self, stage: &str, total: u64);
    /// `n` more steps done.
    fn advance(&self, n: u64);
    /// The stage ended.
    fn end(&self);
    /// The memory budget (bytes) the bake checks again once clustering has
    /// counted the VPLs, before any near-field tree or map is made
    /// ([`crate::budget::check_with`]); `None` (the default): no check.
    fn memory_limit(&self) -> Option<u64> {
        None
    }
}

/// No progress output.
pub struct NoProgress;

impl BakeProgress for NoProgress {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn end(&self) {}
}

/// Wall time of one stage.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StageTime {
    /// Stage name.
    pub stage: &'static str,
    /// Seconds.
    pub seconds: f64,
}

/// Why a bake failed.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// A setting is out of range.
    #[error("invalid bake setting: {0}")]
    InvalidSetting(String),
    /// The light sees no static surface (nothing to bounce).
    #[error("{path}: the primary light reaches no static surface: nothing to bake")]
    NothingLit {
        /// The scene.
        path: std::path::PathBuf,
    },
    /// GPU failure.
    #[error(transparent)]
    Gpu(#[from] gibake_gpu::GpuError),
    /// The VPL count clustering found puts the bake over the memory budget.
    #[error(transparent)]
    OverBudget(#[from] Box<crate::budget::OverBudget>),
}

/// The baked asset and per-stage times.
pub struct BakeOutput {
    /// The asset (write it with `gibake_asset::write`).
    pub asset: Asset,
    /// Stage times, in order.
    pub stages: Vec<StageTime>,
    /// VPLs the clustering made but dropped because their hemisphere sees
    /// no surface and no moving object (they carry light to nothing).
    pub dropped_vpls: usize,
    /// What the bake warns about (also logged): geometry the light's maps
    /// leave out, texels coarse against the level.
    pub warnings: Vec<String>,
}

fn check(what: &str, v: u32, max: u32) -> Result<(), BakeError> {
    if v < 1 || v > max {
        return Err(BakeError::InvalidSetting(format!(
            "{what} is {v}; it must be in 1..={max}"
        )));
    }
    Ok(())
}

/// What a user should know about the light's maps of `scene`: static
/// triangles each directional light's fit leaves out (a distant ground
/// plane) or cuts (a ground round the level: the objects near the view's edge lose
/// part of their bounce light), and a shadow-map texel coarse against the
/// level's geometry (wider than half the median edge of the static
/// triangles inside the view: shadows will be blurred or leak). All are
/// dimensionless tests.
pub fn light_view_warnings(scene: &Scene, view: &LightView, opts: &BakeOptions) -> Vec<String> {
    let mut out = Vec::new();
    // Every directional light's own fit (a second sun has its own view).
    for light in &scene.lights {
        let Some(f) = gibake_gpu::light_fit::fit_light(scene, light) else {
            continue;
        };
        let name = &light.name;
        if f.source == gibake_gpu::light_fit::FitSource::WithoutOutliers && f.clipped > 0 {
            let beyond = match f.rings() {
                0 => "beyond the cut they reflect no bounce light, and objects standing near the edge of the covered part lose some of theirs".to_string(),
                r => format!(
                    "beyond the cut they get no shadow; their bounce light comes from {r} outer ring(s) of the ground, {}× the covered width{}",
                    1u32 << r,
                    if !f.rings_cover_all() {
                        " (the ground beyond reflects none)"
                    } else {
                        ""
                    }
                ),
            };
            out.push(format!(
                "directional light '{name}': its maps cover {:.0}% of the level's width across the light ({:.4e} of {:.4e} scene units): {} large triangle(s), first in mesh '{}', are cut as a ground round the level; {beyond} (docs/method.md, section 1 of the bake and \"Outer rings\"); give --bake-volume or mark a node with extras {{\"bake_volume\": true}} to choose the covered part",
                100.0 * f.width() / f.full_width.max(f32::MIN_POSITIVE),
                f.width(),
                f.full_width,
                f.clipped,
                f.clipped_mesh.as_deref().unwrap_or_default()
            ));
        }
        if f.left_out > 0 {
            let how = match f.source {
                gibake_gpu::light_fit::FitSource::BakeVolume => "outside the bake volume",
                _ => "far outside the rest of the level (outliers such as a distant ground plane)",
            };
            out.push(format!(
                "directional light '{name}': {} static triangle(s) lie {how}, first in mesh '{}': its shadow map and RSM leave them out (they get unshadowed direct light and bounce none); give --bake-volume or mark a node with extras {{\"bake_volume\": true}} to choose the covered part",
                f.left_out,
                f.left_out_mesh.as_deref().unwrap_or_default()
            ));
        }
    }
    if view.directional {
        let mut edges: Vec<f32> = Vec::new();
        for m in &scene.static_meshes {
            for t in m.indices.chunks_exact(3) {
                let p = |k: usize| m.positions[t[k] as usize];
                let size = view.size as f32;
                let inside = view
                    .texel_coords(p(0))
                    .is_some_and(|c| c.x >= 0.0 && c.y >= 0.0 && c.x <= size && c.y <= size);
                if inside {
                    edges.push((p(1) - p(0)).length().max((p(2) - p(1)).length()));
                }
            }
        }
        if !edges.is_empty() {
            edges.sort_by(f32::total_cmp);
            let median = edges[edges.len() / 2];
            let texel = view.texel_scale;
            if texel > 0.5 * median {
                out.push(format!(
                    "the shadow-map texel ({texel:.3e} scene units at --shadow-map-size {}) is coarse against the level (median triangle edge {median:.3e}): shadows will be blurred or leak; raise --shadow-map-size or give --bake-volume",
                    opts.shadow_map_size
                ));
            }
        }
    }
    out
}

/// The manifest's records of `scene`'s primary lights (what the up-to-date
/// check compares, `inspect` and `diff` show), their VPL counts 0.
pub fn light_records(scene: &Scene) -> Vec<gibake_asset::LightRecord> {
    use gibake_scene::LightKind;
    scene
        .lights
        .iter()
        .map(|l| {
            let (kind, inner, outer) = match l.kind {
                LightKind::Directional => (gibake_asset::LIGHT_DIRECTIONAL, 0.0, 0.0),
                LightKind::Spot {
                    inner_cone,
                    outer_cone,
                } => (gibake_asset::LIGHT_SPOT, inner_cone, outer_cone),
                LightKind::Point => (gibake_asset::LIGHT_POINT, 0.0, 0.0),
            };
            gibake_asset::LightRecord {
                name: l.name.clone(),
                kind,
                color: l.color.to_array(),
                position: l.position.to_array(),
                direction: l.direction.to_array(),
                inner_cone: inner,
                outer_cone: outer,
                range: l.range.unwrap_or(0.0),
                vpls: 0,
            }
        })
        .collect()
}

/// The static part of `scene` only (moving objects removed).
pub fn static_only(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    s.dynamic_objects.clear();
    s.dynamic_meshes.clear();
    s
}

/// Bakes `scene`.
pub fn bake(
    ctx: &GpuContext,
    scene: &Scene,
    opts: &BakeOptions,
    progress: &dyn BakeProgress,
    baker_version: &str,
) -> Result<BakeOutput, BakeError> {
    bake_with(ctx, scene, opts, progress, baker_version, None).map(|(out, _, _)| out)
}

/// One shard of a distributed bake: shard `index` of `count` (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: u32,
    /// Number of shards.
    pub count: u32,
}

/// A shard's part and its stage times.
pub struct ShardOutput {
    /// The part (write it with `gibake_asset::write_part`).
    pub part: ShardPart,
    /// Stage times, in order.
    pub stages: Vec<StageTime>,
}

/// Bakes the front part of `scene` (primary shadow map, RSM, clustering:
/// identical on every shard) and the hemisphere maps of the VPLs shard
/// `shard` owns ([`gibake_asset::shard_range`]). Merging the parts of all
/// shards ([`gibake_asset::merge`]) gives exactly [`bake()`]'s asset.
pub fn bake_shard(
    ctx: &GpuContext,
    scene: &Scene,
    opts: &BakeOptions,
    shard: Shard,
    progress: &dyn BakeProgress,
    baker_version: &str,
) -> Result<ShardOutput, BakeError> {
    if shard.count == 0 || shard.count > MAX_SHARDS || shard.index >= shard.count {
        return Err(BakeError::InvalidSetting(format!(
            "--shard {}/{}: the shard count must be in 1..={MAX_SHARDS} and the index in 0..{}",
            shard.index, shard.count, shard.count
        )));
    }
    let (out, maps, lower_maps) =
        bake_with(ctx, scene, opts, progress, baker_version, Some(shard))?;
    Ok(ShardOutput {
        part: ShardPart {
            shard: shard.index,
            shards: shard.count,
            front: out.asset,
            maps,
            lower_maps,
        },
        stages: out.stages,
    })
}

/// The other lights' maps as the asset stores them: the view records, and
/// the maps that hold a surface in the `light_maps.exr` atlas (tiles
/// renumbered in view order; a view without one says [`NO_MAP`]).
fn stored_light_maps(
    ctx: &GpuContext,
    lm: &LightMaps,
) -> Result<(Vec<gibake_asset::ViewRecord>, MapAtlas), BakeError> {
    let texels = readback::read_texture_f32(ctx, &lm.atlas, 0, 1)?;
    let (s, cols) = (lm.size as usize, lm.cols as usize);
    let width = cols * s;
    let mut records = Vec::with_capacity(lm.views.len());
    let mut stored: Vec<Vec<f32>> = Vec::new();
    for (k, (light, view)) in lm.views.iter().enumerate() {
        let (x0, y0) = ((k % cols) * s, (k / cols) * s);
        let mut map = Vec::with_capacity(s * s);
        for y in y0..y0 + s {
            map.extend_from_slice(&texels[y * width + x0..y * width + x0 + s]);
        }
        let mut any = false;
        for v in &mut map {
            if *v >= f32::MAX || !v.is_finite() {
                *v = f32::INFINITY;
            } else {
                any = true;
            }
        }
        let tile = if any {
            stored.push(map);
            stored.len() as u32 - 1
        } else {
            NO_MAP
        };
        records.push(gibake_asset::ViewRecord {
            light: *light,
            view: view.record(),
            tile,
        });
    }
    let atlas = MapAtlas::from_maps(lm.size, stored.iter().map(Vec::as_slice))
        .expect("every map holds size² texels");
    Ok((records, atlas))
}

/// The bake's front part: the VPLs, their near-field trees, and the
/// primary light's RSM with its texels' VPLs (for the dynamic merge).
struct Front {
    vpls: Vec<VplRecord>,
    vpl_nodes: Vec<VplRecord>,
    vpl_coherence: Vec<f32>,
    /// Per VPL, its second origin for the light below its horizon
    /// ([`crate::horizon`]).
    vpl_lower: Vec<Option<glam::Vec3>>,
    /// VPLs per light, in light order (the VPLs are in that order).
    per_light: Vec<u32>,
    /// Per light, its VPLs on its outer rings (the last of its VPLs);
    /// empty when none has any (`Manifest::ring_vpls`).
    ring_vpls: Vec<u32>,
    /// VPLs the clustering made, dropped ones included.
    made: usize,
    dropped: usize,
    threshold: f32,
    /// Per texel of `rsm`, its VPL (an index into `vpls`) or `NO_VPL`.
    texel_vpl: Vec<u32>,
    /// The primary light's RSM (`None`: a point light first, no primary
    /// map).
    rsm: Option<crate::rsm::Rsm>,
    /// The static RSMs of the other lights' views that moving objects can
    /// enter (format 4.1): (view index, its RSM data), in view order;
    /// empty without moving objects.
    view_rsms: Vec<(u32, RsmData)>,
}

/// Whether `scene` takes the bake of every light ([`crate::lights`]):
/// several lights, a point light (its six faces), or a sun with outer
/// rings ([`crate::rings`]: more maps than its one view).
pub(crate) fn bakes_every_light(scene: &Scene) -> bool {
    scene.lights.len() > 1
        || light_maps::first_viewed_light(scene) == 0
        || crate::rings::any_rings(scene)
}

/// The views (indices into the manifest's `views`: every view of
/// `scene.lights[first_viewed_light..]`, in order) whose static RSM a bake
/// of every light stores: those the moving objects' swept bounds can enter
/// (`LightView::may_see`, the runtime's light-merge rule). Empty without
/// moving objects. The bake and the up-to-date check use this one rule.
pub(crate) fn moving_views(scene: &Scene, shadow_map_size: u32) -> Vec<u32> {
    let swept = scene.dynamic_swept_bounds();
    if scene.dynamic_objects.is_empty() || swept.is_empty() {
        return Vec::new();
    }
    scene
        .lights
        .iter()
        .skip(light_maps::first_viewed_light(scene))
        .flat_map(|l| LightView::of_light(scene, l, shadow_map_size))
        .enumerate()
        .filter(|(_, v)| v.may_see(&swept))
        .map(|(i, _)| i as u32)
        .collect()
}

/// The static RSMs of [`moving_views`] as the asset stores them (each
/// texel's VPL, an index into the asset's VPLs, and share of its flux),
/// from `every`'s maps where the view kept one, else rendered with no
/// texel of any VPL (a view whose static bounce was left out still
/// bounces the light that falls on moving objects).
fn moving_view_rsms(
    scene: &Scene,
    reach: &Reach<'_, '_>,
    every: &crate::lights::EveryLight,
    opts: &BakeOptions,
) -> Vec<(u32, RsmData)> {
    let wanted = moving_views(scene, opts.shadow_map_size);
    if wanted.is_empty() {
        return Vec::new();
    }
    // Each map's first VPL in the asset's list (maps in light order).
    let mut base = Vec::with_capacity(every.maps.len());
    let mut next = 0u32;
    for c in &every.clusters.maps {
        base.push(next);
        next += c.vpls.len() as u32;
    }
    // (light, face, view) of every view, in the manifest's order.
    let views: Vec<(usize, usize, LightView)> = scene
        .lights
        .iter()
        .enumerate()
        .skip(light_maps::first_viewed_light(scene))
        .flat_map(|(k, l)| {
            LightView::of_light(scene, l, opts.shadow_map_size)
                .into_iter()
                .enumerate()
                .map(move |(face, v)| (k, face, v))
        })
        .collect();
    wanted
        .into_iter()
        .map(|i| {
            let (k, face, view) = views[i as usize];
            let kept = every
                .maps
                .iter()
                .position(|m| m.light == k && m.face == face && m.ring == 0);
            let data = |rsm: &crate::rsm::Rsm, texel_vpl: Vec<u32>| {
                let flux: Vec<[f32; 3]> = rsm.flux.iter().map(|f| f.to_array()).collect();
                RsmData::from_flux(
                    rsm.size,
                    rsm.metric.clone(),
                    &flux,
                    texel_vpl,
                    next as usize,
                )
            };
            let rsm = match kept {
                Some(j) => data(
                    &every.maps[j].rsm,
                    every.clusters.maps[j]
                        .texel_vpl
                        .iter()
                        .map(|&v| if v == NO_VPL { u32::MAX } else { base[j] + v })
                        .collect(),
                ),
                None => {
                    let rsm = render_rsm(
                        reach.rays,
                        &scene.lights[k],
                        &view.resized(opts.rsm_size),
                        Some(reach),
                    );
                    let n = rsm.flux.len();
                    data(&rsm, vec![u32::MAX; n])
                }
            };
            (i, rsm)
        })
        .collect()
}

/// The front part of a bake of several lights ([`crate::lights`]): one
/// budget over every view of every light; the first light's VPLs come
/// first, so its RSM's texels index `vpls` directly. `view` is the first
/// light's ([`LightView::for_scene`]); a point light first has no primary
/// RSM.
fn every_light_front(
    scene: &Scene,
    reach: &Reach<'_, '_>,
    view: &LightView,
    opts: &BakeOptions,
    budget: Option<(u64, u64)>,
) -> Result<Front, BakeError> {
    let plan = ViewPlan::new(scene, reach, opts.rsm_size, opts.shadow_map_size);
    let full = plan.sizes().iter().filter(|&&s| s == opts.rsm_size).count();
    tracing::info!(
        "RSMs of {} views: {} texels in all ({full} at {}², the others by their share of the bounce)",
        plan.sizes().len(),
        plan.texels(),
        opts.rsm_size
    );
    // The memory budget with each view's own RSM resolution, before the
    // full RSMs are made (`budget`: the limit, and the other lights'
    // shadow-map texels already held).
    if let Some((limit, light_map_texels)) = budget {
        let views = (plan.sizes().len() as u64, plan.texels());
        crate::budget::check_lights(opts, views, light_map_texels, limit)?;
    }
    let every = crate::lights::every_light_planned(scene, reach, plan, opts.target, true);
    let per_light = every
        .vpls_per_light(scene.lights.len())
        .into_iter()
        .map(|n| n as u32)
        .collect();
    let vpls = every.vpl_records();
    let (vpl_nodes, vpl_coherence) = every.vpl_trees();
    let vpl_lower = crate::horizon::lower_origins_of_every(reach.rays, &every);
    // The first light's RSM (one view: a spot or directional light); when
    // its bounce was left out as negligible, rendered for the dynamic merge
    // with no texel of any VPL.
    let first = every.maps.iter().position(|m| m.light == 0 && m.ring == 0);
    let ring_vpls = every.ring_vpls_per_light(scene.lights.len());
    let made = vpls.len() + every.dropped_vpls;
    let threshold = every.clusters.threshold;
    let dropped = every.dropped_vpls;
    let view_rsms = moving_view_rsms(scene, reach, &every, opts);
    let point_first = matches!(scene.light().kind, gibake_scene::LightKind::Point);
    let (rsm, texel_vpl) = match first {
        _ if point_first => (None, Vec::new()),
        Some(k) => {
            let mut maps = every.maps;
            let mut clusters = every.clusters.maps;
            (
                Some(maps.swap_remove(k).rsm),
                clusters.swap_remove(k).texel_vpl,
            )
        }
        None => {
            let rsm = render_rsm(
                reach.rays,
                scene.light(),
                &view.resized(opts.rsm_size),
                Some(reach),
            );
            let n = rsm.flux.len();
            (Some(rsm), vec![NO_VPL; n])
        }
    };
    Ok(Front {
        vpls,
        vpl_nodes,
        vpl_coherence,
        vpl_lower,
        per_light,
        ring_vpls,
        made,
        dropped,
        threshold,
        texel_vpl,
        rsm,
        view_rsms,
    })
}

/// The bake; with `shard`, the asset has no hemisphere maps and the maps of
/// the shard's VPLs are returned apart.
fn bake_with(
    ctx: &GpuContext,
    scene: &Scene,
    opts: &BakeOptions,
    progress: &dyn BakeProgress,
    baker_version: &str,
    shard: Option<Shard>,
) -> Result<(BakeOutput, ShardMaps, ShardMaps), BakeError> {
    let max_tex = ctx.device.limits().max_texture_dimension_2d;
    check("--rsm-size", opts.rsm_size, 8192)?;
    check("--vpl-map-size", opts.vpl_map_size, 2048)?;
    check("--shadow-map-size", opts.shadow_map_size, max_tex)?;
    match opts.target {
        ClusterTarget::Count(n) => check("--vpls", n, 1 << 20)?,
        ClusterTarget::Threshold(t) => {
            if !(t.is_finite() && t >= 0.0) {
                return Err(BakeError::InvalidSetting(format!(
                    "--threshold is {t}; it must be a finite number ≥ 0"
                )));
            }
        }
    }
    let mut stages = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: &'static str, stages: &mut Vec<StageTime>| {
        stages.push(StageTime {
            stage: name,
            seconds: clock.elapsed().as_secs_f64(),
        });
        clock = Instant::now();
    };

    // Static geometry only: BVH for the RSM and the VPL maps.
    progress.begin("BVH", 0);
    let static_scene = static_only(scene);
    let rays = RayScene::build(&static_scene, 0.0);
    progress.end();
    lap("bvh", &mut stages);

    // The light view covers the moving objects' swept bounds too, so the
    // runtime can merge them into the same maps.
    let view = LightView::for_scene(scene, opts.shadow_map_size);
    // (A point light first has no primary map: its six faces are views of
    // the light-map pass; this one face is stored and unused.)
    let point_first = light_maps::first_viewed_light(scene) == 0;
    // (Its moving objects' bounce comes from the stored RSMs of the faces
    // they can enter, as every other light's: `moving_view_rsms`.)
    let warnings = if point_first {
        Vec::new()
    } else {
        light_view_warnings(scene, &view, opts)
    };
    for w in &warnings {
        tracing::warn!("{}: {w}", scene.source.display());
    }

    // Primary shadow map of the static geometry (GPU, the runtime's pass).
    progress.begin("shadow map", 0);
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &static_scene, 0.0);
    let pass = ShadowPass::new(&ctx.device, &scene_gpu, view);
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    pass.encode(&mut enc, &scene_gpu, &scene_gpu.static_draws, None);
    ctx.queue.submit([enc.finish()]);
    let mut primary = readback::read_texture_f32(ctx, &pass.metric, 0, 1)?;
    for v in &mut primary {
        if *v >= f32::MAX {
            *v = f32::INFINITY;
        }
    }
    progress.end();
    lap("shadow map", &mut stages);

    // The other lights' shadow maps (format 4.0), by the same pass.
    let mut warnings = warnings;
    let n = light_maps::view_count(scene);
    // Several lights: every view's RSM is held at once; checked before any
    // is made with the fewest texels the views' plan can have (the views
    // are known from the scene alone), and again once the plan has chosen
    // each view's resolution (every_light_front).
    let every = bakes_every_light(scene);
    let light_map_texels = {
        let (size, _) = light_maps::light_map_size(opts.shadow_map_size, n, max_tex);
        n as u64 * u64::from(size) * u64::from(size)
    };
    let budget = progress
        .memory_limit()
        .map(|limit| (limit, light_map_texels));
    if every && let Some((limit, _)) = budget {
        let least = ViewPlan::least_texels(scene, opts.rsm_size, opts.shadow_map_size);
        crate::budget::check_lights(opts, least, light_map_texels, limit)?;
    }
    let (views, light_maps, light_map_size) = if n > 0 {
        let (size, capped) = light_maps::light_map_size(opts.shadow_map_size, n, max_tex);
        if capped {
            let w = format!(
                "{n} shadow-map views of {} lights: their maps are {size}² to stay within {} texels",
                scene.lights.len() - light_maps::first_viewed_light(scene),
                light_maps::MAX_LIGHT_MAP_TEXELS
            );
            tracing::warn!("{}: {w}", scene.source.display());
            warnings.push(w);
        }
        progress.begin("lights' shadow maps", n as u64);
        let lm = LightMaps::render(&ctx.device, &ctx.queue, scene, &scene_gpu, size, &|| {
            progress.advance(1)
        })?;
        let (v, m) = stored_light_maps(ctx, &lm)?;
        progress.end();
        lap("light maps", &mut stages);
        (v, m, size)
    } else {
        (Vec::new(), MapAtlas::empty(0), 0)
    };

    // RSMs by ray casting, with how much of each texel's light reaches a
    // surface (static geometry or where moving objects can be); quadtree
    // clustering; a VPL whose hemisphere sees nothing carries light to
    // nothing and is dropped (crate::reach).
    let reach = Reach::new(&rays, scene.dynamic_swept_bounds());
    // Several lights, or a point light (its six faces): one budget over
    // every view.
    let front = if every {
        progress.begin("RSMs and clustering of every light", 0);
        let f = every_light_front(scene, &reach, &view, opts, budget)?;
        progress.end();
        lap("rsm+clustering", &mut stages);
        f
    } else {
        progress.begin("RSM", 0);
        let rsm_view = view.resized(opts.rsm_size);
        let rsm = render_rsm(&rays, scene.light(), &rsm_view, Some(&reach));
        progress.end();
        lap("rsm", &mut stages);
        progress.begin("clustering", 0);
        // A `Count` budget counts exactly the VPLs the bake keeps.
        let keep = |_: usize, _: &Rsm, _: &[usize], c: &Cluster, reaching: f64| {
            reach.keeps(c, reaching, false)
        };
        let mut clusters = cluster_keeping(&rsm, opts.target, &keep);
        let dropped = if clusters.vpls.is_empty() {
            0
        } else {
            let reaching = clusters.reaching_flux(&rsm);
            reach.retain(&mut clusters, &reaching, false)
        };
        progress.end();
        lap("clustering", &mut stages);
        // On the clusters' own surfaces (see Cluster::anchor); near-field
        // trees, one per VPL, from its node's texels.
        let vpls: Vec<VplRecord> = clusters.vpls.iter().map(|c| c.record()).collect();
        let (mut vpl_nodes, mut vpl_coherence) = (Vec::new(), Vec::new());
        for i in 0..clusters.vpls.len() {
            let (t, k) = crate::near_field::tree_and_coherence_of(&rsm, &clusters, i);
            vpl_nodes.extend(t);
            vpl_coherence.extend(k);
        }
        let vpl_lower = (0..clusters.vpls.len())
            .map(|i| crate::horizon::lower_origin_of(&rays, &rsm, &clusters, i))
            .collect();
        Front {
            vpl_lower,
            per_light: vec![vpls.len() as u32],
            ring_vpls: Vec::new(),
            vpls,
            vpl_nodes,
            vpl_coherence,
            made: clusters.vpls.len() + dropped,
            dropped,
            threshold: clusters.threshold,
            texel_vpl: clusters.texel_vpl,
            rsm: Some(rsm),
            view_rsms: Vec::new(),
        }
    };
    if front.made == 0 {
        return Err(BakeError::NothingLit {
            path: scene.source.clone(),
        });
    }
    let Front {
        mut vpls,
        vpl_nodes,
        vpl_coherence,
        vpl_lower,
        per_light,
        ring_vpls,
        dropped,
        threshold,
        texel_vpl,
        rsm,
        view_rsms,
        ..
    } = front;
    // The bounces after the first (crate::later): more VPLs, after the
    // first bounce's, lifted by one surfel's radius (as ring VPLs are).
    let first_vpls = vpls.len();
    let (mut vpl_nodes, mut vpl_coherence) = (vpl_nodes, vpl_coherence);
    let mut vpl_lower = vpl_lower;
    let mut rings = gibake_asset::ring_flags(&per_light, &ring_vpls);
    // The memory budget for `n` VPLs' maps (this shard's share of them).
    let check_memory = |n: usize| -> Result<(), BakeError> {
        if let Some(limit) = progress.memory_limit() {
            let mapped = match shard {
                Some(s) => shard_range(n, s.index, s.count).len(),
                None => n,
            };
            crate::budget::check_with(opts, n as u64, mapped as u64, limit)?;
        }
        Ok(())
    };
    let later = match opts.bounces {
        crate::later::Bounces::Count(n) if n <= 1 => None,
        bounces => {
            progress.begin("later bounces", 0);
            let n = opts.later_vpls.unwrap_or(
                ((first_vpls as f64 * crate::later::LATER_VPL_FRACTION).ceil() as u32).max(1),
            );
            // The memory budget, checked before the later bounces are
            // solved: a threshold that makes millions of VPLs is refused
            // here, not after the solve (again below with the exact count).
            check_memory(first_vpls + n as usize)?;
            let l = crate::later::later_bounces(
                &rays,
                &crate::later::LaterOptions {
                    bounces,
                    points: crate::later::surface_points(n),
                    rays: crate::later::LATER_RAYS,
                    vpls: n,
                },
                &vpls[..first_vpls],
            );
            progress.end();
            lap("later bounces", &mut stages);
            // Of which where their light came from (crate::later::sources;
            // only for later bounces the bake keeps).
            if l.kept(bounces) {
                if let Some(s) = stages.last_mut() {
                    s.seconds = (s.seconds - l.sources_seconds).max(0.0);
                }
                stages.push(StageTime {
                    stage: "later sources",
                    seconds: l.sources_seconds,
                });
            }
            if !l.converged {
                let w = format!(
                    "the later bounces do not die down (a closed level of albedo near 1): cut at {} bounces, the light of those after is missing",
                    crate::later::radiosity::MAX_BOUNCES
                );
                tracing::warn!("{}: {w}", scene.source.display());
                warnings.push(w);
            }
            let keep = l.kept(bounces);
            let mut weights = Vec::new();
            if keep {
                for (i, v) in l.vpls.iter().enumerate() {
                    let c = crate::cluster::Cluster {
                        position: glam::Vec3::from_array(v.position),
                        anchor: glam::Vec3::from_array(v.position),
                        normal: glam::Vec3::from_array(v.normal),
                        flux: glam::Vec3::from_array(v.flux),
                        area: v.area,
                        texels: v.texels,
                    };
                    if !reach.sees_cluster(&c, true) {
                        continue;
                    }
                    vpls.push(*v);
                    if let Some(w) = l.sources.weights.get(i) {
                        weights.extend_from_slice(w);
                    }
                    vpl_nodes
                        .extend_from_slice(&l.nodes[i * NODES_PER_VPL..(i + 1) * NODES_PER_VPL]);
                    vpl_coherence
                        .extend_from_slice(&l.coherence[i * LEVEL3_NODES..(i + 1) * LEVEL3_NODES]);
                    rings.push(true);
                    // No second origin (crate::horizon works on the RSM's
                    // texels; a later VPL has none): its light below the
                    // horizon is answered by its map's rim.
                    vpl_lower.push(None);
                }
            }
            // Where their light came from (format 4.8), for the VPLs kept.
            let sources = (keep
                && l.sources.weights.len() == l.vpls.len()
                && weights.len()
                    == (vpls.len() - first_vpls) * gibake_asset::SOURCES_PER_LATER_VPL
                && !weights.is_empty())
            .then(|| gibake_asset::LaterSources {
                first: l.sources.first.clone(),
                weights,
            });
            Some((l, keep, sources))
        }
    };
    check_memory(vpls.len())?;

    // Hemisphere maps by ray casting (a shard: only its VPLs', kept apart).
    let range = match shard {
        Some(s) => shard_range(vpls.len(), s.index, s.count),
        None => 0..vpls.len(),
    };
    // Each VPL's map, then its second map (or none).
    progress.begin("VPL maps", 2 * range.len() as u64);
    let each = crate::vplmap::render_each_vpl_map(
        &rays,
        &vpls[range.clone()],
        &rings[range.clone()],
        opts.vpl_map_size,
        &|| progress.advance(1),
    );
    // The second maps, for the light below the VPLs' horizons
    // (crate::horizon), alike.
    let each_lower = crate::vplmap::render_each_lower_map(
        &rays,
        &vpls[range.clone()],
        &vpl_lower[range],
        opts.vpl_map_size,
        &|| progress.advance(1),
    );
    let mut vpl_lower: Vec<gibake_asset::LowerVpl> = vpl_lower
        .iter()
        .map(|o| match o {
            Some(o) => gibake_asset::LowerVpl {
                origin: o.to_array(),
                map: NO_MAP,
            },
            None => gibake_asset::LowerVpl::NONE,
        })
        .collect();
    let full = || BakeError::InvalidSetting("the VPL maps do not fit one atlas in memory".into());
    let (maps, lower_maps, shard_maps, shard_lower) = match shard {
        Some(_) => (
            MapAtlas::empty(opts.vpl_map_size),
            MapAtlas::empty(opts.vpl_map_size),
            each,
            each_lower,
        ),
        None => {
            let atlas = assign_map_tiles(&mut vpls, opts.vpl_map_size, each).ok_or_else(full)?;
            let lower = assign_lower_tiles(&mut vpl_lower, opts.vpl_map_size, each_lower)
                .ok_or_else(full)?;
            (atlas, lower, Vec::new(), Vec::new())
        }
    };
    progress.end();
    lap("vpl maps", &mut stages);

    // A point light first has no primary map: no RSM for the per-frame
    // bounce off moving objects.
    let has_dynamic = !scene.dynamic_objects.is_empty() && rsm.is_some();
    // Each texel's share of its VPL's flux, for partial occlusion.
    let rsm_data = |rsm: &crate::rsm::Rsm, texel_vpl: &[u32]| {
        let flux: Vec<[f32; 3]> = rsm.flux.iter().map(|f| f.to_array()).collect();
        let texel_vpl = texel_vpl
            .iter()
            .map(|&v| if v == NO_VPL { u32::MAX } else { v })
            .collect();
        RsmData::from_flux(rsm.size, rsm.metric.clone(), &flux, texel_vpl, vpls.len())
    };
    let (view_rsm_views, view_rsms): (Vec<u32>, Vec<RsmData>) = view_rsms.into_iter().unzip();
    let rsm_data = rsm
        .filter(|_| has_dynamic)
        .map(|rsm| rsm_data(&rsm, &texel_vpl));
    let map_count = vpls.iter().filter(|v| v.map != NO_MAP).count() as u32;
    let manifest = Manifest {
        provenance: Provenance {
            baker_version: baker_version.to_string(),
            scene_name: scene
                .source
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            adapter: ctx.record.name.clone(),
            backend: ctx.record.backend.clone(),
            driver: format!("{} {}", ctx.record.driver, ctx.record.driver_info),
        },
        settings: BakeSettings {
            rsm_size: opts.rsm_size,
            vpl_map_size: opts.vpl_map_size,
            shadow_map_size: opts.shadow_map_size,
            // Infinite when no node could split at all (e.g. a 1-texel
            // RSM): every threshold gives this clustering, and the format
            // stores a finite one.
            threshold: if threshold.is_finite() {
                threshold
            } else {
                f32::MAX
            },
            vpl_budget: match opts.target {
                ClusterTarget::Count(n) => Some(n),
                ClusterTarget::Threshold(_) => None,
            },
        },
        static_scene_hash: gibake_scene::static_scene_hash(scene),
        light_view: view.record(),
        vpl_count: vpls.len() as u32,
        map_count,
        has_dynamic,
        files: Vec::new(),
        lights: {
            let mut l = light_records(scene);
            for (r, n) in l.iter_mut().zip(&per_light) {
                r.vpls = *n;
            }
            l
        },
        views,
        light_map_size,
        view_rsms: view_rsm_views,
        ring_vpls,
        // The scene options the level was loaded with are the caller's to
        // record (`gibake bake` does; the `Scene` does not hold them).
        scene_options: None,
        swept_bounds: Some(crate::uptodate::swept_record(scene)),
        later: later
            .as_ref()
            .map(|(l, keep, _)| gibake_asset::LaterRecord {
                bounces: match opts.bounces {
                    crate::later::Bounces::Every => 0,
                    crate::later::Bounces::Count(n) => n,
                },
                vpl_budget: opts.later_vpls.unwrap_or(0),
                vpls: (vpls.len() - first_vpls) as u32,
                left_out: !keep,
                converged: l.converged,
                direct: l.direct.to_array(),
                per_bounce: l.per_bounce.iter().map(|v| v.to_array()).collect(),
                tail: l.tail.to_array(),
            }),
        lower_map_count: lower_maps.count(),
        later_sources: later.and_then(|(_, _, s)| s),
    };
    let asset = Asset {
        manifest,
        vpls,
        vpl_nodes,
        vpl_coherence,
        vpl_lower,
        vpl_lower_maps: lower_maps,
        primary_depth: Map {
            size: opts.shadow_map_size,
            data: primary,
        },
        vpl_maps: maps,
        rsm: rsm_data,
        light_maps,
        view_rsms,
    };
    Ok((
        BakeOutput {
            asset,
            stages,
            dropped_vpls: dropped,
            warnings,
        },
        shard_maps,
        shard_lower,
    ))
}
