//! The bake's memory, estimated from its settings before anything is
//! allocated, and checked against a budget (`gibake --max-memory`).
//!
//! The estimate is the peak the bake holds at once, per part:
//!
//! | part | bytes |
//! |---|---|
//! | RSM (metric, position, normal, flux, area) and the clustering pyramid | 64 × rsm², per view of a bake of several lights (at the view's own resolution: `lights::ViewPlan`) |
//! | hemisphere maps: the layers, the atlas copy and its EXR encoding, for the first maps and at most as many second maps (`crate::horizon`) | 24 × VPLs × map² |
//! | primary shadow map: read-back, map and EXR encoding | 12 × shadow² |
//! | the other lights' shadow maps: the same | 12 × views × light map² |
//!
//! With `--vpls N` the VPL count is N + 2% (the clustering's tolerance);
//! with `--threshold` it is not known before clustering, so the maps are
//! left out of the first estimate, and the bake checks again
//! ([`check_with`]) once clustering has counted the VPLs, before any
//! near-field tree or map exists (`BakeProgress::memory_limit`). A bake of
//! several lights holds every view's RSM at once: it checks
//! ([`check_lights`]) once the scene's views are known, before any RSM,
//! with the fewest texels their plan can have (the probes' resolution for
//! the views that may get less than `rsm_size`,
//! `lights::ViewPlan::least_texels`), and again with the planned
//! resolutions before the full RSMs are made.

use crate::BakeOptions;
use crate::cluster::ClusterTarget;

/// The bake's estimated peak memory, per part (bytes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// RSM and clustering.
    pub rsm: u64,
    /// Hemisphere maps (0 when the VPL count is not known up front).
    pub vpl_maps: u64,
    /// Primary shadow map.
    pub shadow_map: u64,
}

impl MemoryEstimate {
    /// The sum of the parts.
    pub fn total(&self) -> u64 {
        self.rsm
            .saturating_add(self.vpl_maps)
            .saturating_add(self.shadow_map)
    }
}

/// A bake whose estimate is over the budget.
#[derive(Debug, thiserror::Error)]
#[error(
    "the bake would need about {} MiB ({} VPL maps of {vpl_map_size}² = {} MiB, {rsm_views} RSM(s) of {rsm_texels} texels in all (up to {rsm_size}² each) = {} MiB, shadow maps (primary {shadow_map_size}²) = {} MiB), over the memory limit of {} MiB; lower --vpls, --vpl-map-size, --rsm-size or --shadow-map-size, bake fewer lights (--light NAME), or raise the limit with --max-memory",
    mib(estimate.total()),
    vpls,
    mib(estimate.vpl_maps),
    mib(estimate.rsm),
    mib(estimate.shadow_map),
    mib(*limit)
)]
pub struct OverBudget {
    /// The estimate.
    pub estimate: MemoryEstimate,
    /// The budget (bytes).
    pub limit: u64,
    /// VPL count assumed.
    pub vpls: u64,
    /// `--vpl-map-size`.
    pub vpl_map_size: u32,
    /// `--rsm-size`.
    pub rsm_size: u32,
    /// `--shadow-map-size`.
    pub shadow_map_size: u32,
    /// RSMs held at once (every view of every light; 1 with one light).
    pub rsm_views: u64,
    /// Their texels together (`rsm_size²` with one light).
    pub rsm_texels: u64,
}

fn mib(b: u64) -> u64 {
    b.div_ceil(1 << 20)
}

/// `estimate` if it is within `limit`, else the error naming its parts.
fn within(
    estimate: MemoryEstimate,
    limit: u64,
    opts: &BakeOptions,
    vpls: u64,
    (rsm_views, rsm_texels): (u64, u64),
) -> Result<MemoryEstimate, Box<OverBudget>> {
    if estimate.total() <= limit {
        return Ok(estimate);
    }
    Err(Box::new(OverBudget {
        estimate,
        limit,
        vpls,
        vpl_map_size: opts.vpl_map_size,
        rsm_size: opts.rsm_size,
        shadow_map_size: opts.shadow_map_size,
        rsm_views,
        rsm_texels,
    }))
}

/// The VPL count assumed by the estimate (0 when not known up front).
pub fn assumed_vpls(opts: &BakeOptions) -> u64 {
    match opts.target {
        ClusterTarget::Count(n) => n as u64 + (n as u64).div_ceil(50),
        ClusterTarget::Threshold(_) => 0,
    }
}

/// The bake's estimated peak memory for `opts`.
pub fn estimate(opts: &BakeOptions) -> MemoryEstimate {
    MemoryEstimate {
        rsm: sq(opts.rsm_size).saturating_mul(64),
        vpl_maps: assumed_vpls(opts)
            .saturating_mul(sq(opts.vpl_map_size))
            .saturating_mul(MAP_BYTES_PER_TEXEL),
        shadow_map: sq(opts.shadow_map_size).saturating_mul(12),
    }
}

