//! Buffers and accessors: loads the buffers (GLB blob, external files, data
//! URIs), slices buffer views, and reads accessors (strided, normalised,
//! sparse) into tightly packed values, charging every element read against
//! the import's element budget.
//!
//! An accessor without `bufferView` is zeros (glTF 2.0), materialised up to
//! [`MAX_SYNTHETIC_ACCESSOR_BYTES`]; a `sparse` substitution applies on top
//! of either kind. Its indices must lie in range and strictly increase,
//! and its indices and values fit their buffer views; the rules that need
//! no data (its count, no byteStride) are `validation.rs`'s.

use glam::{Vec2, Vec3};
use gltf::json;
use gltf::json::accessor::{ComponentType, GenericComponentType, Type as AccessorType};
use gltf::json::validation::Checked;

use super::Ctx;
use crate::SceneError;

/// Largest accessor we materialise without a buffer view behind it (sparse
/// accessors or all-zero ones), in bytes.
pub(super) const MAX_SYNTHETIC_ACCESSOR_BYTES: usize = 1 << 28;

/// Decoded accessor contents, tightly packed (sparse substitution applied).
pub(super) struct RawAccessor {
    pub(super) dims: usize,
    ctype: ComponentType,
    normalized: bool,
    count: usize,
    bytes: Vec<u8>,
}

pub(super) fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

impl RawAccessor {
    /// All components as floats (normalized integers mapped per the glTF spec).
    pub(super) fn floats(&self) -> Vec<f32> {
        let b = &self.bytes;
        let n = self.count * self.dims;
        let norm = self.normalized;
        match self.ctype {
            ComponentType::F32 => b
                .chunks_exact(4)
                .take(n)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
            ComponentType::U32 => b
                .chunks_exact(4)
                .take(n)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f32)
                .collect(),
            ComponentType::U16 => b
                .chunks_exact(2)
                .take(n)
                .map(|c| {
                    let v = u16::from_le_bytes([c[0], c[1]]) as f32;
                    if norm { v / 65535.0 } else { v }
                })
                .collect(),
            ComponentType::I16 => b
                .chunks_exact(2)
                .take(n)
                .map(|c| {
                    let v = i16::from_le_bytes([c[0], c[1]]) as f32;
                    if norm { (v / 32767.0).max(-1.0) } else { v }
                })
                .collect(),
            ComponentType::U8 => b
                .iter()
                .take(n)
                .map(|&c| {
                    let v = c as f32;
                    if norm { v / 255.0 } else { v }
                })
                .collect(),
            ComponentType::I8 => b
                .iter()
                .take(n)
                .map(|&c| {
                    let v = c as i8 as f32;
                    if norm { (v / 127.0).max(-1.0) } else { v }
                })
                .collect(),
        }
    }

    /// Unsigned integer components (for indices).
    pub(super) fn uints(&self) -> Result<Vec<u32>, String> {
        let b = &self.bytes;
        let n = self.count * self.dims;
        match self.ctype {
            ComponentType::U8 => Ok(b.iter().take(n).map(|&c| c as u32).collect()),
            ComponentType::U16 => Ok(b
                .chunks_exact(2)
                .take(n)
                .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
                .collect()),
            ComponentType::U32 => Ok(b
                .chunks_exact(4)
                .take(n)
                .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect()),
            other => Err(format!(
                "component type {other:?} is not an unsigned integer type"
            )),
        }
    }
}

pub(super) fn vec3s(f: &[f32]) -> Vec<Vec3> {
    f.chunks_exact(3).map(Vec3::from_slice).collect()
}

pub(super) fn vec2s(f: &[f32]) -> Vec<Vec2> {
    f.chunks_exact(2).map(Vec2::from_slice).collect()
}

impl<'a> Ctx<'a> {
    pub(super) fn load_buffers(&mut self, blob: Option<Vec<u8>>) -> Result<(), SceneError> {
        let mut blob = blob;
        let mut buffers = Vec::with_capacity(self.root.buffers.len());
        for (i, b) in self.root.buffers.iter().enumerate() {
            let what = match &b.name {
                Some(n) => format!("buffer {i} '{n}'"),
                None => format!("buffer {i}"),
            };
            let fallback = super::meshopt::is_fallback(b);
            let data = match b.uri.as_deref() {
                // A meshopt fallback buffer needs no data: the views in it
                // are decoded from the compressed bytes elsewhere.
                None if fallback => Vec::new(),
                None => blob.take().ok_or_else(|| {
                    self.invalid(format!(
                        "{what} has no uri and the file has no GLB BIN chunk for it"
                    ))
                })?,
                Some(uri) if uri.starts_with("data:") => {
                    gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
                        .map_err(|e| self.invalid(format!("{what}: bad data URI: {e}")))?
                        .0
                }
                Some(uri) => self.read_external(uri, &what)?.1,
            };
            let expected = b.byte_length.0;
            if (data.len() as u64) < expected && !(fallback && data.is_empty()) {
                return Err(self.invalid(format!(
                    "{what}: byteLength is {expected} but only {} bytes are available (truncated file?)",
                    data.len()
                )));
            }
            buffers.push(gltf::buffer::Data(data));
        }
        self.buffers = buffers;
        Ok(())
    }

