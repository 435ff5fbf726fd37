//! Shard parts of a distributed bake, and merging them into the asset.
//!
//! `gibake bake SCENE -o PART --shard K/N` runs the whole front part of the
//! bake (primary shadow map, RSM, clustering: the same on every shard,
//! because the bake is deterministic) and renders only the hemisphere maps of
//! the VPLs that shard `K` of `N` owns ([`shard_range`]). It writes one
//! **part file** ([`write_part`]); [`merge`] checks a complete set of parts
//! and builds the [`Asset`] that a single-machine bake would have produced,
//! so `gibake_asset::write` gives byte-identical files. The part file layout
//! is documented in `docs/asset-format.md` (section *Shard parts*).

use std::fs;
use std::io::Write;
use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::{
    Asset, AssetError, LowerVpl, Manifest, Map, MapAtlas, NO_LOWER, NO_MAP, RsmData, VplRecord,
};

/// Magic bytes at the start of a part file.
pub const PART_MAGIC: [u8; 8] = *b"GIBKPART";
/// Part format version: parts are transient, so any other version is refused.
/// (7: the manifest's `swept_bounds`, which its serde encoding skips,
/// follows `scene_options`; 8: and its `later`; 9: each VPL's second
/// origin and the second hemisphere maps, format 4.7; 10: the manifest's
/// `later_sources`, format 4.8.)
pub const PART_VERSION: u16 = 10;
/// Largest shard count accepted.
pub const MAX_SHARDS: u32 = 4096;
/// Largest accepted part file (16 GiB).
const MAX_PART_BYTES: u64 = 1 << 34;
/// Magic (8) + version (2) + reserved (2) + payload length (8).
const HEADER_BYTES: usize = 20;
/// BLAKE3 of everything before it.
const TRAILER_BYTES: usize = 32;

type PartConfig = bincode::config::Configuration<
    bincode::config::LittleEndian,
    bincode::config::Varint,
    bincode::config::Limit<{ 1 << 34 }>,
>;

fn part_config() -> PartConfig {
    bincode::config::standard().with_limit::<{ 1 << 34 }>()
}

/// The VPLs (indices into the asset's VPL array) whose maps shard `index` of
/// `count` renders: `count` contiguous ranges as equal as possible, in
/// order, together covering `0..vpl_count` exactly once. A shard may own no
/// VPL when there are fewer VPLs than shards.
pub fn shard_range(vpl_count: usize, index: u32, count: u32) -> Range<usize> {
    let (k, n) = (index as usize, count.max(1) as usize);
    let start = vpl_count * k / n;
    let end = vpl_count * (k + 1) / n;
    start.min(vpl_count)..end.min(vpl_count)
}

/// Gives each VPL with a map (`Some`, `tile²` values) the next atlas tile,
/// in VPL order, and every other VPL [`NO_MAP`]; returns the stored maps as
/// the atlas. This is how both the single bake and [`merge`] number the
/// tiles, so they agree. `None` when a map does not hold `tile²` values.
pub fn assign_map_tiles(
    vpls: &mut [VplRecord],
    tile: u32,
    maps: impl IntoIterator<Item = Option<Vec<f32>>>,
) -> Option<MapAtlas> {
    let mut stored = Vec::new();
    for (v, m) in vpls.iter_mut().zip(maps) {
        match m {
            Some(m) => {
                v.map = stored.len() as u32;
                stored.push(m);
            }
            None => v.map = NO_MAP,
        }
    }
    MapAtlas::from_maps(tile, stored.iter().map(|m| m.as_slice()))
}

/// Gives each VPL with a second origin and a second map (`Some`, `tile²`
/// values) the next tile of the second maps' atlas, in VPL order, and every
/// other VPL with a second origin [`NO_MAP`] (its map sees no surface);
/// VPLs without one ([`NO_LOWER`]) keep it. Returns the stored maps as the
/// atlas, as [`assign_map_tiles`] does for the first maps. `None` when a
/// map does not hold `tile²` values or belongs to a VPL without a second
/// origin.
pub fn assign_lower_tiles(
    lower: &mut [LowerVpl],
    tile: u32,
    maps: impl IntoIterator<Item = Option<Vec<f32>>>,
) -> Option<MapAtlas> {
    let mut stored = Vec::new();
    for (v, m) in lower.iter_mut().zip(maps) {
        match (v.is_some(), m) {
            (true, Some(m)) => {
                v.map = stored.len() as u32;
                stored.push(m);
            }
            (true, None) => v.map = NO_MAP,
            (false, None) => {}
            (false, Some(_)) => return None,
        }
    }
    MapAtlas::from_maps(tile, stored.iter().map(|m| m.as_slice()))
}

