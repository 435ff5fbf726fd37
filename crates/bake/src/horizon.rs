//! The light a VPL sends below its own horizon, and where its visibility is
//! tested from.
//!
//! A VPL's hemisphere map is centred on one origin lifted off the cluster
//! along its mean normal `n` and covers the directions above `n`'s horizon.
//! A cluster whose texels face several ways — a roof with the lit walls of
//! a hole in it, a wall's outer face with the sill and jambs of a window —
//! also sends light *below* that horizon: the hole's walls light the room
//! under the roof, the sill lights the corridor behind the wall. That light
//! leaves from the texels tilted away from `n`, and what it meets is what
//! *they* see (through the hole, the window), not what the lifted origin
//! sees: from above the roof the room is behind the roof, and along the
//! map's rim (where a receiver below the horizon is looked up) the origin
//! sees the open sky. Exact rays from the one origin over-darken that
//! light; the rim answer over-lights it (docs/method.md, "Below the
//! horizon").
//!
//! So a VPL whose texels send enough of their light below its horizon
//! ([`MIN_BELOW_SHARE`]) gets a second origin, [`lower_origin`], off the
//! texels that send it: each texel weighs the share of its cosine lobe
//! that leaves below the VPL's plane, `(1 − n_t·n)/2`, times its flux; the
//! origin is anchored on the weighted texel nearest to their weighted
//! centroid (a texel, not the centroid: the centroid of the two faces of a
//! convex corner lies inside the solid) and lifted along their weighted
//! mean normal by [`LOWER_ORIGIN_OFFSET`] of their disk radius, but at most
//! halfway to the surface that direction runs into (so that it stays
//! inside a roof's hole or a window's reveal, and clears the leaves of a
//! crown or the stones of a rough wall round it). A second hemisphere map,
//! around `−n` from that origin (`crate::vplmap`), answers the receivers
//! below the VPL's horizon. Measured: docs/method.md, "Below the horizon".

use glam::{DVec3, Vec3};

use gibake_raycast::RayScene;

use crate::cluster::Clustering;
use crate::rsm::Rsm;

/// The least share of a VPL's flux that its texels must send below its
/// horizon for it to get a second origin ([`lower_origin`]); a flatter
/// cluster keeps the map's rim answer there, where its little light goes.
pub const MIN_BELOW_SHARE: f64 = 0.01;

/// How far, in the below-horizon texels' disk radius `√(A/π)`, the second
/// origin sits off the texel it is anchored on, at most halfway to the
/// surface in front of it (the first origin's lift is
/// [`gibake_gpu::hemisphere::VPL_ORIGIN_OFFSET`] of the VPL's radius). In
/// the CPU twin with exact rays on thirteen real levels and two probes, 1
/// put every level's indirect bias within ±5% (0.2: the garden −7.6% and
/// the medieval book −8.4%, a second origin among leaves and stones; 3:
/// the town +5.1%); docs/method.md, "Below the horizon".
pub const LOWER_ORIGIN_OFFSET: f32 = 1.0;

/// The share of a cosine lobe about unit normal `nt` that leaves below the
/// plane of unit normal `n`: `(1 − nt·n)/2`, in `[0, 1]`.
pub fn below_share(nt: Vec3, n: Vec3) -> f64 {
    let c = f64::from(nt.dot(n));
    if c.is_finite() {
        ((1.0 - c) * 0.5).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The second origin of every VPL of a bake of every light
/// ([`crate::lights::EveryLight`]), in its VPL order ([`lower_origin_of`]).
pub fn lower_origins_of_every(
    rays: &RayScene<'_>,
    every: &crate::lights::EveryLight,
) -> Vec<Option<Vec3>> {
    every
        .maps
        .iter()
        .zip(&every.clusters.maps)
        .flat_map(|(m, c)| (0..c.vpls.len()).map(move |i| lower_origin_of(rays, &m.rsm, c, i)))
        .collect()
}

/// The second origin of VPL `i` of `clusters` (its texels in `rsm`), or
/// `None` for a VPL that sends under [`MIN_BELOW_SHARE`] of its flux below
/// its horizon (see the module docs).
pub fn lower_origin_of(
    rays: &RayScene<'_>,
    rsm: &Rsm,
    clusters: &Clustering,
    i: usize,
) -> Option<Vec3> {
    let n = clusters.vpls[i].normal;
    lower_origin(rays, rsm, clusters.rects[i], n, |t| {
        clusters.texel_vpl[t] == i as u32
    })
}

/// The second origin of the VPL made of the lit texels of `rect`
/// (`(x0, x1, y0, y1)`, half-open) for which `member(texel index)` holds,
/// whose mean normal is `n` (see the module docs). Sums in `f64`, texels in
/// row-major order (deterministic).
pub fn lower_origin(
    rays: &RayScene<'_>,
    rsm: &Rsm,
    (x0, x1, y0, y1): (u32, u32, u32, u32),
    n: Vec3,
    member: impl Fn(usize) -> bool,
) -> Option<Vec3> {
    let texels = || (y0..y1).flat_map(move |y| (x0..x1).map(move |x| (y * rsm.size + x) as usize));
    let lit = |t: usize| rsm.metric[t].is_finite() && member(t);
    let weight = |t: usize| {
        let f = rsm.flux[t];
        let phi = f64::from(f.x) + f64::from(f.y) + f64::from(f.z);
        if phi > 0.0 && phi.is_finite() {
            phi
        } else {
            0.0
        }
    };
    // Flux, below-horizon flux and its moments.
    let (mut total, mut below, mut wp, mut wn, mut ws) =
        (0f64, 0f64, DVec3::ZERO, DVec3::ZERO, 0f64);
    for t in texels().filter(|&t| lit(t)) {
        let phi = weight(t);
        let s = below_share(rsm.normal[t], n);
        let w = phi * s;
        total += phi;
        below += w;
        wp += rsm.position[t].as_dvec3() * w;
        wn += rsm.normal[t].as_dvec3() * w;
        ws += w * s;
    }
    if !(total > 0.0 && below > 0.0 && below >= MIN_BELOW_SHARE * total) {
        return None;
    }
    let centroid = wp / below;
    // The texels that send the light: at least half the mean share.
    let least = 0.5 * ws / below;
    let (mut best, mut best_d, mut area) = (None, f64::INFINITY, 0f64);
    for t in texels().filter(|&t| lit(t)) {
        if weight(t) <= 0.0 || below_share(rsm.normal[t], n) < least {
            continue;
        }
        area += f64::from(rsm.area[t]);
        let d = (rsm.position[t].as_dvec3() - centroid).length_squared();
        if d < best_d {
            best_d = d;
            best = Some(t);
        }
    }
    let t = best?;
    let mean = wn / below;
    let dir = if mean.length() >= 0.3 {
        mean.normalize().as_vec3()
    } else {
        rsm.normal[t]
    };
    let mut lift = LOWER_ORIGIN_OFFSET * ((area / std::f64::consts::PI).sqrt() as f32);
    // At most halfway to the surface the lift runs into.
    let from = rays.offset_point(rsm.position[t], dir);
    if let Some(h) = rays.intersect(from, dir, f32::INFINITY) {
        lift = lift.min(0.5 * (h.position - rsm.position[t]).length());
    }
    let o = rsm.position[t] + dir * lift;
    o.is_finite().then_some(o)
}
