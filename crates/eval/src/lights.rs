//! Every light's VPLs judged on the CPU (issue 19, before the asset format
//! and the runtime take several lights): the bake's front part for every
//! light ([`gibake_bake::lights::every_light`]: each light's views, one RSM
//! per view, one VPL budget) and the runtime's transport evaluated on the
//! CPU ([`crate::transport`]: near-field trees and far-field lobes) with
//! exact visibility, against the reference's one-bounce indirect light
//! from every light ([`crate::bounce`]), at the pixel centres of a small
//! image from the scene's camera, static part only; with
//! [`JudgeSettings::every_bounce`], against its every-bounce indirect light
//! too ([`Judgement::every_bounce`]). Used by the `lights_twin` example and
//! `tests/every_light.rs`.

use gibake_bake::cluster::{ClusterTarget, cluster_joint};
use gibake_bake::lights::{EveryLight, every_light_with};
use gibake_bake::reach::Reach;
use gibake_bake::rsm::Rsm;
use gibake_reference::{PathStats, RayScene};
use gibake_scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

/// How the VPL budget is spent over the lights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Budget {
    /// One budget spread by each light's bounce (the method).
    Joint,
    /// Each light `N / lights` VPLs over its own views (the alternative).
    EqualSplit,
}

/// What [`judge`] measured.
pub struct Judgement {
    /// The maps and VPLs that were judged.
    pub every: EveryLight,
    /// VPLs per light.
    pub per_light: Vec<usize>,
    /// Seconds of the front part (RSMs, clustering).
    pub bake_seconds: f64,
    /// Mean indirect bias per channel: Σ twin / Σ reference − 1 (NaN on a
    /// channel where the reference sees no bounce light).
    pub bias: DVec3,
    /// Relative RMS error of the 3×3-blurred indirect image.
    pub blurred_error: f64,
    /// With [`JudgeSettings::split`]: where the bias comes from, without
    /// visibility (see [`Split`]).
    pub split: Option<Split>,
    /// Σ reference indirect radiance per channel (0: the camera sees no
    /// bounce light, and the bias means nothing).
    pub reference_sum: DVec3,
    /// The reference's own noise on the bias, per channel: the standard
    /// error of Σ reference over Σ reference (from each receiver's sample
    /// variance; the samples are stratified, so this overestimates it). A
    /// bias within a few of these is not measured.
    pub bias_sigma: DVec3,
    /// With [`JudgeSettings::every_bounce`]: the twin against the
    /// every-bounce reference.
    pub every_bounce: Option<EveryBounceJudgement>,
}

/// The twin against the every-bounce reference at the same receivers
/// ([`crate::bounce::every_bounce_samples`]: the same directions, each
/// secondary hit's radiance with every bounce).
#[derive(Clone, Copy, Debug)]
pub struct EveryBounceJudgement {
    /// Mean indirect bias per channel: Σ twin / Σ every-bounce reference − 1.
    pub bias: DVec3,
    /// Σ every-bounce reference indirect radiance ÷ Σ one-bounce reference
    /// indirect radiance, per channel.
    pub ratio: DVec3,
    /// Σ every-bounce reference indirect radiance per channel.
    pub reference_sum: DVec3,
    /// The standard error of its Σ over Σ (as [`Judgement::bias_sigma`]).
    pub bias_sigma: DVec3,
    /// What the reference's paths from the secondary hits did.
    pub stats: gibake_reference::PathStats,
}

