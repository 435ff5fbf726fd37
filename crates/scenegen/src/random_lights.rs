//! Seeded random scenes with several primary lights, for judging the
//! every-light work on levels nobody tuned.
//!
//! [`random_lights`] turns a seed into a scene of 1–8 `KHR_lights_punctual`
//! lights of all three kinds, built from the same parts as [`crate::random()`]
//! (its floor and walls, boxes, bunny, panel, moving balls and open-side
//! camera). The number of lights is uniform in 1–8 (a level has one sun
//! and some lamps: at most two directional lights, the rest spots and
//! point lights):
//!
//! - **Exteriors** (half of the seeds): one of [`crate::random()`]'s open rooms
//!   (open ground, one wall, a corner, three walls); a sun in 85% of them
//!   (10°–80° from vertical, from the open side), in a tenth of those with
//!   two or more lights a second, weak directional light (a moon or sky
//!   fill, 0.05–0.5 W/m², bluish, from anywhere); the other lights are lamps
//!   standing in the level: spots 2–6 m up (street lamps), point lights
//!   0.4–1.2 m (bollards) or 2.5–5 m up. The camera looks in from the open
//!   side, as in [`crate::random()`].
//! - **Interiors**: a floor, walls and a ceiling at the walls' height: a
//!   "hall" (three walls, open at +Z, where the camera stands just inside or
//!   outside, below the ceiling) or a closed "room" (four walls, the camera
//!   inside in a corner). At least one lamp. In 40% of those with two or
//!   more lights a sun comes in: through the hall's open side (45°–75° from
//!   vertical) or through a 1–2.5 m skylight cut in the room's ceiling
//!   (0°–30° from vertical, aimed through it). Spots hang 0.1–0.5 m under
//!   the ceiling; point lamps hang 0.3–1.2 m under it or stand 0.3–1.5 m
//!   above the floor (table and floor lamps).
//!
//! Lamps are spots or point lights with even odds. Half of them have a glTF
//! `range` (1.5–12 m inside, 3–25 m outside: from a window that cuts off
//! within the room to one beyond everything), half none. Their radiant
//! intensity is log-uniform in 10–200 W/sr (from a dim bulb to a bright
//! floodlight: 0.6–50 W/m² at 2 m, so that neither the lamps nor the sun
//! always dominate); the sun's irradiance is log-uniform in 1–10 W/m².
//! Colours: most lamps warm to neutral white, some cool white, a tenth
//! saturated (coloured bulbs); suns slightly warm. Spot cones are 15°–75°
//! (outer half-angle), the inner angle 0–95% of it, aimed at a point of the
//! floor or, a quarter of them, at a point 0.3 m to 0.8 of the wall height
//! above it (more sideways: onto walls and props). Lamps are kept out of
//! the static props, and moving balls (0–12 on straight loops, below the
//! ceiling) keep 0.2 m clear of every lamp.
//!
//! Nothing here is tuned to make the method look good: the ranges are what
//! a level might contain. The same seed and [`Params`] give the same bytes
//! (SplitMix64, no platform-dependent maths beyond `f64` sin/cos/exp/ln).

use std::f64::consts::PI;

use glam::DVec3;

use crate::geom;
use crate::gltf::Builder;
use crate::random::{Floor, Props, ROOMS, Rng, add_ball, ball_path, open_side, outside_camera};
use crate::{Params, ceil_sqrt};

/// One light of a [`random_lights`] scene, in the order of its nodes.
#[derive(Clone, Debug, PartialEq)]
pub struct LightInfo {
    /// "directional", "spot" or "point".
    pub kind: &'static str,
    /// glTF `range` in metres at scale 1 (`None`: unbounded).
    pub range: Option<f64>,
    /// W/sr (spot, point) or W/m² (directional), at scale 1, before colour.
    pub intensity: f64,
}

/// What [`random_lights`] put in a scene (for test messages).
#[derive(Clone, Debug, PartialEq)]
pub struct RandomLightsInfo {
    /// Whether it is an interior (a ceiling over the lamps).
    pub interior: bool,
    /// Room kind: "ground", "wall", "corner", "three_walls" (exteriors),
    /// "hall" or "room" (interiors).
    pub room: &'static str,
    /// Whether the room's ceiling has a skylight (a closed room with a sun).
    pub skylight: bool,
    /// Static boxes.
    pub boxes: u32,
    /// Whether the bunny is in it.
    pub bunny: bool,
    /// Whether a standing panel is in it.
    pub panel: bool,
    /// The lights, 1 to 8.
    pub lights: Vec<LightInfo>,
    /// Moving balls.
    pub moving: u32,
}

