//! Where each later VPL's light came from (format 4.8): the first bounce's
//! VPLs in source groups, and per later VPL the groups whose direct light
//! carries most of its light.
//!
//! A moving object that shadows a light takes off some of the first
//! bounce's VPLs' flux (the occlusion passes, per first-bounce VPL); the
//! later bounces pass that light on, so they lose it too — but where it
//! went, not over the whole level: a ball in the sunbeam of one room of a
//! grid of rooms darkens that room's later light by a fifth and the
//! others' not at all (docs/method.md, "Where the later light came
//! from"). The runtime gives each later VPL the occluded share of its
//! source groups by these weights, and the level's mean for the rest.
//!
//! Groups: the later VPLs' clusters (at most [`MAX_GROUPS`], consecutive
//! clusters merged — the clustering's order is spatial). A directly lit
//! surfel belongs to its own cluster's group (else its nearest clustered
//! surfel's) and to the first-bounce VPL nearest it that it sees; a
//! first-bounce VPL to the group most of its surfels' light passed on
//! came from, weighted in the group's mean by that light (a sunlit roof
//! under the open sky passes on none and weighs nothing). The weights:
//! the directly reflected light of each group gathered over the bake's
//! links for [`SOURCE_BOUNCES`] bounces, one channel a group, and the rest
//! of each later VPL's light shared as the last bounce gathered shares it.

use gibake_asset::{SOURCES_PER_LATER_VPL, VplRecord};
use gibake_raycast::RayScene;
use glam::Vec3;
use rayon::prelude::*;

use super::radiosity::{ESCAPED, Links};
use super::surfels::Surfels;

/// Source groups at most (within `gibake_asset::MAX_SOURCE_GROUPS`): the
/// gathers carry one channel a group, `surfels × groups` values.
pub const MAX_GROUPS: usize = 128;

/// Bounces gathered one channel a group; the rest of the series follows
/// the last one's mix.
pub const SOURCE_BOUNCES: usize = 3;

/// The source groups and weights (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sources {
    /// Per first-bounce VPL, its group and its weight in the group's mean
    /// (`gibake_asset::LaterSources::first`).
    pub first: Vec<(u32, f32)>,
    /// Per later cluster (in `surfel_vpl`'s numbering), its groups and
    /// weights, the largest first (unused: weight 0).
    pub weights: Vec<[(u32, f32); SOURCES_PER_LATER_VPL]>,
}

/// What the bake's solve left for [`sources`].
pub struct Solved<'a> {
    /// The surfels.
    pub surfels: &'a Surfels,
    /// Their links.
    pub links: &'a Links,
    /// Each surfel's direct irradiance (W/m², RGB).
    pub direct: &'a [Vec3],
    /// Each surfel's later light, `albedo · E · area` (W, RGB).
    pub emitted: &'a [Vec3],
}