/// Where a light's indirect bias comes from (a diagnostic: no visibility
/// on either side, so that the clustering's transport is judged alone).
/// Σ over receivers, channels summed.
#[derive(Clone, Copy, Debug, Default)]
pub struct Split {
    /// The kept VPLs' runtime transport (near-field trees, far-field
    /// lobes), no visibility.
    pub clustered: f64,
    /// Every RSM texel of a kept VPL as its own small disk
    /// ([`crate::transport::disk_irradiance`]), no visibility.
    pub texels: f64,
    /// The same, over every lit texel (kept VPL or not).
    pub all_texels: f64,
    /// The twin with exact visibility from each VPL's origin.
    pub clustered_visible: f64,
    /// The reference.
    pub reference: f64,
    /// `clustered`'s part from VPLs whose disk is in the receiver's far
    /// field (one disk with its lobe, at its far-field centre).
    pub far_clustered: f64,
    /// `texels`' part from the same VPLs at the same receivers.
    pub far_texels: f64,
    /// `far_clustered` with each disk drawn from its map origin instead
    /// (the rule before session 10).
    pub far_from_origin: f64,
    /// `far_clustered` drawn as each VPL's near-field nodes of level
    /// [`JudgeSettings::split`] (disks with their own normals and cosine
    /// lobes).
    pub far_nodes: f64,
}

impl Split {
    /// `clustered / texels − 1`: the clustering's transport loss.
    pub fn transport(&self) -> f64 {
        self.clustered / self.texels - 1.0
    }

    /// The clustered VPLs' visible share over the reference's visible
    /// share of the texels' unshadowed light, − 1 (if the RSM were exact,
    /// what one visibility point per VPL costs).
    pub fn visibility(&self) -> f64 {
        (self.clustered_visible / self.clustered) / (self.reference / self.texels) - 1.0
    }
}

/// The bake settings [`judge`] uses.
#[derive(Clone, Copy, Debug)]
pub struct JudgeSettings {
    /// VPL budget over every light.
    pub vpls: u32,
    /// RSM resolution per view (the bake's default: 512).
    pub rsm_size: u32,
    /// Receivers: a `size²` image from the scene's camera.
    pub size: u32,
    /// The reference's one-bounce samples per receiver: `side²`.
    pub side: u32,
    /// How the budget is spent.
    pub budget: Budget,
    /// Keep the views whose light is negligible.
    pub keep_negligible: bool,
    /// Also compute [`Judgement::split`] (every texel against every
    /// receiver: seconds to minutes), with its far field also drawn as
    /// each VPL's near-field nodes of this level (1, 2 or 3).
    pub split: Option<u32>,
    /// Also judge against the every-bounce reference
    /// ([`Judgement::every_bounce`]):
    /// one every-bounce path from each secondary hit, a few times the
    /// one-bounce reference's rays.
    pub every_bounce: bool,
}

