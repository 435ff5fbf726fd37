//! Cameras: picks the scene's camera node (the first in traversal order
//! whose type is perspective or orthographic) and reads its projection.

use gltf::json;
use gltf::json::validation::Checked;

use super::Ctx;
use crate::animation::Animator;
use crate::{Camera, CameraChoice, Projection, SceneError};

impl<'a> Ctx<'a> {
    /// The camera `choice` asks for: the first camera node, one by name, or
    /// a look-at camera (a fixed node appended to `animator`).
    pub(super) fn camera(
        &mut self,
        order: &[usize],
        choice: &CameraChoice,
        animator: &mut Animator,
    ) -> Result<Option<Camera>, SceneError> {
        let root = self.root;
        // A camera whose type glTF 2.0 does not define (the validator
        // warns) is passed over by the first-camera choice.
        let unknown_type = |c: usize| {
            root.cameras
                .get(c)
                .is_some_and(|c| matches!(c.type_, Checked::Invalid))
        };
        let found = match choice {
            CameraChoice::First => {
                let mut passed = Vec::new();
                let found = order.iter().find_map(|&v| {
                    let c = root.nodes[v].camera?.value();
                    if unknown_type(c) {
                        passed.push(c);
                        return None;
                    }
                    Some((v, c))
                });
                for c in passed {
                    let name = root.cameras[c]
                        .name
                        .clone()
                        .unwrap_or_else(|| format!("camera #{c}"));
                    self.warn(format!(
                        "camera '{name}' ignored: its type is neither perspective nor orthographic"
                    ));
                }
                found
            }
            CameraChoice::Named(want) => {
                let with_camera = || {
                    order
                        .iter()
                        .filter_map(|&v| root.nodes[v].camera.map(|c| (v, c.value())))
                };
                let by_camera = with_camera().find(|&(_, c)| {
                    root.cameras.get(c).and_then(|c| c.name.as_deref()) == Some(want.as_str())
                });
                let by_node = || {
                    with_camera()
                        .find(|&(v, _)| root.nodes[v].name.as_deref() == Some(want.as_str()))
                };
                match by_camera.or_else(by_node) {
                    Some(f) => Some(f),
                    None => {
                        let names: Vec<String> = with_camera()
                            .map(|(v, c)| {
                                root.cameras
                                    .get(c)
                                    .and_then(|c| c.name.clone())
                                    .unwrap_or_else(|| self.node_name(v))
                            })
                            .collect();
                        return Err(self.invalid(format!(
                            "--camera '{want}': no camera of that name (cameras: {})",
                            if names.is_empty() {
                                "none".to_string()
                            } else {
                                names.join(", ")
                            }
                        )));
                    }
                }
            }
            CameraChoice::LookAt {
                eye,
                target,
                yfov_deg,
            } => {
                if !(yfov_deg.is_finite() && *yfov_deg > 0.0 && *yfov_deg < 180.0) {
                    return Err(self.invalid(format!(
                        "--look-at field of view {yfov_deg} must be in (0, 180) degrees"
                    )));
                }
                let world =
                    CameraChoice::look_at_matrix(*eye, *target).map_err(|m| self.invalid(m))?;
                let node = animator.push_fixed_node(world);
                return Ok(Some(Camera {
                    name: "--look-at".into(),
                    node,
                    projection: Projection::Perspective {
                        yfov: yfov_deg.to_radians(),
                        znear: (*target - *eye).length() * 1e-3,
                        zfar: None,
                    },
                }));
            }
        };
        let Some((node, ci)) = found else {
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
            Checked::Invalid => {
                return Err(bad("its type is neither perspective nor orthographic"));
            }
        };
        Ok(Some(Camera {
            name,
            node,
            projection,
        }))
    }
}
