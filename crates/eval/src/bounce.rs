//! The diagnostics' one-bounce estimator (`vpl_diag`, `rsm_ceiling`,
//! `band_sources`, [`crate::lights`]): at a receiver, stratified
//! cosine-distributed directions about its shading normal, each secondary
//! hit's direct radiance from the reference
//! (`gibake_reference::direct_radiance`); and its every-bounce twin
//! ([`every_bounce_samples`]: the same directions, each secondary hit's
//! radiance with every bounce, one reference path from it).
//! Deterministic: the jitter is a hash of the receiver's index and the
//! sample's. And the kernel those diagnostics give one RSM texel as its
//! own point VPL ([`texel_kernel`]).

use gibake_reference::{Hit, RayScene, View};
use glam::Vec3;
use std::f32::consts::PI;

/// Calls `visit(secondary hit, its direct radiance)` for each of the
/// `side × side` stratified cosine samples above receiver `h` (index
/// `seed`) that hit a surface; a sample below the geometric plane or
/// escaping calls nothing. Each sample weighs `1 / side²`: the one-bounce
/// radiance is `albedo · Σ radiance / side²`.
pub fn one_bounce_samples(
    rays: &RayScene<'_>,
    h: &Hit,
    seed: u32,
    side: u32,
    mut visit: impl FnMut(&Hit, Vec3),
) {
    secondary_hits(rays, h, seed, side, |y, _| {
        let radiance = gibake_reference::direct_radiance(rays, y);
        visit(y, radiance);
    });
}

/// [`one_bounce_samples`] with every bounce: the same directions and
/// secondary hits, and `visit(secondary hit, its direct radiance, its
/// radiance with every bounce)`, the last one reference path from the hit
/// ([`gibake_reference::hit_radiance`], [`gibake_reference::Depth::Every`],
/// seeded from the receiver's and the sample's index; `stats` adds what
/// the paths did). The every-bounce indirect radiance at the receiver is
/// `albedo · Σ every / side²`.
pub fn every_bounce_samples(
    rays: &RayScene<'_>,
    h: &Hit,
    seed: u32,
    side: u32,
    stats: &mut gibake_reference::PathStats,
    mut visit: impl FnMut(&Hit, Vec3, Vec3),
) {
    secondary_hits(rays, h, seed, side, |y, k| {
        let direct = gibake_reference::direct_radiance(rays, y);
        let path_seed = u64::from(seed) << 32 | u64::from(k);
        let every = gibake_reference::hit_radiance(
            rays,
            y,
            gibake_reference::Depth::Every,
            path_seed,
            stats,
        );
        visit(y, direct, every);
    });
}

/// Calls `visit(secondary hit, sample index)` for the stratified cosine
/// samples of [`one_bounce_samples`] that hit a surface.
fn secondary_hits(
    rays: &RayScene<'_>,
    h: &Hit,
    seed: u32,
    side: u32,
    mut visit: impl FnMut(&Hit, u32),
) {
    let (t, b) = gibake_gpu::orthonormal_basis(h.shading_normal);
    let origin = rays.offset_point(h.position, h.geometric_normal);
    for i in 0..side {
        for j in 0..side {
            let u1 = (i as f32 + hash(seed, i * side + j, 0)) / side as f32;
            let u2 = (j as f32 + hash(seed, i * side + j, 1)) / side as f32;
            let r = u1.sqrt();
            let phi = 2.0 * PI * u2;
            let dir = t * (r * phi.cos())
                + b * (r * phi.sin())
                + h.shading_normal * (1.0 - u1).max(0.0).sqrt();
            if h.geometric_normal.dot(dir) <= 0.0 {
                continue;
            }
            if let Some(y) = rays.intersect(origin, dir, f32::INFINITY) {
                visit(&y, i * side + j);
            }
        }
    }
}

/// A uniform number in `[0, 1)` from `(p, i, c)` (SplitMix64 finaliser).
pub fn hash(p: u32, i: u32, c: u32) -> f32 {
    let mut z = (p as u64) << 32 | (i as u64) << 2 | c as u64;
    z = z.wrapping_add(0x9e3779b97f4a7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}

/// The transport from one RSM texel, as its own point VPL, to a receiver,
/// per unit flux and before the receiver's albedo and any visibility.
#[derive(Clone, Copy, Debug)]
pub struct TexelKernel {
    /// `cos θ_v · cos θ_r / (π · √(d⁴ + (A/π)²))`: the runtime's bounded
    /// disk kernel (shade.wgsl `vpl_lobe_irradiance` at coherence 1).
    pub bounded: f32,
    /// `cos θ_v · cos θ_r / (π · d²)`: the unbounded point kernel.
    pub point: f32,
}

/// [`TexelKernel`] from a texel at `p` emitting about `n` (the RSM's
/// geometric normal) with area `area` to the receiver `h` (its shading
/// normal's cosine, cut below its geometric plane); `None` where either
/// faces away or the two coincide.
pub fn texel_kernel(p: Vec3, n: Vec3, area: f32, h: &Hit) -> Option<TexelKernel> {
    let dv = h.position - p;
    let d2 = dv.length_squared();
    if d2 <= 0.0 {
        return None;
    }
    let dir = dv / d2.sqrt();
    let (cv, cr) = (n.dot(dir), h.shading_normal.dot(-dir));
    if cv <= 0.0 || cr <= 0.0 || h.geometric_normal.dot(-dir) <= 0.0 {
        return None;
    }
    let g = cv * cr / PI;
    let r2 = area / PI;
    Some(TexelKernel {
        bounded: g / (d2 * d2 + r2 * r2).sqrt(),
        point: g / d2,
    })
}

/// What the centre of pixel `p` (row-major) of a `size × size` image of
/// `cam` sees: the diagnostics' receivers.
pub fn pixel_hit(rays: &RayScene<'_>, cam: &View, size: u32, p: u32) -> Option<Hit> {
    let (x, y) = (p % size, p / size);
    let (o, d, t0) = cam.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
    rays.intersect_range(o, d, t0, f32::INFINITY)
}

/// The RSM of every view of every light of `scene` at `rsm_size`² (a
/// level's one view for its one light), rendered against `rays` (its
/// static part) as the bake renders them, without reach.
pub fn every_view_rsm(
    scene: &gibake_scene::Scene,
    rays: &RayScene<'_>,
    rsm_size: u32,
) -> Vec<(gibake_gpu::LightView, gibake_bake::rsm::Rsm)> {
    scene
        .lights
        .iter()
        .flat_map(|light| {
            gibake_gpu::LightView::of_light(scene, light, 2048)
                .into_iter()
                .map(|v| {
                    let v = v.resized(rsm_size);
                    (v, gibake_bake::rsm::render_rsm(rays, light, &v, None))
                })
                .collect::<Vec<_>>()
        })
        .collect()
}
