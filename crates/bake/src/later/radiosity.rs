//! The bounces after the first, on the surfels: each surfel's direct
//! irradiance from every light (shadow rays), then, along a fixed set of
//! cosine-distributed rays per surfel, which surfel each ray lands on, and
//! the bounces as repeated gathers over those links — the light each
//! surfel receives after `k` bounces is the mean over its rays of the
//! albedo times the light the surfel the ray hit received after `k − 1`.
//!
//! A ray lands on the nearest surfel within reach of its hit point that
//! faces the ray and that the hit point sees (one visibility ray): a floor
//! across a thin wall faces the same way and lies in the same plane, and
//! only visibility tells it from the floor on this side. A ray that leaves
//! the level carries nothing back; one that hits a surface but finds no
//! surfel it sees counts as the mean of the surfel's hits that did
//! ([`Links::scale`]).
//!
//! The bake's own transport (as the RSM is): it shares the ray caster with
//! the reference, never its light transport.

use gibake_raycast::RayScene;
use gibake_scene::{Light, LightKind};
use glam::{IVec3, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;

use super::surfels::{Surfels, unit};
use crate::reach::cosine_direction;

/// No link: the ray hit a surface but found no surfel to land on.
pub const NO_SURFEL: u32 = u32::MAX;

/// No link: the ray left the level.
pub const ESCAPED: u32 = u32::MAX - 1;

/// Which surfel each of a surfel's rays lands on.
#[derive(Clone, Debug)]
pub struct Links {
    /// Rays per surfel.
    pub rays: u32,
    /// `rays` entries per surfel: the surfel hit, [`NO_SURFEL`] or
    /// [`ESCAPED`].
    pub target: Vec<u32>,
    /// Per surfel: its rays that hit a surface over those that landed on a
    /// surfel (1 when all did). A hit that finds no surfel it sees (a stair
    /// step whose own surfel lies beyond the next riser, detail under the
    /// spacing) is taken to send the mean of the hits that did: dropping
    /// it lost a few per cent of the light at every bounce (a white arena:
    /// 2.5% of the rays, a quarter of its light after thirty bounces), and
    /// landing it on a surfel it does not see carried sunlit roofs' light
    /// through the roof.
    pub scale: Vec<f32>,
}

/// Irradiance at `p` (geometric normal `ng`, shading normal `ns`, on the
/// side it faces) from `light`, with its shadow ray: spot and point
/// `I · attenuation · cos / d²`, directional `E · cos`, the shading
/// normal's cosine (as the RSM and the runtime shade).
fn light_irradiance(rays: &RayScene<'_>, light: &Light, p: Vec3, ng: Vec3, ns: Vec3) -> Vec3 {
    let (w, d, e) = match light.kind {
        LightKind::Directional => {
            let w = (-light.direction).normalize_or_zero();
            (w, f32::INFINITY, light.color)
        }
        LightKind::Spot { .. } | LightKind::Point => {
            let l = light.position - p;
            let d = l.length();
            if !(d > 0.0 && d.is_finite()) {
                return Vec3::ZERO;
            }
            let w = l / d;
            let att = light.attenuation(-w, d);
            if !super::gt(att, 0.0) {
                return Vec3::ZERO;
            }
            (w, d, light.color * (att / (d * d)))
        }
    };
    let (cos_g, cos_s) = (ng.dot(w), ns.dot(w));
    if !(super::gt(cos_g, 0.0) && super::gt(cos_s, 0.0)) {
        return Vec3::ZERO;
    }
    let origin = rays.offset_point(p, ng);
    let t_max = if d.is_finite() {
        (light.position - origin).length() - rays.end_margin(light.position)
    } else {
        f32::INFINITY
    };
    if t_max > 0.0 && rays.occluded(origin, w, t_max) {
        return Vec3::ZERO;
    }
    let e = e * cos_s;
    if e.is_finite() { e } else { Vec3::ZERO }
}

/// Each surfel's direct irradiance from every light of `rays`' scene.
pub fn direct(rays: &RayScene<'_>, surfels: &Surfels) -> Vec<Vec3> {
    let lights = &rays.scene().lights;
    (0..surfels.len())
        .into_par_iter()
        .map(|s| {
            lights.iter().fold(Vec3::ZERO, |e, l| {
                e + light_irradiance(
                    rays,
                    l,
                    surfels.position[s],
                    surfels.normal[s],
                    surfels.shading[s],
                )
            })
        })
        .collect()
}

/// The surfels in cells of `cell` world units, for the nearest-surfel
/// query of a ray's hit.
struct Grid {
    cell: f32,
    spacing: f32,
    cells: HashMap<IVec3, Vec<u32>>,
}

impl Grid {
    fn new(surfels: &Surfels, cell: f32) -> Grid {
        let spacing = surfels.spacing;
        let mut cells: HashMap<IVec3, Vec<u32>> = HashMap::new();
        for (i, p) in surfels.position.iter().enumerate() {
            cells.entry(Self::key(*p, cell)).or_default().push(i as u32);
        }
        Grid {
            cell,
            spacing,
            cells,
        }
    }

    fn key(p: Vec3, cell: f32) -> IVec3 {
        (p / cell).floor().as_ivec3()
    }

    /// The surfel a ray that hit `y` (geometric normal `n`, facing the
    /// ray's origin) lands on: the nearest that faces the same way (cosine
    /// ≥ ½) and that `y` sees, within one cell, else within two, else four
    /// (a hit on a sliver or a thin pillar, whose own surfels lie farther).
    fn land(&self, rays: &RayScene<'_>, surfels: &Surfels, y: Vec3, n: Vec3) -> u32 {
        for reach in [1, 2, 4] {
            let s = self.land_within(rays, surfels, y, n, reach);
            if s != NO_SURFEL {
                return s;
            }
        }
        NO_SURFEL
    }

    fn land_within(
        &self,
        rays: &RayScene<'_>,
        surfels: &Surfels,
        y: Vec3,
        n: Vec3,
        reach: i32,
    ) -> u32 {
        let c = Self::key(y, self.cell);
        let radius = self.cell * reach as f32;
        let mut best: Vec<(f32, u32)> = Vec::new();
        for dz in -reach..=reach {
            for dy in -reach..=reach {
                for dx in -reach..=reach {
                    let Some(list) = self.cells.get(&(c + IVec3::new(dx, dy, dz))) else {
                        continue;
                    };
                    for &s in list {
                        let (p, ns) = (surfels.position[s as usize], surfels.normal[s as usize]);
                        let d2 = (p - y).length_squared();
                        if ns.dot(n) >= 0.5 && d2 <= radius * radius {
                            best.push((d2, s));
                        }
                    }
                }
            }
        }
        best.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        // Seen from a quarter of the spacing above the surface, a
        // neighbour on the same surface is in the open (the segment along
        // the surface itself would graze its seams), one across a thin
        // wall is not.
        let lift = 0.25 * self.spacing;
        for &(_, s) in best.iter().take(4) {
            let (p, ns) = (surfels.position[s as usize], surfels.normal[s as usize]);
            let (a, b) = (y + n * lift, p + ns * lift);
            let d = b - a;
            let l = d.length();
            if !super::gt(l, 0.0) || !rays.occluded(a, d / l, l) {
                return s;
            }
        }
        NO_SURFEL
    }
}

/// Casts `per` cosine-distributed rays (stratified `k × k`, `k = √per`,
/// jittered by a hash of the surfel and the ray) from every surfel and
/// links each to the surfel it lands on.
pub fn link(rays: &RayScene<'_>, surfels: &Surfels, per: u32) -> Links {
    let k = (f64::from(per).sqrt().ceil() as u32).max(1);
    let per = k * k;
    let grid = Grid::new(surfels, 1.5 * surfels.spacing);
    let target: Vec<u32> = (0..surfels.len())
        .into_par_iter()
        .flat_map_iter(|s| {
            let (p, n) = (surfels.position[s], surfels.normal[s]);
            let origin = rays.offset_point(p, n);
            let grid = &grid;
            (0..per).map(move |r| {
                let key = (s as u64) << 20 | u64::from(r);
                let u1 = ((r % k) as f64 + unit(key ^ 0x3333_0000)) / f64::from(k);
                let u2 = ((r / k) as f64 + unit(key ^ 0x4444_0000)) / f64::from(k);
                let d = cosine_direction(n, u1 as f32, u2 as f32);
                match rays.intersect(origin, d, f32::INFINITY) {
                    Some(h) => grid.land(rays, surfels, h.position, h.geometric_normal),
                    None => ESCAPED,
                }
            })
        })
        .collect();
    let scale = target
        .chunks_exact(per as usize)
        .map(|rs| {
            let hit = rs.iter().filter(|&&t| t != ESCAPED).count();
            let landed = rs.iter().filter(|&&t| t < ESCAPED).count();
            if landed > 0 {
                hit as f32 / landed as f32
            } else {
                0.0
            }
        })
        .collect();
    Links {
        rays: per,
        target,
        scale,
    }
}

/// How many bounces the bake follows after the first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bounces {
    /// Every bounce that matters: until a bounce carries under
    /// [`NEGLIGIBLE_BOUNCE`] of the light so far, or the rest of a steady
    /// geometric series is added (module docs of `crate::later`).
    Every,
    /// Exactly this many bounces in all (1: the first alone, nothing later).
    Count(u32),
}

