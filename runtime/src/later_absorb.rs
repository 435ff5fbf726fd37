//! What moving objects take from the later bounces (issue 50, item 2).
//!
//! The later bounces' VPLs carry the static scene's light after the first
//! bounce, solved at bake time without the moving objects. In the frame, a
//! moving object stands in the way of some of every bounce: the share of a
//! VPL's light it intercepts ([`crate::merge_cull::intercepted_by_area`],
//! a quarter of its surface seen from the VPL, for the maps it reaches
//! that their baked surfaces do not hide) no longer lands
//! on the static surfaces, and of that the object keeps `1 − albedo` (per
//! channel): `l_v = min(1, Σ_k I_vk (1 − ρ_k))` for VPL `v`. By
//! reciprocity a later VPL loses `l_v` of the light coming in as well, and
//! the light reaching it in the transfers before came from the surfaces
//! round it, which see much of what it sees; so each transfer into the
//! light it passes on loses its own `l_v` ([`local_keep`]). The light
//! reflected after bounce `j` of the bake's series (`LaterRecord::
//! per_bounce`, `P_j`, the later VPLs' flux in all) has passed `j + 1`
//! transfers, so each later VPL's flux is scaled each frame, per channel,
//! by
//!
//!   k_v = (1 − l_v) Σ_j P_j (1 − l_v)^j / Σ_j P_j
//!
//! (the series' tail as a geometric rest), written per later VPL after the
//! occluded shares in the occlusion buffer shading reads. Where no
//! occlusion buffer exists (no RSM for the primary light), one factor for
//! all: the level's flux-weighted means `a₁` (over the first bounce's
//! VPLs) and `a₂` (the later ones'), `(1 − a₂) Σ_j P_j (1 − a₁)^[j≥1]
//! (1 − a₂)^max(j−1, 0) / Σ_j P_j` ([`later_scale`]). First order: where
//! the light is lost does not move the later light beyond a VPL's own
//! neighbourhood (as `later_occlusion.wgsl` for objects that block the
//! lights), and what the object reflects goes on as if a static surface
//! had. Measured in docs/method.md, "Moving objects and the later
//! bounces".

use glam::Vec3;

/// What the moving objects absorb of the later bounces this frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Absorbed {
    /// The share of the first bounce's light (its VPLs' flux-weighted
    /// mean) they absorb on its way to the surfaces, per channel.
    pub first: Vec3,
    /// The same for the later bounces' light.
    pub later: Vec3,
    /// Per later VPL: the share of the light reaching it that the objects
    /// its map sees absorb (`min(1, Σ_k I_vk (1 − ρ_k))`: by reciprocity,
    /// what they take of its light going out they take of the light
    /// coming in).
    pub local: Vec<Vec3>,
    /// Per later VPL: its weight in the means (the channel sum of its
    /// flux), for the flux-weighted mean `FrameStats` reports.
    pub local_weight: Vec<f32>,
}

/// What the moving draws absorb (see [`Absorbed`]): over the maps `v <
/// first_later` (the first bounce's VPLs) and the later VPLs' maps
/// `first_later ≤ v < n_static` (`masks` lists every frame, the second
/// maps after the first, and only the first maps count: a second map is
/// the same VPL's light below its horizon). `masks[v][k]`: whether draw
/// `k` reaches map `v` (not hidden by its baked surfaces); `share(v, k)`
/// the share of map `v`'s VPL's light draw `k` intercepts; `albedo[k]` the
/// draw's mean albedo (`None`: not a moving draw).
pub(crate) fn absorbed(
    masks: &[Vec<u32>],
    weight: &[f32],
    (first_later, n_static): (usize, usize),
    albedo: &[Option<Vec3>],
    share: impl Fn(usize, usize) -> f32,
) -> Absorbed {
    let mut sums = [(Vec3::ZERO, 0.0f32); 2];
    let mut local = Vec::with_capacity(n_static.saturating_sub(first_later));
    let mut local_weight = Vec::with_capacity(n_static.saturating_sub(first_later));
    for v in 0..n_static.min(masks.len()) {
        let mut lost = Vec3::ZERO;
        for (k, &faces) in masks[v].iter().enumerate() {
            if let (true, Some(Some(rho))) = (faces != 0, albedo.get(k)) {
                let f = share(v, k);
                if f.is_finite() {
                    lost += f.clamp(0.0, 1.0) * (Vec3::ONE - rho.clamp(Vec3::ZERO, Vec3::ONE));
                }
            }
        }
        let lost = lost.min(Vec3::ONE);
        let w = weight.get(v).copied().unwrap_or(0.0);
        if v >= first_later {
            local.push(lost);
            local_weight.push(if w.is_finite() { w.max(0.0) } else { 0.0 });
        }
        if w > 0.0 && w.is_finite() {
            let s = &mut sums[usize::from(v >= first_later)];
            s.0 += w * lost;
            s.1 += w;
        }
    }
    local.resize(n_static.saturating_sub(first_later), Vec3::ZERO);
    local_weight.resize(n_static.saturating_sub(first_later), 0.0);
    let mean = |(l, w): (Vec3, f32)| if w > 0.0 { l / w } else { Vec3::ZERO };
    Absorbed {
        first: mean(sums[0]),
        later: mean(sums[1]),
        local,
        local_weight,
    }
}

