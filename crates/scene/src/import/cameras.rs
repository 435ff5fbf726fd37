//! Cameras: picks the scene's camera node (the first in traversal order) and
//! reads its projection.

use gltf::json;
use gltf::json::validation::Checked;

use super::Ctx;
use crate::{Camera, Projection, SceneError};

impl<'a> Ctx<'a> {
    pub(super) fn camera(&self, order: &[usize]) -> Result<Option<Camera>, SceneError> {
        let root = self.root;
        let Some((node, ci)) = order
            .iter()
            .find_map(|&v| root.nodes[v].camera.map(|c| (v, c.value())))
        else {
            return Ok(None);
        };
        let cam = root
            .cameras
            .get(ci)
            .ok_or_else(|| self.invalid(format!("camera {ci} does not exist")))?;
        let name = cam.name.clone().unwrap_or_else(|| format!("camera #{ci}"));
        let bad = |what: &str| self.invalid(format!("camera '{name}': {what}"));
        let projection = match cam.type_ {
            Checked::Valid(json::camera::Type::Perspective) => {
                let p = cam
                    .perspective
                    .as_ref()
                    .ok_or_else(|| bad("type is perspective but there is no perspective object"))?;
                if !(p.yfov.is_finite() && p.yfov > 0.0 && p.yfov < std::f32::consts::PI) {
                    return Err(bad(&format!("yfov {} must be in (0, π)", p.yfov)));
                }
                if !(p.znear.is_finite() && p.znear > 0.0) {
                    return Err(bad(&format!("znear {} must be positive", p.znear)));
                }
                let zfar = p.zfar.filter(|z| z.is_finite());
                if let Some(z) = zfar
                    && z <= p.znear
                {
                    return Err(bad(&format!(
                        "zfar {z} must be greater than znear {}",
                        p.znear
                    )));
                }
                Projection::Perspective {
                    yfov: p.yfov,
                    znear: p.znear,
                    zfar,
                }
            }
            Checked::Valid(json::camera::Type::Orthographic) => {
                let o = cam.orthographic.as_ref().ok_or_else(|| {
                    bad("type is orthographic but there is no orthographic object")
                })?;
                let ok = [o.xmag, o.ymag, o.znear, o.zfar]
                    .iter()
                    .all(|x| x.is_finite())
                    && o.xmag != 0.0
                    && o.ymag != 0.0
                    && o.znear >= 0.0
                    && o.zfar > o.znear;
                if !ok {
                    return Err(bad(
                        "orthographic parameters must be finite, xmag/ymag non-zero, 0 ≤ znear < zfar",
                    ));
                }
                Projection::Orthographic {
                    xmag: o.xmag,
                    ymag: o.ymag,
                    znear: o.znear,
                    zfar: o.zfar,
                }
            }
            Checked::Invalid => return Err(bad("invalid type")),
        };
        Ok(Some(Camera {
            name,
            node,
            projection,
        }))
    }
}
