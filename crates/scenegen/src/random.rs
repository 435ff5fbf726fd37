//! Seeded random scenes, for judging the method on levels nobody tuned.
//!
//! [`random`] turns a seed into a scene: a room (open ground, a floor with
//! one wall, a corner of two walls, or three walls), 0–6 boxes of random
//! proportions (tall pillars and flat slabs among them) turned about +Y,
//! the bunny in half of the scenes, a standing coloured panel in some, random
//! albedos, a spot or directional light from a random direction (a quarter of
//! them grazing: 3°–15° above the floor's plane for a spot, 75°–87° from
//! vertical for a directional light), 0–20 moving balls on straight loops,
//! and a perspective camera looking into the scene from its open side.
//!
//! Nothing here is tuned to make the method look good: the ranges are what
//! a level might contain. The same seed and [`Params`] give the same bytes
//! (the generator is a 64-bit SplitMix, no platform-dependent maths beyond
//! `f64` sin/cos).

use std::f64::consts::PI;

use glam::{DMat3, DVec3};

use crate::geom;
use crate::gltf::Builder;
use crate::{LOOP_SECONDS, Params, ceil_sqrt};

/// SplitMix64 (Steele, Lea & Flood 2014): small, seedable, portable.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }

    /// Log-uniform in `[lo, hi)` (`0 < lo < hi`): every factor of 2 as likely.
    pub(crate) fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        (self.range(lo.ln(), hi.ln())).exp()
    }

    /// Uniform integer in `lo..=hi`.
    pub(crate) fn int(&mut self, lo: u32, hi: u32) -> u32 {
        lo + (self.next_u64() % u64::from(hi - lo + 1)) as u32
    }

    pub(crate) fn chance(&mut self, p: f64) -> bool {
        self.range(0.0, 1.0) < p
    }

    /// A random albedo: each channel in `[0.1, 0.9]`, some saturated.
    pub(crate) fn albedo(&mut self) -> [f32; 3] {
        let base = self.range(0.3, 0.85);
        let sat = self.range(0.0, 0.8);
        let mut c = [0f32; 3];
        for ch in &mut c {
            *ch = (base * (1.0 - sat * self.range(0.0, 1.0))).clamp(0.1, 0.9) as f32;
        }
        c
    }
}

/// What [`random`] put in a scene (for test messages).
#[derive(Clone, Debug, PartialEq)]
pub struct RandomInfo {
    /// Room kind: "ground", "wall", "corner" or "three_walls".
    pub room: &'static str,
    /// Static boxes.
    pub boxes: u32,
    /// Whether the bunny is in it.
    pub bunny: bool,
    /// Whether a standing panel is in it.
    pub panel: bool,
    /// "spot" or "directional".
    pub light: &'static str,
    /// Whether the light grazes the floor.
    pub grazing: bool,
    /// Moving balls.
    pub moving: u32,
}

impl std::fmt::Display for RandomInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} room, {} boxes{}{}, {}{} light, {} moving",
            self.room,
            self.boxes,
            if self.bunny { ", bunny" } else { "" },
            if self.panel { ", panel" } else { "" },
            if self.grazing { "grazing " } else { "" },
            self.light,
            self.moving
        )
    }
}

/// The room kinds open to the sky: "ground", "wall", "corner", "three_walls".
pub(crate) const ROOMS: [&str; 4] = ["ground", "wall", "corner", "three_walls"];

/// A random floor from `(x0, z0)` to `(−x0, −z0)` and a wall height `h`;
/// walls stand at its −X and −Z sides (and +X for three walls).
pub(crate) struct Floor {
    pub(crate) x0: f64,
    pub(crate) z0: f64,
    pub(crate) w: f64,
    pub(crate) d: f64,
    pub(crate) h: f64,
}