/// A bounce carrying less than this share of the light gathered so far
/// ends the series.
pub const NEGLIGIBLE_BOUNCE: f64 = 1e-3;

/// A steady ratio between bounces at or above this has no useful
/// geometric rest (the light barely dies down): the bounces are followed
/// one by one up to [`MAX_BOUNCES`].
pub const MAX_STEADY_RATIO: f64 = 0.999;

/// At most this many bounces are followed; a level whose light does not
/// die down by then (a closed box of albedo 1) has no finite answer.
pub const MAX_BOUNCES: u32 = 256;

/// What the gathers found.
#[derive(Clone, Debug)]
pub struct Solution {
    /// Per surfel: the irradiance of every bounce from the first on (the
    /// light the surfel passes on to the bounces after the first).
    pub indirect: Vec<Vec3>,
    /// Per bounce `k = 1, 2, …`: the light the surfels reflect after it,
    /// `Σ albedo · E_k · area` (W, RGB).
    pub per_bounce: Vec<Vec3>,
    /// The light of the bounces beyond the last one followed, added as the
    /// rest of a geometric series (zero if none was added).
    pub tail: Vec3,
    /// Whether the light died down; false: it was cut at [`MAX_BOUNCES`]
    /// (a closed level of albedo near 1).
    pub converged: bool,
}

