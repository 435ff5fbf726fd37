//! Which moving-object shadows the VPL-map merge may leave out: each
//! object's faintest, up to a share of its shadow
//! ([`crate::RenderSettings::merge_cull_share`]).
//!
//! Drawing a moving object into a VPL's map shadows that VPL's light
//! behind it. The light the shadow takes is at most the share of the VPL's
//! flux the object intercepts: for a Lambertian emitter and an object whose
//! bounding sphere (radius r, centre at distance d, direction at angle θ
//! from the map's normal) lies off the emitter, about `(r/d)² · cos θ`
//! ([`intercepted`]). A VPL across a level from a small object loses a
//! ten-thousandth of its light to it; the VPL beside it, a third. Per
//! moving draw, the merge sorts the maps it reaches by that light — the
//! VPL's flux (luminance) times the share — and leaves out the faintest
//! while their sum stays within the setting's share of the light the draw
//! takes from all of them: its shadow, summed over every VPL, keeps at
//! least the rest. A budget over the whole level's light would not do:
//! the far VPLs' shadows of one object overlap right behind it, and
//! leaving out 0.3% of the level's light took a fifth of a ball's shadow
//! on the wall behind it. As an object moves, a pair near the bound comes
//! and goes with a change in the image no larger than its own light
//! (measured in docs/method.md, "The VPL-map merge" → "Faint shadows left
//! out").

use std::cmp::Ordering;

use gibake_scene::Aabb;
use glam::Vec3;

/// The bounding sphere of `b` seen from `origin` (unit `normal`): its
/// centre's squared distance `d²` and the cosine to it widened by the
/// sphere's half-angle `r/d`, clamped to [0, 1]; `None` where the origin
/// lies inside the sphere.
fn seen_sphere(origin: Vec3, normal: Vec3, b: &Aabb) -> Option<(f32, f32, f32)> {
    let to = (b.min + b.max) * 0.5 - origin;
    let r = (b.max - b.min).length() * 0.5;
    let d2 = to.length_squared();
    if d2.partial_cmp(&(r * r)) != Some(Ordering::Greater) {
        return None;
    }
    let d = d2.sqrt();
    let s = r / d;
    Some((d2, s, (normal.dot(to / d) + s).clamp(0.0, 1.0)))
}

/// The share of a Lambertian emitter's flux at `origin` with unit normal
/// `normal` that an object bounded by `b` intercepts at most: `(r/d)²
/// · cos θ` for its bounding sphere (radius r, centre at distance d), the
/// cosine widened by the sphere's half-angle and clamped to [0, 1]; 1
/// where the origin lies inside the sphere.
pub(crate) fn intercepted(origin: Vec3, normal: Vec3, b: &Aabb) -> f32 {
    match seen_sphere(origin, normal, b) {
        Some((_, s, cos)) => {
            let f = s * s * cos;
            if f.is_finite() { f.min(1.0) } else { 1.0 }
        }
        None => 1.0,
    }
}

/// The share of a Lambertian emitter's flux at `origin` (unit `normal`)
/// that an object of surface `area` (world units², convex: its mean
/// projected area is a quarter of it) within `b` takes, on average over
/// its orientations: `(area/4) / (π d²) · cos θ`, d and θ as in
/// [`intercepted`], and at most that. Exact for a ball; what the later
/// bounces lose to a moving object ([`crate::later_absorb`]), where the
/// bounding sphere — three times a ball's cross-section for its box —
/// would count too much.
pub fn intercepted_by_area(origin: Vec3, normal: Vec3, b: &Aabb, area: f32) -> f32 {
    let bound = intercepted(origin, normal, b);
    match seen_sphere(origin, normal, b) {
        Some((d2, _, cos)) => {
            let f = area.max(0.0) * 0.25 / (std::f32::consts::PI * d2) * cos;
            if f.is_finite() { f.min(bound) } else { bound }
        }
        None => bound,
    }
}

