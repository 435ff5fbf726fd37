//! The node hierarchy: parent links (checked for cycles and shared
//! children), rest matrices, and the `extras.dynamic` flag.

use glam::{Mat4, Quat, Vec3, Vec4};
use gltf::json;

use super::Ctx;
use crate::SceneError;

pub(super) fn extras_dynamic(extras: &json::Extras) -> bool {
    extras_flag(extras, "dynamic")
}

/// Whether `extras` holds `{"<key>": true}`.
pub(super) fn extras_flag(extras: &json::Extras, key: &str) -> bool {
    extras
        .as_ref()
        .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
        .and_then(|v| v.get(key).and_then(|d| d.as_bool()))
        .unwrap_or(false)
}

impl<'a> Ctx<'a> {
    /// Parent of every node, checking that the nodes form a forest.
    pub(super) fn parents(&self) -> Result<Vec<Option<usize>>, SceneError> {
        let n = self.root.nodes.len();
        let mut parents: Vec<Option<usize>> = vec![None; n];
        for (p, node) in self.root.nodes.iter().enumerate() {
            for c in node.children.iter().flatten() {
                let c = c.value();
                if c >= n {
                    return Err(self.invalid(format!(
                        "node {} has child {c}, which does not exist",
                        self.node_name(p)
                    )));
                }
                if c == p {
                    return Err(
                        self.invalid(format!("node {} is its own child", self.node_name(p)))
                    );
                }
                if let Some(q) = parents[c] {
                    return Err(self.invalid(format!(
                        "node {} is a child of both node {} and node {} (the node hierarchy must be a tree)",
                        self.node_name(c),
                        self.node_name(q),
                        self.node_name(p)
                    )));
                }
                parents[c] = Some(p);
            }
        }
        // Cycle check: each node has at most one parent, so walk up with marks.
        let mut state = vec![0usize; n]; // 0 = unseen, usize::MAX = done, k+1 = on walk k
        for start in 0..n {
            let mut cur = Some(start);
            while let Some(c) = cur {
                if state[c] == usize::MAX {
                    break;
                }
                if state[c] == start + 1 {
                    return Err(self.invalid(format!(
                        "the node hierarchy has a cycle through node {}",
                        self.node_name(c)
                    )));
                }
                state[c] = start + 1;
                cur = parents[c];
            }
            let mut cur = Some(start);
            while let Some(c) = cur {
                if state[c] == usize::MAX {
                    break;
                }
                state[c] = usize::MAX;
                cur = parents[c];
            }
        }
        Ok(parents)
    }

    pub(super) fn rest_matrices(&self) -> Result<Vec<Mat4>, SceneError> {
        let mut out = Vec::with_capacity(self.root.nodes.len());
        for (i, node) in self.root.nodes.iter().enumerate() {
            let m = if let Some(m) = node.matrix {
                Mat4::from_cols_array(&m)
            } else {
                let t = Vec3::from(node.translation.unwrap_or([0.0; 3]));
                let r = node
                    .rotation
                    .as_ref()
                    .map(|q| Vec4::from(q.0))
                    .unwrap_or(Vec4::W);
                let s = Vec3::from(node.scale.unwrap_or([1.0; 3]));
                if !(t.is_finite() && r.is_finite() && s.is_finite()) {
                    return Err(self.invalid(format!(
                        "node {} has a non-finite transform",
                        self.node_name(i)
                    )));
                }
                let len = r.length();
                if !(len.is_finite() && len > 0.0) {
                    return Err(self.invalid(format!(
                        "node {} has a zero rotation quaternion",
                        self.node_name(i)
                    )));
                }
                Mat4::from_scale_rotation_translation(s, Quat::from_vec4(r / len), t)
            };
            if !m.is_finite() {
                return Err(self.invalid(format!(
                    "node {} has a non-finite transform",
                    self.node_name(i)
                )));
            }
            out.push(m);
        }
        Ok(out)
    }
}
