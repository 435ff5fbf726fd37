//! Surfels: sample points on both sides of the static surfaces, where the
//! bake gathers the light of the bounces after the first.
//!
//! Placed by area: each static triangle gets `area · d` points on average
//! (systematic sampling along the triangles' order from a fixed offset, so
//! the same scene always gives the same points and a run of small
//! triangles its own count to within one), each standing for `1/d` of
//! area where its triangle is smaller than that, else for its triangle's
//! area over its points; at most [`MAX_TRIANGLE_SHARE`] of all of them (a 400 m ground plane in
//! two triangles does not take the level's samples), each point one surfel
//! per side of the triangle that a ray from that side finds (a hole an
//! alpha mask cuts has none). Positions inside a triangle follow the R2
//! sequence from a hashed start. The density `d` is solved for the target
//! count; nothing depends on the scene's units.

use gibake_raycast::RayScene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::reach::mix;

/// No triangle takes more than this share of the points.
pub const MAX_TRIANGLE_SHARE: f64 = 1.0 / 64.0;

/// Points on the static surfaces, one entry per side that sees out.
#[derive(Clone, Debug, Default)]
pub struct Surfels {
    /// World position on the surface.
    pub position: Vec<Vec3>,
    /// Unit geometric normal on the surfel's side.
    pub normal: Vec<Vec3>,
    /// Unit shading normal on that side (its irradiance's cosine).
    pub shading: Vec<Vec3>,
    /// Surface area the surfel stands for.
    pub area: Vec<f32>,
    /// Lambertian albedo there.
    pub albedo: Vec<Vec3>,
    /// Typical distance between neighbouring surfels, `√(1/d)`.
    pub spacing: f32,
}

impl Surfels {
    /// Number of surfels.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }
}

/// A uniform number in `[0, 1)` from a 64-bit key.
pub(crate) fn unit(key: u64) -> f64 {
    (mix(key) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// About `2 · points` surfels (a point's two sides) on `rays`' static
/// triangles (see the module docs).
pub fn place(rays: &RayScene<'_>, points: u32) -> Surfels {
    let scene = rays.scene();
    // World-space triangles in `meshes_at` order (the ray caster's ids).
    let mut tris: Vec<[DVec3; 3]> = Vec::new();
    for (mesh, m) in scene.meshes_at(0.0) {
        let m = m.as_dmat4();
        for t in mesh.indices.chunks_exact(3) {
            let v = |k: usize| {
                mesh.positions
                    .get(t[k] as usize)
                    .map_or(DVec3::ZERO, |p| m.transform_point3(p.as_dvec3()))
            };
            tris.push([v(0), v(1), v(2)]);
        }
    }
    let areas: Vec<f64> = tris
        .iter()
        .map(|[a, b, c]| {
            let s = 0.5 * (*b - *a).cross(*c - *a).length();
            if s.is_finite() { s } else { 0.0 }
        })
        .collect();
    let target = f64::from(points.max(1));
    let cap = (target * MAX_TRIANGLE_SHARE).max(1.0);
    let count = |d: f64| areas.iter().map(|&a| (a * d).min(cap)).sum::<f64>();
    // The density giving `target` points (count is non-decreasing in d).
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let largest = areas.iter().cloned().fold(0.0, f64::max);
    if !super::gt(largest, 0.0) {
        return Surfels::default();
    }
    hi /= largest;
    while count(hi) < target && hi < 1e300 && count(hi * 2.0) > count(hi) {
        hi *= 2.0;
    }
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if count(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let d = hi;
    let lift = (0.5 / d.sqrt()) as f32;
    const A1: f64 = 0.754_877_666_246_692_7;
    const A2: f64 = 0.569_840_290_998_053_2;
    /// A point's position, geometric normal, shading normal, area and albedo.
    type Point = (Vec3, Vec3, Vec3, f32, Vec3);
    // Points per triangle by systematic sampling along the triangles'
    // order: triangle `i` gets `⌊C_i + u⌋ − ⌊C_{i−1} + u⌋`, `C_i` the
    // running sum of `min(area · d, cap)` and `u` one offset, so `area · d`
    // on average and any run of triangles (a mesh's, a bunny's thousands
    // of small ones) its own sum to within one point. Rounded triangle by
    // triangle, a detailed object's count — and with the shares below its
    // area — varied by the square root of its points: the corner scene's
    // later light moved 2.4% between `--vpls 64` and `--vpls 60`.
    let expected: Vec<f64> = areas.iter().map(|&area| (area * d).min(cap)).collect();
    let mut running = unit(0x5a5a_0000);
    let counts: Vec<u64> = expected
        .iter()
        .map(|&m| {
            let before = running.floor();
            running += m;
            (running.floor() - before) as u64
        })
        .collect();
    let per_tri: Vec<Vec<Point>> = tris
        .par_iter()
        .zip(&areas)
        .zip(expected.par_iter().zip(&counts))
        .enumerate()
        .map(|(i, ((&[a, b, c], &area), (&m, &n)))| {
            let key = i as u64;
            if n == 0 {
                return Vec::new();
            }
            let ng = (b - a).cross(c - a).normalize_or_zero();
            let (u0, u1) = (unit(key ^ 0x1111_0000), unit(key ^ 0x2222_0000));
            // What each point stands for: its triangle's area over its
            // points, where every triangle gets one or more; `1/d` where
            // a triangle under `1/d` gets its one point with chance
            // `area · d`, so that its area counts on average. Its whole
            // area on that one point counted `area² · d` on average: the
            // detailed levels lost most of their small triangles' light
            // (the city diorama 23% of its sunlit reflection at the
            // default 16 384 points, 2% at 16 times the points;
            // docs/method.md, "Every bounce").
            let share = if m < 1.0 {
                (area / m) as f32
            } else {
                (area / n as f64) as f32
            };
            let mut out = Vec::new();
            for k in 1..=n {
                let (mut s, mut t) = ((u0 + k as f64 * A1).fract(), (u1 + k as f64 * A2).fract());
                if s + t > 1.0 {
                    (s, t) = (1.0 - s, 1.0 - t);
                }
                let p = (a + (b - a) * s + (c - a) * t).as_vec3();
                for side in [ng.as_vec3(), -ng.as_vec3()] {
                    // A ray back onto the point from half the spacing off
                    // it: the surface there and its side, or none where an
                    // alpha mask cuts a hole or something lies closer (the
                    // side is covered). Half the spacing: with a tenth, the
                    // sides sandwiched between a diorama's coincident and
                    // overlapping faces got surfels, and light (the city's
                    // later share 12.6% → 26.3%).
                    let origin = p + side * lift;
                    let Some(h) = rays.intersect(origin, -side, 2.0 * lift) else {
                        continue;
                    };
                    if (h.t - lift).abs() > 1e-3 * lift {
                        continue;
                    }
                    if h.geometric_normal.dot(side) <= 0.0 {
                        continue;
                    }
                    out.push((
                        h.position,
                        h.geometric_normal,
                        h.shading_normal,
                        share,
                        h.albedo,
                    ));
                }
            }
            out
        })
        .collect();
    let mut s = Surfels {
        spacing: (1.0 / d).sqrt() as f32,
        ..Default::default()
    };
    for (p, n, ns, a, albedo) in per_tri.into_iter().flatten() {
        s.position.push(p);
        s.normal.push(n);
        s.shading.push(ns);
        s.area.push(a);
        s.albedo.push(albedo);
    }
    s
}