/// Leaves out of `masks` (per map, per draw: the faces drawn) each draw's
/// faintest (map, draw) pairs while the light they take, in all, stays
/// within `share` of the light that draw intercepts from every map it
/// reaches: its shadow, summed over the VPLs, loses at most that share,
/// wherever the left-out shadows fall (behind the object, from many far
/// VPLs at once). `weight[v]`: map `v`'s VPL flux (luminance);
/// `frames[v]`: its origin and normal. Returns the pairs left out. Ties
/// are broken by map, so the choice is the same every run.
pub(crate) fn leave_out_faint(
    masks: &mut [Vec<u32>],
    frames: &[Option<(Vec3, Vec3)>],
    weight: &[f32],
    boxes: &[Aabb],
    share: f32,
) -> u32 {
    if share.partial_cmp(&0.0) != Some(Ordering::Greater) {
        return 0;
    }
    let mut out = 0;
    let mut pairs: Vec<(f32, usize)> = Vec::new();
    for (k, b) in boxes.iter().enumerate() {
        pairs.clear();
        for (v, m) in masks.iter().enumerate() {
            let Some((o, n)) = frames[v] else { continue };
            if m.get(k).is_some_and(|&faces| faces != 0) {
                let w = weight.get(v).copied().unwrap_or(f32::INFINITY);
                let e = w * intercepted(o, n, b);
                pairs.push((if e.is_finite() { e } else { f32::INFINITY }, v));
            }
        }
        let total: f32 = pairs.iter().map(|p| p.0).sum();
        let budget = share * total;
        if !(budget > 0.0 && budget.is_finite()) {
            continue;
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let mut spent = 0.0f32;
        for &(e, v) in &pairs {
            if (spent + e).partial_cmp(&budget) == Some(Ordering::Greater) {
                break;
            }
            spent += e;
            masks[v][k] = 0;
            out += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(c: Vec3, h: f32) -> Aabb {
        Aabb {
            min: c - Vec3::splat(h),
            max: c + Vec3::splat(h),
        }
    }

    /// The intercepted share falls with the square of the distance, is
    /// the same at every scale, and is whole inside the object.
    #[test]
    fn intercepted_share_follows_the_solid_angle_at_every_scale() {
        let n = Vec3::Y;
        for s in [1e-3f32, 1.0, 1e3] {
            let near = intercepted(Vec3::ZERO, n, &cube(Vec3::Y * 4.0 * s, s));
            let far = intercepted(Vec3::ZERO, n, &cube(Vec3::Y * 40.0 * s, s));
            assert!((near / far - 100.0).abs() < 12.0, "{near} {far}");
            assert!((0.0..=1.0).contains(&near), "{near}");
            assert_eq!(intercepted(Vec3::ZERO, n, &cube(Vec3::ZERO, s)), 1.0);
            // Beside the emitter's plane: its cosine, widened by the
            // half-angle, not zero.
            let side = intercepted(Vec3::ZERO, n, &cube(Vec3::X * 4.0 * s, s));
            assert!(side > 0.0 && side < near, "{side} {near}");
        }
    }

    /// A ball's share by its area is its cross-section's, a third of its
    /// box's bounding sphere's, and never more than that bound.
    #[test]
    fn a_balls_share_by_area_is_its_cross_section() {
        let n = Vec3::Y;
        for s in [1e-3f32, 1.0, 1e3] {
            let r = s;
            let area = 4.0 * std::f32::consts::PI * r * r;
            let b = cube(Vec3::Y * 20.0 * s, r);
            let f = intercepted_by_area(Vec3::ZERO, n, &b, area);
            let exact = (r / (20.0 * s)).powi(2);
            assert!((f / exact - 1.0).abs() < 0.06, "{f} {exact}");
            let bound = intercepted(Vec3::ZERO, n, &b);
            assert!(f <= bound && bound / f > 2.5, "{f} {bound}");
            assert_eq!(
                intercepted_by_area(Vec3::ZERO, n, &cube(Vec3::ZERO, r), area),
                1.0
            );
        }
    }

    /// Each draw's faintest pairs go first, never more of its light than
    /// the share, and nothing at share 0.
    #[test]
    fn the_faintest_pairs_go_within_the_budget() {
        let frames = vec![Some((Vec3::ZERO, Vec3::Y)), Some((Vec3::X * 50.0, Vec3::Y))];
        let weight = [1.0, 1.0];
        let boxes = [
            cube(Vec3::Y * 2.0, 0.5),
            cube(Vec3::new(50.0, 30.0, 0.0), 0.5),
        ];
        // Map 0 sees object 0 near (bright) and object 1 far; map 1 sees
        // object 1 far and object 0 far.
        let all = vec![vec![1, 1], vec![1, 1]];
        let mut m = all.clone();
        assert_eq!(leave_out_faint(&mut m, &frames, &weight, &boxes, 0.0), 0);
        assert_eq!(m, all);
        let e: Vec<Vec<f32>> = (0..2)
            .map(|v| {
                (0..2)
                    .map(|k| weight[v] * intercepted(frames[v].unwrap().0, Vec3::Y, &boxes[k]))
                    .collect()
            })
            .collect();
        let share = 0.05;
        let out = leave_out_faint(&mut m, &frames, &weight, &boxes, share);
        assert!(out > 0, "{e:?}");
        // Per draw, what went is within the share of that draw's light.
        for k in 0..2 {
            let total: f32 = (0..2).map(|v| e[v][k]).sum();
            let spent: f32 = (0..2).filter(|&v| m[v][k] == 0).map(|v| e[v][k]).sum();
            assert!(spent <= share * total, "draw {k}: {spent} of {total}");
        }
        // The near, bright pair stays.
        assert_eq!(m[0][0], 1, "{e:?}");
        // Per draw, whatever stays is at least as bright as whatever went.
        for k in 0..2 {
            let kept = (0..2).filter(|&v| m[v][k] != 0).map(|v| e[v][k]);
            let gone = (0..2).filter(|&v| m[v][k] == 0).map(|v| e[v][k]);
            assert!(
                gone.fold(0.0, f32::max) <= kept.fold(f32::INFINITY, f32::min),
                "{e:?} {m:?}"
            );
        }
    }
}