/// A shard's hemisphere maps, one per VPL of its range (`None`: not stored).
pub type ShardMaps = Vec<Option<Vec<f32>>>;

/// One shard's result: the shared front part (everything of the asset but
/// the hemisphere maps) and the maps of the VPLs it owns.
#[derive(Clone, Debug, PartialEq)]
pub struct ShardPart {
    /// This shard's index, `0..shards`.
    pub shard: u32,
    /// Number of shards of the bake.
    pub shards: u32,
    /// The asset without hemisphere maps: `vpl_maps` empty and every VPL's
    /// `map` = [`NO_MAP`]. Its manifest is the single bake's (counts and file
    /// list are filled in when the merged asset is written).
    pub front: Asset,
    /// The maps of the VPLs in `shard_range(vpls, shard, shards)`, in order;
    /// `None` for a VPL whose map sees no surface (not stored).
    pub maps: ShardMaps,
    /// The second maps of the same VPLs ([`LowerVpl`]), in order; `None`
    /// for a VPL without a second origin or whose second map sees no
    /// surface. The front's [`Asset::vpl_lower`] holds their origins, each
    /// with `map` [`NO_MAP`] or [`NO_LOWER`] until the merge numbers the
    /// tiles.
    pub lower_maps: ShardMaps,
}

/// The serialized form (private: the layout is the doc's, not serde's choice).
#[derive(Serialize, Deserialize)]
struct PartPayload {
    shard: u32,
    shards: u32,
    manifest: Manifest,
    vpls: Vec<VplRecord>,
    vpl_nodes: Vec<VplRecord>,
    /// The level-3 coherences (part version 5).
    vpl_coherence: Vec<f32>,
    primary_size: u32,
    primary: Vec<f32>,
    rsm: Option<RsmPayload>,
    maps: Vec<Option<Vec<f32>>>,
    /// The other lights' shadow maps: tile size, count, atlas texels.
    light_maps: (u32, u32, Vec<f32>),
    /// The manifest's `view_rsms` (skipped by its serde encoding) and the
    /// view RSMs, one per entry (part version 4).
    view_rsms: (Vec<u32>, Vec<RsmPayload>),
    /// The manifest's `ring_vpls` and `scene_options` (skipped by its serde
    /// encoding; part version 6: version 5 lost the ring VPLs).
    ring_vpls: Vec<u32>,
    scene_options: Option<crate::SceneOptions>,
    /// The manifest's `swept_bounds` (part version 7).
    swept_bounds: Option<[f32; 6]>,
    /// The manifest's `later` (part version 8).
    later: Option<crate::LaterRecord>,
    /// Per VPL its second origin and `map` ([`NO_MAP`] or [`NO_LOWER`]),
    /// and the shard's second maps (part version 9).
    vpl_lower: Vec<([f32; 3], u32)>,
    lower_maps: Vec<Option<Vec<f32>>>,
    /// The manifest's `later_sources` (part version 10).
    later_sources: Option<crate::LaterSources>,
}

#[derive(Serialize, Deserialize)]
struct RsmPayload {
    size: u32,
    metric: Vec<f32>,
    share: Vec<u32>,
    vpl: Vec<u32>,
}

/// Why a set of parts cannot be merged. Every variant names the part (or
/// the parts) concerned.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// A part cannot be read, is not a part, or is damaged.
    #[error(transparent)]
    Asset(#[from] AssetError),
    /// No parts were given.
    #[error("no shard parts given")]
    NoParts,
    /// A part does not belong with the first one (scene, settings, shard
    /// count, provenance, or front data differ).
    #[error("{}: {message} (compared with {})", part.display(), first.display())]
    Mismatch {
        /// The part that differs.
        part: PathBuf,
        /// The part it was compared with.
        first: PathBuf,
        /// What differs.
        message: String,
    },
    /// Two parts are the same shard.
    #[error("{} and {} are both shard {shard}/{shards}", a.display(), b.display())]
    Repeated {
        /// One part.
        a: PathBuf,
        /// The other.
        b: PathBuf,
        /// The shard index.
        shard: u32,
        /// The shard count.
        shards: u32,
    },
    /// Some shards are missing.
    #[error("shard(s) {missing:?} of {shards} missing: the parts given ({}) cover only {present:?}", parts.join(", "))]
    Missing {
        /// Missing shard indices.
        missing: Vec<u32>,
        /// Present shard indices.
        present: Vec<u32>,
        /// The shard count.
        shards: u32,
        /// The part files given.
        parts: Vec<String>,
    },
}

