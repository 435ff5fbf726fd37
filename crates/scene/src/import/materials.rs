//! Materials: converts a glTF material (base colour factor and texture) into
//! a scene [`Material`], deduplicated per (material, textured) pair.

use glam::Vec3;
use gltf::json;
use gltf::json::validation::Checked;

use super::{Ctx, MaterialTable};
use crate::{Material, SceneError};

impl<'a> Ctx<'a> {
    /// Scene material for glTF material `mi` (None = default), textured with
    /// glTF texture `texture` if given.
    pub(super) fn material(
        &mut self,
        mi: Option<usize>,
        texture: Option<usize>,
        table: &mut MaterialTable,
    ) -> Result<usize, SceneError> {
        let key = (mi, texture.is_some());
        if let Some(&i) = table.by_key.get(&key) {
            return Ok(i);
        }
        let root = self.root;
        let (name, base_color) = match mi {
            None => ("default".to_string(), Vec3::ONE),
            Some(mi) => {
                let m = &root.materials[mi];
                let name = m.name.clone().unwrap_or_else(|| format!("material #{mi}"));
                let f = m.pbr_metallic_roughness.base_color_factor.0;
                let c = Vec3::new(f[0], f[1], f[2]);
                if !c.is_finite() || c.min_element() < 0.0 {
                    return Err(self.invalid(format!(
                        "material '{name}': baseColorFactor {c} is not finite and non-negative"
                    )));
                }
                if !table.warned_inputs {
                    let pbr = &m.pbr_metallic_roughness;
                    let other = m.normal_texture.is_some()
                        || m.occlusion_texture.is_some()
                        || m.emissive_texture.is_some()
                        || m.emissive_factor.0 != [0.0; 3]
                        || pbr.metallic_roughness_texture.is_some()
                        || !matches!(
                            m.alpha_mode,
                            Checked::Valid(json::material::AlphaMode::Opaque)
                        );
                    if other {
                        table.warned_inputs = true;
                        self.warn(
                            "materials: only baseColorFactor and baseColorTexture are used (Lambertian); \
                             other inputs (normal/occlusion/emissive/metallic-roughness maps, alpha) are ignored",
                        );
                    }
                }
                (name, c)
            }
        };
        let tex_index = match texture {
            None => None,
            Some(t) => {
                let image = root
                    .textures
                    .get(t)
                    .ok_or_else(|| {
                        self.invalid(format!("material '{name}': texture {t} does not exist"))
                    })?
                    .source
                    .value();
                Some(match table.by_image.get(&image) {
                    Some(&i) => i,
                    None => {
                        let decoded = self.decode_image(image)?;
                        let decoded = self.fit_texture(decoded, image);
                        table.textures.push(decoded);
                        table.by_image.insert(image, table.textures.len() - 1);
                        table.textures.len() - 1
                    }
                })
            }
        };
        let name = if mi.is_some() && texture.is_none() && self.material_has_texture(mi) {
            format!("{name} (untextured)")
        } else {
            name
        };
        table.materials.push(Material {
            name,
            base_color,
            texture: tex_index,
        });
        let i = table.materials.len() - 1;
        table.by_key.insert(key, i);
        Ok(i)
    }

    pub(super) fn material_has_texture(&self, mi: Option<usize>) -> bool {
        mi.and_then(|i| self.root.materials.get(i))
            .is_some_and(|m| m.pbr_metallic_roughness.base_color_texture.is_some())
    }
}
