//! Node hierarchy and glTF animation sampling (translation / rotation / scale
//! channels; LINEAR, STEP and CUBICSPLINE; each animation clamped to its own
//! time range). Morph-target weights are ignored.
//!
//! Sampling allocates nothing: [`Animator::world_matrix`] walks up the parent
//! chain and evaluates the channels of each node in place, so it can be called
//! per frame per object.

use glam::{Mat4, Quat, Vec3, Vec4};

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

impl Trs {
    /// The identity transform.
    pub const IDENTITY: Trs = Trs {
        translation: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        scale: Vec3::ONE,
    };

    /// `T · R · S` as a matrix.
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

impl Default for Trs {
    fn default() -> Self {
        Trs::IDENTITY
    }
}

/// Which part of a node's transform a channel drives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ChannelPath {
    Translation,
    Rotation,
    Scale,
}

/// glTF sampler interpolation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Interpolation {
    Linear,
    Step,
    CubicSpline,
}

/// One animation channel with its sampler data, validated at import.
#[derive(Clone, Debug)]
pub(crate) struct Channel {
    /// Target node.
    pub node: usize,
    /// Target property.
    pub path: ChannelPath,
    /// Interpolation.
    pub interpolation: Interpolation,
    /// Key times, finite and non-decreasing, at least one.
    pub times: Vec<f32>,
    /// Output values, 4 floats per element (vec3 padded with 0). One element
    /// per key, or three (in-tangent, value, out-tangent) for CUBICSPLINE.
    pub values: Vec<Vec4>,
    /// Index of the animation this channel belongs to.
    pub animation: usize,
}

/// Per-node data.
#[derive(Clone, Debug)]
struct NodeData {
    parent: Option<usize>,
    /// The node's rest local matrix (exact, even if it has shear).
    rest_matrix: Mat4,
    /// The rest transform decomposed (used as the base when channels override parts).
    rest: Trs,
    /// `channels[first..first + count]` target this node (channels are sorted by node).
    first_channel: usize,
    channel_count: usize,
    /// This node or an ancestor is targeted by a channel.
    animated: bool,
}

/// Samples world matrices of glTF nodes at any time.
#[derive(Clone, Debug, Default)]
pub struct Animator {
    nodes: Vec<NodeData>,
    /// Channels sorted (stably) by target node, document order within a node.
    channels: Vec<Channel>,
    /// `(start, end)` of each animation (over its transform channels).
    ranges: Vec<(f32, f32)>,
}

impl Animator {
    /// Builds an animator. `parents[i]` must describe a forest (validated by the
    /// importer); `rest[i]` is node `i`'s local matrix; channels must reference
    /// valid nodes and hold validated data.
    pub(crate) fn new(
        parents: Vec<Option<usize>>,
        rest: Vec<Mat4>,
        mut channels: Vec<Channel>,
    ) -> Animator {
        debug_assert_eq!(parents.len(), rest.len());
        let n = parents.len();
        channels.retain(|c| c.node < n && !c.times.is_empty());
        channels.sort_by_key(|c| c.node);

        let animation_count = channels.iter().map(|c| c.animation + 1).max().unwrap_or(0);
        let mut ranges = vec![(f32::INFINITY, f32::NEG_INFINITY); animation_count];
        for c in &channels {
            let r = &mut ranges[c.animation];
            r.0 = r.0.min(c.times[0]);
            r.1 = r.1.max(c.times[c.times.len() - 1]);
        }
        // Animations without transform channels have an empty range; give them
        // a harmless one (no channel refers to them anyway).
        for r in &mut ranges {
            if r.0 > r.1 {
                *r = (0.0, 0.0);
            }
        }

        let mut nodes: Vec<NodeData> = parents
            .iter()
            .zip(&rest)
            .map(|(&parent, &m)| NodeData {
                parent: parent.filter(|&p| p < n),
                rest_matrix: m,
                rest: decompose(m),
                first_channel: 0,
                channel_count: 0,
                animated: false,
            })
            .collect();
        let mut i = 0;
        while i < channels.len() {
            let node = channels[i].node;
            let start = i;
            while i < channels.len() && channels[i].node == node {
                i += 1;
            }
            nodes[node].first_channel = start;
            nodes[node].channel_count = i - start;
        }
        // Propagate "animated" down: a node is animated if any ancestor has
        // channels. Walk up (bounded by n, in case of a malformed forest).
        for v in 0..n {
            let mut cur = Some(v);
            let mut steps = 0;
            while let Some(c) = cur {
                if nodes[c].channel_count > 0 {
                    nodes[v].animated = true;
                    break;
                }
                steps += 1;
                if steps > n {
                    break;
                }
                cur = nodes[c].parent;
            }
        }
        Animator {
            nodes,
            channels,
            ranges,
        }
    }

    /// Appends a root node fixed at `world` (a camera given on the command
    /// line) and returns its index.
    pub(crate) fn push_fixed_node(&mut self, world: Mat4) -> usize {
        self.nodes.push(NodeData {
            parent: None,
            rest_matrix: world,
            rest: decompose(world),
            first_channel: 0,
            channel_count: 0,
            animated: false,
        });
        self.nodes.len() - 1
    }