impl RandomLightsInfo {
    /// How many lights of `kind` ("directional", "spot" or "point").
    pub fn count(&self, kind: &str) -> usize {
        self.lights.iter().filter(|l| l.kind == kind).count()
    }
}

impl std::fmt::Display for RandomLightsInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {}{}, {} boxes{}{}, {} directional + {} spot + {} point ({} with range), {} moving",
            if self.interior {
                "interior"
            } else {
                "exterior"
            },
            self.room,
            if self.skylight { " with skylight" } else { "" },
            self.boxes,
            if self.bunny { ", bunny" } else { "" },
            if self.panel { ", panel" } else { "" },
            self.count("directional"),
            self.count("spot"),
            self.count("point"),
            self.lights.iter().filter(|l| l.range.is_some()).count(),
            self.moving
        )
    }
}

/// A lamp's colour: warm to neutral white (75%), cool white (15%) or a
/// saturated coloured bulb (10%).
fn lamp_color(r: &mut Rng) -> [f32; 3] {
    let u = r.range(0.0, 1.0);
    let c = if u < 0.75 {
        [1.0, r.range(0.7, 1.0), r.range(0.45, 1.0)]
    } else if u < 0.9 {
        [r.range(0.75, 0.95), r.range(0.85, 1.0), 1.0]
    } else {
        let mut c = [r.range(0.05, 0.4), r.range(0.05, 0.4), r.range(0.05, 0.4)];
        c[r.int(0, 2) as usize] = 1.0;
        c
    };
    c.map(|x| x as f32)
}

/// Whether `p` is within `margin` of one of the boxes `bounds`.
fn in_props(p: DVec3, bounds: &[(DVec3, DVec3)], margin: f64) -> bool {
    bounds.iter().any(|(lo, hi)| {
        p.cmpge(*lo - DVec3::splat(margin)).all() && p.cmple(*hi + DVec3::splat(margin)).all()
    })
}

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).length()
}

/// The ceiling at height `fl.h` facing down, with a rectangular hole
/// `[hx0, hx1] × [hz0, hz1]` if `hole` is given.
fn ceiling(fl: &Floor, hole: Option<(f64, f64, f64, f64)>, k: u32) -> geom::Geom {
    let (x0, z0, w, d, h) = (fl.x0, fl.z0, fl.w, fl.d, fl.h);
    let q = |o: DVec3, u: DVec3, v: DVec3| geom::quad_facing(o, u, v, k, DVec3::NEG_Y);
    let Some((hx0, hx1, hz0, hz1)) = hole else {
        return q(DVec3::new(x0, h, z0), DVec3::X * w, DVec3::Z * d);
    };
    let mut g = q(DVec3::new(x0, h, z0), DVec3::X * w, DVec3::Z * (hz0 - z0));
    g.append(&q(
        DVec3::new(x0, h, hz1),
        DVec3::X * w,
        DVec3::Z * (-z0 - hz1),
    ));
    g.append(&q(
        DVec3::new(x0, h, hz0),
        DVec3::X * (hx0 - x0),
        DVec3::Z * (hz1 - hz0),
    ));
    g.append(&q(
        DVec3::new(hx1, h, hz0),
        DVec3::X * (-x0 - hx1),
        DVec3::Z * (hz1 - hz0),
    ));
    g
}

