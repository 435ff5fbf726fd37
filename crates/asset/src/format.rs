//! Reading and writing the `NAME.gibake/` directory: `manifest.bin` (magic,
//! version, bincode payload, BLAKE3 trailer), `vpls.bin`, and the EXR maps.
//! See `docs/asset-format.md` for the byte layout.

use std::fs;
use std::io::{Read, Write};
use std::path::Path;

use crate::atlas::{MapAtlas, atlas_grid, pack_tiles, unpack_tile, unused_mismatch};
use crate::exrio::{self, Kind, Samples};
use crate::{
    Asset, AssetError, FORMAT_MAJOR, FORMAT_MINOR, FileEntry, LEVEL3_NODES, LIGHT_POINT, MAGIC,
    Manifest, Map, NO_MAP, NODES_PER_VPL, RsmData, SHARE_ONE, VplRecord,
};

/// The manifest file name.
pub const FILE_MANIFEST: &str = "manifest.bin";
/// The VPL record array file name.
pub const FILE_VPLS: &str = "vpls.bin";
/// Near-field trees of the VPLs (`NODES_PER_VPL` records each).
pub const FILE_VPL_NODES: &str = "vpl_nodes.bin";
/// The primary shadow map file name.
pub const FILE_PRIMARY_DEPTH: &str = "primary_depth.exr";
/// The hemisphere map atlas file name (only when `map_count > 0`).
pub const FILE_VPL_MAPS: &str = "vpl_maps.exr";
/// The static RSM file name (only when `has_dynamic`).
pub const FILE_RSM: &str = "rsm.exr";
/// The shadow maps of the lights other than the first (only when a view
/// stores one).
pub const FILE_LIGHT_MAPS: &str = "light_maps.exr";
/// The static RSMs of the views of [`Manifest::view_rsms`] (format 4.1;
/// only when it is not empty).
pub const FILE_VIEW_RSMS: &str = "view_rsms.exr";
/// The level-3 nodes' texel coherences, [`Asset::vpl_coherence`] (format
/// 4.2; only when there are VPLs): `LEVEL3_NODES` little-endian `f32` per
/// VPL.
pub const FILE_VPL_COHERENCE: &str = "vpl_coherence.bin";
/// Each VPL's second visibility test for the light below its horizon,
/// [`Asset::vpl_lower`] (format 4.7; only when there are VPLs): one
/// 16-byte [`crate::LowerVpl`] per VPL.
pub const FILE_VPL_LOWER: &str = "vpl_lower.bin";
/// The second hemisphere maps' atlas (format 4.7; only when
/// `lower_map_count > 0`).
pub const FILE_VPL_LOWER_MAPS: &str = "vpl_lower_maps.exr";

/// Size of one [`VplRecord`] in `vpls.bin`.
pub const VPL_RECORD_BYTES: usize = 48;
/// Size of one [`crate::LowerVpl`] in `vpl_lower.bin`.
pub const LOWER_RECORD_BYTES: usize = 16;
/// Largest accepted map resolution (RSM, primary shadow map, hemisphere map).
pub const MAX_MAP_SIZE: u32 = 16384;
/// Largest accepted number of texels in one map file (the atlas): 2³¹
/// (8 GiB of f32). Protects readers from absurd allocations.
const MAX_TEXELS: u64 = 1 << 31;
/// Largest accepted manifest payload (16 MiB; real ones are a few hundred bytes).
const MAX_PAYLOAD: u64 = 1 << 24;
/// Magic (8) + major (2) + minor (2) + payload length (8).
const HEADER_BYTES: usize = 20;
/// BLAKE3 of everything before it.
const TRAILER_BYTES: usize = 32;

type Limited = bincode::config::Configuration<
    bincode::config::LittleEndian,
    bincode::config::Varint,
    bincode::config::Limit<{ 1 << 24 }>,
>;

fn bincode_config() -> Limited {
    bincode::config::standard().with_limit::<{ 1 << 24 }>()
}

fn hex16(h: &[u8; 32]) -> String {
    h[..8].iter().map(|b| format!("{b:02x}")).collect()
}

// ---------------------------------------------------------------- manifest

fn encode_manifest(manifest: &Manifest, path: &Path) -> Result<Vec<u8>, AssetError> {
    encode_manifest_as(manifest, FORMAT_MINOR, path)
}

/// The manifest as format `4.minor` writes it: the serde fields, then
/// (minor ≥ 1) `view_rsms` as a bincode `Vec<u32>` in the same
/// configuration (varint count, varint indices), (minor ≥ 3) `ring_vpls`
/// likewise, (minor ≥ 4) `scene_options` as a bincode (serde)
/// `Option<SceneOptions>`, (minor ≥ 5) `swept_bounds` as a bincode
/// `Vec<u32>` (none or six `f32` bit patterns), (minor ≥ 6) `later` as a
/// bincode (serde) `Option<LaterRecord>` and (minor ≥ 7) `lower_map_count`
/// as a bincode `u32` (varint), (minor ≥ 8) `later_sources` as a bincode
/// (serde) `Option<LaterSources>`. An older minor lacks the later fields:
/// they must be empty (`None`, 0).
fn encode_manifest_as(manifest: &Manifest, minor: u16, path: &Path) -> Result<Vec<u8>, AssetError> {
    let cannot = |e: bincode::error::EncodeError| {
        AssetError::invalid(path, format!("cannot encode the manifest: {e}"))
    };
    let mut payload = bincode::serde::encode_to_vec(manifest, bincode_config()).map_err(cannot)?;
    if minor >= 1 {
        let appended =
            bincode::encode_to_vec(&manifest.view_rsms, bincode_config()).map_err(cannot)?;
        payload.extend_from_slice(&appended);
    } else if !manifest.view_rsms.is_empty() {
        return Err(AssetError::invalid(
            path,
            "cannot encode the manifest: format 4.0 has no view_rsms",
        ));
    }
    if minor >= 3 {
        let appended =
            bincode::encode_to_vec(&manifest.ring_vpls, bincode_config()).map_err(cannot)?;
        payload.extend_from_slice(&appended);
    } else if !manifest.ring_vpls.is_empty() {
        return Err(AssetError::invalid(
            path,
            format!("cannot encode the manifest: format 4.{minor} has no ring_vpls"),
        ));
    }
    if minor >= 4 {
        // An Option<SceneOptions> through serde: a tag byte, then the
        // fields in order (docs/asset-format.md).
        let appended = bincode::serde::encode_to_vec(&manifest.scene_options, bincode_config())
            .map_err(cannot)?;
        payload.extend_from_slice(&appended);
    } else if manifest.scene_options.is_some() {
        return Err(AssetError::invalid(
            path,
            format!("cannot encode the manifest: format 4.{minor} has no scene_options"),
        ));
    }
    if minor >= 5 {
        let bits: Vec<u32> = manifest
            .swept_bounds
            .map(|b| b.map(f32::to_bits).to_vec())
            .unwrap_or_default();
        let appended = bincode::encode_to_vec(&bits, bincode_config()).map_err(cannot)?;
        payload.extend_from_slice(&appended);
    } else if manifest.swept_bounds.is_some() {
        return Err(AssetError::invalid(
            path,
            format!("cannot encode the manifest: format 4.{minor} has no swept_bounds"),
        ));
    }
    if minor >= 6 {
        // An Option<LaterRecord> through serde: a tag byte, then the fields
        // in order (docs/asset-format.md, `later`).
        let appended =
            bincode::serde::encode_to_vec(&manifest.later, bincode_config()).map_err(cannot)?;
        payload.extend_from_slice(&appended);
    } else if manifest.later.is_some() {
        return Err(AssetError::invalid(
            path,
            format!("cannot encode the manifest: format 4.{minor} has no later bounces"),
        ));
    }
    if minor >= 7 {
        let appended =
            bincode::encode_to_vec(manifest.lower_map_count, bincode_config()).map_err(cannot)?;
        payload.extend_from_slice(&appended);
    } else if manifest.lower_map_count != 0 {
        return Err(AssetError::invalid(
            path,
            format!("cannot encode the manifest: format 4.{minor} has no lower_map_count"),
        ));
    }
    if minor >= 8 {
        let appended = bincode::serde::encode_to_vec(&manifest.later_sources, bincode_config())
            .map_err(cannot)?;
        payload.extend_from_slice(&appended);
    } else if manifest.later_sources.is_some() {
        return Err(AssetError::invalid(
            path,
            format!("cannot encode the manifest: format 4.{minor} has no later_sources"),
        ));
    }
    let mut out = Vec::with_capacity(HEADER_BYTES + payload.len() + TRAILER_BYTES);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT_MAJOR.to_le_bytes());
    out.extend_from_slice(&minor.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&payload);
    let hash = blake3::hash(&out);
    out.extend_from_slice(hash.as_bytes());
    Ok(out)
}