impl Floor {
    /// 5–11 m × 5–11 m, walls 2.5–4.5 m high.
    pub(crate) fn draw(r: &mut Rng) -> Floor {
        let (w, d) = (r.range(5.0, 11.0), r.range(5.0, 11.0));
        let h = r.range(2.5, 4.5);
        Floor {
            x0: -0.5 * w,
            z0: -0.5 * d,
            w,
            d,
            h,
        }
    }

    /// A point on the floor, `margin` inside its edges.
    pub(crate) fn point(&self, r: &mut Rng, margin: f64) -> DVec3 {
        DVec3::new(
            r.range(self.x0 + margin, -self.x0 - margin),
            0.0,
            r.range(self.z0 + margin, -self.z0 - margin),
        )
    }

    /// The floor and the walls of `room` (one of [`ROOMS`]), random albedos.
    pub(crate) fn build(&self, b: &mut Builder, r: &mut Rng, room: &str, k: u32) {
        let (x0, z0, w, d, h) = (self.x0, self.z0, self.w, self.d, self.h);
        let floor = geom::quad_facing(
            DVec3::new(x0, 0.0, z0),
            DVec3::X * w,
            DVec3::Z * d,
            k,
            DVec3::Y,
        );
        b.static_mesh("floor", &floor, r.albedo());
        if room != "ground" {
            let back = geom::quad_facing(
                DVec3::new(x0, 0.0, z0),
                DVec3::X * w,
                DVec3::Y * h,
                k,
                DVec3::Z,
            );
            b.static_mesh("wall_back", &back, r.albedo());
        }
        if room == "corner" || room == "three_walls" {
            let left = geom::quad_facing(
                DVec3::new(x0, 0.0, z0),
                DVec3::Z * d,
                DVec3::Y * h,
                k,
                DVec3::X,
            );
            b.static_mesh("wall_left", &left, r.albedo());
        }
        if room == "three_walls" {
            let right = geom::quad_facing(
                DVec3::new(-x0, 0.0, z0),
                DVec3::Z * d,
                DVec3::Y * h,
                k,
                -DVec3::X,
            );
            b.static_mesh("wall_right", &right, r.albedo());
        }
    }
}

/// The static props of a random scene: 0–6 boxes (slabs, cubes, pillars up
/// to 0.9 of the wall height) turned about +Y, the bunny in half of the
/// scenes, a standing saturated panel in about a third.
pub(crate) struct Props {
    pub(crate) boxes: u32,
    pub(crate) bunny: bool,
    pub(crate) panel: bool,
    /// World bounds `(min, max)` of every prop, at scale 1.
    pub(crate) bounds: Vec<(DVec3, DVec3)>,
}

impl Props {
    /// Draws the props and adds them to `b` as static meshes.
    pub(crate) fn add(b: &mut Builder, r: &mut Rng, fl: &Floor, k: u32) -> Props {
        let mut bounds = Vec::new();
        let mut add = |b: &mut Builder, name: &str, g: &geom::Geom, rgb: [f32; 3]| {
            bounds.push(geom::bounds(&g.pos));
            b.static_mesh(name, g, rgb);
        };
        let boxes = r.int(0, 6);
        for i in 0..boxes {
            let sx = r.range(0.3, 2.0);
            let sz = r.range(0.3, 2.0);
            // Flat slabs, cubes and tall pillars.
            let sy = match r.int(0, 2) {
                0 => r.range(0.15, 0.5),
                1 => r.range(0.5, 1.5),
                _ => r.range(1.5, 0.9 * fl.h),
            };
            let c = fl.point(r, 1.2);
            let yaw = r.range(0.0, PI);
            let g = geom::aabox(
                DVec3::new(-0.5 * sx, 0.0, -0.5 * sz),
                DVec3::new(0.5 * sx, sy, 0.5 * sz),
                k,
                false,
            )
            .rotated_translated(DMat3::from_rotation_y(yaw), c);
            add(b, &format!("box_{i}"), &g, r.albedo());
        }
        let bunny = r.chance(0.5);
        if bunny {
            let c = fl.point(r, 1.0);
            let g = geom::bunny(r.range(0.5, 1.5), r.range(0.0, 2.0 * PI), c.x, c.z);
            add(b, "bunny", &geom::subdivide(g, k.ilog2() / 2), r.albedo());
        }
        let panel = r.chance(0.35);
        if panel {
            // A standing coloured panel (saturated), facing a random way.
            let c = fl.point(r, 1.0);
            let yaw = r.range(0.0, 2.0 * PI);
            let u = DVec3::new(yaw.cos(), 0.0, yaw.sin()) * r.range(0.8, 2.5);
            // A thin slab (2 cm), so both sides are real surfaces.
            let g = geom::aabox(
                DVec3::new(-0.5 * u.length(), 0.0, -0.01),
                DVec3::new(0.5 * u.length(), r.range(0.6, 2.0), 0.01),
                k,
                false,
            )
            .rotated_translated(DMat3::from_rotation_y(-yaw), c);
            let hue = r.int(0, 2) as usize;
            let mut rgb = [0.08f32; 3];
            rgb[hue] = r.range(0.6, 0.9) as f32;
            add(b, "panel", &g, rgb);
        }
        Props {
            boxes,
            bunny,
            panel,
            bounds,
        }
    }
}