    /// The bytes of buffer view `v`, range-checked (the decoded bytes of a
    /// meshopt-compressed view).
    pub(super) fn view_bytes(&self, v: usize) -> Result<(&[u8], Option<usize>), String> {
        let view = self
            .root
            .buffer_views
            .get(v)
            .ok_or_else(|| format!("bufferView {v} does not exist"))?;
        if let Some(d) = self.decoded.get(&v) {
            return Ok((d, view.byte_stride.map(|s| s.0)));
        }
        if self
            .buffers
            .get(view.buffer.value())
            .is_some_and(|b| b.is_empty())
            && self
                .root
                .buffers
                .get(view.buffer.value())
                .is_some_and(super::meshopt::is_fallback)
        {
            return Err(format!(
                "bufferView {v} lies in buffer {}, a meshopt fallback buffer that holds no data",
                view.buffer.value()
            ));
        }
        let buf = self.buffers.get(view.buffer.value()).ok_or_else(|| {
            format!(
                "bufferView {v}: buffer {} does not exist",
                view.buffer.value()
            )
        })?;
        let off = view.byte_offset.map(|o| o.0).unwrap_or(0);
        let len = view.byte_length.0;
        let end = off
            .checked_add(len)
            .filter(|&e| e <= buf.len() as u64)
            .ok_or_else(|| {
                format!(
                    "bufferView {v} (bytes {off}..{}) lies outside buffer {} ({} bytes)",
                    off.saturating_add(len),
                    view.buffer.value(),
                    buf.len()
                )
            })?;
        Ok((
            &buf[off as usize..end as usize],
            view.byte_stride.map(|s| s.0),
        ))
    }