    /// Number of nodes known to the animator (the glTF's node count, plus a
    /// camera given on the command line).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Parent of `node`, if any.
    pub fn parent(&self, node: usize) -> Option<usize> {
        self.nodes.get(node).and_then(|n| n.parent)
    }

    /// Local transform of `node` at time `t` (rest TRS with animated parts
    /// replaced). Identity for an unknown node.
    pub fn local_trs(&self, node: usize, t: f32) -> Trs {
        let Some(nd) = self.nodes.get(node) else {
            return Trs::IDENTITY;
        };
        let mut trs = nd.rest;
        for c in &self.channels[nd.first_channel..nd.first_channel + nd.channel_count] {
            let (start, end) = self.ranges[c.animation];
            let v = c.sample(clamp_time(t, start, end));
            match c.path {
                ChannelPath::Translation => trs.translation = v.truncate(),
                ChannelPath::Scale => trs.scale = v.truncate(),
                ChannelPath::Rotation => trs.rotation = quat_from_vec4(v),
            }
        }
        trs
    }

    /// Local matrix of `node` at time `t` (its exact rest matrix when no channel
    /// targets it). Identity for an unknown node.
    pub fn local_matrix(&self, node: usize, t: f32) -> Mat4 {
        match self.nodes.get(node) {
            None => Mat4::IDENTITY,
            Some(nd) if nd.channel_count == 0 => nd.rest_matrix,
            Some(_) => self.local_trs(node, t).matrix(),
        }
    }

    /// World matrix of `node` at time `t` seconds.
    pub fn world_matrix(&self, node: usize, t: f32) -> Mat4 {
        if node >= self.nodes.len() {
            return Mat4::IDENTITY;
        }
        let mut m = self.local_matrix(node, t);
        let mut cur = self.nodes[node].parent;
        let mut steps = 0;
        while let Some(p) = cur {
            steps += 1;
            if steps > self.nodes.len() {
                break; // malformed hierarchy; the importer rejects cycles
            }
            m = self.local_matrix(p, t) * m;
            cur = self.nodes[p].parent;
        }
        m
    }

    /// Whether `node` or one of its ancestors is targeted by an animation channel.
    pub fn is_animated(&self, node: usize) -> bool {
        self.nodes.get(node).is_some_and(|n| n.animated)
    }

    /// `(start, end)` of all animations together, `None` if there are none.
    pub fn time_range(&self) -> Option<(f32, f32)> {
        if self.channels.is_empty() {
            return None;
        }
        let mut r = (f32::INFINITY, f32::NEG_INFINITY);
        for c in &self.channels {
            let (s, e) = self.ranges[c.animation];
            r.0 = r.0.min(s);
            r.1 = r.1.max(e);
        }
        Some(r)
    }

    /// Times covering the whole animation range: every keyframe time plus at
    /// least `min_steps` evenly spaced samples; `[0.0]` with no animation.
    pub fn sample_times(&self, min_steps: usize) -> Vec<f32> {
        let Some((start, end)) = self.time_range() else {
            return vec![0.0];
        };
        let mut out: Vec<f32> = self
            .channels
            .iter()
            .flat_map(|c| c.times.iter().copied())
            .collect();
        let steps = min_steps.max(2);
        for i in 0..steps {
            let f = i as f32 / (steps - 1) as f32;
            out.push(start + (end - start) * f);
        }
        out.push(end);
        out.sort_by(f32::total_cmp);
        out.dedup();
        out
    }
}

fn clamp_time(t: f32, start: f32, end: f32) -> f32 {
    if t.is_nan() {
        start
    } else {
        t.clamp(start, end)
    }
}

fn quat_from_vec4(v: Vec4) -> Quat {
    let q = Quat::from_vec4(v);
    let len2 = q.length_squared();
    if len2.is_finite() && len2 > 0.0 {
        q.normalize()
    } else {
        Quat::IDENTITY
    }
}

/// Decomposes a rest matrix into TRS; a non-invertible matrix gets an
/// identity rotation instead of NaNs.
pub(crate) fn decompose(m: Mat4) -> Trs {
    let (scale, rotation, translation) = m.to_scale_rotation_translation();
    let rotation = if rotation.is_finite() {
        rotation.normalize()
    } else {
        Quat::IDENTITY
    };
    let rotation = if rotation.is_finite() {
        rotation
    } else {
        Quat::IDENTITY
    };
    let scale = if scale.is_finite() { scale } else { Vec3::ONE };
    Trs {
        translation,
        rotation,
        scale,
    }
}

