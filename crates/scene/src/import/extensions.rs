//! glTF extensions: which ones the importer applies, what it says about the
//! others, and the file-level fix-ups they need before the document is
//! validated.
//!
//! - [`APPLIED`] lists the extensions whose data changes what is imported.
//!   Every other extension the file uses (listed in `extensionsUsed` or
//!   found on an object) gets one warning naming it and the materials,
//!   meshes, nodes or textures that carry it ([`unapplied_warnings`]).
//! - A *required* extension that is neither applied nor safely ignorable
//!   stops the import with a message naming it; for the compressions gibake
//!   does not decode (Draco, Basis Universal, AVIF) the message gives the
//!   command that converts the file ([`conversion_hint`]).
//! - `EXT_texture_webp` names its image in the texture's extension object
//!   (glTF 2.0 makes `source` optional): [`resolve_texture_sources`] makes
//!   that image the texture's source.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use gltf::json;
use serde_json::Value;

use crate::SceneError;

/// The extensions whose data the importer applies.
pub(super) const APPLIED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_materials_pbrSpecularGlossiness",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "EXT_texture_webp",
    "EXT_mesh_gpu_instancing",
];

/// Extensions the importer does not apply but may be required without
/// changing the geometry: material extensions (their inputs are ignored,
/// with a warning naming each material), and the texture compressions,
/// which are refused image by image when an image needs them and has no
/// fallback (see `textures.rs`).
fn ignorable_when_required(ext: &str) -> bool {
    ext.starts_with("KHR_materials_") || matches!(ext, "KHR_texture_basisu" | "EXT_texture_avif")
}

/// The command that converts a file using `ext` into one gibake reads, for
/// the compressions gibake does not decode (see docs/robustness.md).
pub(crate) fn conversion_hint(ext: &str) -> String {
    match ext {
        "KHR_draco_mesh_compression" => "convert the file to meshopt compression, which gibake reads: \
             `npx @gltf-transform/cli meshopt IN.glb OUT.glb`"
            .to_string(),
        "KHR_texture_basisu" => "convert its KTX2 textures to PNG: \
             `npx @gltf-transform/cli ktxdecompress IN.glb OUT.glb` (or WebP: `... webp OUT.glb OUT2.glb`)"
            .to_string(),
        "EXT_texture_avif" => "convert its AVIF textures to WebP or PNG: \
             `npx @gltf-transform/cli webp IN.glb OUT.glb` (or `... png IN.glb OUT.glb`)"
            .to_string(),
        other => format!("{other} has no conversion known to gibake"),
    }
}

/// Checks `extensionsRequired`: applied and ignorable extensions pass,
/// Draco and unknown ones stop the import. Clears the list afterwards (the
/// `gltf` crate's validation would refuse extensions it does not know).
pub(super) fn check_required(root: &mut json::Root, path: &Path) -> Result<(), SceneError> {
    let refused: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !APPLIED.contains(e) && !ignorable_when_required(e))
        .collect();
    if !refused.is_empty() {
        let hints: Vec<String> = refused
            .iter()
            .filter(|e| **e == "KHR_draco_mesh_compression")
            .map(|e| format!("{e}: {}", conversion_hint(e)))
            .collect();
        let mut message = format!("required glTF extension(s) {}", refused.join(", "));
        if !hints.is_empty() {
            message = format!("{message}; {}", hints.join("; "));
        } else {
            message.push_str(&format!(
                " (gibake applies {}, and ignores material extensions with a warning)",
                APPLIED.join(", ")
            ));
        }
        return Err(SceneError::NotSupported {
            path: path.to_path_buf(),
            message,
        });
    }
    root.extensions_required.clear();
    Ok(())
}

