//! File-level checks before the `gltf` crate parses and validates: the GLB
//! container header, required extensions and extension-named texture
//! sources, and the indices gltf-json's validation would use without a
//! bounds check.

use std::path::Path;

use gltf::json;

use super::extensions;
use crate::SceneError;

/// Checks made before the `gltf` crate validates the document: required
/// extensions we cannot honour (a clear "not supported" instead of a generic
/// validation error; the ones we apply or can ignore are removed so
/// validation accepts them), `EXT_texture_webp` sources, and POSITION
/// accessor indices (gltf-json's validation indexes them without a bounds
/// check).
pub(super) fn precheck(root: &mut json::Root, path: &Path) -> Result<(), SceneError> {
    extensions::check_required(root, path)?;
    extensions::resolve_texture_sources(root, path)?;
    extensions::check_draco_fallback(root, path)?;
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            for acc in prim.attributes.values() {
                if acc.value() >= root.accessors.len() {
                    return Err(SceneError::Invalid {
                        path: path.to_path_buf(),
                        message: format!(
                            "mesh {mi} primitive {pi}: accessor {} does not exist ({} accessors)",
                            acc.value(),
                            root.accessors.len()
                        ),
                    });
                }
            }
        }
    }
    Ok(())
}

/// Checks the 12-byte GLB header ourselves (the `gltf` crate subtracts before
/// checking) and returns the bytes the header says belong to the file.
pub(super) fn check_glb_header<'a>(bytes: &'a [u8], path: &Path) -> Result<&'a [u8], SceneError> {
    if !bytes.starts_with(b"glTF") {
        return Ok(bytes);
    }
    let bad = |message: String| SceneError::Invalid {
        path: path.to_path_buf(),
        message,
    };
    if bytes.len() < 20 {
        return Err(bad(format!(
            "truncated GLB: {} bytes, not even a header and a chunk header",
            bytes.len()
        )));
    }
    let word = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let version = word(4);
    if version != 2 {
        return Err(bad(format!(
            "GLB version {version} is not supported (only glTF 2.0)"
        )));
    }
    let length = word(8) as usize;
    if length < 20 {
        return Err(bad(format!(
            "corrupt GLB header: total length {length} is too small"
        )));
    }
    if length > bytes.len() {
        return Err(bad(format!(
            "truncated GLB: the header says {length} bytes but the file has only {}",
            bytes.len()
        )));
    }
    Ok(&bytes[..length])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glb_header_checks() {
        let p = Path::new("x.glb");
        assert!(check_glb_header(b"glTF", p).is_err());
        let mut h = b"glTF".to_vec();
        h.extend_from_slice(&2u32.to_le_bytes());
        h.extend_from_slice(&4u32.to_le_bytes());
        h.extend_from_slice(&[0; 8]);
        let e = check_glb_header(&h, p).unwrap_err().to_string();
        assert!(e.contains("x.glb") && e.contains("too small"), "{e}");
        assert_eq!(check_glb_header(b"{}", p).unwrap(), b"{}");
    }
}
