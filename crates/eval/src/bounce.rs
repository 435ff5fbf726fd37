//! The diagnostics' one-bounce estimator (`vpl_diag`, `rsm_ceiling`): at a
//! receiver, stratified cosine-distributed directions about its shading
//! normal, each secondary hit's direct radiance from the reference
//! (`gibake_reference::direct_radiance`). Deterministic: the jitter is a
//! hash of the receiver's index and the sample's.

use gibake_reference::{Hit, RayScene};
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
                let radiance = gibake_reference::direct_radiance(rays, &y);
                visit(&y, radiance);
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
