//! File-level checks around the parse: the GLB container (header and
//! chunks, split here rather than by the `gltf` crate), then, before the
//! document is validated, required extensions and extension-named texture
//! sources, and the indices gltf-json's validation would use without a
//! bounds check.

use std::path::Path;

use gltf::json;

use super::extensions;
use crate::SceneError;

/// Checks made before the document is validated (`validation.rs`): required
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

/// The JSON and the binary chunk of a `.glb`, or the whole input as JSON
/// when it does not start with the GLB magic.
pub(super) struct Container<'a> {
    pub(super) json: &'a [u8],
    pub(super) bin: Option<&'a [u8]>,
}

/// Splits a GLB container ourselves (the `gltf` crate subtracts before
/// checking the header, and refuses a chunk of unknown type where glTF 2.0
/// says readers ignore it): a 12-byte header, the JSON chunk first, then
/// optionally the BIN chunk, then chunks of other types, which are ignored
/// (the Khronos validator warns `GLB_UNKNOWN_CHUNK_TYPE`). A BIN chunk in
/// any other place, a second JSON chunk, or a chunk that does not fit is an
/// error, as it is for the validator.
pub(super) fn split_glb<'a>(bytes: &'a [u8], path: &Path) -> Result<Container<'a>, SceneError> {
    if !bytes.starts_with(b"glTF") {
        return Ok(Container {
            json: bytes,
            bin: None,
        });
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
    let bytes = &bytes[..length];
    let mut json = None;
    let mut bin = None;
    let mut at = 12;
    let mut index = 0;
    while at < bytes.len() {
        if bytes.len() - at < 8 {
            return Err(bad(format!(
                "corrupt GLB: {} stray bytes after the last chunk, at byte {at}",
                bytes.len() - at
            )));
        }
        let len = word(at) as usize;
        let kind = &bytes[at + 4..at + 8];
        let start = at + 8;
        let Some(end) = start.checked_add(len).filter(|&e| e <= bytes.len()) else {
            return Err(bad(format!(
                "truncated GLB: chunk {index} ({}) says {len} bytes at byte {start}, but the file ends at {}",
                chunk_name(kind),
                bytes.len()
            )));
        };
        let data = &bytes[start..end];
        match (index, kind) {
            (0, b"JSON") => json = Some(data),
            (0, _) => {
                return Err(bad(format!(
                    "corrupt GLB: the first chunk is {}, not JSON",
                    chunk_name(kind)
                )));
            }
            (1, b"BIN\0") => bin = Some(data),
            (_, b"BIN\0") => {
                return Err(bad(format!(
                    "corrupt GLB: a BIN chunk as chunk {index}; it must be the second chunk"
                )));
            }
            (_, b"JSON") => return Err(bad("corrupt GLB: a second JSON chunk".into())),
            // Chunks of other types are ignored (glTF 2.0, GLB file format).
            _ => {}
        }
        // Chunks start on 4-byte boundaries; an unpadded last chunk is
        // accepted, as the `gltf` crate did.
        at = end.saturating_add(3) & !3;
        index += 1;
    }
    let json = json.ok_or_else(|| bad("corrupt GLB: no JSON chunk".into()))?;
    Ok(Container { json, bin })
}

/// A chunk type for messages: its ASCII name, else its bytes in hex.
fn chunk_name(kind: &[u8]) -> String {
    let printable = kind.iter().all(|&b| b == 0 || b.is_ascii_graphic());
    if printable {
        format!("'{}'", String::from_utf8_lossy(kind).trim_end_matches('\0'))
    } else {
        format!(
            "type 0x{}",
            kind.iter()
                .rev()
                .map(|b| format!("{b:02x}"))
                .collect::<String>()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A GLB of `chunks` (type, data), each padded to 4 bytes.
    fn glb(chunks: &[(&[u8; 4], &[u8])]) -> Vec<u8> {
        let mut body = Vec::new();
        for (kind, data) in chunks {
            let mut d = data.to_vec();
            while d.len() % 4 != 0 {
                d.push(b' ');
            }
            body.extend_from_slice(&(d.len() as u32).to_le_bytes());
            body.extend_from_slice(*kind);
            body.extend_from_slice(&d);
        }
        let mut out = b"glTF".to_vec();
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(12 + body.len() as u32).to_le_bytes());
        out.extend_from_slice(&body);
        out
    }

    #[test]
    fn glb_header_checks() {
        let p = Path::new("x.glb");
        assert!(split_glb(b"glTF", p).is_err());
        let mut h = b"glTF".to_vec();
        h.extend_from_slice(&2u32.to_le_bytes());
        h.extend_from_slice(&4u32.to_le_bytes());
        h.extend_from_slice(&[0; 8]);
        let e = split_glb(&h, p).err().unwrap().to_string();
        assert!(e.contains("x.glb") && e.contains("too small"), "{e}");
        let plain = split_glb(b"{}", p).unwrap();
        assert_eq!((plain.json, plain.bin), (&b"{}"[..], None));
    }

    #[test]
    fn glb_chunks_of_unknown_type_are_ignored() {
        let p = Path::new("x.glb");
        // JSON, BIN, then an unknown chunk; JSON then an unknown chunk.
        let c = glb(&[(b"JSON", b"{}"), (b"BIN\0", b"abcd"), (b"XTRA", b"zz")]);
        let s = split_glb(&c, p).unwrap();
        assert_eq!((s.json, s.bin), (&b"{}  "[..], Some(&b"abcd"[..])));
        let c = glb(&[
            (b"JSON", b"{}"),
            (b"XTRA", b"zz"),
            (b"\x01\x02\x03\x04", b""),
        ]);
        let s = split_glb(&c, p).unwrap();
        assert_eq!((s.json, s.bin), (&b"{}  "[..], None));
        // The validator's errors stay errors: BIN not second, JSON not
        // first or twice, a chunk past the end.
        for (chunks, needle) in [
            (
                vec![(b"JSON", &b"{}"[..]), (b"XTRA", b""), (b"BIN\0", b"abcd")],
                "must be the second chunk",
            ),
            (vec![(b"BIN\0", &b"abcd"[..])], "first chunk is 'BIN'"),
            (vec![(b"JSON", &b"{}"[..]), (b"JSON", b"{}")], "second JSON"),
        ] {
            let e = split_glb(&glb(&chunks), p).err().unwrap().to_string();
            assert!(e.contains(needle), "{e}");
        }
        let mut c = glb(&[(b"JSON", b"{}"), (b"BIN\0", b"abcd")]);
        let n = c.len();
        c[20 + 4..24 + 4].copy_from_slice(&100u32.to_le_bytes());
        let e = split_glb(&c[..n], p).err().unwrap().to_string();
        assert!(e.contains("truncated GLB: chunk 1 ('BIN')"), "{e}");
    }
}
