//! Lights: finds the primary light (`KHR_lights_punctual` spot or
//! directional, chosen by name when there are several) and converts glTF's
//! photometric units to gibake's radiometric ones.

use glam::Vec3;
use gltf::json;
use gltf::json::validation::Checked;

use super::{Ctx, LoadOptions};
use crate::animation::Animator;
use crate::{Light, LightKind, SceneError, Sun};

impl<'a> Ctx<'a> {
    /// The `--sun` light; the file's own lights are ignored with a warning.
    fn sun_light(
        &mut self,
        sun: &Sun,
        order: &[usize],
        defined: usize,
    ) -> Result<Light, SceneError> {
        sun.validate().map_err(|m| self.invalid(m))?;
        let used = order
            .iter()
            .filter(|&&v| {
                self.root.nodes[v]
                    .extensions
                    .as_ref()
                    .is_some_and(|e| e.khr_lights_punctual.is_some())
            })
            .count();
        if used > 0 || defined > 0 {
            self.warn(format!(
                "--sun replaces the file's {} KHR_lights_punctual light(s)",
                used.max(defined)
            ));
        }
        Ok(Light {
            name: "--sun".into(),
            kind: LightKind::Directional,
            color: sun.color * sun.irradiance,
            position: Vec3::ZERO,
            direction: -sun.toward(),
        })
    }

