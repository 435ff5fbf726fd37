//! Animation channels: reads glTF animation samplers (times, values,
//! interpolation) into the [`Channel`]s the scene's `Animator` samples.
//! Channels that target no node or a path glTF 2.0 does not define (what
//! an extension such as `KHR_animation_pointer` animates) are ignored with
//! one warning per animation.

use glam::{Vec3, Vec4};
use gltf::json;
use gltf::json::validation::Checked;

use super::Ctx;
use crate::SceneError;
use crate::animation::{Channel, ChannelPath, Interpolation};

impl<'a> Ctx<'a> {
    pub(super) fn channels(&mut self) -> Result<Vec<Channel>, SceneError> {
        let mut out = Vec::new();
        let root = self.root;
        for (ai, anim) in root.animations.iter().enumerate() {
            let aname = match &anim.name {
                Some(n) => format!("animation '{n}'"),
                None => format!("animation #{ai}"),
            };
            let mut warned_weights = false;
            let mut foreign = Vec::new();
            for (ci, ch) in anim.channels.iter().enumerate() {
                let what = format!("{aname} channel {ci}");
                // A channel without a target node, or with a path glTF 2.0
                // does not define, animates what an extension names (e.g.
                // KHR_animation_pointer's "pointer"): ignored.
                if self.nodeless_channels.contains(&(ai, ci))
                    || matches!(ch.target.path, Checked::Invalid)
                {
                    foreign.push(ci.to_string());
                    continue;
                }
                let path = match ch.target.path {
                    Checked::Valid(json::animation::Property::Translation) => {
                        ChannelPath::Translation
                    }
                    Checked::Valid(json::animation::Property::Rotation) => ChannelPath::Rotation,
                    Checked::Valid(json::animation::Property::Scale) => ChannelPath::Scale,
                    Checked::Valid(json::animation::Property::MorphTargetWeights) => {
                        if !warned_weights {
                            warned_weights = true;
                            self.warn(format!("{aname}: morph target weight channels are ignored"));
                        }
                        continue;
                    }
                    Checked::Invalid => continue,
                };
                let node = ch.target.node.value();
                if node >= root.nodes.len() {
                    return Err(self.invalid(format!("{what}: target node {node} does not exist")));
                }
                let sampler = anim.samplers.get(ch.sampler.value()).ok_or_else(|| {
                    self.invalid(format!(
                        "{what}: sampler {} does not exist",
                        ch.sampler.value()
                    ))
                })?;
                let interpolation = match sampler.interpolation {
                    Checked::Valid(json::animation::Interpolation::Linear) => Interpolation::Linear,
                    Checked::Valid(json::animation::Interpolation::Step) => Interpolation::Step,
                    Checked::Valid(json::animation::Interpolation::CubicSpline) => {
                        Interpolation::CubicSpline
                    }
                    Checked::Invalid => {
                        return Err(self.not_supported(format!(
                            "{what}: sampler {} has an interpolation glTF 2.0 does not define (LINEAR, STEP, CUBICSPLINE)",
                            ch.sampler.value()
                        )));
                    }
                };
                let (times, n) = self
                    .read_floats(sampler.input.value(), 1)
                    .map_err(|e| self.invalid(format!("{what}: input: {e}")))?;
                if n == 0 {
                    return Err(self.invalid(format!("{what}: no keyframes")));
                }
                if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0]) {
                    return Err(self.invalid(format!(
                        "{what}: keyframe times (accessor {}) must be finite and increasing",
                        sampler.input.value()
                    )));
                }
                let dims = if path == ChannelPath::Rotation { 4 } else { 3 };
                let (vals, m) = self
                    .read_floats(sampler.output.value(), dims)
                    .map_err(|e| self.invalid(format!("{what}: output: {e}")))?;
                let expected = if interpolation == Interpolation::CubicSpline {
                    3 * n
                } else {
                    n
                };
                if m != expected {
                    return Err(self.invalid(format!(
                        "{what}: output accessor {} has {m} elements, expected {expected} for {n} keyframes",
                        sampler.output.value()
                    )));
                }
                if vals.iter().any(|v| !v.is_finite()) {
                    return Err(self.invalid(format!(
                        "{what}: output accessor {} holds non-finite values",
                        sampler.output.value()
                    )));
                }
                let values: Vec<Vec4> = vals
                    .chunks_exact(dims)
                    .map(|c| {
                        if dims == 4 {
                            Vec4::from_slice(c)
                        } else {
                            Vec3::from_slice(c).extend(0.0)
                        }
                    })
                    .collect();
                out.push(Channel {
                    node,
                    path,
                    interpolation,
                    times,
                    values,
                    animation: ai,
                });
            }
            if !foreign.is_empty() {
                let n = foreign.len();
                let mut list = foreign[..n.min(8)].join(", ");
                if n > 8 {
                    list.push_str(&format!(", … ({n} in all)"));
                }
                self.warn(format!(
                    "{aname}: channel(s) {list} ignored: no target node, or a target path other than translation, rotation, scale and weights (an extension's, such as KHR_animation_pointer)"
                ));
            }
        }
        Ok(out)
    }
}
