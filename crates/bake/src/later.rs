//! The bounces after the first (issue 50): computed at bake time for the
//! static scene and stored as more VPLs, which the runtime shades as it
//! shades the first bounce's.
//!
//! The first bounce is the paper's: VPLs from the lights' RSMs, moving
//! objects merged into their maps each frame. The later bounces carry, in
//! interiors, as much light again or far more (the grid of rooms: 3.8–5.2×
//! the first bounce; a white arena lit through openings: 19×), so a bake of
//! every bounce adds them, in three steps:
//!
//! 1. **Surfels** ([`surfels`]): points on both sides of the static
//!    surfaces, by area.
//! 2. **The bounces** ([`radiosity`]): each surfel's direct irradiance
//!    (shadow rays to every light), then bounce after bounce over fixed
//!    links — the surfel each of its cosine rays lands on — until a bounce
//!    carries under a thousandth of the light so far or the ratio between
//!    bounces is steady (the rest then added as a geometric series); a
//!    level whose light does not die down (a closed box of albedo 1) is cut
//!    at [`radiosity::MAX_BOUNCES`] and the bake warns.
//! 3. **Later-bounce VPLs** ([`secondary`]): each surfel passes on `albedo ·
//!    E · area`, `E` its irradiance from the first bounce on; those are
//!    clustered into VPLs with the first bounce's rule, each with its own
//!    near-field tree and, in the bake, its own hemisphere map. So moving
//!    objects shadow the later bounces as they shadow the first (merged
//!    into their maps); what a moving object changes in the light the
//!    later bounces carry (a door closing) is not followed (docs/method.md,
//!    "Every bounce").

pub mod radiosity;
pub mod secondary;
pub mod sources;
pub mod surfels;

use gibake_asset::VplRecord;
use gibake_raycast::RayScene;
use glam::Vec3;

pub use radiosity::Bounces;

/// The later bounces' VPLs by default: this share of the first bounce's
/// (at least one). A quarter keeps the frame within 1.3× of a bake of the
/// first bounce alone (docs/method.md, "Every bounce").
pub const LATER_VPL_FRACTION: f64 = 0.25;

/// Surface points sampled for the later bounces at most (two surfels each
/// where both sides see out): the default's (64 later VPLs at `--vpls 256`).
pub const LATER_POINTS: u32 = 16384;

/// Surface points per later VPL ([`surface_points`]).
pub const POINTS_PER_LATER_VPL: u32 = 256;

/// The surface points for `later_vpls` later VPLs: 256 a VPL (each VPL's
/// light gathered from a few hundred surfels at least), from 1024 up to
/// [`LATER_POINTS`]: a bake of a handful of VPLs (a preview, a test) does
/// not pay the full solve; from 64 later VPLs (the default's at `--vpls
/// 256`) on, every bake gets all of them.
pub fn surface_points(later_vpls: u32) -> u32 {
    later_vpls
        .saturating_mul(POINTS_PER_LATER_VPL)
        .clamp(1024, LATER_POINTS)
}

/// Rays per surfel.
pub const LATER_RAYS: u32 = 64;

/// Under [`Bounces::Every`] the later bounces are left out when they carry
/// under this share of all the light the level's surfaces reflect
/// ([`Later::later_share`]): outdoors, where direct light dominates (the
/// town: under 0.05%), the bake stores nothing for them and the frame has
/// no VPL more; a room lit through a window carries 3%, a white arena 55%.
/// The share is of the whole level's reflected light, and a camera may see
/// mostly the indirectly lit part: the Japanese room's 0.2% is 5–8% of the
/// indirect light its camera sees, so the bar is low.
pub const NEGLIGIBLE_LATER_SHARE: f64 = 0.001;

/// How the bake follows the later bounces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaterOptions {
    /// How many bounces in all ([`Bounces::Count`]`(1)`: none after the
    /// first).
    pub bounces: Bounces,
    /// Surface points sampled (each gives a surfel per side).
    pub points: u32,
    /// Rays per surfel.
    pub rays: u32,
    /// The later bounces' VPLs.
    pub vpls: u32,
}