    pub(super) fn primary_light(
        &mut self,
        order: &[usize],
        dynamic: &[bool],
        animator: &Animator,
        options: &LoadOptions,
    ) -> Result<Light, SceneError> {
        use json::extensions::scene::khr_lights_punctual::Type;
        let root = self.root;
        let lights: &[json::extensions::scene::khr_lights_punctual::Light] = root.as_ref();
        struct Cand {
            node: usize,
            light: usize,
            name: String,
            ty: Option<Type>,
        }
        let light_name = |i: usize| match lights.get(i).and_then(|l| l.name.as_deref()) {
            Some(n) => n.to_string(),
            None => format!("light #{i}"),
        };
        let mut cands = Vec::new();
        if let Some(sun) = &options.sun {
            return self.sun_light(sun, order, lights.len());
        }
        for &v in order {
            let Some(l) = root.nodes[v]
                .extensions
                .as_ref()
                .and_then(|e| e.khr_lights_punctual.as_ref())
                .map(|k| k.light.value())
            else {
                continue;
            };
            let Some(lj) = lights.get(l) else {
                return Err(self.invalid(format!(
                    "node {} uses light {l}, which does not exist",
                    self.node_name(v)
                )));
            };
            let ty = match lj.type_ {
                Checked::Valid(t) => Some(t),
                Checked::Invalid => None,
            };
            cands.push(Cand {
                node: v,
                light: l,
                name: light_name(l),
                ty,
            });
        }
        let kind_str = |t: Option<Type>| match t {
            Some(Type::Spot) => "spot",
            Some(Type::Directional) => "directional",
            Some(Type::Point) => "point",
            None => "unknown type",
        };
        let usable = |c: &Cand| matches!(c.ty, Some(Type::Spot | Type::Directional));
        let describe = |c: &Cand| {
            format!(
                "'{}' ({} on node {})",
                c.name,
                kind_str(c.ty),
                self.node_name(c.node)
            )
        };

        if cands.is_empty() {
            let extra = if lights.is_empty() {
                String::new()
            } else {
                format!(
                    " ({} light(s) are defined but no node of the scene uses them)",
                    lights.len()
                )
            };
            return Err(self.invalid(format!(
                "no KHR_lights_punctual spot or directional light{extra}; gibake needs one as its primary light (add a sun with --sun AZIMUTH,ELEVATION)"
            )));
        }

        let chosen = if let Some(want) = options.light.as_deref() {
            let mut matches: Vec<usize> = (0..cands.len())
                .filter(|&i| cands[i].name == want)
                .collect();
            if matches.is_empty() {
                // Fall back to the node name.
                matches = (0..cands.len())
                    .filter(|&i| root.nodes[cands[i].node].name.as_deref() == Some(want))
                    .collect();
            }
            match matches.len() {
                0 => {
                    let all: Vec<String> = cands.iter().map(describe).collect();
                    return Err(self.invalid(format!(
                        "no light named '{want}'; available lights: {}",
                        all.join(", ")
                    )));
                }
                1 => {}
                _ => {
                    let all: Vec<String> = matches.iter().map(|&i| describe(&cands[i])).collect();
                    return Err(self.invalid(format!(
                        "the light name '{want}' is ambiguous: {}",
                        all.join(", ")
                    )));
                }
            }
            let c = &cands[matches[0]];
            if !usable(c) {
                return Err(self.not_supported(format!(
                    "light {} is a {} light; gibake supports only spot and directional lights",
                    describe(c),
                    kind_str(c.ty)
                )));
            }
            matches[0]
        } else {
            let valid: Vec<usize> = (0..cands.len()).filter(|&i| usable(&cands[i])).collect();
            match valid.len() {
                0 => {
                    let all: Vec<String> = cands.iter().map(describe).collect();
                    return Err(self.not_supported(format!(
                        "only point lights: {}; gibake needs one KHR_lights_punctual spot or directional light",
                        all.join(", ")
                    )));
                }
                1 => valid[0],
                _ => {
                    let all: Vec<String> = valid.iter().map(|&i| describe(&cands[i])).collect();
                    return Err(self.invalid(format!(
                        "several spot/directional lights: {}; pick one with --light NAME",
                        all.join(", ")
                    )));
                }
            }
        };

        let ignored: Vec<String> = (0..cands.len())
            .filter(|&i| i != chosen)
            .map(|i| describe(&cands[i]))
            .collect();
        if !ignored.is_empty() {
            self.warn(format!(
                "ignoring light(s) other than the primary one: {}",
                ignored.join(", ")
            ));
        }

        let c = &cands[chosen];
        let lj = &lights[c.light];
        if dynamic[c.node] || animator.is_animated(c.node) {
            return Err(self.invalid(format!(
                "light '{}' is on node {}, which is animated or marked dynamic: the primary light must not move",
                c.name,
                self.node_name(c.node)
            )));
        }
        if lj.range.is_some() {
            self.warn(format!("light '{}': range is ignored", c.name));
        }
        let color = Vec3::from(lj.color) * lj.intensity;
        if !color.is_finite() || color.min_element() < 0.0 {
            return Err(self.invalid(format!(
                "light '{}': color × intensity must be finite and non-negative, got {color}",
                c.name
            )));
        }
        let world = animator.world_matrix(c.node, 0.0);
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world
            .transform_vector3(Vec3::NEG_Z)
            .try_normalize()
            .ok_or_else(|| {
                self.invalid(format!(
                    "light '{}': node {} has a degenerate transform (no direction)",
                    c.name,
                    self.node_name(c.node)
                ))
            })?;
        let kind = match c.ty {
            Some(Type::Directional) => LightKind::Directional,
            _ => {
                let (mut inner, outer) = match &lj.spot {
                    Some(s) => (s.inner_cone_angle, s.outer_cone_angle),
                    None => (0.0, std::f32::consts::FRAC_PI_4),
                };
                if !(outer.is_finite()
                    && outer > 0.0
                    && outer <= std::f32::consts::FRAC_PI_2 + 1e-6)
                {
                    return Err(self.invalid(format!(
                        "light '{}': outerConeAngle {outer} must be in (0, π/2]",
                        c.name
                    )));
                }
                if !(inner.is_finite() && (0.0..=outer).contains(&inner)) {
                    self.warn(format!(
                        "light '{}': innerConeAngle {inner} is outside [0, outerConeAngle], clamped",
                        c.name
                    ));
                    inner = if inner.is_finite() {
                        inner.clamp(0.0, outer)
                    } else {
                        0.0
                    };
                }
                LightKind::Spot {
                    inner_cone: inner,
                    outer_cone: outer.min(std::f32::consts::FRAC_PI_2),
                }
            }
        };
        Ok(Light {
            name: c.name.clone(),
            kind,
            color,
            position,
            direction,
        })
    }
}
