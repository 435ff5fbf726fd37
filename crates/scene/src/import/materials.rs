//! Materials: converts a glTF material into a scene [`Material`],
//! deduplicated per (material, textured) pair.
//!
//! - Albedo: baseColorFactor × baseColorTexture, or, for a material with
//!   `KHR_materials_pbrSpecularGlossiness`, diffuseFactor × diffuseTexture
//!   (the extension replaces the metallic-roughness inputs).
//! - Alpha: the factor's alpha × the texture's alpha; `MASK` keeps
//!   `alphaCutoff` (default 0.5), `BLEND` becomes a mask at 0.5 with a
//!   warning naming the material (gibake has no partial transparency).
//! - Every other input a material sets (normal, occlusion, emissive and
//!   metallic-roughness maps and factors, specular-glossiness) is named in
//!   one warning per material.

use glam::Vec3;
use gltf::json;
use gltf::json::validation::Checked;

use super::extensions::missing_source;
use super::{Ctx, MaterialTable};
use crate::{AlphaMode, Material, SceneError};

/// The texture reference a material's albedo is sampled with.
pub(super) fn albedo_info(m: &json::Material) -> Option<&json::texture::Info> {
    match spec_gloss(m) {
        Some(sg) => sg.diffuse_texture.as_ref(),
        None => m.pbr_metallic_roughness.base_color_texture.as_ref(),
    }
}

fn spec_gloss(m: &json::Material) -> Option<&json::extensions::material::PbrSpecularGlossiness> {
    m.extensions
        .as_ref()
        .and_then(|e| e.pbr_specular_glossiness.as_ref())
}

/// The inputs of `m` that a Lambertian albedo-only material ignores.
fn ignored_inputs(m: &json::Material) -> Vec<String> {
    let mut out = Vec::new();
    let pbr = &m.pbr_metallic_roughness;
    if m.normal_texture.is_some() {
        out.push("normalTexture".to_string());
    }
    if m.occlusion_texture.is_some() {
        out.push("occlusionTexture".to_string());
    }
    if m.emissive_texture.is_some() {
        out.push("emissiveTexture".to_string());
    }
    if m.emissive_factor.0 != [0.0; 3] {
        out.push(format!("emissiveFactor {:?}", m.emissive_factor.0));
    }
    match spec_gloss(m) {
        Some(sg) => {
            if sg.specular_glossiness_texture.is_some() {
                out.push("specularGlossinessTexture".to_string());
            }
            if sg.specular_factor.0 != [0.0; 3] {
                out.push(format!("specularFactor {:?}", sg.specular_factor.0));
            }
        }
        None => {
            if pbr.metallic_roughness_texture.is_some() {
                out.push("metallicRoughnessTexture".to_string());
            }
            if pbr.metallic_factor.0 > 0.0 {
                out.push(format!(
                    "metallicFactor {} (drawn as a dielectric)",
                    pbr.metallic_factor.0
                ));
            }
        }
    }
    out
}

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
        let (name, base_color, alpha, alpha_mode) = match mi {
            None => ("default".to_string(), Vec3::ONE, 1.0, AlphaMode::Opaque),
            Some(mi) => {
                let m = &root.materials[mi];
                let name = m.name.clone().unwrap_or_else(|| format!("material #{mi}"));
                let (f, which) = match spec_gloss(m) {
                    Some(sg) => (sg.diffuse_factor.0, "diffuseFactor"),
                    None => (
                        m.pbr_metallic_roughness.base_color_factor.0,
                        "baseColorFactor",
                    ),
                };
                let c = Vec3::new(f[0], f[1], f[2]);
                if !c.is_finite() || c.min_element() < 0.0 {
                    return Err(self.invalid(format!(
                        "material '{name}': {which} {c} is not finite and non-negative"
                    )));
                }
                let a = f[3];
                if !(0.0..=1.0).contains(&a) {
                    return Err(self.invalid(format!(
                        "material '{name}': {which} alpha {a} is not between 0 and 1"
                    )));
                }
                let mode = match m.alpha_mode {
                    Checked::Valid(json::material::AlphaMode::Mask) => {
                        let cutoff = m.alpha_cutoff.map_or(0.5, |c| c.0);
                        if !(cutoff.is_finite() && cutoff >= 0.0) {
                            return Err(self.invalid(format!(
                                "material '{name}': alphaCutoff {cutoff} is not a finite non-negative number"
                            )));
                        }
                        AlphaMode::Mask { cutoff }
                    }
                    Checked::Valid(json::material::AlphaMode::Blend) => {
                        AlphaMode::Mask { cutoff: 0.5 }
                    }
                    _ => AlphaMode::Opaque,
                };
                // Once per glTF material (it may give two scene materials).
                if table.warned.insert(Some(mi)) {
                    if matches!(m.alpha_mode, Checked::Invalid) {
                        self.warn(format!(
                            "material '{name}': its alphaMode is not one glTF 2.0 defines (OPAQUE, MASK, BLEND); drawn OPAQUE"
                        ));
                    }
                    if matches!(
                        m.alpha_mode,
                        Checked::Valid(json::material::AlphaMode::Blend)
                    ) {
                        self.warn(format!(
                            "material '{name}': alphaMode BLEND is drawn as MASK with alphaCutoff 0.5 (gibake has no partial transparency)"
                        ));
                    }
                    let ignored = ignored_inputs(m);
                    if !ignored.is_empty() {
                        self.warn(format!(
                            "material '{name}': input(s) ignored (gibake's materials are Lambertian, albedo and alpha only): {}",
                            ignored.join(", ")
                        ));
                    }
                }
                (name, c, a, mode)
            }
        };
        let tex_index = match texture {
            None => None,
            Some(t) => {
                let tex = root.textures.get(t).ok_or_else(|| {
                    self.invalid(format!("material '{name}': texture {t} does not exist"))
                })?;
                let image = tex.source.value();
                if image == u32::MAX as usize {
                    let (unsupported, why) = missing_source(tex, t);
                    let message = format!("material '{name}': {why}");
                    return Err(if unsupported {
                        self.not_supported(message)
                    } else {
                        self.invalid(message)
                    });
                }
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
            alpha,
            alpha_mode,
        });
        let i = table.materials.len() - 1;
        table.by_key.insert(key, i);
        Ok(i)
    }

    pub(super) fn material_has_texture(&self, mi: Option<usize>) -> bool {
        mi.and_then(|i| self.root.materials.get(i))
            .is_some_and(|m| albedo_info(m).is_some())
    }
}