fn check_part(part: &ShardPart, path: &Path) -> Result<(), AssetError> {
    let bad = |m: String| Err(AssetError::invalid(path, m));
    if part.shards == 0 || part.shards > MAX_SHARDS || part.shard >= part.shards {
        return bad(format!(
            "shard {}/{} is not a valid shard (index 0..N, N in 1..={MAX_SHARDS})",
            part.shard, part.shards
        ));
    }
    let a = &part.front;
    let s = &a.manifest.settings;
    // Every setting the merge's write will check, checked here, so a shard
    // with a setting the merge refuses fails itself, before it is stored.
    crate::format::validate_settings(&a.manifest, path)?;
    if !a.vpl_maps.is_empty() || a.vpls.iter().any(|v| v.map != NO_MAP) {
        return bad("the front part holds hemisphere maps; a part keeps them apart".into());
    }
    if !a.vpl_lower_maps.is_empty()
        || a.vpl_lower
            .iter()
            .any(|v| v.map != NO_MAP && v.map != NO_LOWER)
    {
        return bad("the front part holds second hemisphere maps; a part keeps them apart".into());
    }
    if !a.vpl_lower.is_empty() && a.vpl_lower.len() != a.vpls.len() {
        return bad(format!(
            "{} second-origin records for {} VPLs",
            a.vpl_lower.len(),
            a.vpls.len()
        ));
    }
    for (i, v) in a.vpl_lower.iter().enumerate() {
        let zero = v.map != NO_LOWER || v.origin == [0.0; 3];
        if !(v.origin.iter().all(|x| x.is_finite()) && zero) {
            return bad(format!(
                "VPL {i}'s second origin {:?} is not finite (or not zeros without one)",
                v.origin
            ));
        }
    }
    if a.vpls.len() != a.manifest.vpl_count as usize {
        return bad(format!(
            "{} VPL records but vpl_count {}",
            a.vpls.len(),
            a.manifest.vpl_count
        ));
    }
    for (i, v) in a.vpls.iter().enumerate() {
        let finite = v
            .position
            .iter()
            .chain(&v.normal)
            .chain(&v.flux)
            .chain([&v.area])
            .all(|x| x.is_finite());
        if !finite {
            return bad(format!("VPL {i} holds a value that is not finite"));
        }
    }
    let sm = s.shadow_map_size as usize;
    if a.primary_depth.size != s.shadow_map_size || a.primary_depth.data.len() != sm * sm {
        return bad(format!(
            "primary shadow map is {}² with {} values but shadow_map_size is {sm}",
            a.primary_depth.size,
            a.primary_depth.data.len()
        ));
    }
    if a.rsm.is_some() != a.manifest.has_dynamic {
        return bad("RSM data present/absent against has_dynamic".into());
    }
    if let Some(r) = &a.rsm {
        let n = s.rsm_size as usize * s.rsm_size as usize;
        if r.size != s.rsm_size || r.metric.len() != n || r.share.len() != n || r.vpl.len() != n {
            return bad(format!("RSM data is not rsm_size² = {n} texels"));
        }
    }
    // The view RSMs: one per view_rsms entry, rsm_size² each, each naming
    // only its light's VPLs (what the merge's write checks).
    if let Err(e) = crate::format::check_view_rsms(&a.manifest, &a.view_rsms) {
        return bad(format!("view RSMs: {e}"));
    }
    let range = shard_range(a.vpls.len(), part.shard, part.shards);
    if part.maps.len() != range.len() {
        return bad(format!(
            "holds {} hemisphere map slots but shard {}/{} of {} VPLs owns {}",
            part.maps.len(),
            part.shard,
            part.shards,
            a.vpls.len(),
            range.len()
        ));
    }
    if part.lower_maps.len() != range.len() {
        return bad(format!(
            "holds {} second hemisphere map slots but shard {}/{} of {} VPLs owns {}",
            part.lower_maps.len(),
            part.shard,
            part.shards,
            a.vpls.len(),
            range.len()
        ));
    }
    let texels = s.vpl_map_size as usize * s.vpl_map_size as usize;
    for (i, m) in part.lower_maps.iter().enumerate() {
        let Some(m) = m else { continue };
        let vpl = range.start + i;
        if !a.vpl_lower.get(vpl).is_some_and(LowerVpl::is_some) {
            return bad(format!(
                "holds a second hemisphere map for VPL {vpl}, which has no second origin"
            ));
        }
        if m.len() != texels || m.iter().any(|x| x.is_nan()) {
            return bad(format!(
                "second hemisphere map of VPL {vpl} has {} texels (vpl_map_size² = {texels}) or holds NaN",
                m.len()
            ));
        }
    }
    for (i, m) in part.maps.iter().enumerate() {
        if let Some(m) = m {
            if m.len() != texels {
                return bad(format!(
                    "hemisphere map of VPL {} has {} texels, not vpl_map_size² = {texels}",
                    range.start + i,
                    m.len()
                ));
            }
            if m.iter().any(|x| x.is_nan()) {
                return bad(format!(
                    "hemisphere map of VPL {} holds NaN",
                    range.start + i
                ));
            }
        }
    }
    Ok(())
}

