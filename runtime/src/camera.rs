//! The per-frame camera as GPU matrices: a game's own
//! ([`CameraMatrices::perspective`], [`CameraMatrices::orthographic`]) or a
//! glTF scene's ([`CameraMatrices::from_scene`]). Conventions (shared with
//! the CPU reference): the camera looks down its −Z with +Y up, pixel row 0
//! is the top of the image, depth is reversed Z (near → 1), and a
//! perspective far plane is at infinity (glTF `zfar` is ignored).

use gibake_scene::{Projection, Scene};
use glam::{Mat4, Vec3, Vec4};

/// Camera matrices for one frame.
#[derive(Clone, Copy, Debug)]
pub struct CameraMatrices {
    /// World → clip (reversed Z).
    pub view_proj: Mat4,
    /// Eye position (perspective) in world space.
    pub position: Vec3,
    /// Unit view direction (−Z of the camera node).
    pub forward: Vec3,
    /// True for orthographic cameras.
    pub orthographic: bool,
}

/// Why a camera could not be built.
#[derive(Debug, thiserror::Error)]
#[error(
    "{path}: the scene has no camera; add a camera node (the first one in the scene is used) or pass one per frame"
)]
pub struct NoCamera {
    /// The scene file.
    pub path: std::path::PathBuf,
}

impl CameraMatrices {
    /// A perspective camera at `camera_to_world` (a rigid transform: the
    /// camera looks down its −Z with +Y up), vertical field of view `yfov`
    /// (radians), `aspect` = width / height, near plane `znear`; infinite far
    /// plane, reversed Z.
    pub fn perspective(camera_to_world: Mat4, yfov: f32, aspect: f32, znear: f32) -> Self {
        let f = 1.0 / (0.5 * yfov).tan();
        // Infinite far plane, reversed Z: depth = znear / (−z).
        let proj = Mat4::from_cols(
            Vec4::new(f / aspect, 0.0, 0.0, 0.0),
            Vec4::new(0.0, f, 0.0, 0.0),
            Vec4::new(0.0, 0.0, 0.0, -1.0),
            Vec4::new(0.0, 0.0, znear, 0.0),
        );
        Self::with_projection(camera_to_world, proj, false)
    }

    /// An orthographic camera at `camera_to_world` seeing `2·ymag` world
    /// units vertically (`2·ymag·aspect` horizontally) between `znear` and
    /// `zfar`; reversed Z.
    pub fn orthographic(
        camera_to_world: Mat4,
        ymag: f32,
        aspect: f32,
        znear: f32,
        zfar: f32,
    ) -> Self {
        let proj = gibake_gpu::orthographic_reversed_z(ymag * aspect, ymag, znear, zfar);
        Self::with_projection(camera_to_world, proj, true)
    }

    fn with_projection(camera_to_world: Mat4, proj: Mat4, orthographic: bool) -> Self {
        let (_scale, rot, pos) = camera_to_world.to_scale_rotation_translation();
        let view = Mat4::from_rotation_translation(rot.normalize(), pos).inverse();
        CameraMatrices {
            view_proj: proj * view,
            position: pos,
            forward: rot * -Vec3::Z,
            orthographic,
        }
    }

    /// The first camera of `scene` at time `time` for a `width × height`
    /// output (node scale ignored).
    pub fn from_scene(
        scene: &Scene,
        time: f32,
        width: u32,
        height: u32,
    ) -> Result<CameraMatrices, NoCamera> {
        let cam = scene.camera.as_ref().ok_or_else(|| NoCamera {
            path: scene.source.clone(),
        })?;
        let world = scene.camera_transform(time).unwrap_or(Mat4::IDENTITY);
        let aspect = width as f32 / height.max(1) as f32;
        Ok(match cam.projection {
            Projection::Perspective { yfov, znear, .. } => {
                Self::perspective(world, yfov, aspect, znear)
            }
            Projection::Orthographic {
                ymag, znear, zfar, ..
            } => Self::orthographic(world, ymag, aspect, znear, zfar),
        })
    }

    /// Clip → world: the inverse of `view_proj`, inverted in f64 (shading
    /// rebuilds each G-buffer sample's world position from its depth with
    /// it).
    pub fn inv_view_proj(&self) -> Mat4 {
        self.view_proj.as_dmat4().inverse().as_mat4()
    }

    /// GPU layout.
    pub fn to_gpu(&self) -> GpuCamera {
        GpuCamera {
            view_proj: self.view_proj.to_cols_array_2d(),
            position: self
                .position
                .extend(if self.orthographic { 1.0 } else { 0.0 })
                .to_array(),
            forward: self.forward.extend(0.0).to_array(),
        }
    }
}

/// Must match `Camera` in `gbuffer.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuCamera {
    /// World → clip.
    pub view_proj: [[f32; 4]; 4],
    /// xyz eye; w = 1 orthographic.
    pub position: [f32; 4],
    /// xyz forward.
    pub forward: [f32; 4],
}