/// Gathers bounce after bounce (module docs) from the direct irradiance
/// `direct` over `links`: the first `bounces` of them, or every one that
/// matters.
pub fn solve(surfels: &Surfels, links: &Links, direct: &[Vec3], bounces: Bounces) -> Solution {
    let n = surfels.len();
    let per = links.rays as usize;
    let last = match bounces {
        Bounces::Every => MAX_BOUNCES,
        Bounces::Count(k) => k.saturating_sub(1).min(MAX_BOUNCES),
    };
    let reflected = |e: &[Vec3]| -> Vec3 {
        let mut sum = glam::DVec3::ZERO;
        for ((albedo, e), area) in surfels.albedo.iter().zip(e).zip(&surfels.area).take(n) {
            sum += (*albedo * *e * *area).as_dvec3();
        }
        sum.as_vec3()
    };
    let mut indirect = vec![Vec3::ZERO; n];
    let mut per_bounce = Vec::new();
    let mut prev: Vec<Vec3> = direct.to_vec();
    let mut converged = true;
    let mut tail = Vec3::ZERO;
    let mut total = 0.0f64;
    for k in 1..=last {
        let next: Vec<Vec3> = (0..n)
            .into_par_iter()
            .map(|s| {
                let mut e = Vec3::ZERO;
                for &t in &links.target[s * per..(s + 1) * per] {
                    if t < ESCAPED {
                        e += surfels.albedo[t as usize] * prev[t as usize];
                    }
                }
                e * (links.scale[s] / per as f32)
            })
            .collect();
        let light = reflected(&next);
        let carried = f64::from(light.x + light.y + light.z);
        for (a, b) in indirect.iter_mut().zip(&next) {
            *a += *b;
        }
        per_bounce.push(light);
        total += carried;
        if bounces != Bounces::Every {
            prev = next;
            continue;
        }
        if !super::gt(carried, NEGLIGIBLE_BOUNCE * total) {
            break;
        }
        // A steady ratio r < 1 between bounces (the light has settled into
        // the level's own mode): the rest is E_k · r/(1 − r).
        let sum = |v: Vec3| f64::from(v.x) + f64::from(v.y) + f64::from(v.z);
        let m = per_bounce.len();
        if k >= 8 && m >= 3 {
            let r = sum(per_bounce[m - 1]) / sum(per_bounce[m - 2]);
            let r0 = sum(per_bounce[m - 2]) / sum(per_bounce[m - 3]);
            if r < MAX_STEADY_RATIO && (r - r0).abs() <= 1e-3 * r {
                let f = (r / (1.0 - r)) as f32;
                for (a, b) in indirect.iter_mut().zip(&next) {
                    *a += *b * f;
                }
                tail = light * f;
                break;
            }
        }
        if k == last {
            converged = false;
        }
        prev = next;
    }
    Solution {
        indirect,
        per_bounce,
        tail,
        converged,
    }
}