fn rsm_payload(r: &RsmData) -> RsmPayload {
    RsmPayload {
        size: r.size,
        metric: r.metric.clone(),
        share: r.share.clone(),
        vpl: r.vpl.clone(),
    }
}

fn rsm_data(r: RsmPayload) -> RsmData {
    RsmData {
        size: r.size,
        metric: r.metric,
        share: r.share,
        vpl: r.vpl,
    }
}

fn encode_part(part: &ShardPart, path: &Path) -> Result<Vec<u8>, AssetError> {
    let a = &part.front;
    let payload = PartPayload {
        shard: part.shard,
        shards: part.shards,
        manifest: a.manifest.clone(),
        vpls: a.vpls.clone(),
        vpl_nodes: a.vpl_nodes.clone(),
        vpl_coherence: a.vpl_coherence.clone(),
        primary_size: a.primary_depth.size,
        primary: a.primary_depth.data.clone(),
        rsm: a.rsm.as_ref().map(rsm_payload),
        maps: part.maps.clone(),
        light_maps: (
            a.light_maps.tile_size(),
            a.light_maps.count(),
            a.light_maps.texels().to_vec(),
        ),
        view_rsms: (
            a.manifest.view_rsms.clone(),
            a.view_rsms.iter().map(rsm_payload).collect(),
        ),
        ring_vpls: a.manifest.ring_vpls.clone(),
        scene_options: a.manifest.scene_options.clone(),
        swept_bounds: a.manifest.swept_bounds,
        later: a.manifest.later.clone(),
        vpl_lower: a.vpl_lower.iter().map(|v| (v.origin, v.map)).collect(),
        lower_maps: part.lower_maps.clone(),
        later_sources: a.manifest.later_sources.clone(),
    };
    let body = bincode::serde::encode_to_vec(&payload, part_config())
        .map_err(|e| AssetError::invalid(path, format!("cannot encode the part: {e}")))?;
    let mut out = Vec::with_capacity(HEADER_BYTES + body.len() + TRAILER_BYTES);
    out.extend_from_slice(&PART_MAGIC);
    out.extend_from_slice(&PART_VERSION.to_le_bytes());
    out.extend_from_slice(&0u16.to_le_bytes());
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&body);
    let hash = blake3::hash(&out);
    out.extend_from_slice(hash.as_bytes());
    Ok(out)
}