/// A moving ball's radius and the two ends of its straight loop, between
/// its radius and `top` metres above the floor.
pub(crate) fn ball_path(r: &mut Rng, fl: &Floor, top: f64) -> (f64, DVec3, DVec3) {
    let rad = r.range(0.08, 0.35);
    let a = fl.point(r, 0.8) + DVec3::Y * r.range(rad, top);
    let bpos = fl.point(r, 0.8) + DVec3::Y * r.range(rad, top);
    (rad, a, bpos)
}

/// Moving ball `ball_NN` (random albedo) going from `a` to `bpos` and back
/// once per loop (LINEAR keys at 0, half and the whole loop).
pub(crate) fn add_ball(b: &mut Builder, r: &mut Rng, i: u32, rad: f64, a: DVec3, bpos: DVec3) {
    let name = format!("ball_{i:02}");
    let g = b.geometry(&geom::uv_sphere(DVec3::ZERO, rad, 16, 10));
    let mat = b.material(&name, r.albedo());
    let mesh = b.mesh(&name, g, mat);
    let times = [0.0, 0.5 * LOOP_SECONDS, LOOP_SECONDS];
    b.dynamic_mesh(&name, mesh, &times, &[a, bpos, a]);
}

/// The camera of an open room, from its open side, looking toward `target`
/// (a point of the floor) and the middle of the floor.
pub(crate) fn outside_camera(b: &mut Builder, r: &mut Rng, room: &str, fl: &Floor, target: DVec3) {
    let cam_dir = open_side(room, r.range(15.0, 75.0).to_radians());
    let reach = 0.5 * fl.w.max(fl.d) + r.range(1.5, 4.0);
    let eye = cam_dir * reach + DVec3::Y * r.range(1.5, 4.0);
    // Toward the lit part of the level, between the light's target and the
    // middle of the floor.
    let look = target + DVec3::new(fl.x0 * 0.15, r.range(0.3, 1.0), fl.z0 * 0.15);
    b.perspective(
        "camera",
        eye,
        look,
        r.range(50.0, 65.0).to_radians(),
        0.05,
        100.0,
    );
}

