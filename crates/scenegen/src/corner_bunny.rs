//! `corner_bunny`: the paper's experiment. A floor and two walls meet in a
//! corner at the origin's back-left (x = −1, z = −1); the Stanford bunny
//! (0.6 m tall) sits on the floor in the corner region; 13 small balls circle
//! it on loops of [`crate::LOOP_SECONDS`]; a spot light from the front above
//! aims into the corner; the camera looks into the corner along the diagonal.

use std::f64::consts::{PI, TAU};

use glam::DVec3;

use crate::geom;
use crate::gltf::Builder;
use crate::{Params, ceil_sqrt, loop_times};

/// Half-width of the floor and walls (the room is 2 m × 2 m, walls 2 m tall).
const HALF: f64 = 1.0;
/// Wall height.
const WALL_H: f64 = 2.0;
/// Bunny height.
const BUNNY_H: f64 = 0.6;
/// Bunny yaw about +Y. The model's nose points about 25° from +Z toward −X
/// (its ears lean back toward −Z); this turns the nose about 30° to the right
/// of the camera, a three-quarter view.
const BUNNY_YAW: f64 = 100.0 * PI / 180.0;
/// Centre of the bunny's horizontal bounds, and of the balls' orbits.
const CENTER: (f64, f64) = (-0.38, -0.38);

/// Ball radii, used in turn.
const RADII: [f64; 3] = [0.06, 0.075, 0.09];
/// Ball albedos (linear RGB).
const BALL_COLORS: [[f32; 3]; 13] = [
    [0.80, 0.20, 0.20],
    [0.20, 0.30, 0.80],
    [0.90, 0.80, 0.20],
    [0.20, 0.70, 0.70],
    [0.70, 0.20, 0.70],
    [0.90, 0.50, 0.10],
    [0.30, 0.80, 0.30],
    [0.85, 0.85, 0.85],
    [0.50, 0.30, 0.15],
    [0.20, 0.20, 0.25],
    [0.95, 0.60, 0.70],
    [0.40, 0.60, 0.90],
    [0.60, 0.80, 0.20],
];

/// Keys per loop of a ball's path.
const KEYS: u32 = 32;

/// Position of ball `i` at time `t` (seconds; one loop per 4 s).
///
/// Two carousels about the vertical axis through [`CENTER`]: balls 0–6 circle
/// counter-clockwise (seen from above) around the bunny at heights up to its
/// top, balls 7–12 clockwise above it, bobbing together. Each carousel turns
/// rigidly, so its balls never touch each other, and the two are separated in
/// height.
pub(crate) fn ball_path(i: usize, t: f64) -> DVec3 {
    let w = TAU * t / crate::LOOP_SECONDS;
    let (radius, y, phase, dir, bob) = if i < 7 {
        let fi = i as f64;
        (
            0.39 + RADII[i % RADII.len()],
            0.12 + 0.44 * fi / 6.0,
            TAU * fi / 7.0,
            1.0,
            0.0,
        )
    } else {
        let j = (i - 7) as f64;
        (
            0.15 + 0.07 * j,
            0.86 + 0.08 * j,
            TAU * j / 3.0 + 0.4,
            -1.0,
            0.04 * (2.0 * w).sin(),
        )
    };
    // Counter-clockwise seen from above (+Y) is from +X toward −Z.
    let ang = phase + dir * w;
    DVec3::new(
        CENTER.0 + radius * ang.cos(),
        y + bob,
        CENTER.1 - radius * ang.sin(),
    )
}