/// A later VPL's flux scale where every transfer into the light it passes
/// on loses `l`, its own loss (the objects its map sees): the light
/// reaching it in each transfer came from the surfaces round it, which
/// see much of what it sees (first order: local), so a room with the
/// objects loses more than the level's mean and a room without them
/// less. `(1 − l) · later_scale(per_bounce, tail, l, l)`. Measured against
/// the level-wide means (docs/method.md, "What moving objects absorb"):
/// the grid of rooms with its blue spheres +16.5 → +8.7% red.
pub fn local_keep(per_bounce: &[[f32; 3]], tail: [f32; 3], l: Vec3) -> Vec3 {
    let l = l.clamp(Vec3::ZERO, Vec3::ONE);
    (Vec3::ONE - l) * later_scale(per_bounce, tail, l, l)
}

/// `Σ w k / Σ w` (1 where the weights sum to nothing).
pub(crate) fn weighted_mean(k: &[Vec3], w: &[f32]) -> Vec3 {
    let (mut sum, mut total) = (Vec3::ZERO, 0.0f32);
    for (k, &w) in k.iter().zip(w) {
        sum += *k * w;
        total += w;
    }
    if total > 0.0 && (sum / total).is_finite() {
        sum / total
    } else {
        Vec3::ONE
    }
}

