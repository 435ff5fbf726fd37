//! The bake pipeline: static BVH → primary shadow map (GPU) → RSM (rays) →
//! quadtree VPLs → hemisphere maps (rays) → [`gibake_asset::Asset`].

use std::time::Instant;

use gibake_asset::{
    Asset, BakeSettings, MAX_SHARDS, Manifest, Map, MapAtlas, NO_MAP, Provenance, RsmData,
    ShardMaps, ShardPart, VplRecord, assign_map_tiles, shard_range,
};
use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::passes::shadow::ShadowPass;
use gibake_gpu::{GpuContext, LightView, readback};
use gibake_raycast::RayScene;
use gibake_scene::Scene;

use crate::cluster::{ClusterTarget, NO_VPL, cluster};
use crate::rsm::render_rsm;

/// What to bake.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeOptions {
    /// RSM resolution (square), default 512.
    pub rsm_size: u32,
    /// Hemisphere map resolution per VPL, default 128.
    pub vpl_map_size: u32,
    /// Primary shadow map resolution, default 2048.
    pub shadow_map_size: u32,
    /// VPL count or clustering threshold.
    pub target: ClusterTarget,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions {
            rsm_size: 512,
            vpl_map_size: 128,
            shadow_map_size: 2048,
            target: ClusterTarget::Count(256),
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
}

/// The baked asset and per-stage times.
pub struct BakeOutput {
    /// The asset (write it with `gibake_asset::write`).
    pub asset: Asset,
    /// Stage times, in order.
    pub stages: Vec<StageTime>,
}

fn check(what: &str, v: u32, max: u32) -> Result<(), BakeError> {
    if v < 1 || v > max {
        return Err(BakeError::InvalidSetting(format!(
            "{what} is {v}; it must be in 1..={max}"
        )));
    }
    Ok(())
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
    bake_with(ctx, scene, opts, progress, baker_version, None).map(|(out, _)| out)
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
    let (out, maps) = bake_with(ctx, scene, opts, progress, baker_version, Some(shard))?;
    Ok(ShardOutput {
        part: ShardPart {
            shard: shard.index,
            shards: shard.count,
            front: out.asset,
            maps,
        },
        stages: out.stages,
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
) -> Result<(BakeOutput, ShardMaps), BakeError> {
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
    let view = LightView::new(&scene.light, &scene.full_bounds(), opts.shadow_map_size);

    // Primary shadow map of the static geometry (GPU, the runtime's pass).
    progress.begin("shadow map", 0);
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, &static_scene, 0.0);
    let pass = ShadowPass::new(&ctx.device, &scene_gpu, view);
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    pass.encode(&mut enc, &scene_gpu, &[&scene_gpu.static_draws], None);
    ctx.queue.submit([enc.finish()]);
    let mut primary = readback::read_texture_f32(ctx, &pass.metric, 0, 1)?;
    for v in &mut primary {
        if *v >= f32::MAX {
            *v = f32::INFINITY;
        }
    }
    progress.end();
    lap("shadow map", &mut stages);

    // RSM by ray casting.
    progress.begin("RSM", 0);
    let rsm_view = view.resized(opts.rsm_size);
    let rsm = render_rsm(&rays, &scene.light, &rsm_view);
    progress.end();
    lap("rsm", &mut stages);

    // Quadtree clustering.
    progress.begin("clustering", 0);
    let clusters = cluster(&rsm, opts.target);
    progress.end();
    lap("clustering", &mut stages);
    if clusters.vpls.is_empty() {
        return Err(BakeError::NothingLit {
            path: scene.source.clone(),
        });
    }

    let mut vpls: Vec<VplRecord> = clusters
        .vpls
        .iter()
        .map(|c| VplRecord {
            // On the cluster's own surface (see Cluster::anchor).
            position: c.anchor.to_array(),
            area: c.area,
            normal: c.normal.to_array(),
            texels: c.texels,
            flux: c.flux.to_array(),
            map: NO_MAP,
        })
        .collect();

    // Near-field trees (one per VPL, from its node's texels).
    let vpl_nodes: Vec<VplRecord> = clusters
        .rects
        .iter()
        .flat_map(|&r| crate::near_field::vpl_nodes(&rsm, r))
        .collect();

    // Hemisphere maps by ray casting (a shard: only its VPLs', kept apart).
    let range = match shard {
        Some(s) => shard_range(vpls.len(), s.index, s.count),
        None => 0..vpls.len(),
    };
    progress.begin("VPL maps", range.len() as u64);
    let each = crate::vplmap::render_each_vpl_map(&rays, &vpls[range], opts.vpl_map_size, &|| {
        progress.advance(1)
    });
    let (maps, shard_maps) = match shard {
        Some(_) => (MapAtlas::empty(opts.vpl_map_size), each),
        None => {
            let atlas = assign_map_tiles(&mut vpls, opts.vpl_map_size, each).ok_or_else(|| {
                BakeError::InvalidSetting("the VPL maps do not fit one atlas in memory".into())
            })?;
            (atlas, Vec::new())
        }
    };
    progress.end();
    lap("vpl maps", &mut stages);

    let has_dynamic = !scene.dynamic_objects.is_empty();
    // Each texel's share of its VPL's flux, for partial occlusion.
    let rsm_data = has_dynamic.then(|| {
        let flux: Vec<[f32; 3]> = rsm.flux.iter().map(|f| f.to_array()).collect();
        let texel_vpl = clusters
            .texel_vpl
            .iter()
            .map(|&v| if v == NO_VPL { u32::MAX } else { v })
            .collect();
        RsmData::from_flux(rsm.size, rsm.metric.clone(), &flux, texel_vpl, vpls.len())
    });
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
            threshold: clusters.threshold,
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
    };
    let asset = Asset {
        manifest,
        vpls,
        vpl_nodes,
        primary_depth: Map {
            size: opts.shadow_map_size,
            data: primary,
        },
        vpl_maps: maps,
        rsm: rsm_data,
    };
    Ok((BakeOutput { asset, stages }, shard_maps))
}
