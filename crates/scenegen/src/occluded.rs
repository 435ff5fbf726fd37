//! `occluded`: the paper's Fig. 10 situation. A spot light high behind a tall
//! wall lights mostly what lies behind it, and a strip of floor in front. Behind the wall (z < 0), a
//! saturated blue and a saturated yellow panel lean toward the wall: lit, and
//! facing the receivers in front of the wall, but hidden from them by it — a
//! renderer whose VPLs have no visibility leaks blue and yellow onto the
//! visible floor. In front (z > 0), a red panel whose bounce does reach the
//! visible floor. Two balls move in front of the wall. The camera, lower than
//! the wall's top, sees only the front floor, the wall's front face and the
//! red panel.

use glam::DVec3;

use crate::geom;
use crate::gltf::Builder;
use crate::{LOOP_SECONDS, Params, ceil_sqrt, loop_times};

/// Position of ball `i` (0 or 1) at time `t`.
pub(crate) fn ball_path(i: usize, t: f64) -> DVec3 {
    let w = std::f64::consts::TAU * t / LOOP_SECONDS;
    match i {
        // A circle in front of the wall's left half.
        0 => DVec3::new(-1.0 + 0.6 * w.cos(), 0.35, 1.6 + 0.6 * w.sin()),
        // An ellipse in front of the right half, bobbing.
        _ => DVec3::new(
            0.6 + 0.8 * w.sin(),
            0.6 + 0.2 * (2.0 * w).sin(),
            1.2 + 0.3 * w.cos(),
        ),
    }
}

pub(crate) fn build(p: &Params) -> Vec<u8> {
    let mut b = Builder::new(p.s(), "balls");
    // heavy = N: every static face becomes a k × k grid, k² ≥ N.
    let k = ceil_sqrt(u64::from(p.heavy()));

    let floor = geom::quad_facing(
        DVec3::new(-4.0, 0.0, -3.0),
        DVec3::X * 8.0,
        DVec3::Z * 7.5,
        k,
        DVec3::Y,
    );
    b.static_mesh("floor", &floor, [0.7, 0.7, 0.7]);
    let wall = geom::aabox(
        DVec3::new(-3.0, 0.0, -0.1),
        DVec3::new(3.0, 2.5, 0.1),
        k,
        false,
    );
    b.static_mesh("occluder_wall", &wall, [0.5, 0.5, 0.5]);

    // Hidden panels: 1.6 m × 1.2 m, lower edge on the floor 0.5 m behind the
    // wall's centre plane, rising away from it at 45°, facing (0, 1, 1)/√2.
    let slope = DVec3::new(0.0, 1.0, -1.0).normalize() * 1.2;
    let facing = DVec3::new(0.0, 1.0, 1.0);
    let blue = geom::quad_facing(
        DVec3::new(-1.8, 0.0, -0.5),
        DVec3::X * 1.6,
        slope,
        k,
        facing,
    );
    b.static_mesh("hidden_panel_blue", &blue, [0.05, 0.1, 0.85]);
    let yellow = geom::quad_facing(DVec3::new(0.2, 0.0, -0.5), DVec3::X * 1.6, slope, k, facing);
    b.static_mesh("hidden_panel_yellow", &yellow, [0.85, 0.75, 0.05]);

    // Visible panel: 1.8 m × 1.5 m, standing on the front floor at x = 2,
    // leaning back 30° from vertical, facing (−cos 30°, sin 30°, 0).
    let lean = DVec3::new(30f64.to_radians().sin(), 30f64.to_radians().cos(), 0.0) * 1.5;
    let red = geom::quad_facing(
        DVec3::new(2.0, 0.0, 0.8),
        DVec3::Z * 1.8,
        lean,
        k,
        DVec3::new(-0.866, 0.5, 0.0),
    );
    b.static_mesh("visible_panel_red", &red, [0.8, 0.1, 0.08]);

    // Two moving balls.
    let times = loop_times(32);
    for (i, (r, color)) in [(0.2, [0.8, 0.8, 0.8]), (0.2, [0.3, 0.8, 0.3])]
        .into_iter()
        .enumerate()
    {
        let name = format!("ball_{i:02}");
        let g = b.geometry(&geom::uv_sphere(DVec3::ZERO, r, 16, 12));
        let mat = b.material(&name, color);
        let mesh = b.mesh(&name, g, mat);
        let path: Vec<DVec3> = times.iter().map(|&t| ball_path(i, t)).collect();
        b.dynamic_mesh(&name, mesh, &times, &path);
    }

    // Spot light 6 m up, 2 m behind the wall, aimed at the hidden panels: most
    // of its flux lands behind the wall (the hidden VPLs of Fig. 10); its
    // 35° cone also reaches a strip of the visible floor in front of the
    // wall and part of the red panel. 120 W/sr: ~3 W/m² under it.
    let light = DVec3::new(0.0, 6.0, -2.0);
    b.spot(
        "spot",
        light,
        DVec3::new(0.0, 0.0, -1.0) - light,
        [1.0, 1.0, 1.0],
        120.0,
        25f64.to_radians(),
        35f64.to_radians(),
    );

    // Camera in front, below the wall's top (2.5 m): the hidden panels are out of sight.
    b.perspective(
        "camera",
        DVec3::new(-0.6, 2.2, 5.2),
        DVec3::new(0.3, 0.2, 1.2),
        55f64.to_radians(),
        0.05,
        50.0,
    );
    b.finish()
}