/// Decodes `manifest.bin` bytes; returns the manifest and the file's minor version.
fn decode_manifest(bytes: &[u8], path: &Path) -> Result<(Manifest, u16), AssetError> {
    let bad = |m: String| AssetError::invalid(path, m);
    if bytes.len() >= MAGIC.len() && bytes[..MAGIC.len()] != MAGIC {
        return Err(bad("not a gibake asset manifest (wrong magic bytes)".into()));
    }
    if bytes.len() < HEADER_BYTES {
        return Err(bad(format!(
            "truncated: {} bytes, the header alone is {HEADER_BYTES}",
            bytes.len()
        )));
    }
    let major = u16::from_le_bytes([bytes[8], bytes[9]]);
    let minor = u16::from_le_bytes([bytes[10], bytes[11]]);
    if major != FORMAT_MAJOR {
        return Err(AssetError::NotSupported {
            path: path.to_owned(),
            message: format!(
                "asset format {major}.{minor} is not supported by this gibake (reads {FORMAT_MAJOR}.x, up to {FORMAT_MAJOR}.{FORMAT_MINOR}); re-bake the scene with this gibake"
            ),
        });
    }
    let mut len8 = [0u8; 8];
    len8.copy_from_slice(&bytes[12..20]);
    let len = u64::from_le_bytes(len8);
    let rest = (bytes.len() - HEADER_BYTES) as u64;
    if len > MAX_PAYLOAD || len + TRAILER_BYTES as u64 != rest {
        return Err(bad(format!(
            "payload length field says {len} bytes, but {rest} bytes follow the header (expected the payload plus a {TRAILER_BYTES}-byte checksum): truncated or damaged"
        )));
    }
    let end = HEADER_BYTES + len as usize;
    if blake3::hash(&bytes[..end]).as_bytes() != &bytes[end..] {
        return Err(bad("checksum mismatch: the manifest is damaged".into()));
    }
    let payload = &bytes[HEADER_BYTES..end];
    // A newer minor may append fields after the ones this reader knows.
    let (mut manifest, mut used): (Manifest, usize) =
        bincode::serde::decode_from_slice(payload, bincode_config())
            .map_err(|e| bad(format!("damaged manifest payload: {e}")))?;
    if minor >= 1 {
        // 4.1 appends `view_rsms` (a Vec<u32>) after the serde fields, at
        // most one per view.
        let (v, n) = decode_appended(&payload[used..], "view_rsms", manifest.views.len(), "views")
            .map_err(bad)?;
        manifest.view_rsms = v;
        used += n;
    }
    if minor >= 3 {
        // 4.3 appends `ring_vpls` (a Vec<u32>) after it, at most one per
        // light.
        let (v, n) = decode_appended(
            &payload[used..],
            "ring_vpls",
            manifest.lights.len(),
            "lights",
        )
        .map_err(bad)?;
        manifest.ring_vpls = v;
        used += n;
    }
    if minor >= 4 {
        // 4.4 appends `scene_options` (an Option<SceneOptions>) after it.
        let (v, n): (Option<crate::SceneOptions>, usize) =
            bincode::serde::decode_from_slice(&payload[used..], bincode_config())
                .map_err(|e| bad(format!("damaged manifest payload: scene_options: {e}")))?;
        manifest.scene_options = v;
        used += n;
    }
    if minor >= 5 {
        // 4.5 appends `swept_bounds`: none (not recorded) or the six f32
        // bit patterns of the moving objects' swept box.
        let (v, n) =
            decode_appended(&payload[used..], "swept_bounds", 6, "box bounds").map_err(bad)?;
        manifest.swept_bounds = match v.len() {
            0 => None,
            6 => {
                let b: [f32; 6] = std::array::from_fn(|k| f32::from_bits(v[k]));
                if b.iter().any(|x| x.is_nan()) {
                    return Err(bad("swept_bounds holds NaN".into()));
                }
                Some(b)
            }
            k => {
                return Err(bad(format!(
                    "swept_bounds holds {k} values (none, or the box's six)"
                )));
            }
        };
        used += n;
    }
    if minor >= 6 {
        // 4.6 appends `later` (an Option<LaterRecord>) after it; its list
        // of bounces is bounded by the payload limit before it is read.
        let (v, n): (Option<crate::LaterRecord>, usize) =
            bincode::serde::decode_from_slice(&payload[used..], bincode_config())
                .map_err(|e| bad(format!("damaged manifest payload: later: {e}")))?;
        manifest.later = v;
        used += n;
    }
    if minor >= 7 {
        // 4.7 appends `lower_map_count` (a u32) after it.
        let (v, n): (u32, usize) =
            bincode::decode_from_slice(&payload[used..], bincode_config())
                .map_err(|e| bad(format!("damaged manifest payload: lower_map_count: {e}")))?;
        manifest.lower_map_count = v;
        used += n;
    }
    if minor >= 8 {
        // 4.8 appends `later_sources` (an Option<LaterSources>) after it;
        // its lists are bounded by the payload limit before they are read.
        let (v, n): (Option<crate::LaterSources>, usize) =
            bincode::serde::decode_from_slice(&payload[used..], bincode_config())
                .map_err(|e| bad(format!("damaged manifest payload: later_sources: {e}")))?;
        manifest.later_sources = v;
        used += n;
    }
    if used != payload.len() && !is_newer_minor(minor) {
        return Err(bad(format!(
            "{} unexpected bytes after the manifest payload",
            payload.len() - used
        )));
    }
    Ok((manifest, minor))
}

/// Decodes a `Vec<u32>` a minor appended to the manifest payload (`field`,
/// at most `max` entries, one per `of`) at the start of `rest`: the count is
/// read and bounded first, so a hostile count allocates nothing. The
/// vector and the bytes it used.
fn decode_appended(
    rest: &[u8],
    field: &str,
    max: usize,
    of: &str,
) -> Result<(Vec<u32>, usize), String> {
    let damaged =
        |e: bincode::error::DecodeError| format!("damaged manifest payload: {field}: {e}");
    let (count, _): (u64, usize) =
        bincode::decode_from_slice(rest, bincode_config()).map_err(damaged)?;
    if count > max as u64 {
        return Err(format!(
            "damaged manifest payload: {field} holds {count} entries but there are only {max} {of}"
        ));
    }
    bincode::decode_from_slice(rest, bincode_config()).map_err(damaged)
}

/// Reads a whole file, refusing files larger than `max` bytes (before reading).
fn read_capped(path: &Path, max: u64) -> Result<Vec<u8>, AssetError> {
    check_regular(path)?;
    let f = fs::File::open(path).map_err(|e| AssetError::io(path, e))?;
    let len = f.metadata().map_err(|e| AssetError::io(path, e))?.len();
    if len > max {
        return Err(AssetError::invalid(
            path,
            format!("file is {len} bytes, more than the {max} a valid one can have"),
        ));
    }
    let mut buf = Vec::with_capacity(len as usize);
    f.take(max + 1)
        .read_to_end(&mut buf)
        .map_err(|e| AssetError::io(path, e))?;
    if buf.len() as u64 > max {
        return Err(AssetError::invalid(path, "file grew while being read"));
    }
    Ok(buf)
}

/// Refuses anything but a regular file before it is opened (opening a FIFO
/// blocks; a device never ends).
fn check_regular(path: &Path) -> Result<(), AssetError> {
    let meta = fs::metadata(path).map_err(|e| AssetError::io(path, e))?;
    if meta.is_file() {
        Ok(())
    } else if meta.is_dir() {
        Err(AssetError::invalid(path, "is a directory, not a file"))
    } else {
        Err(AssetError::invalid(
            path,
            "not a regular file (a pipe, device or socket); only regular files are read",
        ))
    }
}

/// Whether a file of format minor `minor` may hold additions this version
/// does not know (trailing payload bytes, more files).
fn is_newer_minor(minor: u16) -> bool {
    minor > FORMAT_MINOR
}

fn is_plain_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 255
        && !name.starts_with('.')
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-' || b == b'.')
}

/// The files a manifest with these counts must list, in the order they are
/// written.
fn required_files(m: &Manifest, minor: u16) -> Vec<&'static str> {
    let mut v = vec![FILE_VPLS, FILE_VPL_NODES, FILE_PRIMARY_DEPTH];
    if minor >= 2 && m.vpl_count > 0 {
        v.push(FILE_VPL_COHERENCE);
    }
    if m.map_count > 0 {
        v.push(FILE_VPL_MAPS);
    }
    if minor >= 7 && m.vpl_count > 0 {
        v.push(FILE_VPL_LOWER);
    }
    if m.lower_map_count > 0 {
        v.push(FILE_VPL_LOWER_MAPS);
    }
    if m.has_dynamic {
        v.push(FILE_RSM);
    }
    if light_map_count(m) > 0 {
        v.push(FILE_LIGHT_MAPS);
    }
    if !m.view_rsms.is_empty() {
        v.push(FILE_VIEW_RSMS);
    }
    v
}

/// The size of `view_rsms.exr`: the atlas of the view RSMs' tiles.
fn view_rsm_atlas_dims(m: &Manifest) -> (u64, u64) {
    let (cols, rows) = atlas_grid(m.view_rsms.len() as u32);
    let s = m.settings.rsm_size as u64;
    (cols as u64 * s, rows as u64 * s)
}

/// `view_rsms`' rules that the manifest alone decides: indices into
/// `views`, strictly ascending, an atlas of at most 2³¹ texels.
fn check_view_rsm_list(m: &Manifest) -> Result<(), String> {
    let mut last: Option<u32> = None;
    for (k, &v) in m.view_rsms.iter().enumerate() {
        if v as usize >= m.views.len() {
            return Err(format!(
                "view_rsms[{k}] = {v} is not a view: there are {} views",
                m.views.len()
            ));
        }
        if let Some(p) = last.filter(|&p| v <= p) {
            return Err(format!(
                "view_rsms[{k}] = {v} follows {p}: the views of view_rsms must be strictly ascending"
            ));
        }
        last = Some(v);
    }
    let (w, h) = view_rsm_atlas_dims(m);
    if w * h > MAX_TEXELS || w > i32::MAX as u64 || h > i32::MAX as u64 {
        return Err(format!(
            "{} view RSMs of {}² make an absurdly large atlas ({w}x{h})",
            m.view_rsms.len(),
            m.settings.rsm_size
        ));
    }
    Ok(())
}

/// The VPLs of light `light` (indices into the VPL records): the lights'
/// VPLs are consecutive in light order; clamped to `vpl_count`.
fn light_vpls(m: &Manifest, light: usize) -> std::ops::Range<u64> {
    let start: u64 = m.lights.iter().take(light).map(|l| l.vpls as u64).sum();
    let end = start + m.lights.get(light).map_or(0, |l| l.vpls as u64);
    let cap = m.vpl_count as u64;
    start.min(cap)..end.min(cap)
}

/// The values of one RSM (`rsm.exr`, a tile of `view_rsms.exr`): no NaN
/// metric; each texel's VPL none (`u32::MAX`) or in `own` (the VPLs of
/// the RSM's light, `whose` in messages); shares at most [`SHARE_ONE`],
/// and 0 outside every VPL. The first bad texel, described.
fn rsm_problem(
    metric: &[f32],
    share: &[u32],
    vpl: &[u32],
    size: u32,
    own: std::ops::Range<u64>,
    whose: &str,
) -> Option<String> {
    let at = |i: usize| {
        let s = size.max(1) as usize;
        format!("texel ({}, {})", i % s, i / s)
    };
    if let Some(i) = metric.iter().position(|x| x.is_nan()) {
        return Some(format!("channel Z holds NaN at {}", at(i)));
    }
    if let Some(i) = vpl
        .iter()
        .position(|&v| v != u32::MAX && !own.contains(&(v as u64)))
    {
        return Some(format!(
            "channel vpl refers to VPL {} at {} but {whose} owns VPLs {}..{}",
            vpl[i],
            at(i),
            own.start,
            own.end
        ));
    }
    share_problem(share, vpl).map(|i| {
        format!(
            "channel share holds {} at {} (VPL {}): over {SHARE_ONE}, or not 0 outside every VPL",
            share[i],
            at(i),
            vpl[i] as i64
        )
    })
}

/// The view RSMs against the manifest: one per `view_rsms` entry, each
/// `rsm_size²` texels, with the values of [`rsm_problem`], each naming
/// only VPLs of its view's light. `Err` names the tile, view and light.
pub(crate) fn check_view_rsms(m: &Manifest, rsms: &[RsmData]) -> Result<(), String> {
    if rsms.len() != m.view_rsms.len() {
        return Err(format!(
            "{} view RSMs but view_rsms lists {} views",
            rsms.len(),
            m.view_rsms.len()
        ));
    }
    let rs = m.settings.rsm_size;
    let n = rs as usize * rs as usize;
    for (k, (r, &view)) in rsms.iter().zip(&m.view_rsms).enumerate() {
        let Some(v) = m.views.get(view as usize) else {
            return Err(format!("view_rsms[{k}] = {view} is not a view"));
        };
        let light = v.light as usize;
        let name = m.lights.get(light).map_or("", |l| l.name.as_str());
        let what = format!("tile {k} (the RSM of views[{view}], light {light} '{name}')");
        if r.size != rs || r.metric.len() != n || r.share.len() != n || r.vpl.len() != n {
            return Err(format!(
                "{what} is {}² ({} / {} / {} values) but settings.rsm_size is {rs}",
                r.size,
                r.metric.len(),
                r.share.len(),
                r.vpl.len()
            ));
        }
        let whose = format!("light {light}");
        if let Some(e) = rsm_problem(
            &r.metric,
            &r.share,
            &r.vpl,
            rs,
            light_vpls(m, light),
            &whose,
        ) {
            return Err(format!("{what}: {e}"));
        }
    }
    Ok(())
}