/// Judges `scene`'s every-light VPLs (see [`JudgeSettings`]).
pub fn judge(scene: &Scene, j: &JudgeSettings) -> Judgement {
    let JudgeSettings {
        vpls,
        rsm_size,
        size,
        side,
        budget,
        keep_negligible,
        split,
        every_bounce,
    } = *j;
    let stat = gibake_bake::static_only(scene);
    let rays = RayScene::build(&stat, 0.0);
    let reach = Reach::new(&rays, scene.dynamic_swept_bounds());
    let t0 = std::time::Instant::now();
    let mut every = every_light_with(
        scene,
        &reach,
        rsm_size,
        2048,
        ClusterTarget::Count(vpls),
        !keep_negligible,
    );
    if budget == Budget::EqualSplit {
        let mut lit: Vec<usize> = every.maps.iter().map(|m| m.light).collect();
        lit.dedup();
        let share = (vpls / lit.len().max(1) as u32).max(1);
        let mut maps = Vec::new();
        for &l in &lit {
            let refs: Vec<&Rsm> = every
                .maps
                .iter()
                .filter(|m| m.light == l)
                .map(|m| &m.rsm)
                .collect();
            maps.extend(cluster_joint(&refs, ClusterTarget::Count(share)).maps);
        }
        every.dropped_vpls = 0;
        for (c, m) in maps.iter_mut().zip(&every.maps) {
            let reaching = c.reaching_flux(&m.rsm);
            every.dropped_vpls += c.retain(|i, v| reach.keeps(v, reaching[i], m.ring > 0));
        }
        every.clusters.maps = maps;
    }
    let bake_seconds = t0.elapsed().as_secs_f64();
    let records = every.vpl_records();
    let (nodes, coherence) = every.vpl_trees();
    let ring = every.ring_flags();
    let twin_vpls = crate::transport::TwinVpls::new(&records, &ring, &nodes, &coherence)
        .with_lower(gibake_bake::horizon::lower_origins_of_every(&rays, &every));
    let per_light = every.vpls_per_light(scene.lights.len());
    let cam = gibake_reference::View::from_scene(scene, 0.0).expect("the scene has a camera");
    // Per pixel: (reference, twin) indirect radiance, and the variance of
    // the reference's mean; with `split`, the split's figures there.
    // (position, normal, area, flux, global VPL index or u32::MAX).
    let texels: Vec<(Vec3, Vec3, f32, Vec3, u32)> = if split.is_some() {
        let mut first = 0u32;
        let mut out = Vec::new();
        for (m, c) in every.maps.iter().zip(&every.clusters.maps) {
            let r = &m.rsm;
            for t in 0..r.flux.len() {
                if r.flux[t] != Vec3::ZERO && r.metric[t].is_finite() {
                    let v = c.texel_vpl.get(t).copied().unwrap_or(u32::MAX);
                    let g = if v == u32::MAX { v } else { first + v };
                    out.push((r.position[t], r.normal[t], r.area[t], r.flux[t], g));
                }
            }
            first += c.vpls.len() as u32;
        }
        out
    } else {
        Vec::new()
    };
    // The split's nodes (records of that level in each tree).
    let far_nodes = match split {
        Some(2) => 4..20,
        Some(3) => 20..84,
        _ => 0..4,
    };
    let split_px = std::sync::Mutex::new(Split::default());
    let every_px = std::sync::Mutex::new((DVec3::ZERO, DVec3::ZERO, PathStats::default()));
    let px: Vec<(Vec3, Vec3, DVec3)> = (0..size * size)
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % size, p / size);
            let (o, d, t0) = cam.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
            let Some(h) = rays.intersect_range(o, d, t0, f32::INFINITY) else {
                return (Vec3::ZERO, Vec3::ZERO, DVec3::ZERO);
            };
            let n = f64::from(side * side);
            // The receiver's albedo · mean, and the variance of that mean.
            let estimate = |s: Vec3, s2: DVec3| {
                let reference = h.albedo * s / (side * side) as f32;
                let mean = reference.as_dvec3();
                let var = ((s2 / n - mean * mean) * (n / (n - 1.0).max(1.0)) / n).max(DVec3::ZERO);
                (reference, var)
            };
            let (mut s, mut s2) = (Vec3::ZERO, DVec3::ZERO);
            let sq = |l: Vec3| (h.albedo * l).as_dvec3() * (h.albedo * l).as_dvec3();
            if every_bounce {
                let (mut e, mut e2) = (Vec3::ZERO, DVec3::ZERO);
                let mut stats = PathStats::default();
                crate::bounce::every_bounce_samples(&rays, &h, p, side, &mut stats, |_, l, le| {
                    s += l;
                    s2 += sq(l);
                    e += le;
                    e2 += sq(le);
                });
                let (every, var) = estimate(e, e2);
                let mut ep = every_px.lock().expect("no panics while held");
                ep.0 += every.as_dvec3();
                ep.1 += var;
                ep.2.paths += stats.paths;
                ep.2.bounces += stats.bounces;
                ep.2.capped += stats.capped;
            } else {
                crate::bounce::one_bounce_samples(&rays, &h, p, side, |_, l| {
                    s += l;
                    s2 += sq(l);
                });
            }
            let (reference, var_mean) = estimate(s, s2);
            let twin = twin_vpls.irradiance(&rays, &h);
            if split.is_some() {
                let (x, ns, ng) = (h.position, h.shading_normal, h.geometric_normal);
                let sum = |v: Vec3| f64::from(h.albedo.dot(v)) / f64::from(PI);
                let mut per_vpl = vec![0f64; records.len()];
                let mut all = 0f64;
                for &(p, n, a, f, g) in &texels {
                    let e = sum(crate::transport::disk_irradiance(p, n, a, f, x, ns, ng));
                    all += e;
                    if let Some(v) = per_vpl.get_mut(g as usize) {
                        *v += e;
                    }
                }
                let kept: f64 = per_vpl.iter().sum();
                let (mut far_c, mut far_t, mut far_o, mut far_n) = (0f64, 0f64, 0f64, 0f64);
                for (i, v) in records.iter().enumerate() {
                    let (origin, centre) = (twin_vpls.origins[i], twin_vpls.centres[i]);
                    let tree = twin_vpls.tree(i);
                    if !crate::transport::is_far(x, centre, v.area) {
                        continue;
                    }
                    let far = |o| {
                        sum(crate::transport::static_vpl_irradiance(
                            v,
                            o,
                            &[],
                            &twin_vpls.lobes[i],
                            x,
                            ns,
                            ng,
                        ))
                    };
                    far_c += far(centre);
                    far_o += far(origin);
                    for n in tree.get(far_nodes.clone()).unwrap_or(&[]) {
                        far_n += sum(crate::transport::node_irradiance(n, x, ns, ng));
                    }
                    far_t += per_vpl[i];
                }
                let mut sp = split_px.lock().expect("no panics while held");
                sp.clustered += sum(twin.unshadowed);
                sp.clustered_visible += sum(twin.visible);
                sp.texels += kept;
                sp.far_clustered += far_c;
                sp.far_texels += far_t;
                sp.far_from_origin += far_o;
                sp.far_nodes += far_n;
                sp.all_texels += all;
                sp.reference += f64::from(reference.x + reference.y + reference.z);
            }
            (reference, h.albedo / PI * twin.visible, var_mean)
        })
        .collect();
    let (mut sr, mut st, mut var) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    for (r, t, v) in &px {
        sr += r.as_dvec3();
        st += t.as_dvec3();
        var += *v;
    }
    // No bounce light in view on a channel: no bias to speak of (NaN).
    let bias = DVec3::select(sr.cmpgt(DVec3::ZERO), st / sr - 1.0, DVec3::NAN);
    let blur = |img: &dyn Fn(usize) -> Vec3, x: u32, y: u32| {
        let mut s = Vec3::ZERO;
        for dy in -1i32..=1 {
            for dx in -1i32..=1 {
                let xx = (x as i32 + dx).clamp(0, size as i32 - 1) as u32;
                let yy = (y as i32 + dy).clamp(0, size as i32 - 1) as u32;
                s += img((yy * size + xx) as usize);
            }
        }
        s / 9.0
    };
    let (mut num, mut den) = (0.0f64, 0.0f64);
    // (An image without bounce light has no relative error: NaN.)
    for y in 0..size {
        for x in 0..size {
            let r = blur(&|i| px[i].0, x, y);
            let t = blur(&|i| px[i].1, x, y);
            num += f64::from((t - r).length_squared());
            den += f64::from(r.length_squared());
        }
    }
    Judgement {
        every,
        per_light,
        bake_seconds,
        bias,
        blurred_error: if den > 0.0 {
            (num / den).sqrt()
        } else {
            f64::NAN
        },
        split: split.map(|_| split_px.into_inner().expect("no panics while held")),
        reference_sum: sr,
        bias_sigma: DVec3::select(sr.cmpgt(DVec3::ZERO), var.sqrt() / sr, DVec3::NAN),
        every_bounce: every_bounce.then(|| {
            let (se, var_e, stats) = every_px.into_inner().expect("no panics while held");
            let lit = se.cmpgt(DVec3::ZERO);
            EveryBounceJudgement {
                bias: DVec3::select(lit, st / se - 1.0, DVec3::NAN),
                ratio: DVec3::select(sr.cmpgt(DVec3::ZERO), se / sr, DVec3::NAN),
                reference_sum: se,
                bias_sigma: DVec3::select(lit, var_e.sqrt() / se, DVec3::NAN),
                stats,
            }
        }),
    }
}