/// A primitive compressed with `KHR_draco_mesh_compression` whose
/// accessors hold no uncompressed fallback (it is not required, yet only
/// the Draco data exists): refused with the conversion command. (Accessors
/// without `bufferView` are otherwise valid glTF, read as zeros; here
/// they would give a mesh of zeros in place of the compressed one.)
pub(super) fn check_draco_fallback(root: &json::Root, path: &Path) -> Result<(), SceneError> {
    let ext = "KHR_draco_mesh_compression";
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let draco = prim
                .extensions
                .as_ref()
                .is_some_and(|e| e.others.contains_key(ext));
            let hollow = prim.attributes.values().any(|a| {
                root.accessors
                    .get(a.value())
                    .is_some_and(|a| a.buffer_view.is_none() && a.sparse.is_none())
            });
            if draco && hollow {
                let name = mesh.name.clone().unwrap_or_else(|| format!("mesh #{mi}"));
                return Err(SceneError::NotSupported {
                    path: path.to_path_buf(),
                    message: format!(
                        "mesh '{name}' primitive {pi}: its geometry exists only compressed with {ext}, which gibake does not decode; {}",
                        conversion_hint(ext)
                    ),
                });
            }
        }
    }
    Ok(())
}

/// The image an `EXT_texture_webp` texture names, if any.
fn webp_source(t: &json::Texture) -> Option<&Value> {
    t.extensions
        .as_ref()
        .and_then(|e| e.others.get("EXT_texture_webp"))
        .and_then(|w| w.get("source"))
}

/// Makes the image of each texture's `EXT_texture_webp` its source (WebP
/// is what the file asks for; a PNG/JPEG `source` beside it is the fallback
/// for readers without the extension).
pub(super) fn resolve_texture_sources(
    root: &mut json::Root,
    path: &Path,
) -> Result<(), SceneError> {
    let images = root.images.len();
    for (i, t) in root.textures.iter_mut().enumerate() {
        let Some(v) = webp_source(t) else { continue };
        let image = v
            .as_u64()
            .filter(|&s| (s as usize) < images)
            .ok_or_else(|| SceneError::Invalid {
                path: path.to_path_buf(),
                message: format!(
                    "texture {i}: EXT_texture_webp source {v} is not an image index (the file has {images} images)"
                ),
            })?;
        t.source = json::Index::new(image as u32);
    }
    Ok(())
}

/// Why texture `t` has no image gibake can use (its `source` is absent).
pub(super) fn missing_source(t: &json::Texture, index: usize) -> (bool, String) {
    let others = t.extensions.as_ref().map(|e| &e.others);
    for ext in ["KHR_texture_basisu", "EXT_texture_avif"] {
        if others.is_some_and(|o| o.contains_key(ext)) {
            return (
                true,
                format!(
                    "texture {index} has no image but its {ext} one, which gibake does not decode; {}",
                    conversion_hint(ext)
                ),
            );
        }
    }
    (
        false,
        format!("texture {index} has no source image (nor an EXT_texture_webp one)"),
    )
}

/// Every extension name found in an `extensions` object anywhere in `v`.
fn extension_names(v: &Value, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(map) => {
            for (k, x) in map {
                if k == "extensions"
                    && let Value::Object(e) = x
                {
                    out.extend(e.keys().cloned());
                }
                extension_names(x, out);
            }
        }
        Value::Array(a) => a.iter().for_each(|x| extension_names(x, out)),
        _ => {}
    }
}

/// Texture indices a material refers to (any `…Texture: {index}` object,
/// in the core material or in an extension).
fn material_textures(v: &Value, out: &mut BTreeSet<u64>) {
    match v {
        Value::Object(map) => {
            for (k, x) in map {
                if k.ends_with("Texture")
                    && let Some(i) = x.get("index").and_then(Value::as_u64)
                {
                    out.insert(i);
                }
                material_textures(x, out);
            }
        }
        Value::Array(a) => a.iter().for_each(|x| material_textures(x, out)),
        _ => {}
    }
}

fn named(kind: &str, v: &Value, i: usize) -> String {
    match v.get("name").and_then(Value::as_str) {
        Some(n) => format!("{kind} '{n}'"),
        None => format!("{kind} #{i}"),
    }
}