/// The multi-light scene of `seed` (GLB bytes) and what it contains (see
/// the module docs). `p.scale` scales it as for the bundled scenes (lamp
/// intensities by `s²`, ranges by `s`); `p.heavy` tessellates its planar
/// faces.
pub fn random_lights(seed: u64, p: &Params) -> (Vec<u8>, RandomLightsInfo) {
    let mut r = Rng(seed ^ 0x6c61_6d70_735f_0000);
    let mut b = Builder::new(p.s(), "motion");
    let k = ceil_sqrt(u64::from(p.heavy()));

    let fl = Floor::draw(&mut r);
    let (x0, z0, h) = (fl.x0, fl.z0, fl.h);
    let interior = r.chance(0.5);
    let room = if interior {
        ["hall", "room"][r.int(0, 1) as usize]
    } else {
        ROOMS[r.int(0, 3) as usize]
    };

    // How many lights, and how many of them directional.
    let total = r.int(1, 8);
    let directional = if interior {
        u32::from(total >= 2 && r.chance(0.4))
    } else if r.chance(0.85) {
        if total >= 2 && r.chance(0.1) { 2 } else { 1 }
    } else {
        0
    };

    // Floor and walls (a hall has random.rs's three walls; a room a fourth
    // at +Z), a ceiling over interiors, a skylight in a sunlit room.
    fl.build(
        &mut b,
        &mut r,
        if interior { "three_walls" } else { room },
        k,
    );
    let mut skylight = None;
    if interior {
        if room == "room" {
            let front = geom::quad_facing(
                DVec3::new(x0, 0.0, -z0),
                DVec3::X * fl.w,
                DVec3::Y * h,
                k,
                DVec3::NEG_Z,
            );
            b.static_mesh("wall_front", &front, r.albedo());
            if directional > 0 {
                let (sx, sz) = (
                    r.range(1.0, 2.5f64.min(0.4 * fl.w)),
                    r.range(1.0, 2.5f64.min(0.4 * fl.d)),
                );
                let c = DVec3::new(
                    r.range(x0 + 1.0 + 0.5 * sx, -x0 - 1.0 - 0.5 * sx),
                    0.0,
                    r.range(z0 + 1.0 + 0.5 * sz, -z0 - 1.0 - 0.5 * sz),
                );
                skylight = Some((
                    c.x - 0.5 * sx,
                    c.x + 0.5 * sx,
                    c.z - 0.5 * sz,
                    c.z + 0.5 * sz,
                ));
            }
        }
        b.static_mesh("ceiling", &ceiling(&fl, skylight, k), r.albedo());
    }
    let props = Props::add(&mut b, &mut r, &fl, k);

    // The directional lights.
    let mut lights = Vec::new();
    for i in 0..directional {
        let (dir, rgb, irradiance, target) = if i == 0 {
            let rgb = [1.0, r.range(0.85, 1.0) as f32, r.range(0.7, 1.0) as f32];
            let irradiance = r.log_range(1.0, 10.0);
            let (dir, target) = if let Some((hx0, hx1, hz0, hz1)) = skylight {
                // Through the skylight: from a point of the hole down to the floor.
                let tilt = r.range(0.0, 30.0f64).to_radians();
                let az = r.range(0.0, 2.0 * PI);
                let dir = DVec3::new(tilt.sin() * az.cos(), -tilt.cos(), tilt.sin() * az.sin());
                let hole = DVec3::new(r.range(hx0, hx1), h, r.range(hz0, hz1));
                (dir, hole + dir * (h / tilt.cos()))
            } else if interior {
                // Into the hall through its open side (+Z), under the ceiling.
                let tilt = r.range(45.0, 75.0f64).to_radians();
                let az = r.range(-35.0, 35.0f64).to_radians();
                let dir = DVec3::new(tilt.sin() * az.sin(), -tilt.cos(), -tilt.sin() * az.cos());
                (dir, fl.point(&mut r, 1.0))
            } else {
                let tilt = r.range(10.0, 80.0f64).to_radians();
                let o = open_side(room, r.range(0.0, 2.0 * PI));
                let dir = DVec3::new(-tilt.sin() * o.x, -tilt.cos(), -tilt.sin() * o.z);
                (dir, fl.point(&mut r, 1.0))
            };
            (dir, rgb, irradiance, target)
        } else {
            // A weak second directional light: a moon or a sky fill.
            let tilt = r.range(20.0, 70.0f64).to_radians();
            let az = r.range(0.0, 2.0 * PI);
            let dir = DVec3::new(-tilt.sin() * az.cos(), -tilt.cos(), -tilt.sin() * az.sin());
            let rgb = [r.range(0.6, 0.8) as f32, r.range(0.7, 0.9) as f32, 1.0];
            (dir, rgb, r.log_range(0.05, 0.5), DVec3::ZERO)
        };
        let name = if i == 0 { "sun" } else { "sun_fill" };
        b.directional(name, target - dir * 10.0, dir, rgb, irradiance);
        lights.push(LightInfo {
            kind: "directional",
            range: None,
            intensity: irradiance,
        });
    }

    // The lamps.
    let mut lamp_pos = Vec::new();
    for i in directional..total {
        let spot = r.chance(0.5);
        let mut pos = DVec3::ZERO;
        for _ in 0..16 {
            let xz = fl.point(&mut r, 0.3);
            let y = match (interior, spot) {
                (true, true) => h - r.range(0.1, 0.5),
                (true, false) if r.chance(0.6) => h - r.range(0.3, 1.2),
                (true, false) => r.range(0.3, 1.5),
                (false, true) => r.range(2.0, 6.0),
                (false, false) if r.chance(0.5) => r.range(0.4, 1.2),
                (false, false) => r.range(2.5, 5.0),
            };
            pos = xz + DVec3::Y * y;
            if !in_props(pos, &props.bounds, 0.15) {
                break;
            }
            // Out of the props' way: just under the ceiling, or high up.
            pos.y = if interior { h - 0.15 } else { 6.0 };
        }
        let range = if r.chance(0.5) {
            Some(if interior {
                r.range(1.5, 12.0)
            } else {
                r.range(3.0, 25.0)
            })
        } else {
            None
        };
        let intensity = r.log_range(10.0, 200.0);
        let rgb = lamp_color(&mut r);
        if spot {
            let mut target = fl.point(&mut r, 0.5);
            if r.chance(0.25) {
                target.y = r.range(0.3, 0.8 * h);
            }
            if (target - pos).length() < 0.5 {
                target = pos - DVec3::Y;
            }
            let outer = r.range(15.0, 75.0f64).to_radians();
            let inner = outer * r.range(0.0, 0.95);
            let name = format!("spot_{i}");
            b.spot_with_range(
                &name,
                pos,
                target - pos,
                rgb,
                intensity,
                inner,
                outer,
                range,
            );
        } else {
            b.point(&format!("point_{i}"), pos, rgb, intensity, range);
        }
        lamp_pos.push(pos);
        lights.push(LightInfo {
            kind: if spot { "spot" } else { "point" },
            range,
            intensity,
        });
    }

    // Moving balls on straight loops, below the ceiling, clear of the lamps.
    let wanted = if r.chance(0.25) { 0 } else { r.int(1, 12) };
    let top = if interior { 1.8f64.min(h - 0.5) } else { 1.8 };
    let mut moving = 0;
    for _ in 0..wanted {
        for _ in 0..8 {
            let (rad, a, bpos) = ball_path(&mut r, &fl, top);
            if lamp_pos
                .iter()
                .all(|&l| segment_distance(l, a, bpos) > rad + 0.2)
            {
                add_ball(&mut b, &mut r, moving, rad, a, bpos);
                moving += 1;
                break;
            }
        }
    }

    // The camera.
    if !interior {
        let focus = fl.point(&mut r, 1.0);
        outside_camera(&mut b, &mut r, room, &fl, focus);
    } else {
        let (eye, look, fov) = if room == "room" {
            // Inside, in the +X/+Z corner, looking at the opposite one.
            let eye = DVec3::new(
                -x0 - r.range(0.4, 1.0),
                r.range(1.3, 2.0f64.min(h - 0.4)),
                -z0 - r.range(0.4, 1.0),
            );
            let look = DVec3::new(0.3 * x0, r.range(0.3, 1.0), 0.3 * z0);
            (eye, look, r.range(60.0, 75.0))
        } else {
            // At the hall's open side, below the ceiling, looking in.
            let eye = DVec3::new(
                r.range(-0.3, 0.3) * fl.w,
                r.range(1.2, 2.2f64.min(h - 0.3)),
                -z0 + r.range(0.0, 2.0),
            );
            let look = DVec3::new(r.range(-0.2, 0.2) * fl.w, r.range(0.3, 1.0), 0.4 * z0);
            (eye, look, r.range(55.0, 70.0))
        };
        b.perspective("camera", eye, look, fov.to_radians(), 0.05, 100.0);
    }

    let info = RandomLightsInfo {
        interior,
        room,
        skylight: skylight.is_some(),
        boxes: props.boxes,
        bunny: props.bunny,
        panel: props.panel,
        lights,
        moving,
    };
    (b.finish(), info)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_distance_is_right() {
        let (a, b) = (DVec3::ZERO, DVec3::X * 2.0);
        assert!((segment_distance(DVec3::new(1.0, 1.0, 0.0), a, b) - 1.0).abs() < 1e-12);
        assert!((segment_distance(DVec3::new(3.0, 0.0, 0.0), a, b) - 1.0).abs() < 1e-12);
        assert!((segment_distance(DVec3::new(-1.0, 0.0, 0.0), a, a) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn ceiling_hole_leaves_the_rest_covered() {
        let fl = Floor {
            x0: -3.0,
            z0: -2.0,
            w: 6.0,
            d: 4.0,
            h: 3.0,
        };
        let area = |g: &geom::Geom| -> f64 {
            g.idx
                .chunks_exact(3)
                .map(|t| {
                    let [a, b, c] = [t[0], t[1], t[2]].map(|i| g.pos[i as usize]);
                    0.5 * (b - a).cross(c - a).length()
                })
                .sum()
        };
        let full = ceiling(&fl, None, 1);
        let holed = ceiling(&fl, Some((-1.0, 0.5, -0.5, 1.0)), 2);
        assert!((area(&full) - 24.0).abs() < 1e-9);
        assert!((area(&holed) - (24.0 - 1.5 * 1.5)).abs() < 1e-9);
        assert!(
            holed
                .nrm
                .iter()
                .all(|n| (*n - DVec3::NEG_Y).length() < 1e-12)
        );
    }
}
