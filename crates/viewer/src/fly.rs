//! The fly camera: a position, a yaw and a pitch, moved by WASD (and Q/E
//! down/up) at a speed scaled to the level, turned by the mouse. It starts
//! where the scene's camera is; until it is moved the viewer keeps the
//! scene's own (animated) camera, so an untouched view renders exactly what
//! `gibake render` renders.

use gibake_runtime::CameraMatrices;
use glam::{EulerRot, Mat4, Quat, Vec3};

/// Radians per pixel of mouse motion.
pub const MOUSE_RADIANS_PER_PIXEL: f32 = 0.003;

/// Which movement keys are held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Held {
    /// W.
    pub forward: bool,
    /// S.
    pub back: bool,
    /// A.
    pub left: bool,
    /// D.
    pub right: bool,
    /// E.
    pub up: bool,
    /// Q.
    pub down: bool,
    /// Shift: four times faster.
    pub fast: bool,
}

impl Held {
    /// Whether any movement key is held.
    pub fn any(&self) -> bool {
        self.forward || self.back || self.left || self.right || self.up || self.down
    }
}

/// A perspective camera flying through the level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlyCamera {
    /// Eye position (world).
    pub position: Vec3,
    /// Turn about +Y, radians (0 looks down −Z).
    pub yaw: f32,
    /// Up/down, radians, within ±89°.
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub yfov: f32,
    /// Near plane.
    pub znear: f32,
    /// World units per second.
    pub speed: f32,
}

impl FlyCamera {
    /// A camera at `camera_to_world` (looking down its −Z; scale and roll
    /// ignored).
    pub fn from_transform(camera_to_world: Mat4, yfov: f32, znear: f32, speed: f32) -> FlyCamera {
        let (_, rot, position) = camera_to_world.to_scale_rotation_translation();
        let f = (rot.normalize() * -Vec3::Z).normalize_or(-Vec3::Z);
        FlyCamera {
            position,
            yaw: (-f.x).atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin(),
            yfov,
            znear,
            speed,
        }
    }

    /// Looking from `eye` at `target`.
    pub fn look_at(eye: Vec3, target: Vec3, yfov: f32, znear: f32, speed: f32) -> FlyCamera {
        let f = (target - eye).normalize_or(-Vec3::Z);
        FlyCamera {
            position: eye,
            yaw: (-f.x).atan2(-f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin(),
            yfov,
            znear,
            speed,
        }
    }

    fn rotation(&self) -> Quat {
        Quat::from_euler(EulerRot::YXZ, self.yaw, self.pitch, 0.0)
    }

    /// The view direction.
    pub fn forward(&self) -> Vec3 {
        self.rotation() * -Vec3::Z
    }

    /// Camera → world.
    pub fn transform(&self) -> Mat4 {
        Mat4::from_rotation_translation(self.rotation(), self.position)
    }

    /// Turns by a mouse motion of `(dx, dy)` pixels (right and down
    /// positive).
    pub fn turn(&mut self, dx: f64, dy: f64) {
        self.yaw -= dx as f32 * MOUSE_RADIANS_PER_PIXEL;
        let limit = 89f32.to_radians();
        self.pitch = (self.pitch - dy as f32 * MOUSE_RADIANS_PER_PIXEL).clamp(-limit, limit);
    }

    /// Moves for `dt` seconds with the keys `held` (forward along the view,
    /// sideways in the horizontal plane, up along +Y).
    pub fn fly(&mut self, held: Held, dt: f32) {
        let fwd = self.forward();
        let right = fwd.cross(Vec3::Y).normalize_or(Vec3::X);
        let axis = |p: bool, n: bool| (p as i32 - n as i32) as f32;
        let d = fwd * axis(held.forward, held.back)
            + right * axis(held.right, held.left)
            + Vec3::Y * axis(held.up, held.down);
        let speed = self.speed * if held.fast { 4.0 } else { 1.0 };
        self.position += d.normalize_or_zero() * speed * dt;
    }

    /// The runtime's matrices for an output of `aspect` = width / height.
    pub fn matrices(&self, aspect: f32) -> CameraMatrices {
        CameraMatrices::perspective(self.transform(), self.yfov, aspect, self.znear)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_transform_round_trips_through_yaw_and_pitch() {
        let eye = Vec3::new(1.0, 2.0, 3.0);
        let cam = FlyCamera::look_at(eye, Vec3::new(-2.0, 0.5, -1.0), 1.0, 0.1, 1.0);
        let again = FlyCamera::from_transform(cam.transform(), 1.0, 0.1, 1.0);
        assert!((again.yaw - cam.yaw).abs() < 1e-5, "{again:?} vs {cam:?}");
        assert!((again.pitch - cam.pitch).abs() < 1e-5);
        assert!(again.position.abs_diff_eq(eye, 1e-6));
        let want = (Vec3::new(-2.0, 0.5, -1.0) - eye).normalize();
        assert!(cam.forward().abs_diff_eq(want, 1e-5), "{}", cam.forward());
        // The matrices see the target at the centre of the image.
        let m = cam.matrices(1.5);
        let c = m.view_proj.project_point3(Vec3::new(-2.0, 0.5, -1.0));
        assert!(c.x.abs() < 1e-4 && c.y.abs() < 1e-4, "{c}");
    }

    #[test]
    fn keys_move_along_the_view_and_mouse_turns_within_limits() {
        let mut cam = FlyCamera::look_at(Vec3::ZERO, -Vec3::Z, 1.0, 0.1, 2.0);
        let w = Held {
            forward: true,
            ..Held::default()
        };
        cam.fly(w, 0.5);
        assert!(cam.position.abs_diff_eq(Vec3::new(0.0, 0.0, -1.0), 1e-6));
        let d = Held {
            right: true,
            fast: true,
            ..Held::default()
        };
        cam.fly(d, 0.25);
        assert!(
            cam.position.abs_diff_eq(Vec3::new(2.0, 0.0, -1.0), 1e-5),
            "{}",
            cam.position
        );
        cam.turn(0.0, -1e6);
        assert!((cam.pitch - 89f32.to_radians()).abs() < 1e-6);
        assert!(!Held::default().any() && w.any());
    }
}
