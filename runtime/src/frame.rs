//! What the game supplies each frame: the cameras and the moving objects'
//! matrices, addressed by [`ObjectHandle`].

use std::sync::atomic::{AtomicU32, Ordering};

use glam::Mat4;

use crate::{CameraMatrices, RuntimeError, Scene, ViewId};

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

/// The moving objects of a renderer: the scene's declared ones, then the
/// spawned copies.
pub(crate) struct Objects {
    /// Handle namespace (a new one when the objects change).
    pub id: u32,
    /// How many the scene declares.
    pub declared: usize,
    pub names: Vec<String>,
    /// The declared object each is drawn as.
    pub template: Vec<usize>,
    pub transforms: Vec<Mat4>,
    /// Shown (not hidden, not removed).
    pub shown: Vec<bool>,
    pub removed: Vec<bool>,
}

static NEXT_ID: AtomicU32 = AtomicU32::new(0);

impl Objects {
    pub(crate) fn of(scene: &Scene) -> Objects {
        let n = scene.dynamic_objects.len();
        Objects {
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            declared: n,
            names: scene
                .dynamic_objects
                .iter()
                .map(|o| o.name.clone())
                .collect(),
            template: (0..n).collect(),
            transforms: scene_transforms(scene, 0.0),
            shown: vec![true; n],
            removed: vec![false; n],
        }
    }

    /// The index of a live handle of these objects.
    pub(crate) fn index(&self, h: ObjectHandle) -> Result<usize, RuntimeError> {
        let i = h.index();
        if h.renderer != self.id || i >= self.names.len() || self.removed[i] {
            return Err(RuntimeError::UnknownObject(h));
        }
        Ok(i)
    }
}