fn atlas_dims(m: &Manifest) -> (u64, u64) {
    let (cols, rows) = atlas_grid(m.map_count);
    let s = m.settings.vpl_map_size as u64;
    (cols as u64 * s, rows as u64 * s)
}

/// The size of `vpl_lower_maps.exr`.
fn lower_atlas_dims(m: &Manifest) -> (u64, u64) {
    let (cols, rows) = atlas_grid(m.lower_map_count);
    let s = m.settings.vpl_map_size as u64;
    (cols as u64 * s, rows as u64 * s)
}

/// How many views store a shadow map in `light_maps.exr`.
fn light_map_count(m: &Manifest) -> u32 {
    m.views.iter().filter(|v| v.tile != NO_MAP).count() as u32
}

/// The size of `light_maps.exr`.
fn light_atlas_dims(m: &Manifest) -> (u64, u64) {
    let (cols, rows) = atlas_grid(light_map_count(m));
    let s = m.light_map_size as u64;
    (cols as u64 * s, rows as u64 * s)
}

/// The lights' and views' consistency: each light after the first (every
/// light when the first is a point light: it has no primary map) has its
/// views in order (a point light six, any other one), and the stored maps
/// are tiles `0, 1, …` in view order.
fn check_views(m: &Manifest) -> Result<(), String> {
    let first = match m.lights.first() {
        Some(l) if l.kind == LIGHT_POINT => 0,
        _ => 1,
    };
    if first == 0 && m.has_dynamic {
        return Err(
            "lights[0] is a point light (no primary map) but has_dynamic says its RSM is stored"
                .into(),
        );
    }
    let mut next_tile = 0u32;
    let mut k = 0usize;
    for (light, l) in m.lights.iter().enumerate().skip(first) {
        let want = if l.kind == LIGHT_POINT { 6 } else { 1 };
        for face in 0..want {
            let Some(v) = m.views.get(k) else {
                return Err(format!(
                    "views ends at {k}: lights[{light}] ('{}') needs {want} views",
                    l.name
                ));
            };
            if v.light as usize != light {
                return Err(format!(
                    "views[{k}] is of light {} but lights[{light}]'s view {face} belongs there",
                    v.light
                ));
            }
            if !v.view.is_finite() {
                return Err(format!("views[{k}] holds a value that is not finite"));
            }
            if v.tile != NO_MAP {
                if v.tile != next_tile {
                    return Err(format!(
                        "views[{k}] stores tile {} but the next tile is {next_tile} (tiles are numbered in view order)",
                        v.tile
                    ));
                }
                next_tile += 1;
            }
            k += 1;
        }
    }
    if k != m.views.len() {
        return Err(format!(
            "{} views but the lights that have views have {k}",
            m.views.len()
        ));
    }
    if !m.views.is_empty() && (m.light_map_size == 0 || m.light_map_size > MAX_MAP_SIZE) {
        return Err(format!(
            "light_map_size = {} is not in 1..={MAX_MAP_SIZE}",
            m.light_map_size
        ));
    }
    if next_tile == 0 && m.light_map_size != 0 && m.views.is_empty() {
        return Err(format!(
            "light_map_size is {} but there are no views",
            m.light_map_size
        ));
    }
    let (w, h) = light_atlas_dims(m);
    if w * h > MAX_TEXELS || w > i32::MAX as u64 || h > i32::MAX as u64 {
        return Err(format!(
            "{next_tile} light maps of {}² make an absurdly large atlas ({w}x{h})",
            m.light_map_size
        ));
    }
    Ok(())
}

/// Checks the manifest's values (sizes, counts, and unless writing, the file
/// list) on their own.
fn validate_manifest(
    m: &Manifest,
    minor: u16,
    path: &Path,
    check_files: bool,
) -> Result<(), AssetError> {
    let bad = |msg: String| Err(AssetError::invalid(path, msg));
    let s = &m.settings;
    for (name, v) in [
        ("rsm_size", s.rsm_size),
        ("vpl_map_size", s.vpl_map_size),
        ("shadow_map_size", s.shadow_map_size),
    ] {
        if v == 0 || v > MAX_MAP_SIZE {
            return bad(format!(
                "settings.{name} = {v} is not in 1..={MAX_MAP_SIZE}"
            ));
        }
    }
    if !s.threshold.is_finite() {
        return bad(format!(
            "settings.threshold = {} is not finite",
            s.threshold
        ));
    }
    if !m.light_view.is_finite() {
        return bad("light_view holds a value that is not finite".into());
    }
    for (i, l) in m.lights.iter().enumerate() {
        let finite = l
            .color
            .iter()
            .chain(&l.position)
            .chain(&l.direction)
            .chain([&l.inner_cone, &l.outer_cone, &l.range])
            .all(|x| x.is_finite());
        if !finite || l.kind > LIGHT_POINT || l.range < 0.0 || l.color.iter().any(|c| *c < 0.0) {
            return bad(format!(
                "lights[{i}] ('{}') is not a valid light (kind {}, values finite and colour and range non-negative required)",
                l.name, l.kind
            ));
        }
    }
    if let Some(p) = m.scene_options.as_ref().and_then(|o| o.problem()) {
        return bad(format!("scene_options: {p}"));
    }
    if let Some(p) = m.later.as_ref().and_then(|l| l.problem(m.vpl_count)) {
        return bad(format!("later: {p}"));
    }
    if m.later_sources.is_some() && m.later_vpls() == 0 {
        return bad("later_sources listed but the asset has no later VPLs".into());
    }
    if let Err(e) = check_views(m) {
        return bad(e);
    }
    if let Err(e) = check_view_rsm_list(m) {
        return bad(e);
    }
    if m.map_count > m.vpl_count {
        return bad(format!(
            "map_count {} is larger than vpl_count {} (each stored map belongs to one VPL)",
            m.map_count, m.vpl_count
        ));
    }
    let (w, h) = atlas_dims(m);
    if w * h > MAX_TEXELS || w > i32::MAX as u64 || h > i32::MAX as u64 {
        return bad(format!(
            "{} hemisphere maps of {}² make an absurdly large atlas ({w}x{h})",
            m.map_count, s.vpl_map_size
        ));
    }
    if m.lower_map_count > m.vpl_count {
        return bad(format!(
            "lower_map_count {} is larger than vpl_count {} (each stored second map belongs to one VPL)",
            m.lower_map_count, m.vpl_count
        ));
    }
    let (w, h) = lower_atlas_dims(m);
    if w * h > MAX_TEXELS || w > i32::MAX as u64 || h > i32::MAX as u64 {
        return bad(format!(
            "{} second hemisphere maps of {}² make an absurdly large atlas ({w}x{h})",
            m.lower_map_count, s.vpl_map_size
        ));
    }
    if !check_files {
        return Ok(());
    }
    let required = required_files(m, minor);
    for (i, f) in m.files.iter().enumerate() {
        if m.files[..i].iter().any(|g| g.name == f.name) {
            return bad(format!("file `{}` is listed twice", f.name));
        }
        let known = [
            FILE_VPLS,
            FILE_VPL_NODES,
            FILE_PRIMARY_DEPTH,
            FILE_VPL_MAPS,
            FILE_RSM,
            FILE_LIGHT_MAPS,
            FILE_VIEW_RSMS,
            FILE_VPL_COHERENCE,
            FILE_VPL_LOWER,
            FILE_VPL_LOWER_MAPS,
            FILE_MANIFEST,
        ];
        if known.contains(&f.name.as_str()) {
            if !required.contains(&f.name.as_str()) {
                return bad(format!(
                    "file `{}` is listed but the counts say it is not stored (format 4.{minor}, vpl_count {}, map_count {}, lower_map_count {}, has_dynamic {}, stored light maps {}, view RSMs {})",
                    f.name,
                    m.vpl_count,
                    m.map_count,
                    m.lower_map_count,
                    m.has_dynamic,
                    light_map_count(m),
                    m.view_rsms.len()
                ));
            }
        } else if !is_newer_minor(minor) || !is_plain_name(&f.name) {
            return bad(format!("unknown file `{}` listed", f.name.escape_debug()));
        }
    }
    for r in &required {
        if !m.files.iter().any(|f| f.name == *r) {
            return bad(format!("file `{r}` is not listed"));
        }
    }
    let vpls_size = m.vpl_count as u64 * VPL_RECORD_BYTES as u64;
    if let Some(f) = m.files.iter().find(|f| f.name == FILE_VPLS)
        && f.size != vpls_size
    {
        return bad(format!(
            "`{FILE_VPLS}` is listed with {} bytes but vpl_count {} needs {vpls_size}",
            f.size, m.vpl_count
        ));
    }
    let nodes_size = vpls_size * NODES_PER_VPL as u64;
    if let Some(f) = m.files.iter().find(|f| f.name == FILE_VPL_NODES)
        && f.size != nodes_size
    {
        return bad(format!(
            "`{FILE_VPL_NODES}` is listed with {} bytes but vpl_count {} needs {nodes_size}",
            f.size, m.vpl_count
        ));
    }
    let coherence_size = m.vpl_count as u64 * 4 * LEVEL3_NODES as u64;
    if let Some(f) = m.files.iter().find(|f| f.name == FILE_VPL_COHERENCE)
        && f.size != coherence_size
    {
        return bad(format!(
            "`{FILE_VPL_COHERENCE}` is listed with {} bytes but vpl_count {} needs {coherence_size}",
            f.size, m.vpl_count
        ));
    }
    let lower_size = m.vpl_count as u64 * LOWER_RECORD_BYTES as u64;
    if let Some(f) = m.files.iter().find(|f| f.name == FILE_VPL_LOWER)
        && f.size != lower_size
    {
        return bad(format!(
            "`{FILE_VPL_LOWER}` is listed with {} bytes but vpl_count {} needs {lower_size}",
            f.size, m.vpl_count
        ));
    }
    Ok(())
}