/// The later bounces of a level: their VPLs and what each bounce carries.
pub struct Later {
    /// The VPLs (no maps yet), their near-field trees and level-3
    /// coherences, in the layout of the first bounce's.
    pub vpls: Vec<VplRecord>,
    /// Near-field trees.
    pub nodes: Vec<VplRecord>,
    /// Level-3 coherences.
    pub coherence: Vec<f32>,
    /// The light the surfels reflect after each bounce, `k = 1, 2, …`
    /// (W, RGB), and after those the rest of the series.
    pub per_bounce: Vec<Vec3>,
    /// The rest of the series beyond the last bounce followed.
    pub tail: Vec3,
    /// The light reflected straight from the lights, `Σ albedo · E_direct ·
    /// area` (W, RGB).
    pub direct: Vec3,
    /// Whether the light died down (else: cut at the bounce cap).
    pub converged: bool,
    /// Surfels used.
    pub surfels: usize,
    /// Where each VPL's light came from ([`sources`]): per VPL of `vpls`,
    /// and per first-bounce VPL its source group.
    pub sources: sources::Sources,
    /// Seconds [`sources`] took (within the whole).
    pub sources_seconds: f64,
}

impl Later {
    /// Whether a bake asked for `bounces` keeps these later bounces: every
    /// count asked for is kept; under [`Bounces::Every`] they are left out
    /// when they carry under [`NEGLIGIBLE_LATER_SHARE`] of the light.
    pub fn kept(&self, bounces: Bounces) -> bool {
        bounces != Bounces::Every || self.later_share() >= NEGLIGIBLE_LATER_SHARE
    }

    /// The light the bounces after the first carry over all the light the
    /// surfaces reflect (direct, first bounce and later): the share a bake
    /// leaves out when it leaves them out.
    pub fn later_share(&self) -> f64 {
        gibake_asset::later_share(
            self.direct.to_array(),
            self.per_bounce.iter().map(|v| v.to_array()),
            self.tail.to_array(),
        )
    }
}

/// The later bounces of the static scene in `rays` (see the module docs),
/// with where their light came from among the first bounce's VPLs `first`.
pub fn later_bounces(rays: &RayScene<'_>, opts: &LaterOptions, first: &[VplRecord]) -> Later {
    let surfels = surfels::place(rays, opts.points);
    let direct = radiosity::direct(rays, &surfels);
    let links = radiosity::link(rays, &surfels, opts.rays);
    let solution = radiosity::solve(&surfels, &links, &direct, opts.bounces);
    let emitted: Vec<Vec3> = (0..surfels.len())
        .map(|s| surfels.albedo[s] * solution.indirect[s] * surfels.area[s])
        .collect();
    let bounds = rays.scene().static_bounds();
    let diag = (bounds.max - bounds.min).length();
    let sec = secondary::cluster(rays, &surfels, &emitted, opts.vpls, diag);
    let mut reflected = glam::DVec3::ZERO;
    for ((albedo, d), area) in surfels.albedo.iter().zip(&direct).zip(&surfels.area) {
        reflected += (*albedo * *d * *area).as_dvec3();
    }
    let mut later = Later {
        vpls: sec.vpls,
        nodes: sec.nodes,
        coherence: sec.coherence,
        per_bounce: solution.per_bounce,
        tail: solution.tail,
        direct: reflected.as_vec3(),
        converged: solution.converged,
        surfels: surfels.len(),
        sources: sources::Sources::default(),
        sources_seconds: 0.0,
    };
    // Where their light came from, only for later bounces the bake keeps.
    if later.kept(opts.bounces) {
        let clock = std::time::Instant::now();
        later.sources = sources::sources(
            rays,
            &sources::Solved {
                surfels: &surfels,
                links: &links,
                direct: &direct,
                emitted: &emitted,
            },
            &sec.surfel_vpl,
            later.vpls.len(),
            first,
        );
        later.sources_seconds = clock.elapsed().as_secs_f64();
    }
    later
}

/// `a > b`, false where either is NaN: `!gt(a, b)` takes a NaN as "not
/// greater", as `!(a > b)` does, in words clippy accepts.
pub(crate) fn gt<T: PartialOrd>(a: T, b: T) -> bool {
    matches!(a.partial_cmp(&b), Some(std::cmp::Ordering::Greater))
}
