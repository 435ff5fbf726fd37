//! `sun`: a directional light (irradiance 3 W/m², 40° from vertical, azimuth
//! not on an axis) over a 10 m × 10 m ground plane with six static blocks; a
//! box slides back and forth and two balls bounce. A perspective camera looks
//! at it from above the +X/+Z quadrant (first camera); a second, orthographic
//! camera looks straight down.

use std::f64::consts::PI;

use glam::{DMat3, DVec3};

use crate::geom;
use crate::gltf::Builder;
use crate::{LOOP_SECONDS, Params, ceil_sqrt, loop_times};

/// Bouncing ball: rest position `(x, z)`, radius, bounces per loop, apex height above rest.
const BALLS: [(f64, f64, f64, u32, f64); 2] = [(0.4, 2.4, 0.3, 4, 1.2), (-3.2, -0.2, 0.25, 3, 0.8)];

/// Position of bouncing ball `i` at time `t`: parabolic hops, touching the ground at the key times.
pub(crate) fn ball_path(i: usize, t: f64) -> DVec3 {
    let (x, z, r, bounces, h) = BALLS[i];
    let f = (t / LOOP_SECONDS * f64::from(bounces)).fract();
    DVec3::new(x, r + h * 4.0 * f * (1.0 - f), z)
}

/// Position of the sliding box's centre at time `t` (for the keys 0, 2, 4 s).
pub(crate) fn box_path(t: f64) -> DVec3 {
    let f = 1.0 - (2.0 * t / LOOP_SECONDS - 1.0).abs(); // 0 → 1 → 0
    DVec3::new(-1.5 + 2.7 * f, 0.25, 0.4)
}

pub(crate) fn build(p: &Params) -> Vec<u8> {
    let mut b = Builder::new(p.s(), "motion");
    // heavy = N: every static face becomes a k × k grid, k² ≥ N.
    let k = ceil_sqrt(u64::from(p.heavy()));

    let ground = geom::quad_facing(
        DVec3::new(-5.0, 0.0, -5.0),
        DVec3::X * 10.0,
        DVec3::Z * 10.0,
        k,
        DVec3::Y,
    );
    b.static_mesh("ground", &ground, [0.55, 0.55, 0.5]);
    let blocks: [(&str, DVec3, DVec3, [f32; 3]); 5] = [
        (
            "block_tall_red",
            DVec3::new(-2.6, 0.0, -2.2),
            DVec3::new(-1.4, 2.0, -1.2),
            [0.6, 0.25, 0.15],
        ),
        (
            "block_flat_blue",
            DVec3::new(0.5, 0.0, -2.8),
            DVec3::new(2.5, 0.6, -1.6),
            [0.15, 0.3, 0.7],
        ),
        (
            "block_cube_yellow",
            DVec3::new(1.8, 0.0, 0.8),
            DVec3::new(2.6, 0.8, 1.6),
            [0.8, 0.7, 0.2],
        ),
        (
            "block_low_green",
            DVec3::new(-0.5, 0.0, -0.6),
            DVec3::new(1.5, 0.35, -0.3),
            [0.2, 0.55, 0.2],
        ),
        (
            "block_pillar_grey",
            DVec3::new(3.2, 0.0, -0.6),
            DVec3::new(3.6, 2.6, -0.2),
            [0.7, 0.7, 0.65],
        ),
    ];
    for (name, lo, hi, color) in blocks {
        b.static_mesh(name, &geom::aabox(lo, hi, k, false), color);
    }
    // A white block turned 25° about +Y.
    let white = geom::aabox(
        DVec3::new(-0.5, 0.0, -0.5),
        DVec3::new(0.5, 1.4, 0.5),
        k,
        false,
    )
    .rotated_translated(
        DMat3::from_rotation_y(25.0 * PI / 180.0),
        DVec3::new(-1.8, 0.0, 1.8),
    );
    b.static_mesh("block_turned_white", &white, [0.8, 0.8, 0.8]);

    // Moving: a sliding 0.5 m box (constant speed, keys at 0, 2, 4 s) and two bouncing balls.
    let cube = b.geometry(&geom::aabox(
        DVec3::splat(-0.25),
        DVec3::splat(0.25),
        1,
        true,
    ));
    let mat = b.material("sliding_box", [0.75, 0.35, 0.55]);
    let mesh = b.mesh("sliding_box", cube, mat);
    let times = loop_times(2);
    let path: Vec<DVec3> = times.iter().map(|&t| box_path(t)).collect();
    b.dynamic_mesh("sliding_box", mesh, &times, &path);
    for (i, color) in [[0.9, 0.45, 0.1], [0.3, 0.6, 0.9]].into_iter().enumerate() {
        let name = format!("ball_{i:02}");
        let (_, _, r, bounces, _) = BALLS[i];
        let g = b.geometry(&geom::uv_sphere(DVec3::ZERO, r, 16, 12));
        let mat = b.material(&name, color);
        let mesh = b.mesh(&name, g, mat);
        let times = loop_times(16 * bounces);
        let path: Vec<DVec3> = times.iter().map(|&t| ball_path(i, t)).collect();
        b.dynamic_mesh(&name, mesh, &times, &path);
    }

    // The sun: travelling 40° from straight down, azimuth −35° (toward +X, −Z).
    let (tilt, az) = (40f64.to_radians(), (-35f64).to_radians());
    let dir = DVec3::new(tilt.sin() * az.cos(), -tilt.cos(), tilt.sin() * az.sin());
    b.directional("sun", -dir * 10.0, dir, [1.0, 0.96, 0.9], 3.0);

    b.perspective(
        "camera",
        DVec3::new(6.5, 4.8, 7.5),
        DVec3::new(0.0, 0.4, 0.0),
        45f64.to_radians(),
        0.1,
        60.0,
    );
    b.orthographic(
        "camera_top",
        DVec3::new(0.0, 20.0, 0.0),
        DVec3::ZERO,
        5.5,
        5.5,
        0.1,
        40.0,
    );
    b.finish()
}
