//! `skylight_gallery`: a level built to break a VPL budget (issue 49). A
//! 24 m × 16 m × 6 m hall whose roof has a 10 m × 6 m opening, standing on
//! a 400 m ground; four plinths along the back wall, two balls moving
//! inside; a sun (3 W/m², azimuth 30°, elevation 55°) shines through the
//! opening. The ground round the hall makes the sun's view a fitted one
//! that cuts it, so the bake adds outer rings, and most of the sunlit
//! roof and ground sends its light to the sky: VPLs made there see the
//! hall only by rays aimed at it. Until method revision 6 a `--vpls N`
//! budget left those out of the count and the bake kept them on top of
//! it — 1175 VPLs at `--vpls 664` (docs/method.md, bake section 3,
//! "Budget"). Every surface is wall-thick (boxes), as a level's are.

use glam::DVec3;

use crate::geom;
use crate::gltf::Builder;
use crate::{Params, loop_times};

/// A static box: name, min and max corners, albedo.
type StaticBox = (&'static str, [f64; 3], [f64; 3], [f32; 3]);

pub(crate) fn build(p: &Params) -> Vec<u8> {
    let mut b = Builder::new(p.s(), "motion");
    let wall = [0.7, 0.7, 0.7];
    let boxes: [StaticBox; 12] = [
        ("floor", [-12.0, -0.3, -8.0], [12.0, 0.0, 8.0], wall),
        ("wall_n", [-12.0, 0.0, -8.3], [12.0, 6.0, -8.0], wall),
        ("wall_s", [-12.0, 0.0, 8.0], [12.0, 6.0, 8.3], wall),
        ("wall_w", [-12.3, 0.0, -8.0], [-12.0, 6.0, 8.0], wall),
        ("wall_e", [12.0, 0.0, -8.0], [12.3, 6.0, 8.0], wall),
        ("roof_n", [-12.0, 6.0, -8.0], [12.0, 6.3, -3.0], wall),
        ("roof_s", [-12.0, 6.0, 3.0], [12.0, 6.3, 8.0], wall),
        ("roof_w", [-12.0, 6.0, -3.0], [-5.0, 6.3, 3.0], wall),
        ("roof_e", [5.0, 6.0, -3.0], [12.0, 6.3, 3.0], wall),
        (
            "plinth_0",
            [-8.5, 0.0, -6.0],
            [-7.5, 1.1, -5.0],
            [0.8, 0.75, 0.6],
        ),
        (
            "plinth_1",
            [-3.5, 0.0, -6.0],
            [-2.5, 1.1, -5.0],
            [0.8, 0.75, 0.6],
        ),
        (
            "plinth_2",
            [2.5, 0.0, -6.0],
            [3.5, 1.1, -5.0],
            [0.8, 0.75, 0.6],
        ),
    ];
    // The ground: one plane, as a level's terrain often is; the sun's view
    // is fitted to the hall and cuts it (outer rings).
    let ground = geom::quad_facing(
        DVec3::new(-200.0, -0.3, -200.0),
        DVec3::X * 400.0,
        DVec3::Z * 400.0,
        1,
        DVec3::Y,
    );
    b.static_mesh("ground", &ground, [0.4, 0.45, 0.3]);
    for (name, lo, hi, color) in boxes {
        let g = geom::aabox(DVec3::from(lo), DVec3::from(hi), 1, true);
        b.static_mesh(name, &g, color);
    }
    // Two balls circling under the opening.
    for (i, (r, radius, height, color)) in [
        (3.0, 0.5, 1.0, [0.8, 0.2, 0.15]),
        (4.5, 0.4, 0.8, [0.15, 0.5, 0.8]),
    ]
    .into_iter()
    .enumerate()
    {
        let name = format!("ball_{i:02}");
        let g = b.geometry(&geom::uv_sphere(DVec3::ZERO, radius, 16, 12));
        let mat = b.material(&name, color);
        let mesh = b.mesh(&name, g, mat);
        let times = loop_times(16);
        let turn = if i == 0 { 1.0 } else { -1.0 };
        let path: Vec<DVec3> = times
            .iter()
            .map(|&t| {
                let a = turn * std::f64::consts::TAU * t / crate::LOOP_SECONDS;
                DVec3::new(r * a.cos(), height, 0.6 * r * a.sin())
            })
            .collect();
        b.dynamic_mesh(&name, mesh, &times, &path);
    }
    let (el, az) = (55f64.to_radians(), 30f64.to_radians());
    // Azimuth clockwise from −Z seen from above (as `--sun`): the sun
    // stands toward (sin az, ·, −cos az) and its light travels away.
    let towards = DVec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos());
    b.directional("sun", towards * 50.0, -towards, [1.0, 0.97, 0.92], 3.0);
    b.perspective(
        "camera",
        DVec3::new(10.0, 2.0, 6.0),
        DVec3::new(-4.0, 1.5, -4.0),
        70f64.to_radians(),
        0.05,
        200.0,
    );
    b.finish()
}