/// Whether the lights' VPL counts (and the later bounces', format 4.6) add
/// up to `vpl_count` (checked once the
/// VPL records are read, so that a hostile count is named by its file),
/// and `ring_vpls` fits them: empty or one entry per light, each at most
/// the light's VPLs, and only a directional light's non-zero.
fn check_light_vpls(m: &Manifest) -> Result<(), String> {
    let sum: u64 = m.lights.iter().map(|l| l.vpls as u64).sum();
    let later = u64::from(m.later_vpls());
    if !m.lights.is_empty() && sum + later != m.vpl_count as u64 {
        return Err(if later > 0 {
            format!(
                "the lights' VPL counts add up to {sum} and the later bounces' to {later}, but vpl_count is {}",
                m.vpl_count
            )
        } else {
            format!(
                "the lights' VPL counts add up to {sum} but vpl_count is {}",
                m.vpl_count
            )
        });
    }
    // Where the later light came from (4.8): one group per first-bounce
    // VPL, the pairs per later VPL, in range.
    if let Some(src) = &m.later_sources {
        let later = m.later_vpls();
        if let Some(p) = src.problem(m.vpl_count.saturating_sub(later), later) {
            return Err(format!("later_sources: {p}"));
        }
    }
    if !m.ring_vpls.is_empty() && m.ring_vpls.len() != m.lights.len() {
        return Err(format!(
            "ring_vpls holds {} entries for {} lights (none or one per light)",
            m.ring_vpls.len(),
            m.lights.len()
        ));
    }
    for (k, (light, &ring)) in m.lights.iter().zip(&m.ring_vpls).enumerate() {
        if ring > light.vpls {
            return Err(format!(
                "ring_vpls[{k}] = {ring} but light {k} has only {} VPLs",
                light.vpls
            ));
        }
        if ring > 0 && light.kind != crate::LIGHT_DIRECTIONAL {
            return Err(format!(
                "ring_vpls[{k}] = {ring} but light {k} is a {} light: only a directional light has outer rings",
                light.kind_name()
            ));
        }
    }
    Ok(())
}

/// The checks of a manifest's values that do not need its file list
/// (settings, light view, counts): what a shard part's front manifest must
/// pass so that its merge can be written.
pub(crate) fn validate_settings(m: &Manifest, path: &Path) -> Result<(), AssetError> {
    validate_manifest(m, FORMAT_MINOR, path, false)
}

fn load_manifest_inner(dir: &Path) -> Result<(Manifest, u16), AssetError> {
    let path = dir.join(FILE_MANIFEST);
    let bytes = read_capped(&path, (HEADER_BYTES + TRAILER_BYTES) as u64 + MAX_PAYLOAD)
        .map_err(|e| crate::what::explain(dir, e))?;
    let (m, minor) = decode_manifest(&bytes, &path)?;
    validate_manifest(&m, minor, &path, true)?;
    Ok((m, minor))
}

/// Reads and verifies `dir/manifest.bin` only (magic, version, length,
/// checksum, values): cheap, for `inspect` and for checking the scene hash
/// before loading the maps. Does not read or verify the other files.
pub fn load_manifest(dir: &Path) -> Result<Manifest, AssetError> {
    load_manifest_inner(dir).map(|(m, _)| m)
}

/// Reads `dir/manifest.bin` and checks every file it lists (size and BLAKE3)
/// without decoding the maps: what an up-to-date check needs to trust an
/// existing asset, at the cost of hashing its bytes once.
pub fn verify_files(dir: &Path) -> Result<Manifest, AssetError> {
    gibake_output::read_stable(dir, || {
        let (m, _) = load_manifest_inner(dir)?;
        for entry in &m.files {
            read_verified(dir, entry)?;
        }
        Ok(m)
    })
}

/// Compares the asset's static scene hash with `hash` (the static scene hash
/// of the scene at `scene_path`); a [`AssetError::SceneMismatch`] naming the
/// asset (by the scene it was baked from) and the scene when they differ,
/// and, in plain words (no command line: the runtime's message), the scene
/// options the asset was baked with ([`Manifest::scene_options`]).
pub fn check_scene_hash(
    manifest: &Manifest,
    hash: &[u8; 32],
    scene_path: &Path,
) -> Result<(), AssetError> {
    let asset = format!("the asset baked from `{}`", manifest.provenance.scene_name);
    let hint = match &manifest.scene_options {
        Some(o) if !o.is_empty() => format!(
            "; it was baked with the scene options {o}: load the scene with them, or re-bake it"
        ),
        _ => "; re-bake it".to_string(),
    };
    check_hash(asset, manifest, hash, scene_path, hint)
}

/// Like [`check_scene_hash`], for a command-line tool: names the asset by
/// its directory `asset_dir` and the scene options it was baked with as
/// the bake's flags (`it was baked with --sun 173,60 --dynamic 'Cylinder*'`).
/// `loaded_with`: the options the scene was loaded with, when the tool
/// knows them ([`crate::SceneOptions::resolve`]): the same as the record,
/// the message says the level itself changed.
pub fn check_scene_hash_for(
    asset_dir: &Path,
    manifest: &Manifest,
    hash: &[u8; 32],
    scene_path: &Path,
    loaded_with: Option<&crate::SceneOptions>,
) -> Result<(), AssetError> {
    let asset = format!(
        "{} (baked from `{}`)",
        asset_dir.display(),
        manifest.provenance.scene_name
    );
    let all = crate::all_flags();
    let hint = match &manifest.scene_options {
        None => format!(
            "; re-bake it, or, if it was baked with {all}, give the same ones (an asset before format 4.4 does not record them)"
        ),
        Some(r) if loaded_with.is_some_and(|l| l.same(r)) => {
            if r.is_empty() {
                "; re-bake it".to_string()
            } else {
                format!(
                    "; it was baked with {}, the same flags as here: the level's static part changed since; re-bake it",
                    r.flags()
                )
            }
        }
        Some(r) if r.is_empty() => {
            format!("; it was baked with none of {all}: give none of them, or re-bake it")
        }
        Some(r) => format!(
            "; it was baked with {}: give the same flags, or re-bake it",
            r.flags()
        ),
    };
    check_hash(asset, manifest, hash, scene_path, hint)
}

fn check_hash(
    asset: String,
    manifest: &Manifest,
    hash: &[u8; 32],
    scene_path: &Path,
    hint: String,
) -> Result<(), AssetError> {
    if &manifest.static_scene_hash == hash {
        return Ok(());
    }
    Err(AssetError::SceneMismatch {
        asset,
        scene: scene_path.to_owned(),
        asset_hash: hex16(&manifest.static_scene_hash),
        scene_hash: hex16(hash),
        hint,
    })
}

// ---------------------------------------------------------------- load

/// Reads one listed file, checking its size (before reading) and BLAKE3.
fn read_verified(dir: &Path, entry: &FileEntry) -> Result<Vec<u8>, AssetError> {
    let path = dir.join(&entry.name);
    check_regular(&path)?;
    let f = fs::File::open(&path).map_err(|e| AssetError::io(&path, e))?;
    let len = f.metadata().map_err(|e| AssetError::io(&path, e))?.len();
    if len != entry.size {
        return Err(AssetError::invalid(
            &path,
            format!(
                "file is {len} bytes but the manifest says {}: truncated or damaged",
                entry.size
            ),
        ));
    }
    let mut buf = Vec::new();
    buf.try_reserve_exact(len as usize)
        .map_err(|_| AssetError::invalid(&path, format!("cannot allocate {len} bytes")))?;
    f.take(len + 1)
        .read_to_end(&mut buf)
        .map_err(|e| AssetError::io(&path, e))?;
    if buf.len() as u64 != len {
        return Err(AssetError::invalid(
            &path,
            "file changed size while being read",
        ));
    }
    if blake3::hash(&buf).as_bytes() != &entry.blake3 {
        return Err(AssetError::invalid(
            &path,
            "checksum mismatch (BLAKE3 differs from the manifest): the file is damaged",
        ));
    }
    Ok(buf)
}

/// What a record array holds: the VPLs of `vpls.bin`, or the near-field
/// nodes of `vpl_nodes.bin` (named by VPL and node in messages).
#[derive(Clone, Copy)]
enum Records {
    Vpls,
    Nodes,
}

impl Records {
    fn name(self, i: usize) -> String {
        match self {
            Records::Vpls => format!("VPL {i}"),
            Records::Nodes => format!(
                "near-field node {} of VPL {} (record {i})",
                i % NODES_PER_VPL,
                i / NODES_PER_VPL
            ),
        }
    }
}

/// The spec's tile rule: the VPLs that store a map hold the tiles
/// `0, 1, …, map_count − 1` in record order, each tile exactly one VPL.
fn check_tiles(vpls: &[VplRecord], map_count: u32) -> Result<(), String> {
    let mut next = 0u32;
    for (i, v) in vpls.iter().enumerate() {
        if v.map == NO_MAP {
            continue;
        }
        if v.map != next {
            let first = vpls[..i].iter().position(|w| w.map == v.map);
            return Err(match first {
                Some(j) => format!(
                    "VPL {i} uses hemisphere map tile {} that VPL {j} already uses (each tile belongs to exactly one VPL)",
                    v.map
                ),
                None => format!(
                    "VPL {i} uses hemisphere map tile {}, but the VPLs with maps must use tiles 0, 1, 2, … in record order (expected {next})",
                    v.map
                ),
            });
        }
        next += 1;
    }
    if next != map_count {
        return Err(format!(
            "{next} VPLs use a hemisphere map but map_count is {map_count}"
        ));
    }
    Ok(())
}

fn decode_vpls(
    bytes: &[u8],
    path: &Path,
    map_count: u32,
    what: Records,
) -> Result<Vec<VplRecord>, AssetError> {
    let mut out = Vec::with_capacity(bytes.len() / VPL_RECORD_BYTES);
    for (i, chunk) in bytes.chunks_exact(VPL_RECORD_BYTES).enumerate() {
        let mut w = [0u32; 12];
        for (k, v) in w.iter_mut().enumerate() {
            *v = u32::from_le_bytes([
                chunk[4 * k],
                chunk[4 * k + 1],
                chunk[4 * k + 2],
                chunk[4 * k + 3],
            ]);
        }
        let f = |k: usize| f32::from_bits(w[k]);
        let rec = VplRecord {
            position: [f(0), f(1), f(2)],
            area: f(3),
            normal: [f(4), f(5), f(6)],
            texels: w[7],
            flux: [f(8), f(9), f(10)],
            map: w[11],
        };
        check_vpl(&rec, &what.name(i), map_count).map_err(|m| AssetError::invalid(path, m))?;
        out.push(rec);
    }
    Ok(out)
}

fn check_vpl(rec: &VplRecord, name: &str, map_count: u32) -> Result<(), String> {
    let fields = [
        ("position.x", rec.position[0]),
        ("position.y", rec.position[1]),
        ("position.z", rec.position[2]),
        ("area", rec.area),
        ("normal.x", rec.normal[0]),
        ("normal.y", rec.normal[1]),
        ("normal.z", rec.normal[2]),
        ("flux.r", rec.flux[0]),
        ("flux.g", rec.flux[1]),
        ("flux.b", rec.flux[2]),
    ];
    if let Some((f, v)) = fields.iter().find(|(_, v)| !v.is_finite()) {
        return Err(format!("{name}: {f} is {v} (not finite)"));
    }
    if let Some((f, v)) = fields
        .iter()
        .find(|(f, v)| (*f == "area" || f.starts_with("flux")) && *v < 0.0)
    {
        return Err(format!(
            "{name}: {f} is {v}; areas and fluxes are never negative"
        ));
    }
    if rec.map != NO_MAP && rec.map >= map_count {
        return Err(format!(
            "{name} refers to hemisphere map {} but only {map_count} are stored",
            rec.map
        ));
    }
    Ok(())
}

