//! glTF → [`Scene`].
//!
//! The file is parsed and validated by the `gltf` crate; everything after that
//! (buffer loading, accessor reading, hierarchy checks) is done here with
//! checked arithmetic, so that malformed input gives a [`SceneError`] naming
//! the file and never a panic. As a last line of defence the whole import runs
//! under `catch_unwind`.

use std::cell::Cell;
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::json;
use gltf::json::accessor::{ComponentType, GenericComponentType, Type as AccessorType};
use gltf::json::validation::Checked;

use crate::animation::{Animator, Channel, ChannelPath, Interpolation};
use crate::limits::{self, FileRefusal, Limits};
use crate::mesh::compute_normals;
use crate::{
    Aabb, Camera, DynamicObject, Light, LightKind, Material, Mesh, Projection, Scene, SceneError,
    Texture,
};

/// Options for [`load`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Pick the primary light by name when the file has several candidates.
    pub light: Option<String>,
    /// Resource budgets (file sizes, accessor elements, texels, animation
    /// work, where external URIs may point).
    pub limits: Limits,
}

/// Loads a `.gltf` (with its external buffers/images) or `.glb` file.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let bytes =
        limits::read_regular(path, options.limits.max_input_bytes).map_err(|e| match e {
            FileRefusal::Io(source) => SceneError::Io {
                path: path.to_path_buf(),
                source,
            },
            e => SceneError::Invalid {
                path: path.to_path_buf(),
                message: e.to_string(),
            },
        })?;
    load_from_slice(&bytes, path, options)
}

/// Loads a glTF held in memory. `path` is used for messages and to resolve
/// relative URIs of external buffers and images.
pub fn load_from_slice(
    bytes: &[u8],
    path: &Path,
    options: &LoadOptions,
) -> Result<Scene, SceneError> {
    match catch_unwind(AssertUnwindSafe(|| import(bytes, path, options))) {
        Ok(result) => result,
        Err(_) => Err(SceneError::Invalid {
            path: path.to_path_buf(),
            message:
                "internal error while importing this file (a bug in gibake-scene, please report it)"
                    .into(),
        }),
    }
}

/// Largest accessor we materialise without a buffer view behind it (sparse
/// accessors or all-zero ones), in bytes.
const MAX_SYNTHETIC_ACCESSOR_BYTES: usize = 1 << 28;

/// Extensions that may be listed in `extensionsRequired` without stopping us.
const HARMLESS_REQUIRED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_mesh_quantization",
    "KHR_materials_variants",
];

fn import(bytes: &[u8], path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let bytes = check_glb_header(bytes, path)?;
    let gltf_err = |source| SceneError::Gltf {
        path: path.to_path_buf(),
        source,
    };
    // Parse, run our own checks on what the gltf crate's validation would
    // choke on (or reject for the wrong reason), then validate.
    let gltf = gltf::Gltf::from_slice_without_validation(bytes).map_err(gltf_err)?;
    let gltf::Gltf { document, blob } = gltf;
    let mut root = document.into_json();
    precheck(&mut root, path)?;
    let document = gltf::Document::from_json(root).map_err(gltf_err)?;
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut ctx = Ctx {
        path,
        base,
        document: &document,
        root: document.as_json(),
        buffers: Vec::new(),
        warnings: Vec::new(),
        limits: &options.limits,
        elements_read: Cell::new(0),
        texels_decoded: Cell::new(0),
    };
    ctx.load_buffers(blob)?;
    ctx.build(options)
}

/// Checks made before the `gltf` crate validates the document: required
/// extensions we cannot honour (a clear "not supported" instead of a generic
/// validation error; the ones we can ignore are removed so validation accepts
/// them), and POSITION accessor indices (gltf-json's validation indexes them
/// without a bounds check).
fn precheck(root: &mut json::Root, path: &Path) -> Result<(), SceneError> {
    let unsupported: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !HARMLESS_REQUIRED.contains(e) && !e.starts_with("KHR_materials_"))
        .collect();
    if !unsupported.is_empty() {
        return Err(SceneError::NotSupported {
            path: path.to_path_buf(),
            message: format!("required glTF extension(s) {}", unsupported.join(", ")),
        });
    }
    root.extensions_required.clear();
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
fn check_glb_header<'a>(bytes: &'a [u8], path: &Path) -> Result<&'a [u8], SceneError> {
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