/// Checks the estimate of `opts` against `limit` bytes.
pub fn check(opts: &BakeOptions, limit: u64) -> Result<MemoryEstimate, Box<OverBudget>> {
    let estimate = estimate(opts);
    within(
        estimate,
        limit,
        opts,
        assumed_vpls(opts),
        (1, sq(opts.rsm_size)),
    )
}

/// Bytes per texel of a VPL's maps: 4 each for the map, the atlas copy and
/// its EXR encoding, for its first map and at most one second map.
const MAP_BYTES_PER_TEXEL: u64 = 2 * 12;

fn sq(n: u32) -> u64 {
    u64::from(n) * u64::from(n)
}

/// The estimate of a bake of several lights: `rsm_views` RSMs of
/// `rsm_texels` texels together held at once (every view of every light)
/// and `light_map_texels` of the other lights' shadow maps.
pub fn estimate_lights(
    opts: &BakeOptions,
    rsm_texels: u64,
    light_map_texels: u64,
) -> MemoryEstimate {
    let e = estimate(opts);
    MemoryEstimate {
        rsm: rsm_texels.saturating_mul(64),
        vpl_maps: e.vpl_maps,
        shadow_map: e
            .shadow_map
            .saturating_add(light_map_texels.saturating_mul(12)),
    }
}

/// Checks [`estimate_lights`] against `limit`, before any RSM is made.
pub fn check_lights(
    opts: &BakeOptions,
    (rsm_views, rsm_texels): (u64, u64),
    light_map_texels: u64,
    limit: u64,
) -> Result<MemoryEstimate, Box<OverBudget>> {
    let estimate = estimate_lights(opts, rsm_texels, light_map_texels);
    within(
        estimate,
        limit,
        opts,
        assumed_vpls(opts),
        (rsm_views, rsm_texels),
    )
}

/// Bytes per VPL besides its map: the record (48) and its near-field tree
/// ([`gibake_asset::NODES_PER_VPL`] records of 48 bytes), twice (built,
/// then encoded).
const BYTES_PER_VPL: u64 = 2 * 48 * (1 + gibake_asset::NODES_PER_VPL as u64);

/// The estimate again once clustering has made `vpls` VPLs, of which
/// `mapped` get a hemisphere map in this run (all of them, or a shard's).
pub fn estimate_with(opts: &BakeOptions, vpls: u64, mapped: u64) -> MemoryEstimate {
    let e = estimate(opts);
    MemoryEstimate {
        rsm: e.rsm.saturating_add(vpls.saturating_mul(BYTES_PER_VPL)),
        vpl_maps: mapped
            .saturating_mul(sq(opts.vpl_map_size))
            .saturating_mul(MAP_BYTES_PER_TEXEL),
        shadow_map: e.shadow_map,
    }
}

/// Checks the estimate with the VPL count clustering found (needed for
/// `--threshold`, whose count is unknown up front) against `limit`, before
/// any near-field tree or map is made.
pub fn check_with(
    opts: &BakeOptions,
    vpls: u64,
    mapped: u64,
    limit: u64,
) -> Result<MemoryEstimate, Box<OverBudget>> {
    let estimate = estimate_with(opts, vpls, mapped);
    within(estimate, limit, opts, vpls, (1, sq(opts.rsm_size)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_64_gib_bake_is_refused_and_the_default_fits() {
        let big = BakeOptions {
            vpl_map_size: 2048,
            target: ClusterTarget::Count(4096),
            ..BakeOptions::default()
        };
        assert!(estimate(&big).total() > 64 << 30);
        let e = check(&big, 2 << 30).expect_err("over budget");
        assert!(e.to_string().contains("--max-memory"), "{e}");
        let small = check(&BakeOptions::default(), 2 << 30).expect("default fits");
        assert!(small.total() < 200 << 20, "{small:?}");
    }

    #[test]
    fn a_threshold_that_makes_every_texel_a_vpl_is_refused_after_clustering() {
        let opts = BakeOptions {
            target: ClusterTarget::Threshold(1e-30),
            ..BakeOptions::default()
        };
        // Up front the count is unknown: only the RSM and shadow map count.
        assert!(check(&opts, 2 << 30).is_ok());
        // 512² texels, each its own VPL: 17 GB of maps.
        let e = check_with(&opts, 512 * 512, 512 * 512, 2 << 30).expect_err("over");
        assert!(e.to_string().contains("262144 VPL maps"), "{e}");
        assert!(check_with(&opts, 256, 256, 2 << 30).is_ok());
    }
}