fn encode_vpls(vpls: &[VplRecord]) -> Vec<u8> {
    let mut out = Vec::with_capacity(vpls.len() * VPL_RECORD_BYTES);
    for r in vpls {
        let words: [u32; 12] = [
            r.position[0].to_bits(),
            r.position[1].to_bits(),
            r.position[2].to_bits(),
            r.area.to_bits(),
            r.normal[0].to_bits(),
            r.normal[1].to_bits(),
            r.normal[2].to_bits(),
            r.texels,
            r.flux[0].to_bits(),
            r.flux[1].to_bits(),
            r.flux[2].to_bits(),
            r.map,
        ];
        for w in words {
            out.extend_from_slice(&w.to_le_bytes());
        }
    }
    out
}

/// `vpl_coherence.bin` (empty bytes: none, an asset of format 4.1 or
/// older): [`LEVEL3_NODES`] `f32` per VPL, each in `[0, 1]`, 1 for an empty
/// node of `nodes` (the listed size was checked against `vpl_count`).
fn decode_coherence(
    bytes: &[u8],
    path: &Path,
    nodes: &[VplRecord],
) -> Result<Vec<f32>, AssetError> {
    let out: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let level3 = nodes
        .chunks(NODES_PER_VPL)
        .flat_map(|t| t.get(NODES_PER_VPL - LEVEL3_NODES..).unwrap_or(&[]));
    for (k, (&c, n)) in out.iter().zip(level3).enumerate() {
        let (vpl, node) = (k / LEVEL3_NODES, k % LEVEL3_NODES);
        if !(0.0..=1.0).contains(&c) {
            return Err(AssetError::invalid(
                path,
                format!("VPL {vpl} level-3 node {node}: coherence {c} is not in [0, 1]"),
            ));
        }
        if n.texels == 0 && c != 1.0 {
            return Err(AssetError::invalid(
                path,
                format!("VPL {vpl} level-3 node {node} is empty but its coherence is {c}, not 1"),
            ));
        }
    }
    Ok(out)
}

fn encode_coherence(coherence: &[f32]) -> Vec<u8> {
    coherence.iter().flat_map(|c| c.to_le_bytes()).collect()
}

/// `vpl_lower.bin` (empty bytes: none, an asset of format 4.6 or older;
/// the listed size was checked against `vpl_count`): one
/// [`crate::LowerVpl`] per VPL, its origin finite, all zeros without a
/// second origin ([`crate::NO_LOWER`]), its map [`NO_MAP`] or below
/// `lower_map_count`.
fn decode_lower(
    bytes: &[u8],
    path: &Path,
    lower_map_count: u32,
) -> Result<Vec<crate::LowerVpl>, AssetError> {
    let mut out = Vec::with_capacity(bytes.len() / LOWER_RECORD_BYTES);
    for (i, c) in bytes.chunks_exact(LOWER_RECORD_BYTES).enumerate() {
        let w = |k: usize| u32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]]);
        let rec = crate::LowerVpl {
            origin: [
                f32::from_bits(w(0)),
                f32::from_bits(w(1)),
                f32::from_bits(w(2)),
            ],
            map: w(3),
        };
        check_lower(&rec, i, lower_map_count).map_err(|m| AssetError::invalid(path, m))?;
        out.push(rec);
    }
    Ok(out)
}

fn check_lower(rec: &crate::LowerVpl, i: usize, lower_map_count: u32) -> Result<(), String> {
    if let Some(v) = rec.origin.iter().find(|v| !v.is_finite()) {
        return Err(format!("VPL {i}'s second origin holds {v} (not finite)"));
    }
    if rec.map == crate::NO_LOWER {
        if rec.origin != [0.0; 3] {
            return Err(format!(
                "VPL {i} has no second origin (map {}) but its origin is {:?}, not zeros",
                crate::NO_LOWER,
                rec.origin
            ));
        }
    } else if rec.map != NO_MAP && rec.map >= lower_map_count {
        return Err(format!(
            "VPL {i} refers to second hemisphere map {} but only {lower_map_count} are stored",
            rec.map
        ));
    }
    Ok(())
}

/// The second maps' tile rule, as [`check_tiles`]'s: the VPLs that store
/// one hold the tiles `0, 1, …, lower_map_count − 1` in record order.
fn check_lower_tiles(lower: &[crate::LowerVpl], lower_map_count: u32) -> Result<(), String> {
    let mut next = 0u32;
    for (i, v) in lower.iter().enumerate() {
        if v.map == NO_MAP || v.map == crate::NO_LOWER {
            continue;
        }
        if v.map != next {
            return Err(format!(
                "VPL {i} uses second hemisphere map tile {}, but the VPLs with second maps must use tiles 0, 1, 2, … in record order (expected {next})",
                v.map
            ));
        }
        next += 1;
    }
    if next != lower_map_count {
        return Err(format!(
            "{next} VPLs use a second hemisphere map but lower_map_count is {lower_map_count}"
        ));
    }
    Ok(())
}

fn encode_lower(lower: &[crate::LowerVpl]) -> Vec<u8> {
    let mut out = Vec::with_capacity(lower.len() * LOWER_RECORD_BYTES);
    for r in lower {
        for w in [
            r.origin[0].to_bits(),
            r.origin[1].to_bits(),
            r.origin[2].to_bits(),
            r.map,
        ] {
            out.extend_from_slice(&w.to_le_bytes());
        }
    }
    out
}

/// The first texel whose flux share is over [`SHARE_ONE`], or not 0
/// though it belongs to no VPL.
fn share_problem(share: &[u32], vpl: &[u32]) -> Option<usize> {
    share
        .iter()
        .zip(vpl)
        .position(|(&s, &v)| s > SHARE_ONE || (v == u32::MAX && s != 0))
}

fn no_nan(data: &[f32], path: &Path, what: &str) -> Result<(), AssetError> {
    match data.iter().position(|x| x.is_nan()) {
        None => Ok(()),
        Some(i) => Err(AssetError::invalid(
            path,
            format!("{what} holds NaN at texel {i}"),
        )),
    }
}

/// Loads the asset at `dir` and verifies everything: magic, version (another
/// major is [`AssetError::NotSupported`] naming both versions), manifest
/// length and checksum, every file's size and BLAKE3 against the manifest,
/// the counts and sizes against the file contents, and the values (finite
/// VPL records, map indices in range, no NaN in maps). Every error names the
/// file concerned. Never panics, and never allocates more than the files on
/// disk justify (plus the decoded maps, whose size the manifest bounds).
pub fn load(dir: &Path) -> Result<Asset, AssetError> {
    load_with_limit(dir, DEFAULT_MAX_DECODED_BYTES)
}

/// Default of [`load_with_limit`]'s budget: 1 GiB of decoded map data.
pub const DEFAULT_MAX_DECODED_BYTES: u64 = 1 << 30;

/// Bytes the maps of an asset with this manifest decode to (every sample
/// 4 bytes; the map atlas is kept as it is decoded).
pub fn decoded_bytes(m: &Manifest) -> u64 {
    let s = &m.settings;
    let sq = |n: u32| n as u64 * n as u64;
    let (aw, ah) = atlas_dims(m);
    let mut samples = sq(s.shadow_map_size);
    if m.map_count > 0 {
        samples = samples.saturating_add(aw.saturating_mul(ah));
    }
    let (lw, lh) = lower_atlas_dims(m);
    samples = samples.saturating_add(lw.saturating_mul(lh));
    if m.has_dynamic {
        samples = samples.saturating_add(sq(s.rsm_size).saturating_mul(3));
    }
    let (lw, lh) = light_atlas_dims(m);
    samples = samples.saturating_add(lw.saturating_mul(lh));
    // Z, share, vpl per atlas texel, then each tile copied out.
    let (vw, vh) = view_rsm_atlas_dims(m);
    samples = samples.saturating_add(vw.saturating_mul(vh).saturating_mul(6));
    samples.saturating_mul(4)
}

/// Like [`load`], refusing (before reading any map) an asset whose maps
/// decode to more than `max_decoded_bytes` ([`decoded_bytes`] plus the
/// files' own bytes, held meanwhile, plus EXR channels the reader does not
/// use, from the headers): a small, highly compressed EXR cannot make the
/// reader allocate gigabytes.
/// A read that fails because a writer swapped the asset mid-read is done
/// again (`gibake_output::read_stable`): a reader sees the old asset or the
/// new one.
pub fn load_with_limit(dir: &Path, max_decoded_bytes: u64) -> Result<Asset, AssetError> {
    gibake_output::read_stable(dir, || load_once(dir, max_decoded_bytes))
}