/// The later VPLs' flux scale, per channel, for the transfers before the
/// last one into each later VPL (that one is its own, [`Absorbed::local`]):
/// the light after bounce `j` of the bake's series (`per_bounce`, `P_j`,
/// and the geometric rest `tail`) has passed `j + 1` transfers, the first
/// from the first bounce's VPLs (`a1` lost), the others between later
/// bounces (`a2`), the last into the VPL itself:
/// `Σ_j P_j (1 − a1)^[j≥1] (1 − a2)^max(j−1, 0) / Σ_j P_j`; 1 where
/// nothing is lost or nothing was reflected.
pub fn later_scale(per_bounce: &[[f32; 3]], tail: [f32; 3], a1: Vec3, a2: Vec3) -> Vec3 {
    let keep1 = (Vec3::ONE - a1).clamp(Vec3::ZERO, Vec3::ONE);
    let keep2 = (Vec3::ONE - a2).clamp(Vec3::ZERO, Vec3::ONE);
    let mut num = Vec3::ZERO;
    let mut den = Vec3::ZERO;
    let mut factor = Vec3::ONE;
    for (j, p) in per_bounce.iter().enumerate() {
        let p = Vec3::from_array(*p).max(Vec3::ZERO);
        num += p * factor;
        den += p;
        factor *= if j == 0 { keep1 } else { keep2 };
    }
    // The rest of the series, ratio r from its last two bounces: Σ_i (1 −
    // r) rⁱ keep2^i of it, times the factor reached.
    let tail = Vec3::from_array(tail).max(Vec3::ZERO);
    let r = match per_bounce {
        [.., a, b] => {
            let (a, b) = (Vec3::from_array(*a), Vec3::from_array(*b));
            Vec3::select(a.cmpgt(Vec3::ZERO), b / a, Vec3::ZERO)
                .clamp(Vec3::ZERO, Vec3::splat(0.999))
        }
        _ => Vec3::ZERO,
    };
    num += tail * factor * (Vec3::ONE - r) / (Vec3::ONE - r * keep2);
    den += tail;
    let s = Vec3::select(den.cmpgt(Vec3::ZERO), num / den, Vec3::ONE);
    if s.is_finite() {
        s.clamp(Vec3::ZERO, Vec3::ONE)
    } else {
        Vec3::ONE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Nothing absorbed: scale 1; a black object intercepting a fifth of
    /// every transfer: the light after bounce 1 keeps 0.8 before its last
    /// transfer (each VPL's own), after bounce 2 0.64, ….
    #[test]
    fn the_scale_follows_the_series() {
        let pb = [[1.0, 1.0, 1.0], [0.5, 0.5, 0.5], [0.25, 0.25, 0.25]];
        assert_eq!(
            later_scale(&pb, [0.0; 3], Vec3::ZERO, Vec3::ZERO),
            Vec3::ONE
        );
        let a = Vec3::splat(0.2);
        let s = later_scale(&pb, [0.0; 3], a, a);
        // The last transfer is each VPL's own: P_0 untouched here.
        let want = (1.0 + 0.5 * 0.8 + 0.25 * 0.64) / 1.75;
        assert!((s - Vec3::splat(want)).abs().max_element() < 1e-6, "{s}");
        // A tail continuing the series: each further bounce loses more.
        let t = later_scale(&pb, [0.25, 0.25, 0.25], a, a);
        assert!(t.x < s.x && t.x > 0.0, "{t} {s}");
        assert_eq!(later_scale(&[], [0.0; 3], a, a), Vec3::ONE);
    }

    /// The loss per transfer is the flux-weighted mean of what each VPL's
    /// map loses to the objects, per channel by their albedo; hidden
    /// objects (mask 0) take nothing.
    #[test]
    fn the_loss_is_flux_weighted_and_coloured() {
        // Two first-bounce VPLs (weights 1 and 3), one later VPL.
        let masks = vec![vec![1], vec![0], vec![1]];
        let weight = [1.0, 3.0, 2.0];
        let blue = [Some(Vec3::new(0.0, 0.5, 1.0))];
        let a = absorbed(&masks, &weight, (2, 3), &blue, |_, _| 0.4);
        // Only VPL 0 sees the object: 0.4 of its light, of which the
        // object keeps 1, 0.5, 0 per channel; weighted 1 of 4.
        let near = |x: Vec3, y: Vec3| (x - y).abs().max_element() < 1e-6;
        assert!(near(a.first, Vec3::new(0.1, 0.05, 0.0)), "{a:?}");
        assert!(near(a.later, Vec3::new(0.4, 0.2, 0.0)), "{a:?}");
        // The later VPL's own share of the light reaching it.
        assert_eq!(a.local.len(), 1);
        assert!(near(a.local[0], Vec3::new(0.4, 0.2, 0.0)), "{a:?}");
        // A static draw (no albedo given) takes nothing.
        let b = absorbed(&masks, &weight, (2, 3), &[None], |_, _| 0.4);
        assert_eq!(b.first, Vec3::ZERO);
        assert_eq!(b.local, vec![Vec3::ZERO]);
    }

    /// A VPL that sees the objects loses its own share at every transfer:
    /// more than one transfer's worth, less than all; none lost, none kept
    /// back; the flux-weighted mean weighs by flux.
    #[test]
    fn a_vpl_loses_its_own_share_at_every_transfer() {
        let series = [[1.0, 1.0, 1.0], [0.5, 0.5, 0.5]];
        let tail = [0.5, 0.5, 0.5];
        assert_eq!(local_keep(&series, tail, Vec3::ZERO), Vec3::ONE);
        let k = local_keep(&series, tail, Vec3::new(0.2, 0.0, 1.0));
        assert!(k.x < 0.8 && k.x > 0.8 * 0.8 * 0.8, "{k}");
        assert_eq!(k.y, 1.0);
        assert_eq!(k.z, 0.0);
        let m = weighted_mean(&[Vec3::ONE, Vec3::ZERO], &[3.0, 1.0]);
        assert!((m - Vec3::splat(0.75)).length() < 1e-6, "{m}");
        assert_eq!(weighted_mean(&[], &[]), Vec3::ONE);
    }
}