fn decode_part(bytes: &[u8], path: &Path) -> Result<ShardPart, AssetError> {
    let bad = |m: String| AssetError::invalid(path, m);
    if bytes.len() < HEADER_BYTES + TRAILER_BYTES || bytes[..8] != PART_MAGIC {
        return Err(bad(
            "not a gibake shard part (wrong magic bytes or too short); parts are written by `gibake bake SCENE -o PART --shard K/N`".into(),
        ));
    }
    let version = u16::from_le_bytes([bytes[8], bytes[9]]);
    if version != PART_VERSION {
        return Err(AssetError::NotSupported {
            path: path.to_owned(),
            message: format!(
                "shard part version {version} is not supported (this gibake writes and reads {PART_VERSION}); re-bake the shard with this gibake"
            ),
        });
    }
    let mut len8 = [0u8; 8];
    len8.copy_from_slice(&bytes[12..20]);
    let len = u64::from_le_bytes(len8);
    let rest = (bytes.len() - HEADER_BYTES) as u64;
    if len + TRAILER_BYTES as u64 != rest {
        return Err(bad(format!(
            "payload length field says {len} bytes but {rest} follow the header: truncated or damaged"
        )));
    }
    let end = HEADER_BYTES + len as usize;
    if blake3::hash(&bytes[..end]).as_bytes() != &bytes[end..] {
        return Err(bad("checksum mismatch: the part is damaged".into()));
    }
    let (p, used): (PartPayload, usize) =
        bincode::serde::decode_from_slice(&bytes[HEADER_BYTES..end], part_config())
            .map_err(|e| bad(format!("damaged part payload: {e}")))?;
    if used != end - HEADER_BYTES {
        return Err(bad("unexpected bytes after the part payload".into()));
    }
    let tile = p.manifest.settings.vpl_map_size;
    let mut manifest = p.manifest;
    let (view_rsm_list, view_rsms) = p.view_rsms;
    manifest.view_rsms = view_rsm_list;
    manifest.ring_vpls = p.ring_vpls;
    manifest.scene_options = p.scene_options;
    manifest.swept_bounds = p.swept_bounds;
    manifest.later = p.later;
    manifest.later_sources = p.later_sources;
    let (lt, ln, lmaps) = p.light_maps;
    let light_maps = if ln == 0 {
        MapAtlas::empty(lt)
    } else {
        MapAtlas::from_texels(lt, ln, lmaps)
            .ok_or_else(|| bad("the light maps have the wrong number of texels".into()))?
    };
    let part = ShardPart {
        shard: p.shard,
        shards: p.shards,
        front: Asset {
            manifest,
            vpls: p.vpls,
            vpl_nodes: p.vpl_nodes,
            vpl_coherence: p.vpl_coherence,
            vpl_lower: p
                .vpl_lower
                .into_iter()
                .map(|(origin, map)| LowerVpl { origin, map })
                .collect(),
            vpl_lower_maps: MapAtlas::empty(tile),
            primary_depth: Map {
                size: p.primary_size,
                data: p.primary,
            },
            vpl_maps: MapAtlas::empty(tile),
            rsm: p.rsm.map(rsm_data),
            light_maps,
            view_rsms: view_rsms.into_iter().map(rsm_data).collect(),
        },
        maps: p.maps,
        lower_maps: p.lower_maps,
    };
    check_part(&part, path)?;
    Ok(part)
}

/// Writes `part` to the file `path` through a temporary sibling and a
/// rename (`gibake_output::FileWriter`), so a failure never leaves a
/// half-written part. An existing `path`
/// is replaced only when it is a part file (starts with [`PART_MAGIC`]);
/// anything else there is refused and left untouched.
pub fn write_part(part: &ShardPart, path: &Path) -> Result<(), AssetError> {
    check_part(part, path).map_err(|e| match e {
        AssetError::Invalid { message, .. } => {
            AssetError::invalid(path, format!("cannot write: {message}"))
        }
        e => e,
    })?;
    match fs::symlink_metadata(path) {
        Ok(meta) => {
            let is_part = meta.is_file()
                && fs::File::open(path)
                    .and_then(|mut f| {
                        let mut m = [0u8; 8];
                        std::io::Read::read_exact(&mut f, &mut m).map(|()| m)
                    })
                    .is_ok_and(|m| m == PART_MAGIC);
            if !is_part {
                return Err(AssetError::invalid(
                    path,
                    "exists and is not a gibake shard part; refusing to replace it",
                ));
            }
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(AssetError::io(path, e)),
    }
    let bytes = encode_part(part, path)?;
    // A temporary created exclusively (never a stale file or link of that
    // name), under the part's lock, renamed into place.
    let mut out = gibake_output::FileWriter::create(path, &mut |_| {})?;
    out.file()
        .write_all(&bytes)
        .map_err(|e| AssetError::io(path, e))?;
    out.commit()?;
    Ok(())
}

/// Reads and verifies a part file (magic, version, length, checksum, and
/// the consistency of its contents). Every error names `path`.
pub fn load_part(path: &Path) -> Result<ShardPart, AssetError> {
    let meta = fs::metadata(path).map_err(|e| AssetError::io(path, e))?;
    if !meta.is_file() {
        return Err(AssetError::invalid(
            path,
            "is not a file; a shard part is the file written by `gibake bake SCENE -o PART --shard K/N`",
        ));
    }
    if meta.len() > MAX_PART_BYTES {
        return Err(AssetError::invalid(
            path,
            format!("is {} bytes, more than a part can be", meta.len()),
        ));
    }
    let bytes = fs::read(path).map_err(|e| AssetError::io(path, e))?;
    decode_part(&bytes, path)
}

/// BLAKE3 of the front data (VPL records and near-field nodes, primary
/// shadow map, the other lights' maps, RSM, view RSMs): equal on
/// every shard of one bake.
fn front_hash(a: &Asset) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(bytemuck::cast_slice(&a.vpls));
    h.update(bytemuck::cast_slice(&a.vpl_nodes));
    h.update(bytemuck::cast_slice(&a.vpl_coherence));
    h.update(b"vpl_lower");
    h.update(&(a.vpl_lower.len() as u64).to_le_bytes());
    for v in &a.vpl_lower {
        h.update(bytemuck::cast_slice(&v.origin));
        h.update(&v.map.to_le_bytes());
    }
    h.update(&a.primary_depth.size.to_le_bytes());
    h.update(bytemuck::cast_slice(&a.primary_depth.data));
    h.update(&a.light_maps.tile_size().to_le_bytes());
    h.update(&a.light_maps.count().to_le_bytes());
    h.update(bytemuck::cast_slice(a.light_maps.texels()));
    if let Some(r) = &a.rsm {
        h.update(b"rsm");
        h.update(&r.size.to_le_bytes());
        h.update(bytemuck::cast_slice(&r.metric));
        h.update(bytemuck::cast_slice(&r.share));
        h.update(bytemuck::cast_slice(&r.vpl));
    }
    h.update(b"view_rsms");
    h.update(&(a.manifest.view_rsms.len() as u64).to_le_bytes());
    h.update(bytemuck::cast_slice(&a.manifest.view_rsms));
    h.update(&(a.view_rsms.len() as u64).to_le_bytes());
    for r in &a.view_rsms {
        h.update(&r.size.to_le_bytes());
        h.update(&(r.metric.len() as u64).to_le_bytes());
        h.update(bytemuck::cast_slice(&r.metric));
        h.update(bytemuck::cast_slice(&r.share));
        h.update(bytemuck::cast_slice(&r.vpl));
    }
    *h.finalize().as_bytes()
}

