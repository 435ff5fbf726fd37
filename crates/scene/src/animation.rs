//! Node hierarchy and glTF animation sampling (translation / rotation / scale
//! channels; LINEAR, STEP and CUBICSPLINE; each animation clamped to its own
//! time range). Morph-target weights are ignored.

use glam::{Mat4, Quat, Vec3};

/// A local transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trs {
    /// Translation.
    pub translation: Vec3,
    /// Rotation (unit quaternion).
    pub rotation: Quat,
    /// Scale.
    pub scale: Vec3,
}

/// Samples world matrices of glTF nodes at any time.
#[derive(Clone, Debug, Default)]
pub struct Animator {
    // Implementation detail: parents, rest TRS per node, channels.
}

impl Animator {
    /// World matrix of `node` at time `t` seconds.
    pub fn world_matrix(&self, node: usize, t: f32) -> Mat4 {
        let _ = (node, t);
        todo!()
    }

    /// Whether `node` or one of its ancestors is targeted by an animation channel.
    pub fn is_animated(&self, node: usize) -> bool {
        let _ = node;
        todo!()
    }

    /// `(start, end)` of all animations together, `None` if there are none.
    pub fn time_range(&self) -> Option<(f32, f32)> {
        todo!()
    }

    /// Times covering the whole animation range: every keyframe time plus at
    /// least `min_steps` evenly spaced samples; `[0.0]` with no animation.
    pub fn sample_times(&self, min_steps: usize) -> Vec<f32> {
        let _ = min_steps;
        todo!()
    }
}