fn load_once(dir: &Path, max_decoded_bytes: u64) -> Result<Asset, AssetError> {
    let (manifest, _minor) = load_manifest_inner(dir)?;
    let need = decoded_bytes(&manifest);
    if need > max_decoded_bytes {
        return Err(AssetError::invalid(
            dir.join(FILE_MANIFEST),
            format!(
                "the asset's maps decode to {need} bytes, over the memory limit of {max_decoded_bytes} bytes (raise it with --max-memory)"
            ),
        ));
    }
    // Verify every listed file (including unknown ones of a newer minor)
    // before decoding anything.
    let mut contents: Vec<(&str, Vec<u8>)> = Vec::new();
    for entry in &manifest.files {
        let bytes = read_verified(dir, entry)?;
        contents.push((entry.name.as_str(), bytes));
    }
    let take = |name: &str| -> &[u8] {
        contents
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, b)| b.as_slice())
            .unwrap_or(&[])
    };
    let s = &manifest.settings;
    // Again with what is now known, before any decoding: the files' bytes
    // (held while the maps are decoded from them), and channels the reader
    // does not use (a newer minor may add some), decoded too, from the EXR
    // headers.
    let files: u64 = contents.iter().map(|(_, b)| b.len() as u64).sum();
    let need = need.saturating_add(files);
    let mut extra = 0u64;
    for (name, expected) in [
        (
            FILE_PRIMARY_DEPTH,
            4 * s.shadow_map_size as u64 * s.shadow_map_size as u64,
        ),
        (FILE_VPL_MAPS, {
            let (w, h) = atlas_dims(&manifest);
            4 * w * h
        }),
        (FILE_VPL_LOWER_MAPS, {
            let (w, h) = lower_atlas_dims(&manifest);
            4 * w * h
        }),
        // Z, share, vpl: 4 bytes each.
        (FILE_RSM, 12 * s.rsm_size as u64 * s.rsm_size as u64),
        (FILE_LIGHT_MAPS, {
            let (w, h) = light_atlas_dims(&manifest);
            4 * w * h
        }),
        // Z, share, vpl of the atlas: 12·rsm_size² per tile of the grid.
        (FILE_VIEW_RSMS, {
            let (w, h) = view_rsm_atlas_dims(&manifest);
            12 * w * h
        }),
    ] {
        let bytes = take(name);
        if !bytes.is_empty() {
            let declared = exrio::declared_bytes(bytes).unwrap_or(0);
            extra = extra.saturating_add(declared.saturating_sub(expected));
        }
    }
    if need.saturating_add(extra) > max_decoded_bytes {
        return Err(AssetError::invalid(
            dir.join(FILE_MANIFEST),
            format!(
                "reading the asset takes {} bytes (its files {files}, EXR channels this reader does not use {extra}, the maps the rest), over the memory limit of {max_decoded_bytes} bytes (raise it with --max-memory)",
                need.saturating_add(extra)
            ),
        ));
    }

    let path = dir.join(FILE_VPLS);
    let vpls = decode_vpls(take(FILE_VPLS), &path, manifest.map_count, Records::Vpls)?;
    check_tiles(&vpls, manifest.map_count).map_err(|m| AssetError::invalid(&path, m))?;
    check_light_vpls(&manifest).map_err(|m| AssetError::invalid(dir.join(FILE_MANIFEST), m))?;
    let path = dir.join(FILE_VPL_NODES);
    let vpl_nodes = decode_vpls(take(FILE_VPL_NODES), &path, 0, Records::Nodes)?;
    let vpl_coherence = decode_coherence(
        take(FILE_VPL_COHERENCE),
        &dir.join(FILE_VPL_COHERENCE),
        &vpl_nodes,
    )?;

    let path = dir.join(FILE_PRIMARY_DEPTH);
    let n = s.shadow_map_size as usize;
    let data = exrio::decode(take(FILE_PRIMARY_DEPTH), &path, n, n, &[("Z", Kind::F32)])?;
    let data = data
        .into_iter()
        .next()
        .map(Samples::into_f32)
        .unwrap_or_default();
    no_nan(&data, &path, "channel Z")?;
    let primary_depth = Map {
        size: s.shadow_map_size,
        data,
    };

    let vpl_maps = decode_atlas(
        take(FILE_VPL_MAPS),
        &dir.join(FILE_VPL_MAPS),
        s.vpl_map_size,
        manifest.map_count,
        atlas_dims(&manifest),
    )?;

    let rsm = if manifest.has_dynamic {
        let path = dir.join(FILE_RSM);
        let n = s.rsm_size as u64;
        let (metric, share, vpl) = decode_rsm_channels(take(FILE_RSM), &path, (n, n))?;
        // The RSM is the first light's: its texels name its VPLs, the
        // first `lights[0].vpls` records.
        let own = 0..first_light_vpls(&manifest);
        if let Some(e) = rsm_problem(&metric, &share, &vpl, s.rsm_size, own, "the first light") {
            return Err(AssetError::invalid(&path, e));
        }
        Some(RsmData {
            size: s.rsm_size,
            metric,
            share,
            vpl,
        })
    } else {
        None
    };

    let light_count = light_map_count(&manifest);
    let light_maps = decode_atlas(
        take(FILE_LIGHT_MAPS),
        &dir.join(FILE_LIGHT_MAPS),
        manifest.light_map_size,
        light_count,
        light_atlas_dims(&manifest),
    )?;

    let view_rsms = decode_view_rsms(take(FILE_VIEW_RSMS), &dir.join(FILE_VIEW_RSMS), &manifest)?;

    let path = dir.join(FILE_VPL_LOWER);
    let vpl_lower = decode_lower(take(FILE_VPL_LOWER), &path, manifest.lower_map_count)?;
    check_lower_tiles(&vpl_lower, manifest.lower_map_count)
        .map_err(|m| AssetError::invalid(&path, m))?;
    let vpl_lower_maps = decode_atlas(
        take(FILE_VPL_LOWER_MAPS),
        &dir.join(FILE_VPL_LOWER_MAPS),
        s.vpl_map_size,
        manifest.lower_map_count,
        lower_atlas_dims(&manifest),
    )?;
    Ok(Asset {
        manifest,
        vpls,
        vpl_nodes,
        vpl_coherence,
        vpl_lower,
        vpl_lower_maps,
        primary_depth,
        vpl_maps,
        rsm,
        light_maps,
        view_rsms,
    })
}

/// The first light's VPLs, `0..this` (every VPL when there are no light
/// records): the ones its RSM (`rsm.exr`) may name.
fn first_light_vpls(m: &Manifest) -> u64 {
    m.lights
        .first()
        .map_or(m.vpl_count, |l| l.vpls.min(m.vpl_count)) as u64
}

/// An RSM's channels (`Z` f32, `share` u32, `vpl` u32), in that order: the
/// channels of `rsm.exr` and of `view_rsms.exr`.
const RSM_CHANNELS: [(&str, Kind); 3] =
    [("Z", Kind::F32), ("share", Kind::U32), ("vpl", Kind::U32)];

/// The EXR bytes of an RSM image of `w × h` ([`RSM_CHANNELS`]).
fn encode_rsm_channels(
    (w, h): (usize, usize),
    metric: Vec<f32>,
    share: Vec<u32>,
    vpl: Vec<u32>,
) -> Result<Vec<u8>, exr::error::Error> {
    exrio::encode(
        w,
        h,
        vec![
            (RSM_CHANNELS[0].0, Samples::F32(metric)),
            (RSM_CHANNELS[1].0, Samples::U32(share)),
            (RSM_CHANNELS[2].0, Samples::U32(vpl)),
        ],
    )
}

/// An RSM's decoded channels: `(metric, share, vpl)`.
type RsmChannels = (Vec<f32>, Vec<u32>, Vec<u32>);

/// Decodes an RSM image of `w × h` ([`RSM_CHANNELS`]): `(metric, share, vpl)`.
fn decode_rsm_channels(
    bytes: &[u8],
    path: &Path,
    (w, h): (u64, u64),
) -> Result<RsmChannels, AssetError> {
    let mut it = exrio::decode(bytes, path, w as usize, h as usize, &RSM_CHANNELS)?.into_iter();
    let mut next = || {
        it.next()
            .ok_or_else(|| AssetError::invalid(path, "channel missing"))
    };
    let metric = next()?.into_f32();
    let share = next()?.into_u32();
    let vpl = next()?.into_u32();
    Ok((metric, share, vpl))
}

/// `view_rsms.exr`: the atlas (layout of `vpl_maps.exr`) of the view RSMs,
/// tile k the RSM of `views[view_rsms[k]]`; unused tiles hold `Z` +inf,
/// `share` 0 and `vpl` `u32::MAX` only. Every tile is checked
/// ([`check_view_rsms`]). Empty when `view_rsms` is.
fn decode_view_rsms(bytes: &[u8], path: &Path, m: &Manifest) -> Result<Vec<RsmData>, AssetError> {
    let count = m.view_rsms.len() as u32;
    if count == 0 {
        return Ok(Vec::new());
    }
    let (metric, share, vpl) = decode_rsm_channels(bytes, path, view_rsm_atlas_dims(m))?;
    let tile = m.settings.rsm_size;
    if let Some(e) = unused_rsm_tile_message(tile, count, &metric, &share, &vpl) {
        return Err(AssetError::invalid(path, e));
    }
    let rsms: Vec<RsmData> = (0..count)
        .map(|k| RsmData {
            size: tile,
            metric: unpack_tile(tile, count, &metric, k),
            share: unpack_tile(tile, count, &share, k),
            vpl: unpack_tile(tile, count, &vpl, k),
        })
        .collect();
    check_view_rsms(m, &rsms).map_err(|e| AssetError::invalid(path, e))?;
    Ok(rsms)
}

/// What is wrong with the unused tiles of a view-RSM atlas of `count`
/// tiles, if anything (`Z` +inf, `share` 0, `vpl` `u32::MAX`: no surface).
fn unused_rsm_tile_message(
    tile: u32,
    count: u32,
    metric: &[f32],
    share: &[u32],
    vpl: &[u32],
) -> Option<String> {
    let found = unused_mismatch(tile, count, metric, &f32::INFINITY)
        .map(|t| ("Z", t))
        .or_else(|| unused_mismatch(tile, count, share, &0).map(|t| ("share", t)))
        .or_else(|| unused_mismatch(tile, count, vpl, &u32::MAX).map(|t| ("vpl", t)));
    found.map(|(channel, (k, x, y))| {
        let i = crate::atlas::atlas_index(tile, count, k, x, y);
        let value = match channel {
            "Z" => metric[i].to_string(),
            "share" => share[i].to_string(),
            _ => vpl[i].to_string(),
        };
        format!(
            "unused tile {k} (after the {count} view RSMs) holds {channel} = {value} at its texel ({x}, {y}): unused tiles must be Z +inf, share 0, vpl 0xFFFFFFFF"
        )
    })
}

/// A map atlas file (`vpl_maps.exr`, `light_maps.exr`): `count` maps of
/// `tile²` in the `(w, h)` atlas, channel `Z`, no NaN; empty when `count`
/// is 0 (the file is not stored).
fn decode_atlas(
    bytes: &[u8],
    path: &Path,
    tile: u32,
    count: u32,
    (w, h): (u64, u64),
) -> Result<MapAtlas, AssetError> {
    if count == 0 {
        return Ok(MapAtlas::empty(tile));
    }
    let data = exrio::decode(bytes, path, w as usize, h as usize, &[("Z", Kind::F32)])?;
    let texels = data
        .into_iter()
        .next()
        .map(Samples::into_f32)
        .unwrap_or_default();
    no_nan(&texels, path, "channel Z")?;
    let atlas = MapAtlas::from_texels(tile, count, texels)
        .ok_or_else(|| AssetError::invalid(path, "the atlas has the wrong number of texels"))?;
    // A finite value past the last map is damage, or an atlas that holds
    // more maps than the manifest counts (the Python reader refuses it too).
    if let Some(m) = unused_tile_message(&atlas) {
        return Err(AssetError::invalid(path, m));
    }
    Ok(atlas)
}

/// What is wrong with `atlas`'s unused tiles, if anything (they must be
/// +inf: docs/asset-format.md).
fn unused_tile_message(atlas: &MapAtlas) -> Option<String> {
    atlas.finite_unused_texel().map(|(k, x, y, v)| {
        format!(
            "unused tile {k} (after the {} maps) holds {v} at its texel ({x}, {y}): unused tiles must be +inf",
            atlas.count()
        )
    })
}

// ---------------------------------------------------------------- write