/// One warning per extension the file uses (in `extensionsUsed` or on any
/// object) that the importer does not apply, naming what carries it:
/// materials, meshes and nodes by name; a texture or image by the
/// materials that use it.
pub(super) fn unapplied_warnings(root: &json::Root) -> Vec<String> {
    let Ok(v) = serde_json::to_value(root) else {
        return Vec::new();
    };
    let array = |k: &str| {
        v.get(k)
            .and_then(Value::as_array)
            .cloned()
            .unwrap_or_default()
    };
    let materials = array("materials");
    let textures = array("textures");
    // Texture → the materials that use it; image → its textures.
    let mut users: BTreeMap<u64, BTreeSet<String>> = BTreeMap::new();
    for (i, m) in materials.iter().enumerate() {
        let mut t = BTreeSet::new();
        material_textures(m, &mut t);
        for ti in t {
            users.entry(ti).or_default().insert(named("material", m, i));
        }
    }
    let texture_users = |ti: u64| -> BTreeSet<String> {
        users
            .get(&ti)
            .cloned()
            .unwrap_or_else(|| [format!("texture #{ti}")].into())
    };

    let mut touched: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    if let Some(Value::Object(e)) = v.get("extensions") {
        for k in e.keys() {
            touched
                .entry(k.clone())
                .or_default()
                .insert("the file".into());
        }
    }
    if let Value::Object(top) = &v {
        for (key, arr) in top {
            let Value::Array(items) = arr else { continue };
            for (i, item) in items.iter().enumerate() {
                let mut names = BTreeSet::new();
                extension_names(item, &mut names);
                if names.is_empty() {
                    continue;
                }
                let labels: BTreeSet<String> = match key.as_str() {
                    "materials" => [named("material", item, i)].into(),
                    "meshes" => [named("mesh", item, i)].into(),
                    "nodes" => [named("node", item, i)].into(),
                    "textures" => texture_users(i as u64),
                    "images" => {
                        let mut s = BTreeSet::new();
                        for (ti, t) in textures.iter().enumerate() {
                            let mut sources = vec![t.get("source")];
                            if let Some(Value::Object(e)) = t.get("extensions") {
                                sources.extend(e.values().map(|x| x.get("source")));
                            }
                            if sources
                                .iter()
                                .any(|x| x.and_then(Value::as_u64) == Some(i as u64))
                            {
                                s.extend(texture_users(ti as u64));
                            }
                        }
                        if s.is_empty() {
                            s.insert(named("image", item, i));
                        }
                        s
                    }
                    other => [format!("{other}[{i}]")].into(),
                };
                for n in names {
                    touched.entry(n).or_default().extend(labels.iter().cloned());
                }
            }
        }
    }
    for e in &root.extensions_used {
        touched.entry(e.clone()).or_default();
    }
    let mut out = Vec::new();
    for (ext, labels) in touched {
        if APPLIED.contains(&ext.as_str()) {
            continue;
        }
        let what = if labels.is_empty() {
            "listed in extensionsUsed, found on no object".to_string()
        } else {
            let mut l: Vec<String> = labels.into_iter().collect();
            let more = l.len().saturating_sub(8);
            l.truncate(8);
            let mut s = format!("used by {}", l.join(", "));
            if more > 0 {
                s.push_str(&format!(" and {more} more"));
            }
            s
        };
        let effect = match ext.as_str() {
            "KHR_draco_mesh_compression" => {
                "gibake does not decode Draco and reads the uncompressed fallback data".to_string()
            }
            "KHR_texture_basisu" | "EXT_texture_avif" => {
                "gibake does not decode it and uses the texture's fallback image".to_string()
            }
            _ => "its data is ignored".to_string(),
        };
        out.push(format!(
            "glTF extension {ext} is not applied ({effect}): {what}"
        ));
    }
    out
}
