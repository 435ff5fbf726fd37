//! gibake's offline bake (design brief, steps 1–3).
//!
//! 1. [`rsm`]: the reflective shadow map of the static geometry from the
//!    primary light (one ray per texel against a BVH).
//! 2. [`cluster`]: scale-invariant quadtree clustering of RSM texels into VPLs.
//! 3. [`near_field`]: each VPL's near-field tree (sub-clusters that shading
//!    uses for receivers close to the VPL).
//! 4. [`vplmap`]: a hemisphere distance map per VPL (one ray per texel),
//!    and a second one for the light below its horizon from the second
//!    origin [`horizon`] places on the texels that send it.
//!
//! plus the static primary shadow map (GPU, the runtime's own pass) and the
//! static-scene hash ([`gibake_scene::static_scene_hash`]). [`bake()`] runs them all and returns a
//! [`gibake_asset::Asset`];
//! [`bake_shard()`] bakes one shard of a distributed bake, and
//! [`check_up_to_date`] decides whether an existing asset needs a re-bake.

pub mod bake;
pub mod budget;
pub mod cluster;
pub mod horizon;
pub mod later;
pub mod lights;
pub mod near_field;
pub mod reach;
pub mod rings;
pub mod rsm;
pub mod uptodate;
pub mod vplmap;

pub use bake::{
    BakeError, BakeOptions, BakeOutput, BakeProgress, NoProgress, Shard, ShardOutput, StageTime,
    bake, bake_shard, static_only,
};
pub use gibake_scene::static_scene_hash;
pub use uptodate::{Freshness, check_up_to_date};

/// Revision of the bake's method. Bump it in every change that makes a bake
/// of the same scene, settings and adapter write other bytes (the RSM, the
/// clustering, the near-field trees, the maps, the lights' plan…): the
/// baker version an asset records is `CRATE_VERSION+bake.N`
/// ([`baker_version`]), so the up-to-date check re-bakes an asset baked by
/// an older method even when the crate version did not change.
/// `crates/bake/tests/method_revision.rs` holds the VPLs of two small bakes
/// to a hash per revision and says when it is due. A change to the runtime alone (how the
/// same asset is shaded) needs no bump.
pub const BAKE_METHOD: u32 = 11;

/// The baker version to record in an asset and to compare with an existing
/// one: this crate's version with the method revision as build metadata,
/// e.g. `0.1.0+bake.1` ([`BAKE_METHOD`]).
pub fn baker_version() -> String {
    format!("{}+bake.{BAKE_METHOD}", env!("CARGO_PKG_VERSION"))
}