/// Checks the in-memory asset's consistency and returns the manifest to
/// write (counts and flags filled in from the data, `files` empty).
fn prepare_manifest(asset: &Asset, dir: &Path) -> Result<Manifest, AssetError> {
    let bad = |m: String| Err(AssetError::invalid(dir, format!("cannot write: {m}")));
    let mut m = asset.manifest.clone();
    m.files.clear();
    // The canonical form (sorted lists, no default texture size): the same
    // options give the same bytes whatever order they were given in.
    m.scene_options = m
        .scene_options
        .as_ref()
        .map(crate::SceneOptions::normalized);
    let s = &m.settings;
    if s.vpl_map_size == 0 {
        return bad("settings.vpl_map_size is 0".into());
    }
    let maps = &asset.vpl_maps;
    if !maps.is_empty() && maps.tile_size() != s.vpl_map_size {
        return bad(format!(
            "vpl_maps holds maps of {}² but settings.vpl_map_size is {}",
            maps.tile_size(),
            s.vpl_map_size
        ));
    }
    let Ok(vpl_count) = u32::try_from(asset.vpls.len()) else {
        return bad(format!("{} VPLs are too many", asset.vpls.len()));
    };
    let map_count = maps.count();
    m.vpl_count = vpl_count;
    m.map_count = map_count;
    let lower_maps = &asset.vpl_lower_maps;
    if !lower_maps.is_empty() && lower_maps.tile_size() != s.vpl_map_size {
        return bad(format!(
            "vpl_lower_maps holds maps of {}² but settings.vpl_map_size is {}",
            lower_maps.tile_size(),
            s.vpl_map_size
        ));
    }
    m.lower_map_count = lower_maps.count();
    if !asset.vpl_lower.is_empty() && asset.vpl_lower.len() != asset.vpls.len() {
        return bad(format!(
            "vpl_lower holds {} records but there are {} VPLs (one each, or none)",
            asset.vpl_lower.len(),
            asset.vpls.len()
        ));
    }
    for (i, r) in asset.vpl_lower.iter().enumerate() {
        check_lower(r, i, m.lower_map_count)
            .map_err(|e| AssetError::invalid(dir, format!("cannot write: {e}")))?;
    }
    check_lower_tiles(&asset.vpl_lower, m.lower_map_count)
        .map_err(|e| AssetError::invalid(dir, format!("cannot write: {e}")))?;
    if lower_maps.texels().iter().any(|x| x.is_nan()) {
        return bad("vpl_lower_maps holds NaN".into());
    }
    if let Some(e) = unused_tile_message(lower_maps) {
        return bad(format!("vpl_lower_maps: {e}"));
    }
    m.has_dynamic = asset.rsm.is_some();
    let coherence = asset.vpl_coherence.len();
    if coherence != 0 && coherence != asset.vpls.len() * LEVEL3_NODES {
        return bad(format!(
            "vpl_coherence holds {coherence} values but {} VPLs need {} (or none)",
            asset.vpls.len(),
            asset.vpls.len() * LEVEL3_NODES
        ));
    }
    let sm = s.shadow_map_size;
    if asset.primary_depth.size != sm || asset.primary_depth.data.len() != sm as usize * sm as usize
    {
        return bad(format!(
            "primary_depth is {}² with {} values but settings.shadow_map_size is {sm}",
            asset.primary_depth.size,
            asset.primary_depth.data.len()
        ));
    }
    if let Some(r) = &asset.rsm {
        let n = s.rsm_size as usize * s.rsm_size as usize;
        if r.size != s.rsm_size || r.metric.len() != n || r.share.len() != n || r.vpl.len() != n {
            return bad(format!(
                "rsm is {}² ({} / {} / {} values) but settings.rsm_size is {}",
                r.size,
                r.metric.len(),
                r.share.len(),
                r.vpl.len(),
                s.rsm_size
            ));
        }
        // The first light's RSM names its VPLs only (the first records).
        let own = 0..first_light_vpls(&m);
        if let Some(e) = rsm_problem(&r.metric, &r.share, &r.vpl, r.size, own, "the first light") {
            return bad(format!("rsm: {e}"));
        }
    }
    if let Err(e) = check_view_rsm_list(&m).and_then(|()| check_view_rsms(&m, &asset.view_rsms)) {
        return bad(format!("view_rsms: {e}"));
    }
    if asset.primary_depth.data.iter().any(|x| x.is_nan()) {
        return bad("primary_depth holds NaN".into());
    }
    let lm = &asset.light_maps;
    let stored = light_map_count(&m);
    if lm.count() != stored || (stored > 0 && lm.tile_size() != m.light_map_size) {
        return bad(format!(
            "light_maps holds {} maps of {}² but the views store {stored} of {}²",
            lm.count(),
            lm.tile_size(),
            m.light_map_size
        ));
    }
    if lm.texels().iter().any(|x| x.is_nan()) {
        return bad("light_maps holds NaN".into());
    }
    if maps.texels().iter().any(|x| x.is_nan()) {
        return bad("vpl_maps holds NaN".into());
    }
    for (name, atlas) in [("vpl_maps", maps), ("light_maps", lm)] {
        if let Some(e) = unused_tile_message(atlas) {
            return bad(format!("{name}: {e}"));
        }
    }
    for (i, r) in asset.vpls.iter().enumerate() {
        check_vpl(r, &Records::Vpls.name(i), map_count)
            .map_err(|e| AssetError::invalid(dir, format!("cannot write: {e}")))?;
    }
    check_tiles(&asset.vpls, map_count)
        .map_err(|e| AssetError::invalid(dir, format!("cannot write: {e}")))?;
    check_light_vpls(&m).map_err(|e| AssetError::invalid(dir, format!("cannot write: {e}")))?;
    if asset.vpl_nodes.len() != asset.vpls.len() * NODES_PER_VPL {
        return bad(format!(
            "vpl_nodes holds {} records but {} VPLs need {}",
            asset.vpl_nodes.len(),
            asset.vpls.len(),
            asset.vpls.len() * NODES_PER_VPL
        ));
    }
    for (i, r) in asset.vpl_nodes.iter().enumerate() {
        check_vpl(r, &Records::Nodes.name(i), 0)
            .map_err(|e| AssetError::invalid(dir, format!("cannot write: {e}")))?;
    }
    validate_manifest(&m, FORMAT_MINOR, dir, false).map_err(|e| match e {
        AssetError::Invalid { message, .. } => {
            AssetError::invalid(dir, format!("cannot write: {message}"))
        }
        e => e,
    })?;
    Ok(m)
}

/// The names of the files an asset directory's format owns: the fixed names
/// and, if the old manifest can be decoded, every plain name it lists.
/// Anything else in an asset directory is a user's (kept by every replace,
/// never removed as a stale temporary's content).
pub fn owned_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = [
        FILE_MANIFEST,
        FILE_VPLS,
        FILE_VPL_NODES,
        FILE_PRIMARY_DEPTH,
        FILE_VPL_MAPS,
        FILE_RSM,
        FILE_LIGHT_MAPS,
        FILE_VIEW_RSMS,
        FILE_VPL_COHERENCE,
        FILE_VPL_LOWER,
        FILE_VPL_LOWER_MAPS,
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let path = dir.join(FILE_MANIFEST);
    let decoded = read_capped(&path, (HEADER_BYTES + TRAILER_BYTES) as u64 + MAX_PAYLOAD)
        .and_then(|bytes| decode_manifest(&bytes, &path));
    if let Ok((m, _)) = decoded {
        for f in m.files {
            if is_plain_name(&f.name) && !names.contains(&f.name) {
                names.push(f.name);
            }
        }
    }
    names
}

/// Whether `path` is a regular file that starts with the manifest magic bytes.
fn has_magic(path: &Path) -> bool {
    if !fs::metadata(path).is_ok_and(|m| m.is_file()) {
        return false;
    }
    let mut head = [0u8; 8];
    fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && head == MAGIC
}

/// Whether `dir` may receive an asset: absent, an empty directory or a
/// gibake asset (judged by the magic bytes of its `manifest.bin`); anything
/// else is an error and is left untouched.
fn check_target(dir: &Path) -> Result<(), AssetError> {
    let meta = match fs::symlink_metadata(dir) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(AssetError::io(dir, e)),
    };
    if !meta.is_dir() {
        // Say what is there: a link to an asset is a directory to its user.
        let what = gibake_output::describe(dir).unwrap_or_else(|| "gone".into());
        let hint = if meta.file_type().is_symlink() {
            ": an asset is replaced by swapping directories, which would replace the link itself; give the directory it points to"
        } else {
            ", not a directory"
        };
        return Err(AssetError::invalid(
            dir,
            format!("is {what}{hint}; refusing to replace it with an asset"),
        ));
    }
    let empty = fs::read_dir(dir)
        .map_err(|e| AssetError::io(dir, e))?
        .next()
        .is_none();
    if empty {
        return Ok(());
    }
    let manifest = dir.join(FILE_MANIFEST);
    if manifest.exists() && !has_magic(&manifest) {
        return Err(AssetError::invalid(
            dir,
            "exists and is not a gibake asset (its manifest.bin lacks the gibake magic bytes); refusing to replace it",
        ));
    }
    if !manifest.exists() {
        return Err(AssetError::invalid(
            dir,
            "exists and is not a gibake asset (no manifest.bin); refusing to replace it",
        ));
    }
    Ok(())
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), AssetError> {
    let mut f = fs::File::create(path).map_err(|e| AssetError::io(path, e))?;
    f.write_all(bytes).map_err(|e| AssetError::io(path, e))?;
    f.sync_all().map_err(|e| AssetError::io(path, e))
}

/// A step of [`write()`] at which a fault can be injected (tests only).
type Hook<'a> = &'a mut dyn FnMut(&str) -> std::io::Result<()>;

/// Writes `asset` to the directory `dir` (conventionally `NAME.gibake`).
///
/// Everything is written into a temporary sibling directory
/// (`.NAME.gibake.XXXXXX.tmp`, created exclusively), `manifest.bin` last,
/// then swapped with the old asset in one step under the output's lock
/// (`gibake_output::DirWriter`): at every instant `dir` is the old asset or
/// the new one, complete. An existing `dir` is replaced only if it is a
/// gibake asset (has `manifest.bin` with the magic bytes) or empty; anything
/// else is refused and left untouched. Files in an old asset directory that
/// the format does not own are kept. On failure the temporary directory is
/// removed and the old asset (if any) stays as it was.
///
/// `manifest.files`, `vpl_count`, `map_count` and `has_dynamic` are filled
/// in from the data (the in-memory `asset` is not changed); the data must be
/// consistent with the settings (map sizes, map indices, no NaN), else
/// [`AssetError::Invalid`] and nothing is written. The output is
/// deterministic: the same asset gives byte-identical files.
pub fn write(asset: &Asset, dir: &Path) -> Result<(), AssetError> {
    write_with_hook(asset, dir, &mut |_| Ok(()))
}

/// Checks, before any work, that [`write()`] may put an asset at `dir`:
/// absent, an empty directory or a gibake asset (anything else is an
/// [`AssetError::Invalid`] saying what is there).
pub fn check_output(dir: &Path) -> Result<(), AssetError> {
    check_target(dir).map(|_| ())
}

fn write_with_hook(asset: &Asset, dir: &Path, hook: Hook<'_>) -> Result<(), AssetError> {
    let mut manifest = prepare_manifest(asset, dir)?;
    check_target(dir)?;
    let owned = owned_names(dir).into_iter().map(Into::into).collect();
    let out = gibake_output::DirWriter::create(dir, owned, &mut |_| {})?;
    // Under the lock: what is there now is what gets replaced.
    check_target(dir)?;
    write_into(asset, &mut manifest, out.path(), hook)?;
    hook("rename").map_err(|e| AssetError::io(dir, e))?;
    out.commit()?;
    Ok(())
}

