//! Lights: finds the primary lights (every `KHR_lights_punctual` light on a
//! node of the scene, or the ones `--light NAME` picks) and converts glTF's
//! units to gibake's radiometric ones (`color × intensity`; glTF's
//! photometric intensity is read as W/sr or W/m², docs/method.md).

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
            range: None,
        })
    }

    /// The primary lights: every `KHR_lights_punctual` light on a node of
    /// the scene, or the ones `--light NAME` (repeatable) picks; more than
    /// `max_lights` is refused. The first directional light leads, else the
    /// first spot (see below).
    pub(super) fn primary_lights(
        &mut self,
        order: &[usize],
        dynamic: &[bool],
        animator: &Animator,
        options: &LoadOptions,
    ) -> Result<Vec<Light>, SceneError> {
        let root = self.root;
        let lights: &[json::extensions::scene::khr_lights_punctual::Light] = root.as_ref();
        let light_name = |i: usize| match lights.get(i).and_then(|l| l.name.as_deref()) {
            Some(n) => n.to_string(),
            None => format!("light #{i}"),
        };
        if let Some(sun) = &options.sun {
            return Ok(vec![self.sun_light(sun, order, lights.len())?]);
        }
        let mut cands = Vec::new();
        for &v in order {
            let Some(l) = root.nodes[v]
                .extensions
                .as_ref()
                .and_then(|e| e.khr_lights_punctual.as_ref())
                .map(|k| k.light.value())
            else {
                continue;
            };
            if lights.get(l).is_none() {
                return Err(self.invalid(format!(
                    "node {} uses light {l}, which does not exist",
                    self.node_name(v)
                )));
            }
            let ty = match lights[l].type_ {
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
        let described: Vec<String> = cands
            .iter()
            .map(|c: &Cand| {
                format!(
                    "'{}' ({} on node {})",
                    c.name,
                    kind_str(c.ty),
                    self.node_name(c.node)
                )
            })
            .collect();
        let describe = |i: usize| described[i].clone();

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
                "no KHR_lights_punctual light{extra}; gibake needs one as its primary light (add a sun with --sun AZIMUTH,ELEVATION)"
            )));
        }

        // `--light NAME…`: each name picks exactly one light (by light
        // name, else by node name).
        let mut picked: Vec<usize> = Vec::new();
        for want in &options.lights {
            let mut matches: Vec<usize> = (0..cands.len())
                .filter(|&i| cands[i].name == *want)
                .collect();
            if matches.is_empty() {
                matches = (0..cands.len())
                    .filter(|&i| root.nodes[cands[i].node].name.as_deref() == Some(want.as_str()))
                    .collect();
            }
            match matches.len() {
                0 => {
                    let all: Vec<String> = (0..cands.len()).map(describe).collect();
                    return Err(self.invalid(format!(
                        "no light named '{want}'; available lights: {}",
                        all.join(", ")
                    )));
                }
                1 => {
                    if !picked.contains(&matches[0]) {
                        picked.push(matches[0]);
                    }
                }
                _ => {
                    let all: Vec<String> = matches.iter().map(|&i| describe(i)).collect();
                    return Err(self.invalid(format!(
                        "the light name '{want}' is ambiguous: {}",
                        all.join(", ")
                    )));
                }
            }
        }
        picked.sort_unstable();

        let set: Vec<usize> = if picked.is_empty() {
            (0..cands.len()).collect()
        } else {
            picked
        };
        let mut chosen = Vec::with_capacity(set.len());
        for i in set {
            if cands[i].ty.is_none() {
                self.warn(format!(
                    "ignoring light {}: its type is not directional, spot or point",
                    describe(i)
                ));
            } else {
                chosen.push(i);
            }
        }
        if chosen.is_empty() {
            return Err(self.not_supported(
                "no light of a known type (directional, spot or point)".to_string(),
            ));
        }
        // The first light is the primary one: full-size maps, and
        // cascades when it is a sun on a large level. A directional
        // light leads (it covers the whole level; a lamp a part of it),
        // else a spot; the first such light in file order, the others
        // keep their order. (Exporters write lights in node order,
        // which need not put the sun first.)
        let directional = |i: &usize| {
            matches!(
                cands[*i].ty,
                Some(json::extensions::scene::khr_lights_punctual::Type::Directional)
            )
        };
        let lead = chosen
            .iter()
            .position(directional)
            .or_else(|| chosen.iter().position(|&i| is_spot(&cands[i])));
        if let Some(p) = lead {
            let lead = chosen.remove(p);
            chosen.insert(0, lead);
        }
        let max = options.limits.max_lights as usize;
        if chosen.len() > max {
            return Err(self.invalid(format!(
                "{} lights, over the limit of {max} (raise it with --max-lights, or pick lights with --light NAME)",
                chosen.len()
            )));
        }

        let ignored: Vec<String> = (0..cands.len())
            .filter(|i| !chosen.contains(i))
            .map(describe)
            .collect();
        if !ignored.is_empty() {
            self.warn(format!(
                "ignoring the lights --light left out: {}",
                ignored.join(", ")
            ));
        }
        chosen
            .into_iter()
            .map(|i| self.convert(&cands[i], dynamic, animator))
            .collect()
    }

    /// One glTF light on its node, in gibake's units.
    fn convert(
        &mut self,
        c: &Cand,
        dynamic: &[bool],
        animator: &Animator,
    ) -> Result<Light, SceneError> {
        use json::extensions::scene::khr_lights_punctual::Type;
        let lights: &[json::extensions::scene::khr_lights_punctual::Light] = self.root.as_ref();
        let lj = &lights[c.light];
        if dynamic[c.node] || animator.is_animated(c.node) {
            return Err(self.invalid(format!(
                "light '{}' is on node {}, which is animated or marked dynamic: a primary light must not move (moving a light is a re-bake)",
                c.name,
                self.node_name(c.node)
            )));
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
        if !position.is_finite() {
            return Err(self.invalid(format!(
                "light '{}': node {} has a non-finite position",
                c.name,
                self.node_name(c.node)
            )));
        }
        let kind = match c.ty {
            Some(Type::Directional) => LightKind::Directional,
            Some(Type::Point) => LightKind::Point,
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
        // glTF `range`: in the light's node space; the world distance
        // scales with the node's uniform scale (the mean of the axes'
        // scales for a non-uniform one).
        let range = match (lj.range, &kind) {
            (None, _) => None,
            (Some(_), LightKind::Directional) => {
                self.warn(format!(
                    "light '{}': range is ignored on a directional light",
                    c.name
                ));
                None
            }
            (Some(r), _) => {
                let (scale, _, _) = world.to_scale_rotation_translation();
                let world_r = r * (scale.abs().element_sum() / 3.0);
                if !(r.is_finite() && r > 0.0 && world_r.is_finite() && world_r > 0.0) {
                    return Err(self.invalid(format!(
                        "light '{}': range {r} must be a finite number > 0",
                        c.name
                    )));
                }
                Some(world_r)
            }
        };
        Ok(Light {
            name: c.name.clone(),
            kind,
            color,
            position,
            direction,
            range,
        })
    }
}

/// A light on a node of the scene.
struct Cand {
    node: usize,
    light: usize,
    name: String,
    ty: Option<json::extensions::scene::khr_lights_punctual::Type>,
}

fn kind_str(t: Option<json::extensions::scene::khr_lights_punctual::Type>) -> &'static str {
    use json::extensions::scene::khr_lights_punctual::Type;
    match t {
        Some(Type::Spot) => "spot",
        Some(Type::Directional) => "directional",
        Some(Type::Point) => "point",
        None => "unknown type",
    }
}

/// What the single-light bake takes.
fn is_spot(c: &Cand) -> bool {
    use json::extensions::scene::khr_lights_punctual::Type;
    matches!(c.ty, Some(Type::Spot))
}