/// Decoded accessor contents, tightly packed (sparse substitution applied).
struct RawAccessor {
    dims: usize,
    ctype: ComponentType,
    normalized: bool,
    count: usize,
    bytes: Vec<u8>,
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

impl RawAccessor {
    /// All components as floats (normalized integers mapped per the glTF spec).
    fn floats(&self) -> Vec<f32> {
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
    fn uints(&self) -> Result<Vec<u32>, String> {
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

fn vec3s(f: &[f32]) -> Vec<Vec3> {
    f.chunks_exact(3).map(Vec3::from_slice).collect()
}

fn vec2s(f: &[f32]) -> Vec<Vec2> {
    f.chunks_exact(2).map(Vec2::from_slice).collect()
}

fn extras_dynamic(extras: &json::Extras) -> bool {
    extras
        .as_ref()
        .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
        .and_then(|v| v.get("dynamic").and_then(|d| d.as_bool()))
        .unwrap_or(false)
}

/// Percent-decodes a relative URI (malformed escapes are kept literally).
fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push(h << 4 | l);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8(out).ok()
}

/// One primitive's data as read from the file (node-local space).
struct PrimData {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    indices: Vec<u32>,
    material: usize,
}

struct Ctx<'a> {
    path: &'a Path,
    base: PathBuf,
    document: &'a gltf::Document,
    root: &'a json::Root,
    buffers: Vec<gltf::buffer::Data>,
    warnings: Vec<String>,
    limits: &'a Limits,
    /// Accessor elements read so far (against `limits.max_elements`).
    elements_read: Cell<u64>,
    /// Texels decoded so far (against `limits.max_texels`).
    texels_decoded: Cell<u64>,
}

/// Per-import state for materials and textures.
#[derive(Default)]
struct MaterialTable {
    materials: Vec<Material>,
    textures: Vec<Texture>,
    /// (glTF material, textured) → scene material.
    by_key: HashMap<(Option<usize>, bool), usize>,
    /// glTF image → scene texture.
    by_image: HashMap<usize, usize>,
    warned_inputs: bool,
}

impl<'a> Ctx<'a> {
    fn invalid(&self, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_path_buf(),
            message: message.into(),
        }
    }

    fn acc_err(&self, name: &str, acc: usize, what: &str, e: String) -> SceneError {
        self.invalid(format!("mesh {name}: {what} (accessor {acc}): {e}"))
    }

    fn not_supported(&self, message: impl Into<String>) -> SceneError {
        SceneError::NotSupported {
            path: self.path.to_path_buf(),
            message: message.into(),
        }
    }

    fn warn(&mut self, message: impl Into<String>) {
        let message = message.into();
        tracing::warn!("{}: {}", self.path.display(), message);
        self.warnings.push(message);
    }

    fn node_name(&self, i: usize) -> String {
        match self.root.nodes.get(i).and_then(|n| n.name.as_deref()) {
            Some(n) => format!("'{n}'"),
            None => format!("#{i}"),
        }
    }

    fn mesh_name(&self, i: usize) -> String {
        match self.root.meshes.get(i).and_then(|n| n.name.as_deref()) {
            Some(n) => n.to_string(),
            None => format!("mesh #{i}"),
        }
    }

    // ---------------------------------------------------------------- buffers

    /// Resolves a non-data URI to a file path.
    fn resolve_uri(&self, uri: &str, what: &str) -> Result<PathBuf, SceneError> {
        let file = self.resolve_uri_unchecked(uri, what)?;
        if !self.limits.allow_outside_uris && !limits::is_inside(&self.base, &file) {
            return Err(self.invalid(format!(
                "{what}: URI '{uri}' points outside the scene's directory {} (to {}); pass --allow-outside-uris to allow it",
                self.base.display(),
                file.display()
            )));
        }
        Ok(file)
    }

    fn resolve_uri_unchecked(&self, uri: &str, what: &str) -> Result<PathBuf, SceneError> {
        if let Some(rest) = uri
            .strip_prefix("file://")
            .or_else(|| uri.strip_prefix("file:"))
        {
            return Ok(PathBuf::from(rest));
        }
        if uri.contains(':') {
            return Err(self.not_supported(format!(
                "{what}: URI scheme of '{uri}' (only relative paths, file: and data: URIs)"
            )));
        }
        let decoded = percent_decode(uri).ok_or_else(|| {
            self.invalid(format!(
                "{what}: URI '{uri}' is not valid UTF-8 once percent-decoded"
            ))
        })?;
        Ok(self.base.join(decoded))
    }

    fn read_external(&self, uri: &str, what: &str) -> Result<(PathBuf, Vec<u8>), SceneError> {
        let file = self.resolve_uri(uri, what)?;
        match limits::read_regular(&file, self.limits.max_input_bytes) {
            Ok(b) => Ok((file, b)),
            Err(e) => Err(self.invalid(format!(
                "{what}: cannot read '{uri}' ({}): {e}",
                file.display()
            ))),
        }
    }