/// What differs between two parts' manifests (first difference found).
fn manifest_difference(a: &Manifest, b: &Manifest) -> Option<String> {
    if a.static_scene_hash != b.static_scene_hash {
        return Some("baked from a different static scene (static-scene hash differs)".into());
    }
    if a.settings != b.settings {
        let show = |s: &crate::BakeSettings| {
            format!(
                "RSM {}, VPL maps {}, shadow map {}, threshold {}, {}",
                s.rsm_size,
                s.vpl_map_size,
                s.shadow_map_size,
                s.threshold,
                s.vpl_budget
                    .map_or_else(|| "--threshold".to_string(), |n| format!("--vpls {n}"))
            )
        };
        return Some(format!(
            "baked with different settings ({} against {})",
            show(&b.settings),
            show(&a.settings)
        ));
    }
    if a.provenance.baker_version != b.provenance.baker_version {
        return Some(format!(
            "baked by gibake {} against {}",
            b.provenance.baker_version, a.provenance.baker_version
        ));
    }
    let adapter = |m: &Manifest| {
        format!(
            "{} ({}, {})",
            m.provenance.adapter, m.provenance.backend, m.provenance.driver
        )
    };
    if adapter(a) != adapter(b) {
        return Some(format!(
            "baked on another adapter ({} against {})",
            adapter(b),
            adapter(a)
        ));
    }
    if a.scene_options != b.scene_options {
        let flags = |m: &Manifest| {
            m.scene_options
                .as_ref()
                .map_or_else(|| "none recorded".to_string(), |o| o.flags_or_none())
        };
        return Some(format!(
            "baked with other scene flags ({} against {})",
            flags(b),
            flags(a)
        ));
    }
    if a != b {
        return Some("the manifests differ (scene name, light view, counts or ring VPLs)".into());
    }
    None
}

/// Merges a complete set of parts (any order) into the asset the
/// single-machine bake gives. Checks that every part comes from the same
/// scene, settings, baker version, adapter and shard count, that the front
/// data agrees, and that every shard `0..N` is present exactly once. See
/// [`Merger`] to merge while loading (one part's front data in memory at a
/// time).
pub fn merge(parts: Vec<(PathBuf, ShardPart)>) -> Result<Asset, MergeError> {
    let mut m = Merger::default();
    for (path, part) in parts {
        m.add(path, part)?;
    }
    m.finish()
}

