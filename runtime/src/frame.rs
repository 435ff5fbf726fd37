//! What the game supplies each frame: the camera and the moving objects'
//! matrices, addressed by [`ObjectHandle`].

use glam::Mat4;

use crate::{CameraMatrices, Scene};

/// A moving object of one [`Renderer`] (from [`Renderer::object`] or
/// [`Renderer::objects`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ObjectHandle {
    pub(crate) renderer: u32,
    pub(crate) index: u32,
}

impl ObjectHandle {
    /// Position of the object in the scene's `dynamic_objects`.
    pub fn index(self) -> usize {
        self.index as usize
    }
}

/// What the game supplies each frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameInput<'a> {
    /// The camera (the output's aspect ratio is the caller's to match).
    pub camera: CameraMatrices,
    /// Either empty (objects stay where they are) or one world matrix per
    /// moving object, in handle order ([`ObjectHandle::index`]).
    pub transforms: &'a [Mat4],
    /// World matrices of single objects, applied after `transforms`.
    pub moved: &'a [(ObjectHandle, Mat4)],
}

impl<'a> FrameInput<'a> {
    /// A frame with `camera` and no object moved.
    pub fn new(camera: CameraMatrices) -> FrameInput<'a> {
        FrameInput {
            camera,
            transforms: &[],
            moved: &[],
        }
    }

    /// With one world matrix per moving object.
    pub fn transforms(self, transforms: &'a [Mat4]) -> FrameInput<'a> {
        FrameInput { transforms, ..self }
    }

    /// With single objects moved.
    pub fn moving(self, moved: &'a [(ObjectHandle, Mat4)]) -> FrameInput<'a> {
        FrameInput { moved, ..self }
    }
}

/// The world matrices of `scene`'s moving objects at `time` of its
/// animation, in handle order.
pub fn scene_transforms(scene: &Scene, time: f32) -> Vec<Mat4> {
    scene.dynamic_transforms(time)
}