/// The sources of `clusters` later VPLs (each surfel's cluster in
/// `surfel_vpl`, `u32::MAX` for none) for the first-bounce VPLs `first`,
/// from the solve `solved` (visibility by `rays`).
pub fn sources(
    rays: &RayScene<'_>,
    solved: &Solved<'_>,
    surfel_vpl: &[u32],
    clusters: usize,
    first: &[VplRecord],
) -> Sources {
    let Solved {
        surfels,
        links,
        direct,
        emitted,
    } = *solved;
    let n = surfels.len();
    if clusters == 0 || n == 0 {
        return Sources::default();
    }
    let groups = clusters.min(MAX_GROUPS);
    let group_of_cluster = |c: u32| (c as usize * groups / clusters) as u32;
    let clustered: Vec<u32> = (0..n as u32)
        .filter(|&i| (surfel_vpl[i as usize] as usize) < clusters)
        .collect();
    if clustered.is_empty() {
        return Sources::default();
    }
    // The clustered surfel nearest `p` facing `normal`'s way (cosine ≥ ½;
    // any, where none does), first on a tie.
    let nearest = |p: Vec3, normal: Vec3| -> u32 {
        let mut best = (f32::INFINITY, u32::MAX, f32::INFINITY, u32::MAX);
        for &i in &clustered {
            let d = (surfels.position[i as usize] - p).length_squared();
            if surfels.normal[i as usize].dot(normal) >= 0.5 {
                if d < best.0 {
                    best.0 = d;
                    best.1 = i;
                }
            } else if d < best.2 {
                best.2 = d;
                best.3 = i;
            }
        }
        let i = if best.1 != u32::MAX { best.1 } else { best.3 };
        group_of_cluster(surfel_vpl[i as usize])
    };
    // Each surfel's directly reflected light (a scalar: the channels'
    // mean) in its group's channel.
    let albedo: Vec<f32> = surfels
        .albedo
        .iter()
        .map(|a| a.element_sum() / 3.0)
        .collect();
    let source: Vec<Option<(u32, f32)>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let e = direct[i].element_sum() / 3.0;
            if !super::gt(e, 0.0) || !e.is_finite() {
                return None;
            }
            let c = surfel_vpl[i];
            let g = if (c as usize) < clusters {
                group_of_cluster(c)
            } else {
                nearest(surfels.position[i], surfels.normal[i])
            };
            Some((g, e))
        })
        .collect();
    let first = first_vpls(rays, surfels, links, &source, &albedo, first, groups);
    let mut prev = vec![0.0f32; n * groups];
    for (i, s) in source.iter().enumerate() {
        if let Some((g, e)) = s {
            prev[i * groups + *g as usize] = *e;
        }
    }
    let per = links.rays as usize;
    let mut acc = vec![0.0f32; n * groups];
    for _ in 0..SOURCE_BOUNCES {
        let next: Vec<f32> = (0..n)
            .into_par_iter()
            .flat_map_iter(|s| {
                let mut e = vec![0.0f32; groups];
                for &t in &links.target[s * per..(s + 1) * per] {
                    if t < ESCAPED {
                        let (a, row) = (
                            albedo[t as usize],
                            &prev[t as usize * groups..(t as usize + 1) * groups],
                        );
                        for (x, y) in e.iter_mut().zip(row) {
                            *x += a * y;
                        }
                    }
                }
                let k = links.scale[s] / per as f32;
                e.into_iter().map(move |x| x * k)
            })
            .collect();
        for (a, x) in acc.iter_mut().zip(&next) {
            *a += x;
        }
        prev = next;
    }
    // Per cluster: the gathered light by group, the last bounce's by
    // group, and the whole of its light (the bake's emitted light: the
    // caller's clusters carry it).
    let mut gathered = vec![0.0f64; clusters * groups];
    let mut last = vec![0.0f64; clusters * groups];
    let mut whole = vec![0.0f64; clusters];
    for i in 0..n {
        let c = surfel_vpl[i] as usize;
        if c >= clusters {
            continue;
        }
        whole[c] += f64::from(emitted[i].element_sum() / 3.0);
        let w = f64::from(albedo[i] * surfels.area[i]);
        for g in 0..groups {
            gathered[c * groups + g] += w * f64::from(acc[i * groups + g]);
            last[c * groups + g] += w * f64::from(prev[i * groups + g]);
        }
    }
    let weights = (0..clusters)
        .map(|c| {
            let (ga, la) = (
                &gathered[c * groups..(c + 1) * groups],
                &last[c * groups..(c + 1) * groups],
            );
            weights_of(ga, la, whole[c])
        })
        .collect();
    Sources { first, weights }
}

