//! `lamps`: a small room lit by lamps only, the bundled scene with several
//! primary lights. The room is 7 m × 6 m × 3 m: floor, back, left and right
//! walls and a ceiling, open at the front (+Z) where the camera stands. Three
//! lamps: a ceiling spot (60 W/sr, warm white, 40° cone, glTF `range` 6 m)
//! aimed at the floor near the back-left corner, a hanging point lamp (25
//! W/sr, warm, no range) over the table, and a low blue-white point lamp (8
//! W/sr, `range` 2.5 m) in the front-right corner. Four static blocks (a table,
//! a floor-to-ceiling pillar, a bench, a turned cube) and three balls on
//! LINEAR loops: one rolling around under the hanging lamp, one bobbing past
//! the pillar, one circling through the spot's cone.
//!
//! One spot light and two point lights, all three primary lights (the spot
//! leads: the first spot when there is no directional light).

use std::f64::consts::{PI, TAU};

use glam::{DMat3, DVec3};

use crate::geom;
use crate::gltf::Builder;
use crate::{LOOP_SECONDS, Params, ceil_sqrt, loop_times};

/// Half width (x), half depth (z) and height of the room.
const HALF_W: f64 = 3.5;
const HALF_D: f64 = 3.0;
const HEIGHT: f64 = 3.0;

/// Position of ball `i` (0, 1 or 2) at time `t`.
pub(crate) fn ball_path(i: usize, t: f64) -> DVec3 {
    let w = TAU * t / LOOP_SECONDS;
    match i {
        // Rolling on the floor in a circle under the hanging lamp.
        0 => DVec3::new(1.3 + 0.7 * w.cos(), 0.25, 0.3 + 0.7 * w.sin()),
        // Back and forth past the pillar, bobbing twice per loop.
        1 => DVec3::new(-0.95 - 0.95 * w.cos(), 0.8 + 0.3 * (2.0 * w).sin(), 0.6),
        // An ellipse at 1.5 m through the spot's cone.
        _ => DVec3::new(-1.0 + 0.8 * w.cos(), 1.5, -1.0 - 0.5 * w.sin()),
    }
}

/// Radius and albedo of ball `i`.
const BALLS: [(f64, [f32; 3]); 3] = [
    (0.25, [0.85, 0.85, 0.8]),
    (0.2, [0.9, 0.55, 0.1]),
    (0.18, [0.3, 0.7, 0.85]),
];

pub(crate) fn build(p: &Params) -> Vec<u8> {
    let mut b = Builder::new(p.s(), "balls");
    // heavy = N: every static face becomes a k × k grid, k² ≥ N.
    let k = ceil_sqrt(u64::from(p.heavy()));
    let (x0, z0) = (-HALF_W, -HALF_D);
    let (w, d, h) = (2.0 * HALF_W, 2.0 * HALF_D, HEIGHT);

    let room = [
        (
            "floor",
            DVec3::new(x0, 0.0, z0),
            DVec3::X * w,
            DVec3::Z * d,
            DVec3::Y,
            [0.55, 0.55, 0.5],
        ),
        (
            "ceiling",
            DVec3::new(x0, h, z0),
            DVec3::X * w,
            DVec3::Z * d,
            DVec3::NEG_Y,
            [0.8, 0.8, 0.78],
        ),
        (
            "wall_back",
            DVec3::new(x0, 0.0, z0),
            DVec3::X * w,
            DVec3::Y * h,
            DVec3::Z,
            [0.75, 0.72, 0.68],
        ),
        (
            "wall_left",
            DVec3::new(x0, 0.0, z0),
            DVec3::Z * d,
            DVec3::Y * h,
            DVec3::X,
            [0.65, 0.4, 0.35],
        ),
        (
            "wall_right",
            DVec3::new(-x0, 0.0, z0),
            DVec3::Z * d,
            DVec3::Y * h,
            DVec3::NEG_X,
            [0.35, 0.45, 0.65],
        ),
    ];
    for (name, o, u, v, facing, rgb) in room {
        b.static_mesh(name, &geom::quad_facing(o, u, v, k, facing), rgb);
    }
    let blocks: [(&str, DVec3, DVec3, [f32; 3]); 3] = [
        (
            "block_table",
            DVec3::new(0.6, 0.0, -2.0),
            DVec3::new(2.0, 0.75, -1.2),
            [0.6, 0.45, 0.3],
        ),
        (
            "block_pillar",
            DVec3::new(-2.6, 0.0, -0.4),
            DVec3::new(-2.1, h, 0.1),
            [0.75, 0.75, 0.72],
        ),
        (
            "block_bench_green",
            DVec3::new(-1.0, 0.0, 1.0),
            DVec3::new(0.6, 0.45, 1.4),
            [0.25, 0.5, 0.3],
        ),
    ];
    for (name, lo, hi, rgb) in blocks {
        b.static_mesh(name, &geom::aabox(lo, hi, k, false), rgb);
    }
    let cube = geom::aabox(
        DVec3::new(-0.35, 0.0, -0.35),
        DVec3::new(0.35, 0.7, 0.35),
        k,
        false,
    )
    .rotated_translated(
        DMat3::from_rotation_y(20.0 * PI / 180.0),
        DVec3::new(-0.8, 0.0, -2.1),
    );
    b.static_mesh("block_cube_red", &cube, [0.7, 0.2, 0.15]);

    // Three balls, sampled 32 times a loop (LINEAR keys).
    let times = loop_times(32);
    for (i, (r, rgb)) in BALLS.into_iter().enumerate() {
        let name = format!("ball_{i:02}");
        let g = b.geometry(&geom::uv_sphere(DVec3::ZERO, r, 16, 12));
        let mat = b.material(&name, rgb);
        let mesh = b.mesh(&name, g, mat);
        let path: Vec<DVec3> = times.iter().map(|&t| ball_path(i, t)).collect();
        b.dynamic_mesh(&name, mesh, &times, &path);
    }

    // The lamps: a ceiling spot with a range, a hanging point lamp without
    // one, a low point lamp with a short range.
    let spot = DVec3::new(-1.2, 2.9, -1.0);
    b.spot_with_range(
        "spot_lamp",
        spot,
        DVec3::new(-1.4, 0.0, -2.2) - spot,
        [1.0, 0.9, 0.75],
        60.0,
        28f64.to_radians(),
        40f64.to_radians(),
        Some(6.0),
    );
    b.point(
        "point_lamp",
        DVec3::new(1.6, 2.4, -0.6),
        [1.0, 0.85, 0.6],
        25.0,
        None,
    );
    b.point(
        "point_lamp_low",
        DVec3::new(2.7, 0.6, 1.8),
        [0.55, 0.7, 1.0],
        8.0,
        Some(2.5),
    );

    // From the open front, below the ceiling's edge.
    b.perspective(
        "camera",
        DVec3::new(0.8, 1.7, 6.0),
        DVec3::new(0.0, 1.0, -1.0),
        55f64.to_radians(),
        0.05,
        50.0,
    );
    b.finish()
}
