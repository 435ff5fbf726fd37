//! Camera rays, with exactly the conventions the GPU renderer uses.
//!
//! The glTF camera looks down its local −Z with +Y up; its node's world
//! matrix gives rotation and translation (scale is ignored). For output size
//! `W × H` (aspect = W/H, never the file's `aspectRatio`) a sample at pixel
//! position `(px, py)` (pixel `(x, y)` covers `[x, x+1) × [y, y+1)`, `y = 0` is
//! the top row) has `ndc_x = 2·px/W − 1`, `ndc_y = 1 − 2·py/H`.
//! - Perspective: `dir_cam = normalize(ndc_x·tan(yfov/2)·aspect, ndc_y·tan(yfov/2), −1)`
//!   from the camera position; the ray starts at the near plane `z = −znear`
//!   (`t_min = znear / |dir_cam.z|`); `zfar` is ignored.
//! - Orthographic: `origin_cam = (ndc_x·ymag·aspect, ndc_y·ymag, 0)`,
//!   `dir_cam = (0, 0, −1)`, `t_min = znear`; `xmag` and `zfar` are ignored.

use gibake_scene::{Projection, Scene};
use glam::{Mat3, Mat4, Quat, Vec3};

use crate::ReferenceError;

/// A camera pose and projection at one time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// World position of the eye (the node's translation).
    pub position: Vec3,
    /// World rotation of the camera node (camera looks down its −Z).
    pub rotation: Quat,
    /// Projection parameters (aspect comes from the output size).
    pub projection: Projection,
}

impl View {
    /// The same view of the scene scaled by `s` about the origin: the eye
    /// moves with it, a perspective camera's near plane scales (its far
    /// plane and field of view stay), an orthographic one is unchanged
    /// (scale invariance tests).
    pub fn scaled(&self, s: f32) -> View {
        let projection = match self.projection {
            Projection::Perspective { yfov, znear, zfar } => Projection::Perspective {
                yfov,
                znear: znear * s,
                zfar,
            },
            p => p,
        };
        View {
            position: self.position * s,
            rotation: self.rotation,
            projection,
        }
    }

    /// The scene camera at `time` seconds; an error if the scene has none.
    pub fn from_scene(scene: &Scene, time: f32) -> Result<View, ReferenceError> {
        let camera = scene
            .camera
            .as_ref()
            .ok_or_else(|| ReferenceError::NoCamera {
                path: scene.source.clone(),
            })?;
        let m = scene.camera_transform(time).unwrap_or(Mat4::IDENTITY);
        Ok(View::from_matrix(m, camera.projection))
    }

    /// A view from a node world matrix (rotation and translation used, scale ignored).
    pub fn from_matrix(world: Mat4, projection: Projection) -> View {
        let (_scale, rotation, translation) = world.to_scale_rotation_translation();
        let rotation = if rotation.is_finite() && rotation.length_squared() > 0.0 {
            rotation.normalize()
        } else {
            Quat::IDENTITY
        };
        View {
            position: translation,
            rotation,
            projection,
        }
    }

    /// A camera at `eye` looking at `target` with `up` roughly up.
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3, projection: Projection) -> View {
        let f = (target - eye).normalize();
        let r = f.cross(up).normalize();
        let u = r.cross(f);
        let rotation = Quat::from_mat3(&Mat3::from_cols(r, u, -f)).normalize();
        View {
            position: eye,
            rotation,
            projection,
        }
    }

    /// World-space unit forward direction (the camera's −Z).
    pub fn forward(&self) -> Vec3 {
        self.rotation * Vec3::NEG_Z
    }

    /// World-space up direction (the camera's +Y).
    pub fn up(&self) -> Vec3 {
        self.rotation * Vec3::Y
    }

    /// The primary ray through image position `(px, py)` (pixels, `y` down)
    /// of a `width × height` image: `(origin, unit direction, t_min)`.
    pub fn primary_ray(&self, width: u32, height: u32, px: f32, py: f32) -> (Vec3, Vec3, f32) {
        let aspect = width as f32 / height as f32;
        let ndc_x = 2.0 * px / width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * py / height as f32;
        match self.projection {
            Projection::Perspective { yfov, znear, .. } => {
                let th = (0.5 * yfov).tan();
                let d = Vec3::new(ndc_x * th * aspect, ndc_y * th, -1.0).normalize();
                let t_min = znear.max(0.0) / d.z.abs();
                let dir = (self.rotation * d).normalize();
                (self.position, dir, t_min)
            }
            Projection::Orthographic { ymag, znear, .. } => {
                let o = Vec3::new(ndc_x * ymag * aspect, ndc_y * ymag, 0.0);
                let origin = self.position + self.rotation * o;
                let dir = (self.rotation * Vec3::NEG_Z).normalize();
                (origin, dir, znear.max(0.0))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_and_centre_ray() {
        let proj = Projection::Perspective {
            yfov: 1.0,
            znear: 0.1,
            zfar: None,
        };
        let v = View::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, proj);
        assert!((v.forward() - Vec3::NEG_Z).length() < 1e-6);
        let (o, d, tmin) = v.primary_ray(4, 2, 2.0, 1.0);
        assert_eq!(o, Vec3::new(0.0, 0.0, 5.0));
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        assert!((tmin - 0.1).abs() < 1e-7);
        // Top-left corner: up and to the left, aspect 2.
        let (_, d, _) = v.primary_ray(4, 2, 0.0, 0.0);
        let t = 0.5f32.tan();
        let e = Vec3::new(-t * 2.0, t, -1.0).normalize();
        assert!((d - e).length() < 1e-6, "{d} vs {e}");
    }

    #[test]
    fn orthographic_rays() {
        let proj = Projection::Orthographic {
            xmag: 9.0,
            ymag: 2.0,
            znear: 0.5,
            zfar: 10.0,
        };
        let v = View::look_at(Vec3::new(0.0, 10.0, 0.0), Vec3::ZERO, Vec3::Z, proj);
        let (o, d, tmin) = v.primary_ray(2, 2, 2.0, 0.0); // right, top corner
        assert!((d - Vec3::NEG_Y).length() < 1e-6);
        assert_eq!(tmin, 0.5);
        // camera right = f × up = (−Y) × Z = −X; camera up = Z.
        assert!((o - Vec3::new(-2.0, 10.0, 2.0)).length() < 1e-5, "{o}");
    }
}