/// Each first-bounce VPL's group and weight: the directly lit surfels
/// (`source`: group and irradiance) each go to the first-bounce VPL nearest
/// them that faces their way and that they see (of the four nearest; the
/// nearest facing one where none is seen), with the light they pass on to
/// other surfaces (`albedo · E · area` times the share of their rays that
/// hit one: a sunlit roof under the open sky passes on none); a VPL's
/// weight is the sum, its group the one most of that came from.
fn first_vpls(
    rays: &RayScene<'_>,
    surfels: &Surfels,
    links: &Links,
    source: &[Option<(u32, f32)>],
    albedo: &[f32],
    first: &[VplRecord],
    groups: usize,
) -> Vec<(u32, f32)> {
    if first.is_empty() {
        return Vec::new();
    }
    let per = links.rays as usize;
    let lift = 0.25 * surfels.spacing;
    // Per directly lit surfel: its VPL, its group and the light it passes on.
    let fed: Vec<Option<(usize, u32, f32)>> = (0..surfels.len())
        .into_par_iter()
        .map(|i| {
            let (g, e) = source[i]?;
            let rs = &links.target[i * per..(i + 1) * per];
            let hit = rs.iter().filter(|&&t| t != ESCAPED).count() as f32 / per.max(1) as f32;
            let w = albedo[i] * e * surfels.area[i] * hit;
            if !super::gt(w, 0.0) || !w.is_finite() {
                return None;
            }
            let (p, n) = (surfels.position[i], surfels.normal[i]);
            // The four nearest facing VPLs, nearest first (first on a tie).
            let mut near: Vec<(f32, usize)> = Vec::with_capacity(5);
            for (k, v) in first.iter().enumerate() {
                if Vec3::from_array(v.normal).dot(n) < 0.5 {
                    continue;
                }
                let d = (Vec3::from_array(v.position) - p).length_squared();
                if near.len() < 4 || d < near[near.len() - 1].0 {
                    let at = near.partition_point(|e| e.0 <= d);
                    near.insert(at, (d, k));
                    near.truncate(4);
                }
            }
            let seen = near.iter().find(|&&(_, k)| {
                let (a, b) = (
                    p + n * lift,
                    Vec3::from_array(first[k].position) + Vec3::from_array(first[k].normal) * lift,
                );
                let d = b - a;
                let l = d.length();
                !super::gt(l, 0.0) || !rays.occluded(a, d / l, l)
            });
            let k = seen.or(near.first())?.1;
            Some((k, g, w))
        })
        .collect();
    let mut votes = vec![0.0f64; first.len() * groups];
    let mut weight = vec![0.0f64; first.len()];
    for (k, g, w) in fed.into_iter().flatten() {
        votes[k * groups + g as usize] += f64::from(w);
        weight[k] += f64::from(w);
    }
    (0..first.len())
        .map(|k| {
            let v = &votes[k * groups..(k + 1) * groups];
            let mut best = 0;
            for (g, x) in v.iter().enumerate() {
                if *x > v[best] {
                    best = g;
                }
            }
            (best as u32, weight[k] as f32)
        })
        .collect()
}

/// A cluster's weights from its light gathered by group (`gathered`), its
/// last gathered bounce's (`last`) and its whole later light (`whole`):
/// the light beyond the gathered bounces, `whole − Σ gathered`, is shared
/// as the last bounce shares it (a room far from the light, lit only after
/// many bounces, by where its latest light came from). The
/// [`SOURCES_PER_LATER_VPL`] largest, over the whole.
fn weights_of(gathered: &[f64], last: &[f64], whole: f64) -> [(u32, f32); SOURCES_PER_LATER_VPL] {
    let (sg, sl): (f64, f64) = (gathered.iter().sum(), last.iter().sum());
    let rest = if sl > 0.0 { (whole - sg).max(0.0) } else { 0.0 };
    let total = sg + rest;
    let mix: Vec<f64> = gathered
        .iter()
        .zip(last)
        .map(|(g, l)| {
            let m = g + if sl > 0.0 { rest * l / sl } else { 0.0 };
            if total > 0.0 && m.is_finite() {
                m / total
            } else {
                0.0
            }
        })
        .collect();
    let mut order: Vec<usize> = (0..mix.len()).collect();
    order.sort_by(|&a, &b| mix[b].total_cmp(&mix[a]).then(a.cmp(&b)));
    let mut out = [(0u32, 0.0f32); SOURCES_PER_LATER_VPL];
    for (o, &g) in out.iter_mut().zip(&order) {
        if mix[g] > 0.0 {
            *o = (g as u32, mix[g] as f32);
        }
    }
    // f32 rounding never lets the sum pass 1.
    let sum: f32 = out.iter().map(|(_, w)| w).sum();
    if sum > 1.0 {
        for o in &mut out {
            o.1 /= sum;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest groups first, the rest left to the level's mean; a
    /// cluster no light reached names none.
    #[test]
    fn weights_keep_the_largest_groups() {
        let mut gathered = vec![0.0; 12];
        let mut last = vec![0.0; 12];
        for g in 0..12 {
            gathered[g] = g as f64;
            last[g] = g as f64;
        }
        // As much again after the gathered bounces, in the last one's mix
        // (here the same).
        let w = weights_of(&gathered, &last, 2.0 * gathered.iter().sum::<f64>());
        assert_eq!(w[0].0, 11);
        assert_eq!(w[7].0, 4);
        let sum: f32 = w.iter().map(|(_, x)| x).sum();
        let want = (4..12).sum::<usize>() as f32 / (0..12).sum::<usize>() as f32;
        assert!((sum - want).abs() < 1e-6, "{sum} {want}");
        assert!(
            weights_of(&[0.0; 4], &[0.0; 4], 1.0)
                .iter()
                .all(|(_, x)| *x == 0.0)
        );
    }
}