    fn load_buffers(&mut self, blob: Option<Vec<u8>>) -> Result<(), SceneError> {
        let mut blob = blob;
        let mut buffers = Vec::with_capacity(self.root.buffers.len());
        for (i, b) in self.root.buffers.iter().enumerate() {
            let what = match &b.name {
                Some(n) => format!("buffer {i} '{n}'"),
                None => format!("buffer {i}"),
            };
            let data = match b.uri.as_deref() {
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
            if (data.len() as u64) < expected {
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

    /// The bytes of buffer view `v`, range-checked.
    fn view_bytes(&self, v: usize) -> Result<(&[u8], Option<usize>), String> {
        let view = self
            .root
            .buffer_views
            .get(v)
            .ok_or_else(|| format!("bufferView {v} does not exist"))?;
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
    fn read_accessor(&self, idx: usize) -> Result<RawAccessor, String> {
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
            if sc > count {
                return Err(format!(
                    "{label}: sparse count {sc} exceeds the accessor count {count}"
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
    fn charge_elements(&self, label: &str, n: u64) -> Result<(), String> {
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

    /// Counts a `w × h` image against the texel budget, before it is decoded.
    fn charge_texels(&self, what: &str, w: u32, h: u32) -> Result<(), SceneError> {
        let n = w as u64 * h as u64;
        let total = self.texels_decoded.get().saturating_add(n);
        let max = self.limits.max_texels;
        if total > max {
            return Err(self.invalid(format!(
                "{what}: {w}x{h} texels would bring the texels decoded to {total}, over the limit of {max} (raise it with --max-texels)"
            )));
        }
        self.texels_decoded.set(total);
        Ok(())
    }

    /// Reads a float accessor with `dims` components per element.
    fn read_floats(&self, idx: usize, dims: usize) -> Result<(Vec<f32>, usize), String> {
        let raw = self.read_accessor(idx)?;
        if raw.dims != dims {
            return Err(format!(
                "accessor {idx} has {} components per element, expected {dims}",
                raw.dims
            ));
        }
        Ok((raw.floats(), raw.count))
    }

    // -------------------------------------------------------------- hierarchy

    /// Parent of every node, checking that the nodes form a forest.
    fn parents(&self) -> Result<Vec<Option<usize>>, SceneError> {
        let n = self.root.nodes.len();
        let mut parents: Vec<Option<usize>> = vec![None; n];
        for (p, node) in self.root.nodes.iter().enumerate() {
            for c in node.children.iter().flatten() {
                let c = c.value();
                if c >= n {
                    return Err(self.invalid(format!(
                        "node {} has child {c}, which does not exist",
                        self.node_name(p)
                    )));
                }
                if c == p {
                    return Err(
                        self.invalid(format!("node {} is its own child", self.node_name(p)))
                    );
                }
                if let Some(q) = parents[c] {
                    return Err(self.invalid(format!(
                        "node {} is a child of both node {} and node {} (the node hierarchy must be a tree)",
                        self.node_name(c),
                        self.node_name(q),
                        self.node_name(p)
                    )));
                }
                parents[c] = Some(p);
            }
        }
        // Cycle check: each node has at most one parent, so walk up with marks.
        let mut state = vec![0usize; n]; // 0 = unseen, usize::MAX = done, k+1 = on walk k
        for start in 0..n {
            let mut cur = Some(start);
            while let Some(c) = cur {
                if state[c] == usize::MAX {
                    break;
                }
                if state[c] == start + 1 {
                    return Err(self.invalid(format!(
                        "the node hierarchy has a cycle through node {}",
                        self.node_name(c)
                    )));
                }
                state[c] = start + 1;
                cur = parents[c];
            }
            let mut cur = Some(start);
            while let Some(c) = cur {
                if state[c] == usize::MAX {
                    break;
                }
                state[c] = usize::MAX;
                cur = parents[c];
            }
        }
        Ok(parents)
    }

    fn rest_matrices(&self) -> Result<Vec<Mat4>, SceneError> {
        let mut out = Vec::with_capacity(self.root.nodes.len());
        for (i, node) in self.root.nodes.iter().enumerate() {
            let m = if let Some(m) = node.matrix {
                Mat4::from_cols_array(&m)
            } else {
                let t = Vec3::from(node.translation.unwrap_or([0.0; 3]));
                let r = node
                    .rotation
                    .as_ref()
                    .map(|q| Vec4::from(q.0))
                    .unwrap_or(Vec4::W);
                let s = Vec3::from(node.scale.unwrap_or([1.0; 3]));
                if !(t.is_finite() && r.is_finite() && s.is_finite()) {
                    return Err(self.invalid(format!(
                        "node {} has a non-finite transform",
                        self.node_name(i)
                    )));
                }
                let len = r.length();
                if !(len.is_finite() && len > 0.0) {
                    return Err(self.invalid(format!(
                        "node {} has a zero rotation quaternion",
                        self.node_name(i)
                    )));
                }
                Mat4::from_scale_rotation_translation(s, Quat::from_vec4(r / len), t)
            };
            if !m.is_finite() {
                return Err(self.invalid(format!(
                    "node {} has a non-finite transform",
                    self.node_name(i)
                )));
            }
            out.push(m);
        }
        Ok(out)
    }

    fn channels(&mut self) -> Result<Vec<Channel>, SceneError> {
        let mut out = Vec::new();
        let root = self.root;
        for (ai, anim) in root.animations.iter().enumerate() {
            let aname = match &anim.name {
                Some(n) => format!("animation '{n}'"),
                None => format!("animation #{ai}"),
            };
            let mut warned_weights = false;
            for (ci, ch) in anim.channels.iter().enumerate() {
                let what = format!("{aname} channel {ci}");
                let path = match ch.target.path {
                    Checked::Valid(json::animation::Property::Translation) => {
                        ChannelPath::Translation
                    }
                    Checked::Valid(json::animation::Property::Rotation) => ChannelPath::Rotation,
                    Checked::Valid(json::animation::Property::Scale) => ChannelPath::Scale,
                    Checked::Valid(json::animation::Property::MorphTargetWeights) => {
                        if !warned_weights {
                            warned_weights = true;
                            self.warn(format!("{aname}: morph target weight channels are ignored"));
                        }
                        continue;
                    }
                    Checked::Invalid => {
                        return Err(self.invalid(format!("{what}: invalid target path")));
                    }
                };
                let node = ch.target.node.value();
                if node >= root.nodes.len() {
                    return Err(self.invalid(format!("{what}: target node {node} does not exist")));
                }
                let sampler = anim.samplers.get(ch.sampler.value()).ok_or_else(|| {
                    self.invalid(format!(
                        "{what}: sampler {} does not exist",
                        ch.sampler.value()
                    ))
                })?;
                let interpolation = match sampler.interpolation {
                    Checked::Valid(json::animation::Interpolation::Linear) => Interpolation::Linear,
                    Checked::Valid(json::animation::Interpolation::Step) => Interpolation::Step,
                    Checked::Valid(json::animation::Interpolation::CubicSpline) => {
                        Interpolation::CubicSpline
                    }
                    Checked::Invalid => {
                        return Err(self.invalid(format!("{what}: invalid interpolation")));
                    }
                };
                let (times, n) = self
                    .read_floats(sampler.input.value(), 1)
                    .map_err(|e| self.invalid(format!("{what}: input: {e}")))?;
                if n == 0 {
                    return Err(self.invalid(format!("{what}: no keyframes")));
                }
                if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0]) {
                    return Err(self.invalid(format!(
                        "{what}: keyframe times (accessor {}) must be finite and increasing",
                        sampler.input.value()
                    )));
                }
                let dims = if path == ChannelPath::Rotation { 4 } else { 3 };
                let (vals, m) = self
                    .read_floats(sampler.output.value(), dims)
                    .map_err(|e| self.invalid(format!("{what}: output: {e}")))?;
                let expected = if interpolation == Interpolation::CubicSpline {
                    3 * n
                } else {
                    n
                };
                if m != expected {
                    return Err(self.invalid(format!(
                        "{what}: output accessor {} has {m} elements, expected {expected} for {n} keyframes",
                        sampler.output.value()
                    )));
                }
                if vals.iter().any(|v| !v.is_finite()) {
                    return Err(self.invalid(format!(
                        "{what}: output accessor {} holds non-finite values",
                        sampler.output.value()
                    )));
                }
                let values: Vec<Vec4> = vals
                    .chunks_exact(dims)
                    .map(|c| {
                        if dims == 4 {
                            Vec4::from_slice(c)
                        } else {
                            Vec3::from_slice(c).extend(0.0)
                        }
                    })
                    .collect();
                out.push(Channel {
                    node,
                    path,
                    interpolation,
                    times,
                    values,
                    animation: ai,
                });
            }
        }
        Ok(out)
    }

    // ------------------------------------------------------------------ build

    fn build(mut self, options: &LoadOptions) -> Result<Scene, SceneError> {
        let root = self.root;
        let scene_index = match root.scene {
            Some(s) => s.value(),
            None if !root.scenes.is_empty() => 0,
            None => return Err(self.invalid("the file has no scene")),
        };
        let scene = root
            .scenes
            .get(scene_index)
            .ok_or_else(|| self.invalid(format!("scene {scene_index} does not exist")))?;

        let parents = self.parents()?;
        let rest = self.rest_matrices()?;
        let channels = self.channels()?;
        let total_keys: u64 = channels.iter().map(|c| c.times.len() as u64).sum();
        let animator = Animator::new(parents.clone(), rest, channels);

        // Depth-first traversal in document order, computing dynamic flags.
        let n = root.nodes.len();
        let mut order = Vec::new();
        let mut dynamic = vec![false; n];
        let mut visited = vec![false; n];
        let mut stack: Vec<(usize, bool)> = Vec::new();
        for r in scene.nodes.iter().rev() {
            let r = r.value();
            if r >= n {
                return Err(self.invalid(format!(
                    "scene {scene_index} lists node {r}, which does not exist"
                )));
            }
            if let Some(p) = parents[r] {
                return Err(self.invalid(format!(
                    "scene root node {} is also a child of node {}",
                    self.node_name(r),
                    self.node_name(p)
                )));
            }
            stack.push((r, false));
        }
        while let Some((v, parent_dynamic)) = stack.pop() {
            if visited[v] {
                continue;
            }
            visited[v] = true;
            let d =
                parent_dynamic || extras_dynamic(&root.nodes[v].extras) || animator.is_animated(v);
            dynamic[v] = d;
            order.push(v);
            for c in root.nodes[v].children.iter().flatten().rev() {
                stack.push((c.value(), d));
            }
        }

        let light = self.primary_light(&order, &dynamic, &animator, options)?;
        let camera = self.camera(&order)?;

        let mut table = MaterialTable::default();
        let mut static_meshes = Vec::new();
        let mut dynamic_meshes = Vec::new();
        let mut dynamic_objects = Vec::new();
        for &v in &order {
            let node = &root.nodes[v];
            let Some(mesh_index) = node.mesh.map(|m| m.value()) else {
                continue;
            };
            if node.skin.is_some() {
                self.warn(format!(
                    "node {}: skin ignored, the mesh is rendered rigid",
                    self.node_name(v)
                ));
            }
            let node_label = match &node.name {
                Some(nm) => nm.clone(),
                None => format!("node #{v}"),
            };
            let prims = self.read_mesh(mesh_index, &node_label, &mut table)?;
            if dynamic[v] {
                let mut object = DynamicObject {
                    name: node_label.clone(),
                    node: v,
                    meshes: Vec::new(),
                    local_bounds: Aabb::EMPTY,
                };
                for (name, p) in prims {
                    for &q in &p.positions {
                        object.local_bounds.grow(q);
                    }
                    let normals = match p.normals {
                        Some(nr) => nr,
                        None => compute_normals(&p.positions, &p.indices),
                    };
                    object.meshes.push(dynamic_meshes.len());
                    dynamic_meshes.push(Mesh {
                        name,
                        positions: p.positions,
                        normals,
                        uvs: p.uvs,
                        indices: p.indices,
                        material: p.material,
                    });
                }
                if !object.meshes.is_empty() {
                    dynamic_objects.push(object);
                }
            } else {
                let world = animator.world_matrix(v, 0.0);
                for (name, p) in prims {
                    static_meshes.push(self.flatten(name, p, world)?);
                }
            }
        }

        let work = total_keys.saturating_mul(dynamic_objects.len() as u64);
        if work > self.limits.max_animation_work {
            return Err(self.invalid(format!(
                "{total_keys} animation keyframes × {} moving objects = {work}, over the animation work limit of {} (raise it with --max-animation-work)",
                dynamic_objects.len(),
                self.limits.max_animation_work
            )));
        }

        let static_triangles: usize = static_meshes
            .iter()
            .map(|m: &Mesh| m.indices.len() / 3)
            .sum();
        if static_triangles == 0 {
            return Err(self.invalid(
                "no static triangles: the scene needs static geometry (everything is dynamic, skipped or empty)",
            ));
        }

        Ok(Scene {
            source: self.path.to_path_buf(),
            light,
            camera,
            materials: table.materials,
            textures: table.textures,
            static_meshes,
            dynamic_meshes,
            dynamic_objects,
            animator,
            warnings: self.warnings,
        })
    }

    // ------------------------------------------------------------------ light

    fn primary_light(
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
                "no KHR_lights_punctual spot or directional light{extra}; gibake needs exactly one as its primary light"
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

    // ----------------------------------------------------------------- camera

    fn camera(&self, order: &[usize]) -> Result<Option<Camera>, SceneError> {
        let root = self.root;
        let Some((node, ci)) = order
            .iter()
            .find_map(|&v| root.nodes[v].camera.map(|c| (v, c.value())))
        else {
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
                if let Some(z) = zfar {
                    if z <= p.znear {
                        return Err(bad(&format!(
                            "zfar {z} must be greater than znear {}",
                            p.znear
                        )));
                    }
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
            Checked::Invalid => return Err(bad("invalid type")),
        };
        Ok(Some(Camera {
            name,
            node,
            projection,
        }))
    }

    // ----------------------------------------------------------------- meshes

    /// Reads all usable primitives of mesh `mi` (node-local space).
    fn read_mesh(
        &mut self,
        mi: usize,
        node_label: &str,
        table: &mut MaterialTable,
    ) -> Result<Vec<(String, PrimData)>, SceneError> {
        let root = self.root;
        let mesh = root
            .meshes
            .get(mi)
            .ok_or_else(|| self.invalid(format!("mesh {mi} does not exist")))?;
        let mesh_label = self.mesh_name(mi);
        let mut out = Vec::new();
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let name = format!("{node_label}/{mesh_label}/{pi}");
            if let Some(p) = self.read_primitive(prim, &name, table)? {
                out.push((name, p));
            }
        }
        Ok(out)
    }

    fn read_primitive(
        &mut self,
        prim: &json::mesh::Primitive,
        name: &str,
        table: &mut MaterialTable,
    ) -> Result<Option<PrimData>, SceneError> {
        use json::mesh::{Mode, Semantic};
        let mode = match prim.mode {
            Checked::Valid(m) => m,
            Checked::Invalid => {
                self.warn(format!("mesh {name}: invalid primitive mode, skipped"));
                return Ok(None);
            }
        };
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.warn(format!(
                "mesh {name}: primitive mode {mode:?} is not triangles, skipped"
            ));
            return Ok(None);
        }
        if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) {
            self.warn(format!("mesh {name}: morph targets ignored"));
        }
        let attr = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|i| i.value());
        let Some(pos_acc) = attr(Semantic::Positions) else {
            self.warn(format!("mesh {name}: primitive has no POSITION, skipped"));
            return Ok(None);
        };
        let (pos, vcount) = self
            .read_floats(pos_acc, 3)
            .map_err(|e| self.acc_err(name, pos_acc, "POSITION", e))?;
        if let Some(bad) = pos.iter().position(|x| !x.is_finite()) {
            return Err(self.acc_err(
                name,
                pos_acc,
                "POSITION",
                format!("vertex {} is not finite (NaN or infinite)", bad / 3),
            ));
        }
        let positions = vec3s(&pos);

        // Indices.
        let raw_indices: Vec<u32> = match prim.indices {
            Some(ia) => {
                let ia = ia.value();
                let raw = self
                    .read_accessor(ia)
                    .map_err(|e| self.acc_err(name, ia, "indices", e))?;
                if raw.dims != 1 {
                    return Err(self.acc_err(
                        name,
                        ia,
                        "indices",
                        "indices must be scalars".into(),
                    ));
                }
                let idx = raw
                    .uints()
                    .map_err(|e| self.acc_err(name, ia, "indices", e))?;
                if let Some(&bad) = idx.iter().find(|&&i| i as usize >= vcount) {
                    return Err(self.acc_err(
                        name,
                        ia,
                        "indices",
                        format!("index {bad} is out of range ({vcount} vertices)"),
                    ));
                }
                idx
            }
            None => {
                let n = u32::try_from(vcount).map_err(|_| {
                    self.acc_err(name, pos_acc, "POSITION", "too many vertices".into())
                })?;
                (0..n).collect()
            }
        };
        let mut indices = match mode {
            Mode::Triangles => {
                if !raw_indices.len().is_multiple_of(3) {
                    self.warn(format!(
                        "mesh {name}: {} indices is not a multiple of 3, the last {} ignored",
                        raw_indices.len(),
                        raw_indices.len() % 3
                    ));
                }
                let mut v = raw_indices;
                v.truncate(v.len() / 3 * 3);
                v
            }
            Mode::TriangleStrip => {
                let mut v = Vec::with_capacity(raw_indices.len().saturating_sub(2) * 3);
                for i in 0..raw_indices.len().saturating_sub(2) {
                    if i % 2 == 0 {
                        v.extend_from_slice(&[
                            raw_indices[i],
                            raw_indices[i + 1],
                            raw_indices[i + 2],
                        ]);
                    } else {
                        v.extend_from_slice(&[
                            raw_indices[i],
                            raw_indices[i + 2],
                            raw_indices[i + 1],
                        ]);
                    }
                }
                v
            }
            _ => {
                // Triangle fan.
                let mut v = Vec::with_capacity(raw_indices.len().saturating_sub(2) * 3);
                for i in 0..raw_indices.len().saturating_sub(2) {
                    v.extend_from_slice(&[raw_indices[i + 1], raw_indices[i + 2], raw_indices[0]]);
                }
                v
            }
        };
        if indices.is_empty() {
            self.warn(format!("mesh {name}: primitive has no triangles, skipped"));
            return Ok(None);
        }
        indices.shrink_to_fit();

        // Normals.
        let normals = match attr(Semantic::Normals) {
            None => None,
            Some(na) => {
                let (nf, ncount) = self
                    .read_floats(na, 3)
                    .map_err(|e| self.acc_err(name, na, "NORMAL", e))?;
                if ncount != vcount {
                    return Err(self.acc_err(
                        name,
                        na,
                        "NORMAL",
                        format!("{ncount} normals for {vcount} vertices"),
                    ));
                }
                let nv = vec3s(&nf);
                let unit: Option<Vec<Vec3>> = nv.iter().map(|n| n.try_normalize()).collect();
                if unit.is_none() {
                    self.warn(format!(
                        "mesh {name}: NORMAL (accessor {na}) has zero or non-finite normals, recomputed"
                    ));
                }
                unit
            }
        };

        // Material and texture coordinates.
        let mat_index = prim.material.map(|m| m.value());
        let mut tex = None;
        if let Some(mi) = mat_index {
            let m = self.root.materials.get(mi).ok_or_else(|| {
                self.invalid(format!("mesh {name}: material {mi} does not exist"))
            })?;
            if let Some(info) = &m.pbr_metallic_roughness.base_color_texture {
                tex = Some((info.index.value(), info.tex_coord));
            }
        }
        let mut uvs = None;
        if let Some((_, set)) = tex {
            match attr(Semantic::TexCoords(set)) {
                None => {
                    self.warn(format!(
                        "mesh {name}: the material has a base colour texture but the primitive has no TEXCOORD_{set}; drawn untextured"
                    ));
                }
                Some(ua) => {
                    let what = format!("TEXCOORD_{set}");
                    let (uf, ucount) = self
                        .read_floats(ua, 2)
                        .map_err(|e| self.acc_err(name, ua, &what, e))?;
                    if ucount != vcount {
                        return Err(self.acc_err(
                            name,
                            ua,
                            &what,
                            format!("{ucount} texture coordinates for {vcount} vertices"),
                        ));
                    }
                    if uf.iter().any(|x| !x.is_finite()) {
                        return Err(self.acc_err(
                            name,
                            ua,
                            &what,
                            "texture coordinates are not finite".into(),
                        ));
                    }
                    uvs = Some(vec2s(&uf));
                }
            }
        }
        let material = self.material(
            mat_index,
            if uvs.is_some() {
                tex.map(|t| t.0)
            } else {
                None
            },
            table,
        )?;
        Ok(Some(PrimData {
            positions,
            normals,
            uvs,
            indices,
            material,
        }))
    }

    /// Scene material for glTF material `mi` (None = default), textured with
    /// glTF texture `texture` if given.
    fn material(
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

    fn material_has_texture(&self, mi: Option<usize>) -> bool {
        mi.and_then(|i| self.root.materials.get(i))
            .is_some_and(|m| m.pbr_metallic_roughness.base_color_texture.is_some())
    }

    fn decode_image(&self, i: usize) -> Result<Texture, SceneError> {
        let img = self
            .root
            .images
            .get(i)
            .ok_or_else(|| self.invalid(format!("image {i} does not exist")))?;
        let what = match &img.name {
            Some(n) => format!("image {i} '{n}'"),
            None => format!("image {i}"),
        };
        let mime = img.mime_type.as_ref().map(|m| m.0.as_str());
        let file_uri;
        let source = if let Some(v) = img.buffer_view {
            let v = v.value();
            let (bytes, _) = self
                .view_bytes(v)
                .map_err(|e| self.invalid(format!("{what}: {e}")))?;
            self.check_image_header(&what, bytes)?;
            let view =
                self.document.views().nth(v).ok_or_else(|| {
                    self.invalid(format!("{what}: bufferView {v} does not exist"))
                })?;
            let mime_type = mime.ok_or_else(|| {
                self.invalid(format!("{what}: bufferView image without mimeType"))
            })?;
            gltf::image::Source::View { view, mime_type }
        } else if let Some(uri) = img.uri.as_deref() {
            if uri.starts_with("data:") {
                let bytes = gltf::buffer::Data::from_source(gltf::buffer::Source::Uri(uri), None)
                    .map_err(|e| self.invalid(format!("{what}: bad data URI: {e}")))?;
                self.check_image_header(&what, &bytes.0)?;
                gltf::image::Source::Uri {
                    uri,
                    mime_type: mime,
                }
            } else {
                let file = self.resolve_uri(uri, &what)?;
                if let Err(e) = limits::check_regular(&file, self.limits.max_input_bytes) {
                    return Err(self.invalid(format!(
                        "{what}: cannot read '{uri}' ({}): {e}",
                        file.display()
                    )));
                }
                let head = match sniff_image(&file) {
                    Ok(h) => h,
                    Err(e) => {
                        return Err(self.invalid(format!(
                            "{what}: cannot read '{uri}' ({}): {e}",
                            file.display()
                        )));
                    }
                };
                self.check_image_header(&what, &head_bytes(&file))?;
                let s = file.to_str().ok_or_else(|| {
                    self.invalid(format!(
                        "{what}: path {} is not valid UTF-8",
                        file.display()
                    ))
                })?;
                file_uri = format!("file:{s}");
                // Without a mimeType the gltf crate goes by the extension;
                // give it the type from the file's magic bytes instead.
                gltf::image::Source::Uri {
                    uri: &file_uri,
                    mime_type: mime.or(head),
                }
            }
        } else {
            return Err(self.invalid(format!("{what} has neither uri nor bufferView")));
        };
        let data = gltf::image::Data::from_source(source, Some(&self.base), &self.buffers)
            .map_err(|e| self.invalid(format!("{what}: cannot decode: {e}")))?;
        to_rgba8(&data).ok_or_else(|| self.invalid(format!("{what}: unexpected pixel data size")))
    }

    /// Reads the image's size from its header and charges it to the texel
    /// budget, before anything is decoded.
    fn check_image_header(&self, what: &str, bytes: &[u8]) -> Result<(), SceneError> {
        match limits::image_dimensions(bytes) {
            Some((w, h)) => self.charge_texels(what, w, h),
            // Neither PNG nor JPEG: the decoder rejects it without decoding.
            None => Ok(()),
        }
    }

    /// Downscales a texture larger than `--max-texture-size`, with a warning.
    fn fit_texture(&mut self, tex: Texture, image: usize) -> Texture {
        let max = self.limits.max_texture_size;
        match limits::downscale_to_fit(&tex, max) {
            None => tex,
            Some(small) => {
                self.warn(format!(
                    "image {image}: {}x{} is larger than {max} texels on a side, downscaled to {}x{} (raise --max-texture-size up to the GPU's limit to keep it)",
                    tex.width, tex.height, small.width, small.height
                ));
                small
            }
        }
    }

    /// Flattens a primitive to world space with `world`.
    fn flatten(&self, name: String, p: PrimData, world: Mat4) -> Result<Mesh, SceneError> {
        let positions: Vec<Vec3> = p
            .positions
            .iter()
            .map(|&q| world.transform_point3(q))
            .collect();
        if positions.iter().any(|q| !q.is_finite()) {
            return Err(self.invalid(format!(
                "mesh {name}: world-space positions overflow (node transforms too large)"
            )));
        }
        let mut indices = p.indices;
        let m3 = Mat3::from_mat4(world);
        let det = m3.determinant();
        if det < 0.0 {
            for t in indices.chunks_exact_mut(3) {
                t.swap(1, 2);
            }
        }
        let normal_matrix = m3.inverse().transpose();
        let normals = match p.normals {
            Some(nr) if det != 0.0 && normal_matrix.is_finite() => {
                let out: Vec<Vec3> = nr
                    .iter()
                    .map(|&n| (normal_matrix * n).normalize_or_zero())
                    .collect();
                if out.iter().all(|n| n.length_squared() > 0.0) {
                    out
                } else {
                    compute_normals(&positions, &indices)
                }
            }
            _ => compute_normals(&positions, &indices),
        };
        Ok(Mesh {
            name,
            positions,
            normals,
            uvs: p.uvs,
            indices,
            material: p.material,
        })
    }
}

/// The first 64 KiB of `file` (enough for a PNG or JPEG header), empty on error.
fn head_bytes(file: &Path) -> Vec<u8> {
    use std::io::Read;
    let mut out = Vec::new();
    if let Ok(f) = std::fs::File::open(file) {
        let _ = f.take(1 << 16).read_to_end(&mut out);
    }
    out
}

/// The MIME type of a PNG or JPEG file from its first bytes (`None` if neither).
fn sniff_image(file: &Path) -> std::io::Result<Option<&'static str>> {
    use std::io::Read;
    let mut head = [0u8; 8];
    let mut f = std::fs::File::open(file)?;
    let n = f.read(&mut head)?;
    Ok(if head[..n].starts_with(b"\x89PNG") {
        Some("image/png")
    } else if head[..n].starts_with(&[0xff, 0xd8, 0xff]) {
        Some("image/jpeg")
    } else {
        None
    })
}

/// Converts any decoded image to RGBA8 (RGB kept sRGB-encoded as in the file).
fn to_rgba8(d: &gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format;
    let (w, h) = (d.width as usize, d.height as usize);
    let n = w.checked_mul(h)?;
    let p = &d.pixels;
    let u16_at = |i: usize| -> u8 {
        let v = u16::from_ne_bytes([p[2 * i], p[2 * i + 1]]) as u32;
        ((v * 255 + 32767) / 65535) as u8
    };
    let f32_at = |i: usize| -> u8 {
        let v = f32::from_ne_bytes([p[4 * i], p[4 * i + 1], p[4 * i + 2], p[4 * i + 3]]);
        (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
    };
    let (channels, bytes_per) = match d.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    if p.len() != n.checked_mul(channels * bytes_per)? {
        return None;
    }
    let comp = |i: usize| -> u8 {
        match bytes_per {
            1 => p[i],
            2 => u16_at(i),
            _ => f32_at(i),
        }
    };
    let mut out = Vec::with_capacity(n * 4);
    for px in 0..n {
        let b = px * channels;
        let rgba = match channels {
            1 => {
                let l = comp(b);
                [l, l, l, 255]
            }
            2 => {
                let l = comp(b);
                [l, l, l, comp(b + 1)]
            }
            3 => [comp(b), comp(b + 1), comp(b + 2), 255],
            _ => [comp(b), comp(b + 1), comp(b + 2), comp(b + 3)],
        };
        out.extend_from_slice(&rgba);
    }
    Some(Texture {
        width: d.width,
        height: d.height,
        rgba8_srgb: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("100%").as_deref(), Some("100%"));
        assert_eq!(percent_decode("%zz").as_deref(), Some("%zz"));
        assert_eq!(percent_decode("%FF"), None);
    }

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
