//! `EXT_meshopt_compression` and `KHR_meshopt_compression` (what `gltfpack
//! -c` and `gltf-transform meshopt` write): a buffer view whose extension
//! object points at compressed bytes in another buffer is decoded once,
//! right after the buffers are loaded, and every accessor reading that
//! view reads the decoded bytes ([`Ctx::view_bytes`]).
//!
//! Budgets: a decoded view of `count` elements is charged `count` elements
//! against `--max-elements` (accessors that read it are charged again, as
//! for any view), and its bytes against `--max-input-bytes`, summed over
//! every decoded view, before the decoder allocates anything. Fallback
//! buffers (`"fallback": true`: no data, only there for readers without the
//! extension) are never read.

use gltf::json;
use serde_json::Value;

use super::Ctx;
use crate::SceneError;
use crate::decode::{MeshoptFilter, MeshoptMode, meshopt_view};

/// The two names of the extension (the KHR one adds the COLOR filter and
/// version 1 of the vertex codec, both decoded alike).
pub(super) const NAMES: [&str; 2] = ["KHR_meshopt_compression", "EXT_meshopt_compression"];

/// The extension object of a buffer view or buffer, under either name.
fn ext_object(others: Option<&serde_json::Map<String, Value>>) -> Option<(&'static str, &Value)> {
    let others = others?;
    NAMES.iter().find_map(|n| others.get(*n).map(|v| (*n, v)))
}

/// Whether buffer `b` is a meshopt fallback buffer (it may have no data).
pub(super) fn is_fallback(b: &json::Buffer) -> bool {
    ext_object(b.extensions.as_ref().map(|e| &e.others))
        .and_then(|(_, v)| v.get("fallback"))
        .and_then(Value::as_bool)
        .unwrap_or(false)
}

/// One compressed view, as its extension object describes it.
struct Compressed {
    name: &'static str,
    buffer: usize,
    offset: u64,
    length: u64,
    stride: usize,
    count: usize,
    mode: MeshoptMode,
    filter: MeshoptFilter,
}

fn parse(name: &'static str, v: &Value) -> Result<Compressed, String> {
    let uint = |k: &str| -> Result<u64, String> {
        v.get(k)
            .and_then(Value::as_u64)
            .ok_or_else(|| format!("{name}: `{k}` is missing or not a non-negative integer"))
    };
    let size = |k: &str| -> Result<usize, String> {
        usize::try_from(uint(k)?).map_err(|_| format!("{name}: `{k}` is too large"))
    };
    let mode_s = v
        .get("mode")
        .and_then(Value::as_str)
        .ok_or_else(|| format!("{name}: `mode` is missing"))?;
    let mode =
        MeshoptMode::parse(mode_s).ok_or_else(|| format!("{name}: unknown mode '{mode_s}'"))?;
    let filter_s = v.get("filter").and_then(Value::as_str).unwrap_or("NONE");
    let filter = MeshoptFilter::parse(filter_s)
        .ok_or_else(|| format!("{name}: unknown filter '{filter_s}'"))?;
    if filter == MeshoptFilter::Color && name == "EXT_meshopt_compression" {
        return Err(format!(
            "{name}: filter COLOR belongs to KHR_meshopt_compression only"
        ));
    }
    Ok(Compressed {
        name,
        buffer: size("buffer")?,
        offset: v.get("byteOffset").and_then(Value::as_u64).unwrap_or(0),
        length: uint("byteLength")?,
        stride: size("byteStride")?,
        count: size("count")?,
        mode,
        filter,
    })
}

impl<'a> Ctx<'a> {
    /// Decodes every meshopt-compressed buffer view into `self.decoded`.
    pub(super) fn decode_meshopt_views(&mut self) -> Result<(), SceneError> {
        let root = self.root;
        let mut decoded_bytes: u64 = 0;
        for (vi, view) in root.buffer_views.iter().enumerate() {
            let Some((name, v)) = ext_object(view.extensions.as_ref().map(|e| &e.others)) else {
                continue;
            };
            let what = format!("bufferView {vi}");
            let c = parse(name, v).map_err(|e| self.invalid(format!("{what}: {e}")))?;
            let out_len = (c.count as u64).checked_mul(c.stride as u64);
            if out_len != Some(view.byte_length.0) {
                return Err(self.invalid(format!(
                    "{what}: {} count {} × byteStride {} does not equal the view's byteLength {}",
                    c.name, c.count, c.stride, view.byte_length.0
                )));
            }
            let out_len = view.byte_length.0;
            // Budgets first: nothing is allocated for a view over them.
            self.charge_elements(&what, c.count as u64)
                .map_err(|e| self.invalid(format!("{e} (meshopt-compressed data)")))?;
            decoded_bytes = decoded_bytes.saturating_add(out_len);
            let max = self.limits.max_input_bytes;
            if decoded_bytes > max {
                return Err(self.invalid(format!(
                    "{what}: decoding its {out_len} bytes would bring the meshopt-decoded data to {decoded_bytes} bytes, over the limit of {max} (raise it with --max-input-bytes)"
                )));
            }
            let src = self.buffers.get(c.buffer).ok_or_else(|| {
                self.invalid(format!(
                    "{what}: {} buffer {} does not exist",
                    c.name, c.buffer
                ))
            })?;
            let end = c
                .offset
                .checked_add(c.length)
                .filter(|&e| e <= src.len() as u64)
                .ok_or_else(|| {
                    self.invalid(format!(
                        "{what}: {} bytes {}..{} lie outside buffer {} ({} bytes)",
                        c.name,
                        c.offset,
                        c.offset.saturating_add(c.length),
                        c.buffer,
                        src.len()
                    ))
                })?;
            let bytes = &src[c.offset as usize..end as usize];
            let data = meshopt_view(bytes, c.count, c.stride, c.mode, c.filter)
                .map_err(|e| self.invalid(format!("{what}: cannot decode {} data: {e}", c.name)))?;
            self.decoded.insert(vi, data);
        }
        Ok(())
    }
}
