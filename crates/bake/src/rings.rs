//! Outer rings: the ground beyond a directional light's fitted view.
//!
//! When a level stands on a ground many times its size, the sun's view is
//! fitted to the detailed part ([`gibake_gpu::light_fit`]) and cuts the
//! ground a quarter of that part's size beyond it. The ground outside
//! reflects no VPL light, yet the sides of objects near the cut get much of
//! their bounce from it: on the Blenvy level the sun's bounce on the
//! receivers that carry most of the indirect light was 5.8% short, and the
//! frame's indirect light 6% (docs/results.md, "Every light").
//!
//! An outer ring is a view of that ground as shadow cascades are: ring `j`
//! is the view's own square `2^j` times as wide ([`LightFit::ring_box`]),
//! its RSM at the view's resolution (so its texels are `2^j` times as
//! wide), with the part the next smaller square covers left empty: each
//! point of the ground is in exactly one of the view and its rings. Rings
//! are made until they cover every static surface across the light, at
//! most [`gibake_gpu::light_fit::MAX_RINGS`] ([`LightFit::rings`]), only
//! where the cut outliers are a ground.
//!
//! A ring's RSM is clustered with every other view under the one budget
//! (`cluster_joint`): its texels' light mostly goes to the sky, so by their
//! reaching flux a ring gets few, wide VPLs (a sixteenth of a ring each on
//! a town: 134 m squares). Two things about such a VPL are set apart from
//! a view's:
//!
//! - **Its map origin is lifted by one of its texels' radius**, not a fifth
//!   of its own ([`gibake_asset::VplRecord::map_origin_area`]): the patch
//!   is flat ground, and 15 m up its origin looked over the houses and
//!   hills its texels cannot see past. The asset says which VPLs lie on
//!   rings ([`gibake_asset::Manifest::ring_vpls`]).
//! - **It is seen from its inner edge**: its anchor (the record's position,
//!   where its map is centred) is its lit texel nearest the ring's centre
//!   ([`anchor_near_centre`]), not the one nearest its centroid. Its light
//!   reaches the view's receivers mostly from the part nearest them, and
//!   from a hillside the foot of the hill is hidden where ground 100 m
//!   farther out is not. Its transport (near-field tree, far-field centre)
//!   is still its texels'.
//!
//! Measured on the CPU twin (`lights_twin town --split`, "visibility from
//! one point per VPL": the clustered light's visible share against the
//! reference's; docs/method.md, "Outer rings"): +0.6% on the town without
//! rings; with them +5.8% from origins lifted by a fifth of their radius
//! at the texel nearest their centroid, +4.5% lifted by one texel, +2.7%
//! lifted by one texel at their inner edge (built). The rings' direct
//! light is not shadowed (outside every shadow map, as before).

use gibake_gpu::LightView;
use gibake_gpu::light_fit::LightFit;
use gibake_scene::{Light, LightKind, Scene};

use crate::cluster::{Clustering, NO_VPL};
use crate::reach::Reach;
use crate::rsm::{Rsm, render_rsm_masked};

/// The fit of `light`'s view when it has outer rings (a directional light
/// whose view cut a ground, [`LightFit::rings`] > 0).
pub fn ring_fit(scene: &Scene, light: &Light) -> Option<LightFit> {
    if !matches!(light.kind, LightKind::Directional) {
        return None;
    }
    gibake_gpu::light_fit::fit_light(scene, light).filter(|f| f.rings() > 0)
}

/// Whether any light of `scene` has outer rings.
pub fn any_rings(scene: &Scene) -> bool {
    scene.lights.iter().any(|l| ring_fit(scene, l).is_some())
}

/// Whether texel `(x, y)` of a `size²` ring lies inside the next smaller
/// square (its middle half on each axis), by its centre.
pub fn inside_smaller(x: u32, y: u32, size: u32) -> bool {
    let n = size as f32;
    let inside = |c: u32| {
        let t = c as f32 + 0.5;
        t >= 0.25 * n && t < 0.75 * n
    };
    inside(x) && inside(y)
}

/// Moves each VPL of a ring's clustering to its lit texel nearest the
/// ring's centre ([`anchor_texel`]): its inner edge, where the light its
/// texels send the view's receivers mostly comes from, and where its map
/// sees from (module docs). The flux, normal, area and near-field tree
/// stay its texels'.
pub fn anchor_near_centre(rsm: &Rsm, clustering: &mut Clustering) {
    let mut texels = vec![Vec::new(); clustering.vpls.len()];
    for (t, &v) in clustering.texel_vpl.iter().enumerate() {
        if v != NO_VPL {
            texels[v as usize].push(t);
        }
    }
    for (v, texels) in clustering.vpls.iter_mut().zip(&texels) {
        if let Some(t) = anchor_texel(rsm, texels) {
            v.anchor = rsm.position[t];
        }
    }
}

/// Of a ring VPL's lit `texels` (row-major), the one nearest the ring's
/// centre: the largest of its two texel offsets from the centre smallest,
/// the first on a tie. `None` for no texel.
pub fn anchor_texel(rsm: &Rsm, texels: &[usize]) -> Option<usize> {
    let n = rsm.size as f32;
    let mut best = (f32::INFINITY, None);
    for &t in texels {
        let (x, y) = (
            (t as u32 % rsm.size) as f32 + 0.5,
            (t as u32 / rsm.size) as f32 + 0.5,
        );
        let d = (x - 0.5 * n).abs().max((y - 0.5 * n).abs());
        if d < best.0 {
            best = (d, Some(t));
        }
    }
    best.1.filter(|&t| t < rsm.position.len())
}

/// The RSMs of the outer rings of `light` (fitted as `fit`), ring 1 first,
/// each `size²` (the view's own RSM resolution), with reach measured as the
/// views' are. `shadow_map_size` is the view's (its texel scale is rescaled
/// to `size`, as every view's RSM is).
pub fn ring_rsms(
    reach: &Reach<'_, '_>,
    light: &Light,
    fit: &LightFit,
    size: u32,
    shadow_map_size: u32,
) -> Vec<Rsm> {
    let dir = light.direction.normalize();
    (1..=fit.rings())
        .map(|j| {
            let (lo, hi) = fit.ring_box(j);
            let view = LightView::directional(dir, lo, hi, shadow_map_size).resized(size);
            render_rsm_masked(reach.rays, light, &view, Some(reach), &|x, y| {
                inside_smaller(x, y, size)
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_middle_half_is_inside_and_nothing_else() {
        for size in [8u32, 64, 100, 512] {
            let inside = (0..size * size)
                .filter(|k| inside_smaller(k % size, k / size, size))
                .count() as u32;
            // The middle half per axis: a quarter of the texels (exactly
            // when size is a multiple of 4).
            let half = (0..size)
                .filter(|&x| inside_smaller(x, size / 2, size))
                .count() as u32;
            assert_eq!(inside, half * half);
            if size % 4 == 0 {
                assert_eq!(half, size / 2);
            }
            assert!(!inside_smaller(0, size / 2, size));
            assert!(!inside_smaller(size - 1, size / 2, size));
        }
    }
}
