//! What the game supplies each frame: the cameras and the moving objects'
//! matrices, addressed by [`ObjectHandle`].

use glam::Mat4;

use crate::{CameraMatrices, Scene, ViewId};

/// A moving object of one [`crate::Renderer`] (from
/// [`crate::Renderer::object`] or [`crate::Renderer::objects`]). It stays
/// valid across [`crate::Renderer::set_asset`] when the moving objects are
/// the same, and dies with [`crate::Renderer::remove`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ObjectHandle {
    pub(crate) renderer: u32,
    pub(crate) index: u32,
}

impl ObjectHandle {
    /// Position of the object in the scene's `dynamic_objects` (spawned
    /// copies follow them, in spawn order).
    pub fn index(self) -> usize {
        self.index as usize
    }
}

/// What the game supplies each frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameInput<'a> {
    /// The camera (the output's aspect ratio is the caller's to match).
    pub camera: CameraMatrices,
    /// Either empty (objects stay where they are), or one world matrix per
    /// moving object in handle order ([`ObjectHandle::index`]), or one per
    /// object the scene declares (spawned copies stay where they are).
    pub transforms: &'a [Mat4],
    /// World matrices of single objects, applied after `transforms`.
    pub moved: &'a [(ObjectHandle, Mat4)],
    /// Cameras of the other views ([`crate::Renderer::add_view`]); a view
    /// not listed keeps its last camera.
    pub views: &'a [(ViewId, CameraMatrices)],
}

impl<'a> FrameInput<'a> {
    /// A frame with `camera` (the main view's) and no object moved.
    pub fn new(camera: CameraMatrices) -> FrameInput<'a> {
        FrameInput {
            camera,
            transforms: &[],
            moved: &[],
            views: &[],
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

    /// With the cameras of other views.
    pub fn views(self, views: &'a [(ViewId, CameraMatrices)]) -> FrameInput<'a> {
        FrameInput { views, ..self }
    }
}

/// The world matrices of `scene`'s moving objects at `time` of its
/// animation, in handle order.
pub fn scene_transforms(scene: &Scene, time: f32) -> Vec<Mat4> {
    scene.dynamic_transforms(time)
}