/// An incremental [`merge`]: [`Merger::add`] each part as it is loaded
/// (it keeps the first part's front data and every part's maps, and drops the
/// rest), then [`Merger::finish`].
#[derive(Default)]
pub struct Merger {
    /// The first part: its path, front data and that data's hash.
    first: Option<(PathBuf, Asset, [u8; 32])>,
    shards: u32,
    /// Per shard: the part's path, its maps and its second maps.
    slots: Vec<Option<(PathBuf, ShardMaps, ShardMaps)>>,
    /// Every part added, for messages.
    paths: Vec<PathBuf>,
}

impl Merger {
    /// Adds one part, checking it against the first one added and the
    /// shards seen so far (a repeated shard is an error at once).
    pub fn add(&mut self, path: PathBuf, part: ShardPart) -> Result<(), MergeError> {
        check_part(&part, &path)?;
        let ShardPart {
            shard,
            shards,
            front,
            maps,
            lower_maps,
        } = part;
        let hash = front_hash(&front);
        let Some((first_path, first, first_hash)) = &self.first else {
            self.shards = shards;
            self.slots = vec![None; shards as usize];
            self.slots[shard as usize] = Some((path.clone(), maps, lower_maps));
            self.paths.push(path.clone());
            self.first = Some((path, front, hash));
            return Ok(());
        };
        let mismatch = |message: String| MergeError::Mismatch {
            part: path.clone(),
            first: first_path.clone(),
            message,
        };
        if shards != self.shards {
            return Err(mismatch(format!(
                "is shard {shard}/{shards}, from a bake split into {shards} shards, not {}",
                self.shards
            )));
        }
        if let Some(d) = manifest_difference(&first.manifest, &front.manifest) {
            return Err(mismatch(d));
        }
        if hash != *first_hash {
            return Err(mismatch(
                "its shared front data (VPLs, primary shadow map, RSM, view RSMs) differs: the shards did not compute the same bake".into(),
            ));
        }
        let slot = &mut self.slots[shard as usize];
        if let Some((other, _, _)) = slot {
            return Err(MergeError::Repeated {
                a: other.clone(),
                b: path,
                shard,
                shards,
            });
        }
        *slot = Some((path.clone(), maps, lower_maps));
        self.paths.push(path);
        Ok(())
    }