pub(crate) fn build(p: &Params) -> Vec<u8> {
    let mut b = Builder::new(p.s(), "balls");
    let heavy = u64::from(p.heavy());

    // Static part. heavy = N: the bunny is subdivided ⌊log₄ N⌋ times, the
    // walls take the rest of N × (base triangle count).
    let mut levels = 0;
    while 4u64.pow(levels + 1) <= heavy {
        levels += 1;
    }
    let bunny = geom::subdivide(geom::bunny(BUNNY_H, BUNNY_YAW, CENTER.0, CENTER.1), levels);
    let base = geom::raw_bunny().triangles() as u64 + 3 * 2;
    let rest = (heavy * base).saturating_sub(bunny.triangles() as u64);
    let k = ceil_sqrt(rest.div_ceil(3 * 2));

    let (o, w) = (DVec3::new(-HALF, 0.0, -HALF), 2.0 * HALF);
    let floor = geom::quad_facing(o, DVec3::X * w, DVec3::Z * w, k, DVec3::Y);
    let left = geom::quad_facing(o, DVec3::Z * w, DVec3::Y * WALL_H, k, DVec3::X);
    let back = geom::quad_facing(o, DVec3::X * w, DVec3::Y * WALL_H, k, DVec3::Z);
    b.static_mesh("floor", &floor, [0.7, 0.7, 0.7]);
    b.static_mesh("wall_left", &left, [0.7, 0.15, 0.1]);
    b.static_mesh("wall_back", &back, [0.15, 0.6, 0.15]);
    b.static_mesh("bunny", &bunny, [0.8, 0.8, 0.8]);

    // Dynamic part: 13 balls sharing three sphere geometries.
    let spheres: Vec<_> = RADII
        .iter()
        .map(|&r| b.geometry(&geom::uv_sphere(DVec3::ZERO, r, 16, 12)))
        .collect();
    let times = loop_times(KEYS);
    for (i, color) in BALL_COLORS.iter().enumerate() {
        let name = format!("ball_{i:02}");
        let mat = b.material(&name, *color);
        let mesh = b.mesh(&name, spheres[i % RADII.len()], mat);
        let path: Vec<DVec3> = times.iter().map(|&t| ball_path(i, t)).collect();
        b.dynamic_mesh(&name, mesh, &times, &path);
    }

    // Spot light: front-right above, aimed into the corner. 40 W/sr gives
    // ~3–5 W/m² on the floor and walls.
    let light = DVec3::new(0.9, 2.3, 1.4);
    let aim = DVec3::new(-0.45, 0.35, -0.45);
    b.spot(
        "spot",
        light,
        aim - light,
        [1.0, 1.0, 1.0],
        40.0,
        28f64.to_radians(),
        40f64.to_radians(),
    );

    // Camera: on the room's diagonal, looking into the corner.
    b.perspective(
        "camera",
        DVec3::new(1.4, 1.4, 1.4),
        DVec3::new(-0.4, 0.5, -0.4),
        38f64.to_radians(),
        0.05,
        20.0,
    );
    b.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Balls keep clear of each other, the walls, the floor and the bunny.
    #[test]
    fn balls_do_not_collide() {
        let bunny = geom::bunny(BUNNY_H, BUNNY_YAW, CENTER.0, CENTER.1);
        let n = BALL_COLORS.len();
        let r = |i: usize| RADII[i % RADII.len()];
        for step in 0..=200 {
            let t = crate::LOOP_SECONDS * f64::from(step) / 200.0;
            for i in 0..n {
                let p = ball_path(i, t);
                assert!(p.y - r(i) > 0.02, "ball {i} touches the floor at t={t}");
                assert!(
                    p.x - r(i) > -HALF + 0.02 && p.z - r(i) > -HALF + 0.02,
                    "ball {i} touches a wall at t={t}"
                );
                let d = bunny
                    .pos
                    .iter()
                    .map(|q| (*q - p).length())
                    .fold(f64::INFINITY, f64::min);
                assert!(d - r(i) > 0.03, "ball {i} touches the bunny at t={t}");
                for k in i + 1..n {
                    let gap = (ball_path(k, t) - p).length() - r(i) - r(k);
                    assert!(gap > 0.01, "balls {i} and {k} touch at t={t}");
                }
            }
        }
        // The loop closes.
        for i in 0..n {
            assert!((ball_path(i, 0.0) - ball_path(i, crate::LOOP_SECONDS)).length() < 1e-12);
        }
    }
}