fn write_into(
    asset: &Asset,
    manifest: &mut Manifest,
    tmp: &Path,
    hook: Hook<'_>,
) -> Result<(), AssetError> {
    let s = manifest.settings.clone();
    for name in required_files(manifest, FORMAT_MINOR) {
        let path = tmp.join(name);
        hook(name).map_err(|e| AssetError::io(&path, e))?;
        let exr_err =
            |e: exr::error::Error| AssetError::invalid(&path, format!("cannot encode EXR: {e}"));
        let bytes = match name {
            FILE_VPLS => encode_vpls(&asset.vpls),
            FILE_VPL_NODES => encode_vpls(&asset.vpl_nodes),
            // None (an asset read from an older format): every node one
            // cosine lobe, coherence 1.
            FILE_VPL_COHERENCE if asset.vpl_coherence.is_empty() => {
                encode_coherence(&vec![1.0; asset.vpls.len() * LEVEL3_NODES])
            }
            FILE_VPL_COHERENCE => encode_coherence(&asset.vpl_coherence),
            // None (an asset read from an older format): no VPL has a
            // second origin.
            FILE_VPL_LOWER if asset.vpl_lower.is_empty() => {
                encode_lower(&vec![crate::LowerVpl::NONE; asset.vpls.len()])
            }
            FILE_VPL_LOWER => encode_lower(&asset.vpl_lower),
            FILE_PRIMARY_DEPTH => {
                let n = s.shadow_map_size as usize;
                let d = asset.primary_depth.data.clone();
                exrio::encode(n, n, vec![("Z", Samples::F32(d))]).map_err(exr_err)?
            }
            FILE_VPL_MAPS => {
                let m = &asset.vpl_maps;
                let texels = Samples::F32(m.texels().to_vec());
                let (w, h) = (m.width() as usize, m.height() as usize);
                exrio::encode(w, h, vec![("Z", texels)]).map_err(exr_err)?
            }
            FILE_VPL_LOWER_MAPS => {
                let m = &asset.vpl_lower_maps;
                let texels = Samples::F32(m.texels().to_vec());
                let (w, h) = (m.width() as usize, m.height() as usize);
                exrio::encode(w, h, vec![("Z", texels)]).map_err(exr_err)?
            }
            FILE_LIGHT_MAPS => {
                let m = &asset.light_maps;
                let texels = Samples::F32(m.texels().to_vec());
                let (w, h) = (m.width() as usize, m.height() as usize);
                exrio::encode(w, h, vec![("Z", texels)]).map_err(exr_err)?
            }
            FILE_VIEW_RSMS => {
                let v = &asset.view_rsms;
                let tile = s.rsm_size;
                let pack = |fail: &str| {
                    AssetError::invalid(&path, format!("cannot lay out the view RSMs: {fail}"))
                };
                let metric: Vec<&[f32]> = v.iter().map(|r| r.metric.as_slice()).collect();
                let share: Vec<&[u32]> = v.iter().map(|r| r.share.as_slice()).collect();
                let vpl: Vec<&[u32]> = v.iter().map(|r| r.vpl.as_slice()).collect();
                let metric = pack_tiles(tile, &metric, f32::INFINITY).ok_or_else(|| pack("Z"))?;
                let share = pack_tiles(tile, &share, 0).ok_or_else(|| pack("share"))?;
                let vpl = pack_tiles(tile, &vpl, u32::MAX).ok_or_else(|| pack("vpl"))?;
                let (w, h) = view_rsm_atlas_dims(manifest);
                encode_rsm_channels((w as usize, h as usize), metric, share, vpl)
                    .map_err(exr_err)?
            }
            _ => {
                let Some(r) = &asset.rsm else { continue };
                let n = r.size as usize;
                encode_rsm_channels((n, n), r.metric.clone(), r.share.clone(), r.vpl.clone())
                    .map_err(exr_err)?
            }
        };
        write_file(&path, &bytes)?;
        manifest.files.push(FileEntry {
            name: name.to_owned(),
            size: bytes.len() as u64,
            blake3: *blake3::hash(&bytes).as_bytes(),
        });
    }
    let path = tmp.join(FILE_MANIFEST);
    hook(FILE_MANIFEST).map_err(|e| AssetError::io(&path, e))?;
    let bytes = encode_manifest(manifest, &path)?;
    write_file(&path, &bytes)
}

/// Helpers for tests of this crate and its users; not part of the format.
pub mod testing {
    use super::*;

    /// Like [`write()`], but fails with an injected I/O error just before the
    /// step `step`: a file name (`"vpls.bin"`, `"primary_depth.exr"`,
    /// `"vpl_maps.exr"`, `"rsm.exr"`, `"manifest.bin"`) or `"rename"`.
    pub fn write_failing_before(asset: &Asset, dir: &Path, step: &str) -> Result<(), AssetError> {
        write_with_hook(asset, dir, &mut |s| {
            if s == step {
                Err(std::io::Error::other(format!(
                    "injected failure before {s}"
                )))
            } else {
                Ok(())
            }
        })
    }

    /// Decodes and validates `manifest.bin` bytes as [`load()`] does (magic,
    /// version, length, checksum, payload, values). For fuzzing.
    pub fn decode_manifest_bytes(bytes: &[u8]) -> Result<Manifest, AssetError> {
        let path = Path::new(FILE_MANIFEST);
        let (m, minor) = decode_manifest(bytes, path)?;
        validate_manifest(&m, minor, path, true)?;
        Ok(m)
    }

    /// Decodes one EXR map the way [`load()`] does, its size taken from its
    /// own header (at most 2048² texels). For fuzzing.
    pub fn decode_exr_bytes(bytes: &[u8]) -> Result<(), AssetError> {
        exrio::decode_any(bytes, Path::new("map.exr"))
    }

    /// The bytes of a one-channel (`Z`, f32) EXR map of `width × height`
    /// as [`write()`] encodes the atlases: to store hand-made damage
    /// behind a valid checksum in tests.
    pub fn z_exr_bytes(
        width: usize,
        height: usize,
        texels: Vec<f32>,
    ) -> Result<Vec<u8>, AssetError> {
        exrio::encode(width, height, vec![("Z", Samples::F32(texels))])
            .map_err(|e| AssetError::invalid(Path::new("map.exr"), e.to_string()))
    }

    /// The bytes of `manifest.bin` for `manifest` as [`write()`] would write them.
    pub fn manifest_bytes(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        encode_manifest(manifest, Path::new(FILE_MANIFEST))
    }

    /// The bytes of `manifest.bin` for `manifest` as a format 4.0 writer
    /// wrote them (minor 0, the payload ends after `light_map_size`; its
    /// `view_rsms` must be empty; `vpl_coherence.bin`, format 4.2, and the
    /// files of 4.7 not listed): to check that 4.0 assets still load.
    pub fn manifest_bytes_4_0(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        encode_manifest_as(&before_4_2(manifest), 0, Path::new(FILE_MANIFEST))
    }

    /// `manifest` without what format 4.7 added: no second maps counted,
    /// `vpl_lower.bin` and `vpl_lower_maps.exr` not listed (an older
    /// writer's manifest of the same asset).
    fn before_4_7(manifest: &Manifest) -> Manifest {
        let mut m = manifest.clone();
        m.lower_map_count = 0;
        m.later_sources = None;
        m.files
            .retain(|f| f.name != FILE_VPL_LOWER && f.name != FILE_VPL_LOWER_MAPS);
        m
    }

    /// The bytes of `manifest.bin` for `manifest` as a format 4.1 writer
    /// wrote them (minor 1; `vpl_coherence.bin`, format 4.2, and the files
    /// of 4.7 not listed): to check that 4.1 assets still load.
    pub fn manifest_bytes_4_1(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        encode_manifest_as(&before_4_2(manifest), 1, Path::new(FILE_MANIFEST))
    }

    /// The bytes of `manifest.bin` for `manifest` as a format 4.2 writer
    /// wrote them (minor 2, the payload ends after `view_rsms`; its
    /// `ring_vpls` must be empty, its `scene_options` `None`; the files of
    /// 4.7 not listed): to check that 4.2 assets still load.
    pub fn manifest_bytes_4_2(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        encode_manifest_as(&before_4_7(manifest), 2, Path::new(FILE_MANIFEST))
    }

    /// The bytes of `manifest.bin` for `manifest` as a format 4.3 writer
    /// wrote them (minor 3, the payload ends after `ring_vpls`; its
    /// `scene_options` and `swept_bounds` must be `None`; the files of 4.7
    /// not listed): to check that 4.3 assets still load.
    pub fn manifest_bytes_4_3(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        encode_manifest_as(&before_4_7(manifest), 3, Path::new(FILE_MANIFEST))
    }

    /// The bytes of `manifest.bin` for `manifest` as a format 4.4 writer
    /// wrote them (minor 4, the payload ends after `scene_options`; its
    /// `swept_bounds` must be `None`; the files of 4.7 not listed, no
    /// second map counted): to check that 4.4 assets still load.
    pub fn manifest_bytes_4_4(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        encode_manifest_as(&before_4_7(manifest), 4, Path::new(FILE_MANIFEST))
    }

    /// The bytes of `manifest.bin` for `manifest` as a format 4.5 writer
    /// wrote them (minor 5, the payload ends after `swept_bounds`; its
    /// `later` must be `None`; the files of 4.7 not listed): to check that
    /// 4.5 assets still load.
    pub fn manifest_bytes_4_5(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        encode_manifest_as(&before_4_7(manifest), 5, Path::new(FILE_MANIFEST))
    }

    /// The bytes of `manifest.bin` for `manifest` as a format 4.6 writer
    /// wrote them (minor 6, the payload ends after `later`; the files of
    /// 4.7 not listed, no second map counted): to check that 4.6 assets
    /// still load, every VPL without a second origin.
    pub fn manifest_bytes_4_6(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        encode_manifest_as(&before_4_7(manifest), 6, Path::new(FILE_MANIFEST))
    }

    /// The bytes of `manifest.bin` for `manifest` as a format 4.7 writer
    /// wrote them (minor 7, the payload ends after `lower_map_count`; no
    /// `later_sources`): to check that 4.7 assets still load, their later
    /// VPLs with the level's mean occluded share.
    pub fn manifest_bytes_4_7(manifest: &Manifest) -> Result<Vec<u8>, AssetError> {
        let mut m = manifest.clone();
        m.later_sources = None;
        encode_manifest_as(&m, 7, Path::new(FILE_MANIFEST))
    }

    fn before_4_2(manifest: &Manifest) -> Manifest {
        let mut m = before_4_7(manifest);
        m.files.retain(|f| f.name != FILE_VPL_COHERENCE);
        m
    }

    /// Decodes `manifest.bin` bytes (magic, version, length, checksum,
    /// payload) without checking the values: the manifest and the file's
    /// minor version. To edit a manifest in tests.
    pub fn decode_manifest_unchecked(bytes: &[u8]) -> Result<(Manifest, u16), AssetError> {
        decode_manifest(bytes, Path::new(FILE_MANIFEST))
    }

    /// The bytes of an RSM image (`Z` f32, `share` u32, `vpl` u32) of
    /// `width × height` as [`write()`] encodes `rsm.exr` and
    /// `view_rsms.exr`: to store hand-made damage behind a valid checksum.
    pub fn rsm_exr_bytes(
        width: usize,
        height: usize,
        metric: Vec<f32>,
        share: Vec<u32>,
        vpl: Vec<u32>,
    ) -> Result<Vec<u8>, AssetError> {
        encode_rsm_channels((width, height), metric, share, vpl)
            .map_err(|e| AssetError::invalid(Path::new("map.exr"), e.to_string()))
    }
}