    /// The merged asset, or which shards are missing.
    pub fn finish(self) -> Result<Asset, MergeError> {
        let Some((first, mut asset, _)) = self.first else {
            return Err(MergeError::NoParts);
        };
        let missing: Vec<u32> = (0..self.shards)
            .filter(|&k| self.slots[k as usize].is_none())
            .collect();
        if !missing.is_empty() {
            return Err(MergeError::Missing {
                missing,
                present: (0..self.shards)
                    .filter(|&k| self.slots[k as usize].is_some())
                    .collect(),
                shards: self.shards,
                parts: self.paths.iter().map(|p| p.display().to_string()).collect(),
            });
        }
        // Shard order is VPL order: the ranges are contiguous and ordered.
        let (maps, lower): (Vec<ShardMaps>, Vec<ShardMaps>) = self
            .slots
            .into_iter()
            .flatten()
            .map(|(_, m, l)| (m, l))
            .unzip();
        let tile = asset.manifest.settings.vpl_map_size;
        asset.vpl_maps = assign_map_tiles(&mut asset.vpls, tile, maps.into_iter().flatten())
            .ok_or_else(|| {
                AssetError::invalid(
                    &first,
                    "a hemisphere map does not have vpl_map_size² texels",
                )
            })?;
        asset.vpl_lower_maps =
            assign_lower_tiles(&mut asset.vpl_lower, tile, lower.into_iter().flatten())
                .ok_or_else(|| {
                    AssetError::invalid(
                        &first,
                        "a second hemisphere map does not have vpl_map_size² texels or has no second origin",
                    )
                })?;
        Ok(asset)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_cover_every_vpl_once_in_order() {
        for v in [0usize, 1, 5, 64, 100, 257] {
            for n in [1u32, 2, 3, 4, 7, 300] {
                let mut next = 0;
                for k in 0..n {
                    let r = shard_range(v, k, n);
                    assert_eq!(r.start, next, "v={v} n={n} k={k}");
                    assert!(r.end >= r.start);
                    next = r.end;
                }
                assert_eq!(next, v);
            }
        }
    }

    fn tiny_part(shard: u32, shards: u32) -> ShardPart {
        let manifest = crate::Manifest {
            provenance: crate::Provenance {
                baker_version: "t".into(),
                scene_name: "s.glb".into(),
                adapter: "a".into(),
                backend: "b".into(),
                driver: "d".into(),
            },
            settings: crate::BakeSettings {
                rsm_size: 2,
                vpl_map_size: 2,
                shadow_map_size: 2,
                threshold: 0.5,
                vpl_budget: Some(3),
            },
            static_scene_hash: [7; 32],
            light_view: crate::LightViewRecord {
                directional: false,
                view_proj: [0.0; 16],
                origin: [0.0; 3],
                direction: [0.0, -1.0, 0.0],
                texel_scale: 1.0,
                texel_area: 1.0,
            },
            vpl_count: 3,
            map_count: 0,
            has_dynamic: false,
            files: Vec::new(),
            lights: Vec::new(),
            views: Vec::new(),
            light_map_size: 0,
            view_rsms: Vec::new(),
            ring_vpls: Vec::new(),
            scene_options: None,
            swept_bounds: None,
            later: None,
            lower_map_count: 0,
            later_sources: None,
        };
        let rec = VplRecord {
            position: [0.0; 3],
            area: 1.0,
            normal: [0.0, 0.0, 1.0],
            texels: 1,
            flux: [1.0; 3],
            map: NO_MAP,
        };
        let range = shard_range(3, shard, shards);
        ShardPart {
            shard,
            shards,
            front: Asset {
                manifest,
                vpls: vec![rec; 3],
                vpl_nodes: vec![
                    VplRecord {
                        texels: 0,
                        area: 0.0,
                        flux: [0.0; 3],
                        ..rec
                    };
                    3 * crate::NODES_PER_VPL
                ],
                vpl_coherence: vec![1.0; 3 * crate::LEVEL3_NODES],
                vpl_lower: Vec::new(),
                vpl_lower_maps: MapAtlas::empty(2),
                primary_depth: Map {
                    size: 2,
                    data: vec![1.0; 4],
                },
                vpl_maps: MapAtlas::empty(2),
                rsm: None,
                light_maps: MapAtlas::empty(0),
                view_rsms: Vec::new(),
            },
            lower_maps: vec![None; range.len()],
            maps: range.map(|i| (i != 1).then(|| vec![i as f32; 4])).collect(),
        }
    }

    #[test]
    fn parts_round_trip_and_merge_in_any_order() {
        let dir = tempfile::tempdir().unwrap();
        let mut loaded = Vec::new();
        for k in [2, 0, 1] {
            let path = dir.path().join(format!("p{k}"));
            let part = tiny_part(k, 3);
            write_part(&part, &path).unwrap();
            let back = load_part(&path).unwrap();
            assert_eq!(back, part);
            loaded.push((path, back));
        }
        let asset = merge(loaded).unwrap();
        assert_eq!(
            asset.vpls.iter().map(|v| v.map).collect::<Vec<_>>(),
            [0, NO_MAP, 1]
        );
        let maps: Vec<_> = asset.vpl_maps.maps().collect();
        assert_eq!(maps, [[0.0; 4], [2.0; 4]]);
    }

    #[test]
    fn invalid_parts_are_errors_not_panics() {
        let mut bad = tiny_part(0, 2);
        bad.shard = 5;
        let mut m = Merger::default();
        assert!(m.add("x".into(), bad).is_err());
        let mut short = tiny_part(1, 2);
        short.maps.pop();
        assert!(Merger::default().add("y".into(), short).is_err());
        assert!(matches!(
            Merger::default().finish(),
            Err(MergeError::NoParts)
        ));
        let mut m = Merger::default();
        m.add("a".into(), tiny_part(0, 2)).unwrap();
        let e = m.finish().unwrap_err().to_string();
        assert!(e.contains("[1]"), "{e}");
    }

    #[test]
    fn tiles_numbered_in_vpl_order() {
        let rec = VplRecord {
            position: [0.0; 3],
            area: 1.0,
            normal: [0.0, 0.0, 1.0],
            texels: 1,
            flux: [1.0; 3],
            map: 7,
        };
        let mut v = vec![rec; 3];
        let out = assign_map_tiles(&mut v, 1, [Some(vec![1.0]), None, Some(vec![2.0])]).unwrap();
        assert_eq!(out.maps().collect::<Vec<_>>(), [[1.0], [2.0]]);
        assert_eq!(v.iter().map(|r| r.map).collect::<Vec<_>>(), [0, NO_MAP, 1]);
    }
}
