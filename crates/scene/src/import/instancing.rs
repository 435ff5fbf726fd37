//! `EXT_mesh_gpu_instancing`: a node that draws its mesh once per instance,
//! each with its own translation, rotation and scale (accessors named by
//! the extension, in the node's local space). gibake expands the instances
//! into one mesh each — static ones flattened to world space like any other
//! mesh, a moving node's instances kept in its local space — and charges
//! every expanded vertex to the element budget (`--max-elements`), so a
//! million instances of a small mesh cost what a million small meshes do.

use glam::{Mat4, Quat, Vec3};
use serde_json::Value;

use super::Ctx;
use crate::SceneError;

/// The extension's name.
pub(super) const NAME: &str = "EXT_mesh_gpu_instancing";

impl<'a> Ctx<'a> {
    /// The instance matrices of node `v` (local: applied before the node's
    /// own transform), or `None` when the node does not use the extension.
    pub(super) fn instances(&self, v: usize) -> Result<Option<Vec<Mat4>>, SceneError> {
        let node = &self.root.nodes[v];
        let Some(ext) = node.extensions.as_ref().and_then(|e| e.others.get(NAME)) else {
            return Ok(None);
        };
        let what = format!("node {} {NAME}", self.node_name(v));
        let attrs = ext
            .get("attributes")
            .and_then(Value::as_object)
            .ok_or_else(|| self.invalid(format!("{what}: no `attributes` object")))?;
        let accessor = |k: &str| -> Result<Option<usize>, SceneError> {
            match attrs.get(k) {
                None => Ok(None),
                Some(x) => x
                    .as_u64()
                    .and_then(|i| usize::try_from(i).ok())
                    .map(Some)
                    .ok_or_else(|| self.invalid(format!("{what}: {k} is not an accessor index"))),
            }
        };
        let read = |k: &str, dims: usize| -> Result<Option<(Vec<f32>, usize)>, SceneError> {
            match accessor(k)? {
                None => Ok(None),
                Some(a) => self
                    .read_floats(a, dims)
                    .map(Some)
                    .map_err(|e| self.invalid(format!("{what}: {k}: {e}"))),
            }
        };
        let t = read("TRANSLATION", 3)?;
        let r = read("ROTATION", 4)?;
        let s = read("SCALE", 3)?;
        let counts: Vec<usize> = [&t, &r, &s]
            .iter()
            .filter_map(|x| x.as_ref().map(|x| x.1))
            .collect();
        let Some(&n) = counts.first() else {
            return Err(self.invalid(format!(
                "{what}: none of TRANSLATION, ROTATION, SCALE is given"
            )));
        };
        if counts.iter().any(|&c| c != n) {
            return Err(self.invalid(format!(
                "{what}: the attributes have different counts {counts:?}"
            )));
        }
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let tr = t
                .as_ref()
                .map_or(Vec3::ZERO, |(f, _)| Vec3::from_slice(&f[3 * i..]));
            let sc = s
                .as_ref()
                .map_or(Vec3::ONE, |(f, _)| Vec3::from_slice(&f[3 * i..]));
            let q = r
                .as_ref()
                .map_or(Quat::IDENTITY, |(f, _)| Quat::from_slice(&f[4 * i..]));
            if !(tr.is_finite() && sc.is_finite() && q.is_finite()) || q.length_squared() == 0.0 {
                return Err(self.invalid(format!(
                    "{what}: instance {i} has a non-finite or zero-rotation transform"
                )));
            }
            out.push(Mat4::from_scale_rotation_translation(sc, q.normalize(), tr));
        }
        Ok(Some(out))
    }

    /// Charges the copies of an instanced mesh (`instances − 1` more copies
    /// of `vertices` vertices) to the element budget.
    pub(super) fn charge_instances(
        &self,
        v: usize,
        instances: usize,
        vertices: usize,
    ) -> Result<(), SceneError> {
        let n = (instances.saturating_sub(1) as u64).saturating_mul(vertices as u64);
        self.charge_elements(
            &format!("node {} {NAME} ({instances} instances)", self.node_name(v)),
            n,
        )
        .map_err(|e| self.invalid(e))
    }
}