    /// Reads accessor `idx` into a tightly packed byte array, checking every
    /// offset and count against the buffers.
    pub(super) fn read_accessor(&self, idx: usize) -> Result<RawAccessor, String> {
        let acc = self
            .root
            .accessors
            .get(idx)
            .ok_or_else(|| format!("accessor {idx} does not exist"))?;
        let label = match &acc.name {
            Some(n) => format!("accessor {idx} '{n}'"),
            None => format!("accessor {idx}"),
        };
        let ctype = match acc.component_type {
            Checked::Valid(GenericComponentType(c)) => c,
            Checked::Invalid => return Err(format!("{label}: invalid componentType")),
        };
        let dims = match acc.type_ {
            Checked::Valid(AccessorType::Scalar) => 1,
            Checked::Valid(AccessorType::Vec2) => 2,
            Checked::Valid(AccessorType::Vec3) => 3,
            Checked::Valid(AccessorType::Vec4) => 4,
            Checked::Valid(t) => return Err(format!("{label}: type {t:?} is not supported here")),
            Checked::Invalid => return Err(format!("{label}: invalid type")),
        };
        let elem = dims * component_size(ctype);
        let count = usize::try_from(acc.count.0)
            .map_err(|_| format!("{label}: count {} is too large", acc.count.0))?;
        let total = count
            .checked_mul(elem)
            .ok_or_else(|| format!("{label}: count {count} is too large"))?;
        let sparse_count = acc.sparse.as_ref().map_or(0, |s| s.count.0);
        self.charge_elements(&label, (count as u64).saturating_add(sparse_count))?;

        let mut bytes;
        if let Some(v) = acc.buffer_view {
            let (view, stride) = self
                .view_bytes(v.value())
                .map_err(|e| format!("{label}: {e}"))?;
            let stride = stride.unwrap_or(elem);
            if stride < elem {
                return Err(format!(
                    "{label}: byteStride {stride} is smaller than the element size {elem}"
                ));
            }
            let off = usize::try_from(acc.byte_offset.map(|o| o.0).unwrap_or(0))
                .map_err(|_| format!("{label}: byteOffset is too large"))?;
            if count > 0 {
                let need = stride
                    .checked_mul(count - 1)
                    .and_then(|x| x.checked_add(off))
                    .and_then(|x| x.checked_add(elem))
                    .filter(|&need| need <= view.len());
                if need.is_none() {
                    return Err(format!(
                        "{label}: {count} elements of {elem} bytes (stride {stride}, offset {off}) do not fit in its bufferView {} of {} bytes",
                        v.value(),
                        view.len()
                    ));
                }
            }
            bytes = Vec::with_capacity(total);
            for i in 0..count {
                let s = off + i * stride;
                bytes.extend_from_slice(&view[s..s + elem]);
            }
        } else {
            if total > MAX_SYNTHETIC_ACCESSOR_BYTES {
                return Err(format!(
                    "{label}: count {count} is too large for an accessor without bufferView"
                ));
            }
            bytes = vec![0u8; total];
        }

        if let Some(sparse) = &acc.sparse {
            let sc = usize::try_from(sparse.count.0)
                .map_err(|_| format!("{label}: sparse count is too large"))?;
            if sc == 0 || sc > count {
                return Err(format!(
                    "{label}: sparse count {sc} must be between 1 and the accessor count {count}"
                ));
            }
            let ityp = match sparse.indices.component_type {
                Checked::Valid(json::accessor::IndexComponentType(c)) => c,
                Checked::Invalid => {
                    return Err(format!("{label}: invalid sparse index componentType"));
                }
            };
            let isize = component_size(ityp);
            let (iview, _) = self
                .view_bytes(sparse.indices.buffer_view.value())
                .map_err(|e| format!("{label}: sparse indices: {e}"))?;
            let (vview, _) = self
                .view_bytes(sparse.values.buffer_view.value())
                .map_err(|e| format!("{label}: sparse values: {e}"))?;
            let ioff = usize::try_from(sparse.indices.byte_offset.0).unwrap_or(usize::MAX);
            let voff = usize::try_from(sparse.values.byte_offset.0).unwrap_or(usize::MAX);
            let ifits = sc
                .checked_mul(isize)
                .and_then(|x| x.checked_add(ioff))
                .is_some_and(|e| e <= iview.len());
            let vfits = sc
                .checked_mul(elem)
                .and_then(|x| x.checked_add(voff))
                .is_some_and(|e| e <= vview.len());
            if !ifits || !vfits {
                return Err(format!(
                    "{label}: sparse indices or values do not fit in their bufferViews"
                ));
            }
            let mut previous: Option<usize> = None;
            for k in 0..sc {
                let p = ioff + k * isize;
                let target = match ityp {
                    ComponentType::U8 => iview[p] as usize,
                    ComponentType::U16 => u16::from_le_bytes([iview[p], iview[p + 1]]) as usize,
                    ComponentType::U32 => {
                        u32::from_le_bytes([iview[p], iview[p + 1], iview[p + 2], iview[p + 3]])
                            as usize
                    }
                    other => {
                        return Err(format!(
                            "{label}: sparse index type {other:?} is not allowed"
                        ));
                    }
                };
                if target >= count {
                    return Err(format!(
                        "{label}: sparse index {target} is out of range (count {count})"
                    ));
                }
                // glTF 2.0: the indices strictly increase (so no element is
                // substituted twice and the order of writes cannot matter).
                if let Some(prev) = previous
                    && target <= prev
                {
                    return Err(format!(
                        "{label}: sparse indices must strictly increase, but index {k} is {target} after {prev}"
                    ));
                }
                previous = Some(target);
                let src = voff + k * elem;
                bytes[target * elem..(target + 1) * elem].copy_from_slice(&vview[src..src + elem]);
            }
        }
        Ok(RawAccessor {
            dims,
            ctype,
            normalized: acc.normalized,
            count,
            bytes,
        })
    }

    /// Counts `n` more accessor elements against the budget, before they are read.
    pub(super) fn charge_elements(&self, label: &str, n: u64) -> Result<(), String> {
        let total = self.elements_read.get().saturating_add(n);
        let max = self.limits.max_elements;
        if total > max {
            return Err(format!(
                "{label}: reading its {n} elements would bring the accessor elements read to {total}, over the limit of {max} (raise it with --max-elements)"
            ));
        }
        self.elements_read.set(total);
        Ok(())
    }

    /// Reads a float accessor with `dims` components per element.
    pub(super) fn read_floats(&self, idx: usize, dims: usize) -> Result<(Vec<f32>, usize), String> {
        let raw = self.read_accessor(idx)?;
        if raw.dims != dims {
            return Err(format!(
                "accessor {idx} has {} components per element, expected {dims}",
                raw.dims
            ));
        }
        Ok((raw.floats(), raw.count))
    }
}