impl Channel {
    /// Samples the channel at `t` (already clamped to the animation's range);
    /// before the first / after the last key the end values hold.
    fn sample(&self, t: f32) -> Vec4 {
        let times = &self.times;
        let n = times.len();
        let cubic = self.interpolation == Interpolation::CubicSpline;
        let value = |k: usize| {
            if cubic {
                self.values[3 * k + 1]
            } else {
                self.values[k]
            }
        };
        if n == 1 || t <= times[0] {
            return value(0);
        }
        if t >= times[n - 1] {
            return value(n - 1);
        }
        // First key strictly after t; 1 ≤ k1 ≤ n − 1 here.
        let k1 = times.partition_point(|&x| x <= t).clamp(1, n - 1);
        let k0 = k1 - 1;
        let (t0, t1) = (times[k0], times[k1]);
        let td = t1 - t0;
        if td <= 0.0 {
            return value(k1);
        }
        let s = ((t - t0) / td).clamp(0.0, 1.0);
        let rotation = self.path == ChannelPath::Rotation;
        match self.interpolation {
            Interpolation::Step => value(k0),
            Interpolation::Linear => {
                let (a, b) = (self.values[k0], self.values[k1]);
                if rotation {
                    let qa = quat_from_vec4(a);
                    let qb = quat_from_vec4(b);
                    Vec4::from(qa.slerp(qb, s).normalize())
                } else {
                    a.lerp(b, s)
                }
            }
            Interpolation::CubicSpline => {
                // glTF 2.0 spec, Appendix C: Hermite spline with tangents
                // scaled by the key interval.
                let v0 = self.values[3 * k0 + 1];
                let b0 = self.values[3 * k0 + 2]; // out-tangent of k0
                let a1 = self.values[3 * k1]; // in-tangent of k1
                let v1 = self.values[3 * k1 + 1];
                let s2 = s * s;
                let s3 = s2 * s;
                let p = v0 * (2.0 * s3 - 3.0 * s2 + 1.0)
                    + b0 * (td * (s3 - 2.0 * s2 + s))
                    + v1 * (-2.0 * s3 + 3.0 * s2)
                    + a1 * (td * (s3 - s2));
                if rotation {
                    Vec4::from(quat_from_vec4(p))
                } else {
                    p
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chan(
        path: ChannelPath,
        interpolation: Interpolation,
        times: &[f32],
        values: &[Vec4],
    ) -> Channel {
        Channel {
            node: 0,
            path,
            interpolation,
            times: times.to_vec(),
            values: values.to_vec(),
            animation: 0,
        }
    }

    #[test]
    fn empty_animator() {
        let a = Animator::default();
        assert_eq!(a.world_matrix(3, 1.0), Mat4::IDENTITY);
        assert!(!a.is_animated(0));
        assert_eq!(a.time_range(), None);
        assert_eq!(a.sample_times(8), vec![0.0]);
    }

    #[test]
    fn linear_step_cubic() {
        let v = |x: f32| Vec4::new(x, 0.0, 0.0, 0.0);
        let lin = chan(
            ChannelPath::Translation,
            Interpolation::Linear,
            &[1.0, 3.0],
            &[v(0.0), v(4.0)],
        );
        assert_eq!(lin.sample(2.0).x, 2.0);
        assert_eq!(lin.sample(0.0).x, 0.0);
        assert_eq!(lin.sample(9.0).x, 4.0);
        let step = chan(
            ChannelPath::Translation,
            Interpolation::Step,
            &[1.0, 3.0],
            &[v(0.0), v(4.0)],
        );
        assert_eq!(step.sample(2.9).x, 0.0);
        assert_eq!(step.sample(3.0).x, 4.0);
        // Zero tangents: smoothstep between the values.
        let cub = chan(
            ChannelPath::Translation,
            Interpolation::CubicSpline,
            &[0.0, 2.0],
            &[v(0.0), v(0.0), v(0.0), v(0.0), v(4.0), v(0.0)],
        );
        assert!((cub.sample(0.5).x - 4.0 * (3.0 * 0.0625 - 2.0 * 0.015625)).abs() < 1e-6);
        assert!((cub.sample(1.0).x - 2.0).abs() < 1e-6);
    }

    #[test]
    fn parent_chain_and_clamp() {
        let parents = vec![None, Some(0)];
        let rest = vec![
            Mat4::from_translation(Vec3::X),
            Mat4::from_translation(Vec3::Y),
        ];
        let c = Channel {
            node: 0,
            path: ChannelPath::Translation,
            interpolation: Interpolation::Linear,
            times: vec![1.0, 2.0],
            values: vec![Vec4::ZERO, Vec4::new(0.0, 0.0, 10.0, 0.0)],
            animation: 0,
        };
        let a = Animator::new(parents, rest, vec![c]);
        assert!(a.is_animated(1));
        assert_eq!(a.time_range(), Some((1.0, 2.0)));
        let p = a.world_matrix(1, 1.5).transform_point3(Vec3::ZERO);
        assert!((p - Vec3::new(0.0, 1.0, 5.0)).length() < 1e-6);
        let p = a.world_matrix(1, -5.0).transform_point3(Vec3::ZERO);
        assert!((p - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-6);
        let p = a.world_matrix(1, f32::NAN).transform_point3(Vec3::ZERO);
        assert!(p.is_finite());
        let ts = a.sample_times(4);
        assert_eq!(ts.first(), Some(&1.0));
        assert_eq!(ts.last(), Some(&2.0));
        assert!(ts.len() >= 4);
    }
}