/// The scene of `seed` (GLB bytes) and what it contains. `p.scale` scales it
/// as for the bundled scenes; `p.heavy` tessellates its planar faces.
pub fn random(seed: u64, p: &Params) -> (Vec<u8>, RandomInfo) {
    let mut r = Rng(seed ^ 0x6769_6261_6b65_0000);
    let mut b = Builder::new(p.s(), "motion");
    let k = ceil_sqrt(u64::from(p.heavy()));

    let fl = Floor::draw(&mut r);
    let room = ROOMS[r.int(0, 3) as usize];
    fl.build(&mut b, &mut r, room, k);
    let props = Props::add(&mut b, &mut r, &fl, k);

    // The light, aimed at a point of the floor.
    let target = fl.point(&mut r, 1.0);
    let grazing = r.chance(0.25);
    let az = r.range(0.0, 2.0 * PI);
    let spot = r.chance(0.5);
    if spot {
        // Elevation above the floor plane, seen from the target.
        let elev = if grazing {
            r.range(3.0, 15.0)
        } else {
            r.range(25.0, 80.0)
        }
        .to_radians();
        let dist = r.range(3.0, 7.0);
        // Keep the light over the open side of walled rooms.
        let dir_xz = open_side(room, az);
        let pos = target + (dir_xz * elev.cos() + DVec3::Y * elev.sin()) * dist;
        let outer = r.range(20.0, 55.0).to_radians();
        let inner = outer * r.range(0.5, 0.95);
        // About 3 W/m² at the target, whatever the distance.
        let intensity = 3.0 * dist * dist;
        b.spot(
            "spot",
            pos,
            target - pos,
            [1.0, r.range(0.85, 1.0) as f32, r.range(0.75, 1.0) as f32],
            intensity,
            inner,
            outer,
        );
    } else {
        let tilt = if grazing {
            r.range(75.0, 87.0)
        } else {
            r.range(10.0, 65.0)
        }
        .to_radians();
        let o = open_side(room, az);
        let dir = DVec3::new(-tilt.sin() * o.x, -tilt.cos(), -tilt.sin() * o.z);
        b.directional(
            "sun",
            target - dir * 10.0,
            dir,
            [1.0, r.range(0.85, 1.0) as f32, r.range(0.75, 1.0) as f32],
            r.range(1.5, 4.0),
        );
    }

    // Moving balls on straight back-and-forth loops.
    let moving = if r.chance(0.3) { 0 } else { r.int(1, 20) };
    for i in 0..moving {
        let (rad, a, bpos) = ball_path(&mut r, &fl, 1.8);
        add_ball(&mut b, &mut r, i, rad, a, bpos);
    }

    outside_camera(&mut b, &mut r, room, &fl, target);

    let info = RandomInfo {
        room,
        boxes: props.boxes,
        bunny: props.bunny,
        panel: props.panel,
        light: if spot { "spot" } else { "directional" },
        grazing,
        moving,
    };
    (b.finish(), info)
}

/// A horizontal unit direction toward the room's open side for the angle
/// `az`: the +X/+Z quadrant, or about +Z in a three-walled room (whose right
/// wall closes +X).
pub(crate) fn open_side(room: &str, az: f64) -> DVec3 {
    if room == "three_walls" {
        DVec3::new(0.4 * az.cos(), 0.0, 1.0).normalize()
    } else {
        DVec3::new(az.cos().abs(), 0.0, az.sin().abs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_bytes_and_seeds_differ() {
        let p = Params::default();
        assert_eq!(random(7, &p).0, random(7, &p).0);
        assert_ne!(random(7, &p).0, random(8, &p).0);
    }

    #[test]
    fn seeds_cover_the_cases() {
        let infos: Vec<RandomInfo> = (0..40).map(|s| random(s, &Params::default()).1).collect();
        assert!(infos.iter().any(|i| i.light == "spot"));
        assert!(infos.iter().any(|i| i.light == "directional"));
        assert!(infos.iter().any(|i| i.grazing));
        assert!(infos.iter().any(|i| i.moving == 0));
        assert!(infos.iter().any(|i| i.moving > 10));
        assert!(infos.iter().any(|i| i.bunny));
        for room in ["ground", "wall", "corner", "three_walls"] {
            assert!(infos.iter().any(|i| i.room == room), "{room}");
        }
    }
}
