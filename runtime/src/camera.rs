//! The scene camera as GPU matrices. Conventions (shared with the CPU
//! reference): the camera looks down its node's −Z with +Y up, node scale is
//! ignored, the aspect ratio comes from the output size, pixel row 0 is the
//! top of the image, and the far plane is at infinity (glTF `zfar` is
//! ignored; reversed Z keeps depth precise).

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
#[error("{path}: the scene has no camera; add a camera node (the first one in the scene is used)")]
pub struct NoCamera {
    /// The scene file.
    pub path: std::path::PathBuf,
}

impl CameraMatrices {
    /// The first camera of `scene` at time `time` for a `width × height` output.
    pub fn new(
        scene: &Scene,
        time: f32,
        width: u32,
        height: u32,
    ) -> Result<CameraMatrices, NoCamera> {
        let cam = scene.camera.as_ref().ok_or_else(|| NoCamera {
            path: scene.source.clone(),
        })?;
        let world = scene.camera_transform(time).unwrap_or(Mat4::IDENTITY);
        let (_scale, rot, pos) = world.to_scale_rotation_translation();
        let rigid = Mat4::from_rotation_translation(rot.normalize(), pos);
        let view = rigid.inverse();
        let aspect = width as f32 / height.max(1) as f32;
        let (proj, orthographic) = match cam.projection {
            Projection::Perspective { yfov, znear, .. } => {
                let f = 1.0 / (0.5 * yfov).tan();
                // Infinite far plane, reversed Z: depth = znear / (−z).
                let p = Mat4::from_cols(
                    Vec4::new(f / aspect, 0.0, 0.0, 0.0),
                    Vec4::new(0.0, f, 0.0, 0.0),
                    Vec4::new(0.0, 0.0, 0.0, -1.0),
                    Vec4::new(0.0, 0.0, znear, 0.0),
                );
                (p, false)
            }
            Projection::Orthographic {
                ymag, znear, zfar, ..
            } => (
                gibake_gpu::orthographic_reversed_z(ymag * aspect, ymag, znear, zfar),
                true,
            ),
        };
        Ok(CameraMatrices {
            view_proj: proj * view,
            position: pos,
            forward: rot * -Vec3::Z,
            orthographic,
        })
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
