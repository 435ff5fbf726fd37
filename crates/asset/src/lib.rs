//! The `.gibake` baked asset: a directory holding a manifest, the VPL records
//! and EXR maps of one bake. The byte-level specification is
//! `docs/asset-format.md`; this crate is its reference implementation.
//!
//! The types below are the in-memory model shared by the baker
//! (`gibake-bake`) and the runtime (`gibake-runtime`). The functions:
//!
//! - [`write()`]: atomic write (temporary sibling directory, manifest last,
//!   one-step swap under the output's lock: `gibake-output`); [`check_output`];
//! - [`load`] / [`load_manifest`]: read and verify everything (magic, version,
//!   checksums, counts, sizes, values) without panicking on any input;
//! - [`check_scene_hash`]: refuse an asset baked from a different static scene;
//! - [`SceneOptions`]: the scene options a bake applied (`--sun`,
//!   `--dynamic`, `--light`, ...), recorded so that users load the level the
//!   same way ([`SceneOptions::resolve`]);
//! - [`inspect`]: a summary ([`Inspection`], `Display` + `Serialize`);
//! - [`diff`] / [`write_diff_images`]: compare two assets under a [`Tolerance`];
//! - [`verify_files`]: manifest and file checksums only (up-to-date checks);
//! - [`write_part`] / [`load_part`] / [`merge`]: shard parts of a distributed
//!   bake and their merge into the single bake's asset.

use serde::{Deserialize, Serialize};

mod atlas;
mod diff;
mod error;
mod exrio;
mod format;
mod inspect;
mod scene_options;
mod shard;
mod tolerance;
mod what;

pub use atlas::{MapAtlas, atlas_grid};
pub use diff::{
    DiffReport, FieldDiff, MapDiff, Tolerance, TreeDiff, VplDiff, VplMismatch, diff,
    write_diff_images,
};
pub use error::AssetError;
#[doc(hidden)]
pub use format::testing;
pub use format::{
    DEFAULT_MAX_DECODED_BYTES, FILE_LIGHT_MAPS, FILE_MANIFEST, FILE_PRIMARY_DEPTH, FILE_RSM,
    FILE_VIEW_RSMS, FILE_VPL_COHERENCE, FILE_VPL_LOWER, FILE_VPL_LOWER_MAPS, FILE_VPL_MAPS,
    FILE_VPL_NODES, FILE_VPLS, LOWER_RECORD_BYTES, MAX_MAP_SIZE, VPL_RECORD_BYTES, check_output,
    check_scene_hash, check_scene_hash_for, decoded_bytes, load, load_manifest, load_with_limit,
    owned_names, verify_files, write,
};
pub use inspect::{FileSize, Inspection, MapStats, Stats, inspect};
pub use scene_options::{
    DEFAULT_MAX_TEXTURE_SIZE, OptionsConflict, Resolution, SceneOption, SceneOptions, SunOption,
    all_flags, shell_word,
};
pub use shard::{
    MAX_SHARDS, MergeError, Merger, PART_MAGIC, PART_VERSION, ShardMaps, ShardPart,
    assign_lower_tiles, assign_map_tiles, load_part, merge, shard_range, write_part,
};
pub use tolerance::{MAX_TOLERANCE, ToleranceError, parse_tolerance};

/// Magic bytes at the start of `manifest.bin`.
pub const MAGIC: [u8; 8] = *b"GIBAKE\0\x01";
/// Format major version: readers reject any other major (4: every light,
/// [`Manifest::lights`] and [`Manifest::views`]; 3.x assets are re-baked).
pub const FORMAT_MAJOR: u16 = 4;
/// Format minor version: additive changes only (4.1: [`Manifest::view_rsms`]
/// appended to the manifest payload and `view_rsms.exr`; a 4.0 asset reads
/// with no view RSMs. 4.2: `vpl_coherence.bin`, [`Asset::vpl_coherence`];
/// an older asset reads with none, every level-3 node one cosine lobe.
/// 4.3: [`Manifest::ring_vpls`] appended after `view_rsms`; an older asset
/// reads with no ring VPLs. 4.4: [`Manifest::scene_options`] appended after
/// `ring_vpls`; an older asset reads with none recorded. 4.5:
/// [`Manifest::swept_bounds`] appended after `scene_options`; an older
/// asset reads with `None`. 4.6: [`Manifest::later`] appended after
/// `swept_bounds`; an older asset reads with `None`, the first bounce
/// alone. 4.7: [`Manifest::lower_map_count`] appended after `later`,
/// `vpl_lower.bin` and `vpl_lower_maps.exr`, [`Asset::vpl_lower`]: each
/// VPL's second visibility test for the light below its horizon; an older
/// asset reads with none).
pub const FORMAT_MINOR: u16 = 8;

/// One static VPL record. Stored as a little-endian array in `vpls.bin`
/// (48 bytes each, fields in this order).
#[repr(C)]
#[derive(
    Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable, Serialize, Deserialize,
)]
pub struct VplRecord {
    /// World position.
    pub position: [f32; 3],
    /// Surface area its texels cover (world units²).
    pub area: f32,
    /// Unit normal.
    pub normal: [f32; 3],
    /// Number of RSM texels.
    pub texels: u32,
    /// Flux (W, linear RGB); it emits flux/π · cos θ per steradian.
    pub flux: [f32; 3],
    /// Tile of its hemisphere map in `vpl_maps.exr`, or [`NO_MAP`] when
    /// its map sees no surface (every direction is unoccluded).
    pub map: u32,
}

/// [`VplRecord::map`] of a VPL whose map is not stored.
pub const NO_MAP: u32 = u32::MAX;

impl VplRecord {
    /// The area whose disk radius sets how far the VPL's map origin is
    /// lifted off its surface (`gibake_gpu::hemisphere::vpl_origin`): its
    /// own area, or one of its texels' (`area / texels`) for a VPL on a
    /// light's outer rings ([`Manifest::ring_vpls`]): a ring VPL is a wide
    /// patch of flat ground, and lifted by its own radius (tens of metres
    /// on a town's outer ground) its origin would see over the houses its
    /// texels cannot (docs/method.md, "Outer rings").
    pub fn map_origin_area(&self, ring: bool) -> f32 {
        if ring {
            self.area / self.texels.max(1) as f32
        } else {
            self.area
        }
    }
}

/// A static VPL's second visibility test, for the light it sends below
/// its own horizon (format 4.7, `vpl_lower.bin`: 16 bytes per VPL, the
/// origin's three little-endian `f32`, then `map` as a `u32`). A cluster
/// whose texels face several ways (a roof round a hole, a wall's face
/// with a window's sill and jambs) lights receivers below its mean
/// normal's horizon from the texels tilted away from it, which see what
/// the VPL's lifted map origin does not; such a VPL has a second origin on
/// those texels and a hemisphere map around the opposite of its normal
/// from there (docs/method.md, "Below the horizon").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LowerVpl {
    /// Where the second map is centred (world units); all zeros for
    /// [`NO_LOWER`].
    pub origin: [f32; 3],
    /// Tile of its map in `vpl_lower_maps.exr`, [`NO_MAP`] when the map
    /// sees no surface (every direction open), or [`NO_LOWER`] when the VPL
    /// has no second origin (its light below the horizon is small: the
    /// first map's rim answers for it).
    pub map: u32,
}

impl LowerVpl {
    /// A VPL without a second origin.
    pub const NONE: LowerVpl = LowerVpl {
        origin: [0.0; 3],
        map: NO_LOWER,
    };

    /// Whether the VPL has a second origin.
    pub fn is_some(&self) -> bool {
        self.map != NO_LOWER
    }
}

/// [`LowerVpl::map`] of a VPL without a second origin.
pub const NO_LOWER: u32 = u32::MAX - 1;

/// Levels of each VPL's near-field tree in `vpl_nodes.bin` (below the VPL
/// itself, which is level 0).
pub const NEAR_FIELD_LEVELS: u32 = 3;
/// Node records per VPL in `vpl_nodes.bin`: 4 + 16 + 64 (levels 1–3 of a
/// quadtree over the VPL's RSM texel rectangle, level by level, each level
/// row-major).
pub const NODES_PER_VPL: usize = 84;
/// Level-3 (deepest) nodes per VPL: the last 64 of its [`NODES_PER_VPL`],
/// one coherence each in `vpl_coherence.bin` ([`Asset::vpl_coherence`]).
pub const LEVEL3_NODES: usize = 64;

/// A near-field tree `nodes` with its level-3 normals scaled by their
/// texels' coherence `coherence` ([`LEVEL3_NODES`] values in `[0, 1]`,
/// [`Asset::vpl_coherence`]; missing or shorter: left unit): each level-3
/// normal becomes the flux-weighted mean of its texels' normals, so that
/// the sums over level-3 nodes of [`lobe_coherence`],
/// [`node_lobe_coherences`] and [`facings`] are their sums over the
/// texels themselves (docs/method.md, "Texel coherence").
pub fn texel_tree(nodes: &[VplRecord], coherence: &[f32]) -> Vec<VplRecord> {
    let mut out = nodes.to_vec();
    if nodes.len() == NODES_PER_VPL && coherence.len() == LEVEL3_NODES {
        for (n, &c) in out[NODES_PER_VPL - LEVEL3_NODES..]
            .iter_mut()
            .zip(coherence)
        {
            let c = if c.is_finite() {
                c.clamp(0.0, 1.0)
            } else {
                1.0
            };
            n.normal = n.normal.map(|v| v * c);
        }
    }
    out
}

/// What shading draws a static VPL's far-field disks with: the lobe
/// coherence of the VPL's one disk ([`lobe_coherence`]) and of its level-1
/// and level-2 nodes ([`node_lobe_coherences`]), and their facing shifts
/// ([`facings`]), all from its [`texel_tree`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeLobes {
    /// The VPL's, where it is drawn as one disk.
    pub vpl: f32,
    /// Its level-1 and level-2 nodes', in tree order.
    pub nodes: [f32; 4 + 16],
    /// Facing shifts: the VPL's, then its level-1 and level-2 nodes'.
    pub facings: [Facing; FACINGS_PER_VPL],
}

/// [`TreeLobes`] of a VPL with near-field tree `nodes` and level-3
/// coherences `coherence` (see [`texel_tree`]).
pub fn tree_lobes(nodes: &[VplRecord], coherence: &[f32]) -> TreeLobes {
    let t = texel_tree(nodes, coherence);
    TreeLobes {
        vpl: lobe_coherence(&t),
        nodes: node_lobe_coherences(&t),
        facings: facings(&t),
    }
}

/// How well one cosine lobe stands for a VPL's texels: the flux-weighted
/// coherence `c = |Σ Φₖ nₖ| / Σ Φₖ` of the deepest level of its near-field
/// tree `nodes` ([`NODES_PER_VPL`] records; fewer: 1). 1 where every node
/// faces the same way; towards 0 for texels facing every way (a tree's
/// crown, a mech). Shading draws a VPL seen from afar with the lobe
/// `far_lobe(c, cos θ)/π` per unit flux (shade.wgsl), whose first moment is
/// the texels' own (docs/method.md, "Far-field lobe"). Computed at load from
/// what the asset stores, so it needs no field of its own. Flux weights
/// are the channel sum; the result is finite and in `[0, 1]`.
pub fn lobe_coherence(nodes: &[VplRecord]) -> f32 {
    if nodes.len() < NODES_PER_VPL {
        return 1.0;
    }
    let side = 1usize << NEAR_FIELD_LEVELS;
    coherence_of(&nodes[NODES_PER_VPL - side * side..NODES_PER_VPL])
}

/// [`lobe_coherence`] of one level-1 or level-2 node of a near-field tree
/// `nodes`: the coherence of the deepest-level nodes under it. `k` is the
/// node's index in the tree (0–3 level 1, 4–19 level 2, each level
/// row-major); 1 for a deeper or missing node, or a tree of fewer than
/// [`NODES_PER_VPL`] records. Shading draws such a node, where the
/// receiver is beyond its own near field, with the far-field lobe at this
/// coherence (docs/method.md, "Node lobes"); computed at load.
pub fn node_lobe_coherence(nodes: &[VplRecord], k: usize) -> f32 {
    let side = 1usize << NEAR_FIELD_LEVELS;
    if nodes.len() < NODES_PER_VPL || k >= 4 + 16 {
        return 1.0;
    }
    // (column, row, side) of the node on its level's grid.
    let (i, j, level_side) = if k < 4 {
        (k % 2, k / 2, 2)
    } else {
        ((k - 4) % 4, (k - 4) / 4, 4)
    };
    let span = side / level_side;
    let deepest = &nodes[NODES_PER_VPL - side * side..NODES_PER_VPL];
    let under = (j * span..(j + 1) * span)
        .flat_map(|r| deepest[r * side + i * span..r * side + (i + 1) * span].iter());
    coherence_of(under)
}

/// [`node_lobe_coherence`] of every level-1 and level-2 node of a tree
/// `nodes`, in tree order (all 1 for a tree of fewer than
/// [`NODES_PER_VPL`] records): what shading reads, computed once per VPL.
pub fn node_lobe_coherences(nodes: &[VplRecord]) -> [f32; 4 + 16] {
    std::array::from_fn(|k| node_lobe_coherence(nodes, k))
}

/// Where a static VPL, or one of its level-1 and level-2 nodes, sends each
/// direction's light from, beyond the point it is drawn at: its *facing
/// shift*. A cluster whose parts face different ways sends its light
/// towards `ω` mostly from the parts that face `ω` — the near side of a
/// tree's crown, the wall of a crease rather than its floor — which lie off
/// its centroid `p̄`, towards `ω` on a convex cluster. Shading draws the
/// cluster towards a receiver in direction `ω` from `p̄ + F·ω` (shade.wgsl
/// `facing_point`; docs/method.md, "Facing shift"), with
/// `F = 2 Σ Φₖ (pₖ − p̄) nₖᵀ / Σ Φₖ` over the level-3 nodes under it (their
/// centroids `pₖ`, normals `nₖ`, channel-sum flux `Φₖ`): the first-order
/// model of the emission centroid `Σ Φₖ (nₖ·ω)⁺ pₖ / Σ Φₖ (nₖ·ω)⁺`, exact
/// for a uniformly lit sphere (`p̄ + ⅔ρω`) and for a right-angled crease of
/// two equal faces (the facing face's centre), zero for a flat cluster.
/// `F` is scaled down where needed so that no shift is longer than the
/// distance from `p̄` of the farthest level-3 node (by its largest singular
/// value), so shading needs no test. Computed at load from what the asset
/// stores.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facing {
    /// The columns of `F` (`F·ω = Σⱼ cols[j]·ωⱼ`).
    pub cols: [[f32; 3]; 3],
}

impl Facing {
    /// No shift (a flat cluster, a missing tree, or degenerate input).
    pub const NONE: Facing = Facing {
        cols: [[0.0; 3]; 3],
    };

    /// The shift towards unit direction `w`: `F·w` (none where not finite).
    pub fn shift(&self, w: [f32; 3]) -> [f32; 3] {
        let mut s = [0f32; 3];
        for (j, c) in self.cols.iter().enumerate() {
            for (si, ci) in s.iter_mut().zip(c) {
                *si += ci * w[j];
            }
        }
        if s.iter().all(|v| v.is_finite()) {
            s
        } else {
            [0.0; 3]
        }
    }
}

/// The largest singular value of the 3×3 matrix with columns `f`: the
/// square root of the largest eigenvalue of the symmetric `FᵀF`, in closed
/// form (the trigonometric solution of its characteristic cubic; `f64`).
fn largest_singular_value(f: &[[f64; 3]; 3]) -> f64 {
    let dot = |a: &[f64; 3], b: &[f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // FᵀF[i][j] = colᵢ · colⱼ.
    let g: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| dot(&f[i], &f[j])));
    let off = g[0][1] * g[0][1] + g[0][2] * g[0][2] + g[1][2] * g[1][2];
    let largest = if off == 0.0 {
        g[0][0].max(g[1][1]).max(g[2][2])
    } else {
        let q = (g[0][0] + g[1][1] + g[2][2]) / 3.0;
        let d = [g[0][0] - q, g[1][1] - q, g[2][2] - q];
        let p = ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + 2.0 * off) / 6.0).sqrt();
        // B = (G − qI)/p; r = det(B)/2 ∈ [−1, 1].
        let b: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| (g[i][j] - if i == j { q } else { 0.0 }) / p)
        });
        let det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
            - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
            + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
        let phi = (det / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
        q + 2.0 * p * phi.cos()
    };
    largest.max(0.0).sqrt()
}

/// [`Facing`] of a static VPL (`k = None`: all its level-3 nodes) or of its
/// level-1 or level-2 node `k` (0–3 level 1, 4–19 level 2, each level
/// row-major: the level-3 nodes under it) in its near-field tree `nodes`;
/// [`Facing::NONE`] for a tree of fewer than [`NODES_PER_VPL`] records, a
/// deeper `k`, or nodes without finite positive flux.
pub fn facing(nodes: &[VplRecord], k: Option<usize>) -> Facing {
    let side = 1usize << NEAR_FIELD_LEVELS;
    if nodes.len() < NODES_PER_VPL || k.is_some_and(|k| k >= 4 + 16) {
        return Facing::NONE;
    }
    let deepest = &nodes[NODES_PER_VPL - side * side..NODES_PER_VPL];
    let under: Vec<&VplRecord> = match k {
        None => deepest.iter().collect(),
        Some(k) => {
            let (i, j, level_side) = if k < 4 {
                (k % 2, k / 2, 2)
            } else {
                ((k - 4) % 4, (k - 4) / 4, 4)
            };
            let span = side / level_side;
            (j * span..(j + 1) * span)
                .flat_map(|r| deepest[r * side + i * span..r * side + (i + 1) * span].iter())
                .collect()
        }
    };
    let weight = |n: &VplRecord| {
        let w = f64::from(n.flux[0]) + f64::from(n.flux[1]) + f64::from(n.flux[2]);
        (n.texels != 0 && w > 0.0 && w.is_finite()).then_some(w)
    };
    let (mut wsum, mut wp) = (0f64, [0f64; 3]);
    for n in &under {
        if let Some(w) = weight(n) {
            wsum += w;
            for (a, p) in wp.iter_mut().zip(n.position) {
                *a += w * f64::from(p);
            }
        }
    }
    if !(wsum > 0.0 && wsum.is_finite()) {
        return Facing::NONE;
    }
    let mean = wp.map(|a| a / wsum);
    let (mut f, mut reach) = ([[0f64; 3]; 3], 0f64);
    for n in &under {
        if let Some(w) = weight(n) {
            let d: [f64; 3] = std::array::from_fn(|a| f64::from(n.position[a]) - mean[a]);
            for (col, nj) in f.iter_mut().zip(n.normal) {
                for (c, di) in col.iter_mut().zip(d) {
                    *c += 2.0 * w * di * f64::from(nj) / wsum;
                }
            }
            reach = reach.max((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt());
        }
    }
    let sigma = largest_singular_value(&f);
    let scale = if sigma > reach { reach / sigma } else { 1.0 };
    let cols = f.map(|c| c.map(|v| (v * scale) as f32));
    if cols.iter().flatten().all(|v| v.is_finite()) {
        Facing { cols }
    } else {
        Facing::NONE
    }
}

/// [`facings`] per VPL: the VPL's own and its 4 + 16 level-1 and level-2
/// nodes' (shade.wgsl `FACINGS_PER_VPL`, which must match).
pub const FACINGS_PER_VPL: usize = 1 + 4 + 16;

/// [`facing`] of a VPL and of every level-1 and level-2 node of its tree
/// `nodes`: the VPL's first, then its nodes' in tree order (what shading
/// reads, computed once per VPL at load).
pub fn facings(nodes: &[VplRecord]) -> [Facing; FACINGS_PER_VPL] {
    std::array::from_fn(|k| facing(nodes, k.checked_sub(1)))
}

/// `|Σ Φₖ nₖ| / Σ Φₖ` over `nodes` (flux weights the channel sum; nodes
/// without finite positive flux left out; 1 where none is left).
fn coherence_of<'a>(nodes: impl IntoIterator<Item = &'a VplRecord>) -> f32 {
    let (mut sum, mut weight) = ([0f64; 3], 0f64);
    for n in nodes {
        let w = f64::from(n.flux[0]) + f64::from(n.flux[1]) + f64::from(n.flux[2]);
        if !(w > 0.0 && w.is_finite()) {
            continue;
        }
        for (s, c) in sum.iter_mut().zip(n.normal) {
            *s += w * f64::from(c);
        }
        weight += w;
    }
    if weight <= 0.0 {
        return 1.0;
    }
    let c = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt() / weight;
    if c.is_finite() {
        c.clamp(0.0, 1.0) as f32
    } else {
        1.0
    }
}

/// Where shading draws a VPL seen from afar: the flux-weighted centroid of
/// its texels, from the level-1 nodes of its near-field tree `nodes`
/// ([`NODES_PER_VPL`] records; `None` for fewer, or for a tree without
/// finite flux). Not the VPL's record position (the lit texel nearest that
/// centroid, where its hemisphere map is centred): a cluster spanning a
/// crease or two depth layers has its centroid off any texel, and its far
/// field drawn from its map origin instead lost 7% of a Blenvy lamp's
/// bounce light against its texels drawn one by one (2% from the
/// centroid; docs/method.md, "Far-field centre"). Computed at load from
/// what the asset stores, so it needs no field of its own.
pub fn far_field_centre(nodes: &[VplRecord]) -> Option<[f32; 3]> {
    if nodes.len() < NODES_PER_VPL {
        return None;
    }
    let (mut sum, mut weight) = ([0f64; 3], 0f64);
    for n in &nodes[..4] {
        let w = f64::from(n.flux[0]) + f64::from(n.flux[1]) + f64::from(n.flux[2]);
        if n.texels == 0 || !(w > 0.0 && w.is_finite()) {
            continue;
        }
        for (s, c) in sum.iter_mut().zip(n.position) {
            *s += w * f64::from(c);
        }
        weight += w;
    }
    if weight <= 0.0 {
        return None;
    }
    let c = sum.map(|s| (s / weight) as f32);
    c.iter().all(|v| v.is_finite()).then_some(c)
}

/// Bake settings, as given (or resolved) at bake time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BakeSettings {
    /// RSM resolution (square).
    pub rsm_size: u32,
    /// Hemisphere map resolution per VPL (square).
    pub vpl_map_size: u32,
    /// Primary shadow map resolution (square).
    pub shadow_map_size: u32,
    /// Clustering threshold used.
    pub threshold: f32,
    /// `--vpls N` if a count was asked for.
    pub vpl_budget: Option<u32>,
}

/// The light view the maps were rendered with (so the runtime merges
/// moving objects in exactly the same projection). Mirrors
/// `gibake_gpu::LightView`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightViewRecord {
    /// Orthographic (directional light).
    pub directional: bool,
    /// World → clip, column-major.
    pub view_proj: [f32; 16],
    /// Origin.
    pub origin: [f32; 3],
    /// Direction.
    pub direction: [f32; 3],
    /// Texel scale.
    pub texel_scale: f32,
    /// Texel area.
    pub texel_area: f32,
}

impl LightViewRecord {
    /// Whether every value is finite (what a valid manifest holds).
    pub fn is_finite(&self) -> bool {
        self.view_proj
            .iter()
            .chain(&self.origin)
            .chain(&self.direction)
            .chain([&self.texel_scale, &self.texel_area])
            .all(|x| x.is_finite())
    }
}

/// Where and with what the asset was baked.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// `gibake` version that baked it.
    pub baker_version: String,
    /// Scene file name (no directory).
    pub scene_name: String,
    /// Adapter name.
    pub adapter: String,
    /// Backend.
    pub backend: String,
    /// Driver and version.
    pub driver: String,
}

/// Checksum entry of one file of the asset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileEntry {
    /// File name inside the asset directory.
    pub name: String,
    /// Size in bytes.
    pub size: u64,
    /// BLAKE3 hash of the file's bytes.
    pub blake3: [u8; 32],
}

/// The manifest payload (bincode 2.0.1, serde, standard config).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Provenance.
    pub provenance: Provenance,
    /// Settings.
    pub settings: BakeSettings,
    /// BLAKE3 of the static part of the scene (see `gibake_bake::static_scene_hash`).
    pub static_scene_hash: [u8; 32],
    /// The light view of the primary shadow map (shadow_map_size) and RSM (rsm_size).
    pub light_view: LightViewRecord,
    /// Number of VPLs.
    pub vpl_count: u32,
    /// Number of stored hemisphere maps.
    pub map_count: u32,
    /// Whether the scene has moving objects (then `rsm.exr` is stored).
    pub has_dynamic: bool,
    /// Per-stage bake times are NOT stored (determinism); files and checksums are.
    pub files: Vec<FileEntry>,
    /// The primary lights the asset was baked with, in the scene's order;
    /// `lights[0]` is the one of [`Manifest::light_view`] (a spot or
    /// directional light). What the runtime lights with, and what the
    /// up-to-date check, `inspect` and `diff` report about lights.
    pub lights: Vec<LightRecord>,
    /// The shadow-map views of `lights[1..]`, in light order (a point
    /// light's six cube faces +X, −X, +Y, −Y, +Z, −Z; a spot's or
    /// directional light's one). Empty for a one-light asset.
    pub views: Vec<ViewRecord>,
    /// Resolution of every stored map of [`Manifest::views`] in
    /// `light_maps.exr` (0 when there are no views).
    pub light_map_size: u32,
    /// Format 4.1, appended after [`Manifest::light_map_size`] (a 4.0
    /// manifest ends before it: empty): the views of [`Manifest::views`]
    /// whose static RSM is stored in `view_rsms.exr` for the per-frame
    /// bounce off moving objects in their light, as indices into `views`,
    /// ascending; the k-th is tile k of the file. The views moving objects
    /// can enter, of a scene with moving objects. Encoded by hand after the
    /// serde fields (see `format.rs`), hence skipped here.
    #[serde(skip)]
    pub view_rsms: Vec<u32>,
    /// Format 4.3, appended after [`Manifest::view_rsms`] (an older
    /// manifest ends before it: empty, no ring VPLs): per light, in light
    /// order, how many of its VPLs — the last ones of its range — lie on
    /// its **outer rings**, the ground beyond a directional light's fitted
    /// view (docs/method.md, "Outer rings"). Their map origin is lifted by
    /// one of their texels' radius instead of their own
    /// ([`VplRecord::map_origin_area`]). Empty when no light has any; else
    /// one entry per light, each at most its `vpls`, non-zero only for a
    /// directional light. Encoded by hand (see `format.rs`).
    #[serde(skip)]
    pub ring_vpls: Vec<u32>,
    /// Format 4.4, appended after [`Manifest::ring_vpls`] (an older
    /// manifest ends before it: `None`): the scene options the bake applied
    /// to the level as exported that are part of its static-scene hash
    /// (`--sun`, `--dynamic`, `--light`, `--bake-volume`,
    /// `--max-texture-size`), in their canonical form
    /// ([`SceneOptions::normalized`]; the writer normalizes). `None`: not
    /// recorded (an older asset, or a bake by a library call that did not
    /// say); `Some` of an empty record: none was given. `gibake render`,
    /// `gibake view` and the runtime's `load_scene_for` apply them
    /// ([`SceneOptions::resolve`]). Encoded by hand (see `format.rs`).
    #[serde(skip)]
    pub scene_options: Option<SceneOptions>,
    /// Format 4.5, appended after [`Manifest::scene_options`] (an older
    /// manifest ends before it: `None`, not recorded): the moving objects'
    /// swept bounds the bake used, `[min x, min y, min z, max x, max y,
    /// max z]` in world units (`Scene::dynamic_swept_bounds`; an empty box,
    /// `+∞ … −∞`, for a scene without moving objects). The static-scene
    /// hash leaves the moving objects out, yet the bake's bytes depend on
    /// these bounds (the light views are fitted to them; the reach probe
    /// aims rays at them and keeps the VPLs that light only them, which
    /// moves a `--vpls` budget's threshold), so the up-to-date check
    /// compares them bit for bit. Encoded by hand as the six values' f32
    /// bit patterns in a bincode `Vec<u32>` (0 entries: not recorded).
    #[serde(skip)]
    pub swept_bounds: Option<[f32; 6]>,
    /// Format 4.6, appended after [`Manifest::swept_bounds`] (an older
    /// manifest ends before it: `None`): the bounces after the first, when
    /// the bake followed them (`gibake bake --bounces`, default every
    /// bounce that matters); `None`: the first bounce alone (`--bounces
    /// 1`, or an older asset). Its VPLs are the last [`LaterRecord::vpls`]
    /// of the asset's, after every light's. Encoded by hand as a bincode
    /// (serde) `Option<LaterRecord>` (see `format.rs`).
    #[serde(skip)]
    pub later: Option<LaterRecord>,
    /// Format 4.7, appended after [`Manifest::later`] (an older manifest
    /// ends before it: 0): the number of second hemisphere maps stored in
    /// `vpl_lower_maps.exr` ([`LowerVpl`], [`Asset::vpl_lower`]). Encoded
    /// by hand (see `format.rs`).
    #[serde(skip)]
    pub lower_map_count: u32,
    /// Format 4.8, appended after [`Manifest::lower_map_count`] (an older
    /// manifest ends before it: `None`): where each later VPL's light came
    /// from, so that a moving object shadowing a light darkens the later
    /// bounces where that light went ([`LaterSources`]). `None` without
    /// later VPLs. Encoded by hand as a bincode (serde)
    /// `Option<LaterSources>` (see `format.rs`).
    #[serde(skip)]
    pub later_sources: Option<LaterSources>,
}

/// Source groups a later VPL names at most ([`LaterSources::weights`]).
pub const SOURCES_PER_LATER_VPL: usize = 8;

/// Source groups an asset has at most ([`LaterSources::first`]).
pub const MAX_SOURCE_GROUPS: u32 = 256;

/// Where the later bounces' light came from (format 4.8; docs/method.md,
/// "Where the later light came from"): the first bounce's VPLs in source
/// groups (the directly lit surfaces near each other), and per later VPL
/// the groups whose direct light carries most of its light. The runtime
/// gives each later VPL the occluded share of those groups (what the
/// moving objects take off the first bounce's VPLs in them, flux-weighted)
/// by those weights, and the level's mean for the rest.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LaterSources {
    /// Per first-bounce VPL (the asset's VPLs before the later ones), its
    /// source group, below [`MAX_SOURCE_GROUPS`], and its weight in the
    /// group's mean: the light of it that the bake's surfels pass on to
    /// other surfaces (W, the channels' mean; ≥ 0). 0: none of its light
    /// reaches another surface (a sunlit roof under the open sky), and it
    /// counts in no group.
    pub first: Vec<(u32, f32)>,
    /// Per later VPL, [`SOURCES_PER_LATER_VPL`] `(group, weight)` pairs:
    /// the share of its light whose direct light fell on the group, the
    /// largest first (unused pairs: weight 0); the weights sum to at most 1.
    pub weights: Vec<(u32, f32)>,
}

impl LaterSources {
    /// What is wrong with the record for `first` first-bounce VPLs and
    /// `later` later ones, if anything.
    pub fn problem(&self, first: u32, later: u32) -> Option<String> {
        if self.first.len() != first as usize {
            return Some(format!(
                "{} source groups listed for {first} first-bounce VPLs",
                self.first.len()
            ));
        }
        if self.weights.len() != later as usize * SOURCES_PER_LATER_VPL {
            return Some(format!(
                "{} source weights listed for {later} later VPLs ({SOURCES_PER_LATER_VPL} each)",
                self.weights.len()
            ));
        }
        if let Some((g, _)) = self.first.iter().find(|(g, _)| *g >= MAX_SOURCE_GROUPS) {
            return Some(format!(
                "source group {g} (at most {MAX_SOURCE_GROUPS} groups)"
            ));
        }
        if self
            .first
            .iter()
            .any(|(_, w)| !(w.is_finite() && *w >= 0.0))
        {
            return Some("a first-bounce VPL's weight is negative or not finite".into());
        }
        for (j, w) in self.weights.chunks_exact(SOURCES_PER_LATER_VPL).enumerate() {
            if w.iter()
                .any(|(g, x)| *g >= MAX_SOURCE_GROUPS || !(x.is_finite() && *x >= 0.0))
            {
                return Some(format!(
                    "later VPL {j}: a source group out of range or a weight negative or not finite"
                ));
            }
            let sum: f32 = w.iter().map(|(_, x)| x).sum();
            if sum > 1.0 + 1e-3 {
                return Some(format!(
                    "later VPL {j}: its source weights sum to {sum} (at most 1)"
                ));
            }
        }
        None
    }
}

/// The bounces after the first, as a bake of format 4.6 followed them
/// (`gibake_bake::later`; docs/method.md, "Every bounce").
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaterRecord {
    /// The bounces asked for: 0 for every bounce that matters (the
    /// default), else `N ≥ 2` in all, the first included.
    pub bounces: u32,
    /// The later VPL budget asked for (`--later-vpls`); 0: the default, a
    /// quarter of the first bounce's VPLs.
    pub vpl_budget: u32,
    /// The later bounces' VPLs: the last `vpls` of the asset's (0 when
    /// they were left out).
    pub vpls: u32,
    /// Whether they were left out: under the default, they carried under
    /// 0.1% of the light the level's surfaces reflect.
    pub left_out: bool,
    /// Whether the light died down (false: a closed level of albedo near
    /// 1, cut at the bake's bounce cap; the bake warned).
    pub converged: bool,
    /// The light the level's surfaces reflect straight from the lights
    /// (W, linear RGB), as the bake's surface samples measured it.
    pub direct: [f32; 3],
    /// The light they reflect after each bounce followed, `k = 1, 2, …`
    /// (W, linear RGB); at most [`MAX_LATER_BOUNCES`] entries.
    pub per_bounce: Vec<[f32; 3]>,
    /// The light of the bounces beyond the last followed, added as the
    /// rest of a geometric series (zero when none was added).
    pub tail: [f32; 3],
}

/// The light of the bounces after the first over all the light the
/// surfaces reflect: `direct` straight from the lights, `per_bounce` after
/// bounce 1, 2, …, `tail` beyond the last followed (W, linear RGB; 0 when
/// nothing is reflected). [`LaterRecord::later_share`] and the bake's
/// decision to leave the later bounces out (`gibake_bake::later`).
pub fn later_share(
    direct: [f32; 3],
    per_bounce: impl IntoIterator<Item = [f32; 3]>,
    tail: [f32; 3],
) -> f64 {
    let sum = |v: [f32; 3]| f64::from(v[0]) + f64::from(v[1]) + f64::from(v[2]);
    let (mut first, mut later) = (0.0, sum(tail));
    for (k, b) in per_bounce.into_iter().enumerate() {
        if k == 0 {
            first += sum(b);
        } else {
            later += sum(b);
        }
    }
    let all = sum(direct) + first + later;
    if all > 0.0 { later / all } else { 0.0 }
}

/// The most bounces a [`LaterRecord`] lists (the bake's cap).
pub const MAX_LATER_BOUNCES: usize = 256;

impl LaterRecord {
    /// The later bounces' light over all the light the surfaces reflect
    /// (direct, first bounce and later): the share the bake left out when
    /// it left them out.
    pub fn later_share(&self) -> f64 {
        later_share(self.direct, self.per_bounce.iter().copied(), self.tail)
    }

    /// What is wrong with the record's values, if anything.
    pub fn problem(&self, vpl_count: u32) -> Option<String> {
        if self.bounces == 1 {
            return Some("bounces = 1 (the first bounce alone has no later record)".into());
        }
        if self.vpls > vpl_count {
            return Some(format!(
                "{} later VPLs but the asset has {vpl_count}",
                self.vpls
            ));
        }
        if self.left_out && self.vpls != 0 {
            return Some(format!("left out, yet {} later VPLs", self.vpls));
        }
        if self.per_bounce.len() > MAX_LATER_BOUNCES {
            return Some(format!(
                "{} bounces listed (at most {MAX_LATER_BOUNCES})",
                self.per_bounce.len()
            ));
        }
        let bad = |v: &[f32; 3]| v.iter().any(|x| !(x.is_finite() && *x >= 0.0));
        if bad(&self.direct) || bad(&self.tail) || self.per_bounce.iter().any(bad) {
            return Some("a light total is negative or not finite".into());
        }
        None
    }
}

impl Manifest {
    /// The later bounces' VPLs (the last of the asset's; 0 without).
    pub fn later_vpls(&self) -> u32 {
        self.later.as_ref().map_or(0, |l| l.vpls)
    }

    /// Per VPL record: whether its map origin is lifted by one member's
    /// radius rather than its own (`gibake_gpu::hemisphere::record_origin`):
    /// a VPL on a light's outer rings ([`Manifest::ring_flags`]) or of the
    /// later bounces ([`Manifest::later`]); `vpl_count` entries.
    pub fn origin_lift_flags(&self) -> Vec<bool> {
        let mut out = self.ring_flags();
        let later = self.later_vpls() as usize;
        let n = out.len();
        for f in out.iter_mut().skip(n.saturating_sub(later)) {
            *f = true;
        }
        out
    }

    /// Per VPL record: whether it lies on its light's outer rings
    /// ([`Manifest::ring_vpls`]); `vpl_count` entries.
    pub fn ring_flags(&self) -> Vec<bool> {
        let per_light: Vec<u32> = self.lights.iter().map(|l| l.vpls).collect();
        let mut out = ring_flags(&per_light, &self.ring_vpls);
        out.resize(self.vpl_count as usize, false);
        out
    }
}

/// Per VPL, in light order (`per_light[k]` VPLs each): whether it lies on
/// its light's outer rings, the last `ring_vpls[k]` of light `k`'s
/// ([`Manifest::ring_vpls`]; a missing entry is 0, an entry over the
/// light's count is clamped to it).
pub fn ring_flags(per_light: &[u32], ring_vpls: &[u32]) -> Vec<bool> {
    let mut out = Vec::new();
    for (k, &n) in per_light.iter().enumerate() {
        let ring = ring_vpls.get(k).copied().unwrap_or(0).min(n);
        out.extend(std::iter::repeat_n(false, (n - ring) as usize));
        out.extend(std::iter::repeat_n(true, ring as usize));
    }
    out
}

/// One shadow-map view of a light other than the first (format 4.0).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ViewRecord {
    /// Index into [`Manifest::lights`] (≥ 1).
    pub light: u32,
    /// The view (its `view_proj` at [`Manifest::light_map_size`]).
    pub view: LightViewRecord,
    /// Its static shadow map's tile in `light_maps.exr`, or [`NO_MAP`]
    /// when the map holds no surface (nothing shadows: not stored).
    pub tile: u32,
}

/// [`LightRecord::kind`] of a directional light.
pub const LIGHT_DIRECTIONAL: u8 = 0;
/// [`LightRecord::kind`] of a spot light.
pub const LIGHT_SPOT: u8 = 1;
/// [`LightRecord::kind`] of a point light.
pub const LIGHT_POINT: u8 = 2;

/// A baked primary light, as the scene gave it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightRecord {
    /// glTF light name (or `light #i`, or `--sun`).
    pub name: String,
    /// [`LIGHT_DIRECTIONAL`], [`LIGHT_SPOT`] or [`LIGHT_POINT`].
    pub kind: u8,
    /// `color × intensity`, linear RGB: W/sr (spot, point) or W/m²
    /// (directional).
    pub color: [f32; 3],
    /// World-space position.
    pub position: [f32; 3],
    /// World-space unit direction the light points to.
    pub direction: [f32; 3],
    /// Spot inner cone angle, radians (0 for other kinds).
    pub inner_cone: f32,
    /// Spot outer cone angle, radians (0 for other kinds).
    pub outer_cone: f32,
    /// glTF range in world units; 0: none.
    pub range: f32,
    /// VPLs made from this light's views (its share of the budget).
    pub vpls: u32,
}

impl LightRecord {
    /// `directional`, `spot`, `point` (or `unknown`).
    pub fn kind_name(&self) -> &'static str {
        match self.kind {
            LIGHT_DIRECTIONAL => "directional",
            LIGHT_SPOT => "spot",
            LIGHT_POINT => "point",
            _ => "unknown",
        }
    }
}

/// A single-channel square f32 map.
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
    /// Width = height.
    pub size: u32,
    /// `size²` values, row-major, row 0 at the top.
    pub data: Vec<f32>,
}

/// The static RSM data only the dynamic merge reads (stored only when the
/// scene has moving objects).
#[derive(Clone, Debug, PartialEq)]
pub struct RsmData {
    /// Width = height (rsm_size).
    pub size: u32,
    /// Static metric per texel (INFINITY = empty).
    pub metric: Vec<f32>,
    /// Per texel, its share of its VPL's flux (`R + G + B`), fixed point:
    /// [`SHARE_ONE`] is the whole VPL; 0 for a texel of no VPL.
    pub share: Vec<u32>,
    /// VPL index per texel (u32::MAX = none).
    pub vpl: Vec<u32>,
}

/// [`RsmData::share`] of a texel that holds its VPL's whole flux: 2²⁴.
pub const SHARE_ONE: u32 = 1 << 24;

impl RsmData {
    /// The RSM data of `size²` texels with reflected `flux` (RGB) clustered
    /// into `vpl_count` VPLs (`vpl`: index per texel, u32::MAX = none):
    /// each texel's share of its VPL's flux, `(r + g + b) / Σ (r + g + b)`
    /// over the VPL's texels (sums in f64, in texel order), rounded to
    /// fixed point. Computed once, at bake time; partial occlusion adds the
    /// shares of the texels a moving object hides.
    pub fn from_flux(
        size: u32,
        metric: Vec<f32>,
        flux: &[[f32; 3]],
        vpl: Vec<u32>,
        vpl_count: usize,
    ) -> RsmData {
        let mut total = vec![0.0f64; vpl_count];
        for (f, &v) in flux.iter().zip(&vpl) {
            if let Some(t) = total.get_mut(v as usize) {
                *t += (f[0] + f[1] + f[2]) as f64;
            }
        }
        let one = f64::from(SHARE_ONE);
        let share = flux
            .iter()
            .zip(&vpl)
            .map(|(f, &v)| match total.get(v as usize) {
                Some(&t) if t > 0.0 => ((f[0] + f[1] + f[2]) as f64 / t * one)
                    .round()
                    .clamp(0.0, one) as u32,
                _ => 0,
            })
            .collect();
        RsmData {
            size,
            metric,
            share,
            vpl,
        }
    }
}

/// A whole baked asset in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Asset {
    /// The manifest (its `files` is filled in when written).
    pub manifest: Manifest,
    /// VPLs.
    pub vpls: Vec<VplRecord>,
    /// Near-field trees: [`NODES_PER_VPL`] records per VPL, in VPL order
    /// (`map` is [`NO_MAP`]; a node without lit texels is all zeros but
    /// `map`). See docs/asset-format.md.
    pub vpl_nodes: Vec<VplRecord>,
    /// Per VPL, its [`LEVEL3_NODES`] level-3 nodes' texel coherence `|Σ w n|
    /// / Σ w` (texel normals `n`, weights `w` their flux's channel sum; 1
    /// for an empty node), in tree order: shading draws a level-3 node with
    /// the far-field lobe at it (docs/method.md, "Texel coherence").
    /// Empty for an asset of format 4.1 or older (every node a cosine
    /// lobe). `vpl_coherence.bin`.
    pub vpl_coherence: Vec<f32>,
    /// Per VPL its second visibility test for the light below its horizon
    /// ([`LowerVpl`]), in VPL order; empty for an asset of format 4.6 or
    /// older (every VPL without one). `vpl_lower.bin`.
    pub vpl_lower: Vec<LowerVpl>,
    /// The second hemisphere maps ([`LowerVpl::map`]), each `vpl_map_size²`
    /// distances around the opposite of its VPL's normal, in the atlas
    /// layout of `vpl_lower_maps.exr` ([`MapAtlas`]).
    pub vpl_lower_maps: MapAtlas,
    /// Static primary shadow map (metric, shadow_map_size²).
    pub primary_depth: Map,
    /// Hemisphere maps, `map_count` maps of `vpl_map_size²` distances
    /// (INFINITY = no surface), in the atlas layout of `vpl_maps.exr`
    /// ([`MapAtlas`]).
    pub vpl_maps: MapAtlas,
    /// RSM data for the dynamic merge, `None` without moving objects.
    pub rsm: Option<RsmData>,
    /// The static shadow maps of [`Manifest::views`] (metric, as
    /// `primary_depth`), one tile per view whose `tile` is not [`NO_MAP`],
    /// in the atlas layout of `light_maps.exr` ([`MapAtlas`]).
    pub light_maps: MapAtlas,
    /// The static RSMs of [`Manifest::view_rsms`] (one per entry, in its
    /// order, each `rsm_size²`, at the view resized to `rsm_size`; `vpl`
    /// indexes [`Asset::vpls`], only VPLs of the view's own light). Empty
    /// without moving objects.
    pub view_rsms: Vec<RsmData>,
}

impl Asset {
    /// The scene options the bake applied ([`Manifest::scene_options`];
    /// `None`: not recorded). Load the level with them
    /// ([`SceneOptions::resolve`]) or the static-scene hash differs.
    pub fn scene_options(&self) -> Option<&SceneOptions> {
        self.manifest.scene_options.as_ref()
    }

    /// Each VPL's [`TreeLobes`] ([`tree_lobes`] of its near-field tree and
    /// level-3 coherences), in VPL order: what shading draws its far-field
    /// disks with, computed once per VPL at load.
    pub fn tree_lobes(&self) -> Vec<TreeLobes> {
        (0..self.vpls.len())
            .map(|i| tree_lobes(self.tree(i), self.level3_coherence(i)))
            .collect()
    }

    /// VPL `i`'s near-field tree as stored (empty where it has none).
    pub fn tree(&self, i: usize) -> &[VplRecord] {
        self.vpl_nodes
            .get(i * NODES_PER_VPL..(i + 1) * NODES_PER_VPL)
            .unwrap_or(&[])
    }

    /// VPL `i`'s level-3 coherences (empty where the asset has none).
    pub fn level3_coherence(&self, i: usize) -> &[f32] {
        self.vpl_coherence
            .get(i * LEVEL3_NODES..(i + 1) * LEVEL3_NODES)
            .unwrap_or(&[])
    }

    /// VPL `i`'s near-field tree as [`texel_tree`] (empty where it has
    /// none): what its lobes and facing shifts are computed from.
    pub fn texel_tree(&self, i: usize) -> Vec<VplRecord> {
        texel_tree(self.tree(i), self.level3_coherence(i))
    }

    /// Each VPL's far-field centre ([`far_field_centre`] of its near-field
    /// tree), in VPL order; `None` where shading draws it from its map
    /// origin (no full tree).
    pub fn far_field_centres(&self) -> Vec<Option<[f32; 3]>> {
        (0..self.vpls.len())
            .map(|i| {
                far_field_centre(
                    self.vpl_nodes
                        .get(i * NODES_PER_VPL..(i + 1) * NODES_PER_VPL)
                        .unwrap_or(&[]),
                )
            })
            .collect()
    }

    /// Number of stored hemisphere maps.
    pub fn stored_map_count(&self) -> usize {
        self.vpl_maps.count() as usize
    }

    /// A copy of hemisphere map `layer` (`vpl_map_size²` distances, row 0
    /// at the top), or `None` when the layer is not stored.
    pub fn vpl_map(&self, layer: u32) -> Option<Vec<f32>> {
        self.vpl_maps.map(layer)
    }

    /// A copy of the hemisphere map of VPL `vpl`, or `None` when it has no
    /// stored map ([`NO_MAP`]: every direction is unoccluded) or the index
    /// is out of range.
    pub fn vpl_map_of(&self, vpl: usize) -> Option<Vec<f32>> {
        let rec = self.vpls.get(vpl)?;
        if rec.map == NO_MAP {
            None
        } else {
            self.vpl_map(rec.map)
        }
    }

    /// A copy of the second hemisphere map of VPL `vpl` ([`LowerVpl`]), or
    /// `None` when it has none stored (no second origin, or its map sees no
    /// surface) or the index is out of range.
    pub fn vpl_lower_map_of(&self, vpl: usize) -> Option<Vec<f32>> {
        let rec = self.vpl_lower.get(vpl)?;
        if rec.map == NO_MAP || rec.map == NO_LOWER {
            None
        } else {
            self.vpl_lower_maps.map(rec.map)
        }
    }
}

impl VplRecord {
    /// A node of a near-field tree without lit texels (all zeros, no map).
    pub const EMPTY_NODE: VplRecord = VplRecord {
        position: [0.0; 3],
        area: 0.0,
        normal: [0.0; 3],
        texels: 0,
        flux: [0.0; 3],
        map: NO_MAP,
    };

    /// Luminance of the flux (Rec. 709 weights).
    pub fn flux_luminance(&self) -> f32 {
        0.2126 * self.flux[0] + 0.7152 * self.flux[1] + 0.0722 * self.flux[2]
    }
}

#[cfg(test)]
mod tests {
    /// A one-texel node at the origin with normal `n` and flux `f` per
    /// channel.
    fn node(n: [f32; 3], f: f32) -> crate::VplRecord {
        crate::VplRecord {
            position: [0.0; 3],
            area: 1.0,
            normal: n,
            texels: 1,
            flux: [f; 3],
            map: crate::NO_MAP,
        }
    }

    #[test]
    fn lobe_coherence_of_aligned_and_opposed_nodes() {
        let zero = node([0.0, 1.0, 0.0], 0.0);
        let mut nodes = vec![zero; crate::NODES_PER_VPL];
        // Too few records: one lobe.
        assert_eq!(crate::lobe_coherence(&nodes[..10]), 1.0);
        // No flux: one lobe.
        assert_eq!(crate::lobe_coherence(&nodes), 1.0);
        let first = crate::NODES_PER_VPL - 64;
        nodes[first] = node([0.0, 1.0, 0.0], 2.0);
        nodes[first + 1] = node([0.0, 1.0, 0.0], 1.0);
        assert!((crate::lobe_coherence(&nodes) - 1.0).abs() < 1e-6);
        // Two equal nodes at right angles: |(1, 1)| / 2.
        nodes[first] = node([1.0, 0.0, 0.0], 1.0);
        let c = crate::lobe_coherence(&nodes);
        assert!((c - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6, "{c}");
        // Opposed: 0; a NaN flux is skipped.
        nodes[first] = node([0.0, -1.0, 0.0], 1.0);
        nodes[first + 2] = node([0.0, 0.0, 1.0], f32::NAN);
        assert!(crate::lobe_coherence(&nodes).abs() < 1e-6);
    }

    /// A level-1 or level-2 node's coherence is its own level-3 nodes'
    /// (the 4×4 or 2×2 block under it), not the whole tree's.
    #[test]
    fn node_lobe_coherence_of_the_nodes_under_it() {
        let mut nodes = vec![node([0.0, 1.0, 0.0], 1.0); crate::NODES_PER_VPL];
        // Level-3 grid 8×8 from record 20; the right half faces ±x by
        // columns, the bottom-left quarter faces +x.
        for r in 0..8 {
            for c in 0..8 {
                let n = if c >= 4 {
                    [if c % 2 == 0 { 1.0 } else { -1.0 }, 0.0, 0.0]
                } else if r >= 4 {
                    [1.0, 0.0, 0.0]
                } else {
                    [0.0, 1.0, 0.0]
                };
                nodes[20 + r * 8 + c] = node(n, 1.0);
            }
        }
        let c = |k| crate::node_lobe_coherence(&nodes, k);
        assert!((c(0) - 1.0).abs() < 1e-6, "top-left level-1 node: {}", c(0));
        assert!(c(1).abs() < 1e-6, "top-right level-1 node: {}", c(1));
        assert!(
            (c(2) - 1.0).abs() < 1e-6,
            "bottom-left level-1 node: {}",
            c(2)
        );
        // Level 2: (0, 0) faces +y; (2, 0) holds columns 4–5: +x and −x.
        assert!((c(4) - 1.0).abs() < 1e-6);
        assert!(c(6).abs() < 1e-6, "{}", c(6));
        // The whole tree: 16 +y, 16 +x, 32 cancelling.
        let whole = crate::lobe_coherence(&nodes);
        assert!(
            (whole - (16f32 * 16.0 * 2.0).sqrt() / 64.0).abs() < 1e-6,
            "{whole}"
        );
        // Level 3, out of range and short trees: one lobe.
        assert_eq!(c(20), 1.0);
        assert_eq!(crate::node_lobe_coherence(&nodes[..83], 0), 1.0);
    }

    /// A tree whose 64 level-3 nodes sit at `at(r, c)` facing `n(r, c)`,
    /// each of flux 1.
    fn tree_of(
        at: impl Fn(usize, usize) -> [f32; 3],
        n: impl Fn(usize, usize) -> [f32; 3],
    ) -> Vec<crate::VplRecord> {
        let mut nodes = vec![node([0.0, 1.0, 0.0], 1.0); crate::NODES_PER_VPL];
        for r in 0..8 {
            for c in 0..8 {
                nodes[20 + r * 8 + c] = crate::VplRecord {
                    position: at(r, c),
                    ..node(n(r, c), 1.0)
                };
            }
        }
        nodes
    }

    fn close(a: [f32; 3], b: [f32; 3], tol: f32) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    /// The facing shift: none on a flat cluster; the facing face's centre
    /// of a right-angled crease of two equal faces; `⅔ρ` towards the
    /// receiver on a sphere; at most the reach; none without a full tree.
    /// A texel tree scales the level-3 normals by their coherences and
    /// nothing else; without coherences (or with the wrong count) it is
    /// the tree as stored.
    #[test]
    fn texel_tree_weights_the_level_3_normals() {
        let n = |k: usize| VplRecord {
            position: [k as f32, 0.0, 0.0],
            area: 1.0,
            normal: [0.0, 1.0, 0.0],
            texels: 1,
            flux: [1.0; 3],
            map: NO_MAP,
        };
        let tree: Vec<VplRecord> = (0..NODES_PER_VPL).map(n).collect();
        let c: Vec<f32> = (0..LEVEL3_NODES).map(|k| k as f32 / 64.0).collect();
        let t = texel_tree(&tree, &c);
        assert_eq!(
            t[..NODES_PER_VPL - LEVEL3_NODES],
            tree[..NODES_PER_VPL - LEVEL3_NODES]
        );
        for k in 0..LEVEL3_NODES {
            let m = &t[NODES_PER_VPL - LEVEL3_NODES + k];
            assert_eq!(m.normal, [0.0, k as f32 / 64.0, 0.0]);
            assert_eq!(m.position, tree[NODES_PER_VPL - LEVEL3_NODES + k].position);
        }
        // The level-3 nodes' coherence is then their texels': the mean of
        // k/64 over k.
        let want = (0..64).map(|k| k as f32 / 64.0).sum::<f32>() / 64.0;
        assert!((lobe_coherence(&t) - want).abs() < 1e-6);
        assert_eq!(lobe_coherence(&tree), 1.0);
        assert_eq!(texel_tree(&tree, &[]), tree);
        assert_eq!(texel_tree(&tree, &c[1..]), tree);
    }

    #[test]
    fn facing_shift_of_flat_crease_and_sphere() {
        let up = [0.0, 1.0, 0.0];
        let flat = tree_of(|r, c| [c as f32, 0.0, r as f32], |_, _| up);
        for w in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, 0.8, 0.0]] {
            assert!(close(crate::facing(&flat, None).shift(w), [0.0; 3], 1e-5));
            assert!(close(
                crate::facing(&flat, Some(5)).shift(w),
                [0.0; 3],
                1e-5
            ));
        }
        // Columns 0–3: a floor (y = 0, facing +y) at x = 0.5 … 3.5;
        // columns 4–7: a wall (x = 0, facing +x) at y = 0.5 … 3.5.
        let crease = tree_of(
            |r, c| {
                if c < 4 {
                    [c as f32 + 0.5, 0.0, r as f32]
                } else {
                    [0.0, (c - 4) as f32 + 0.5, r as f32]
                }
            },
            |_, c| if c < 4 { up } else { [1.0, 0.0, 0.0] },
        );
        let f = crate::facing(&crease, None);
        let centre = [1.0, 1.0, 3.5];
        let to = |w: [f32; 3]| {
            let s = f.shift(w);
            [centre[0] + s[0], centre[1] + s[1], centre[2] + s[2]]
        };
        assert!(
            close(to([1.0, 0.0, 0.0]), [0.0, 2.0, 3.5], 1e-5),
            "{:?}",
            to([1.0, 0.0, 0.0])
        );
        assert!(
            close(to([0.0, 1.0, 0.0]), [2.0, 0.0, 3.5], 1e-5),
            "{:?}",
            to([0.0, 1.0, 0.0])
        );
        // A unit sphere sampled by 64 Fibonacci points: ⅔ towards w.
        let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
        let fib = |r: usize, c: usize| {
            let k = (r * 8 + c) as f32;
            let y = 1.0 - 2.0 * (k + 0.5) / 64.0;
            let q = (1.0 - y * y).sqrt();
            [q * (golden * k).cos(), y, q * (golden * k).sin()]
        };
        let sphere = tree_of(fib, fib);
        let f = crate::facing(&sphere, None);
        for w in [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.6, 0.8]] {
            let s = f.shift(w);
            assert!(
                close(s, w.map(|v| v * 2.0 / 3.0), 0.03),
                "{s:?} towards {w:?}"
            );
        }
        // No shift is longer than the farthest level-3 node from the
        // centroid: two nodes 1 apart facing one way, two facing the other,
        // would shift by 2 unscaled.
        let pair = tree_of(
            |_, c| [if c % 2 == 0 { -0.5 } else { 0.5 }, 0.0, 0.0],
            |_, c| [if c % 2 == 0 { -1.0 } else { 1.0 }, 0.0, 0.0],
        );
        let s = crate::facing(&pair, None).shift([1.0, 0.0, 0.0]);
        assert!(close(s, [0.5, 0.0, 0.0], 1e-5), "{s:?}");
        // The same along (1, −1, 0)/√2, orthogonal to (1, 1, 1): still at
        // most the reach.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let u = [h, -h, 0.0];
        let diagonal = tree_of(
            |_, c| u.map(|v| if c % 2 == 0 { -0.5 * v } else { 0.5 * v }),
            |_, c| u.map(|v| if c % 2 == 0 { -v } else { v }),
        );
        let s = crate::facing(&diagonal, None).shift(u);
        assert!(close(s, u.map(|v| 0.5 * v), 1e-5), "{s:?}");
        let nan = crate::Facing {
            cols: [[f32::NAN; 3], [0.0; 3], [0.0; 3]],
        };
        assert_eq!(nan.shift([1.0, 0.0, 0.0]), [0.0; 3]);
        // Short trees, deeper nodes, no flux: no shift.
        assert_eq!(crate::facing(&sphere[..83], None), crate::Facing::NONE);
        assert_eq!(crate::facing(&sphere, Some(20)), crate::Facing::NONE);
        let dark: Vec<_> = sphere
            .iter()
            .map(|n| crate::VplRecord {
                flux: [0.0; 3],
                ..*n
            })
            .collect();
        assert_eq!(crate::facing(&dark, None), crate::Facing::NONE);
        let all = crate::facings(&sphere);
        assert_eq!(all[0], crate::facing(&sphere, None));
        assert_eq!(all[1 + 6], crate::facing(&sphere, Some(6)));
    }

    /// The largest singular value in closed form: a rotated diag(3, 1,
    /// 0.5), a rank-one matrix orthogonal to (1, 1, 1), zero.
    #[test]
    fn largest_singular_value_in_closed_form() {
        let (c, s) = (0.6f64, 0.8f64);
        // Columns of R·diag(3, 1, 0.5), R a rotation about z.
        let f = [[3.0 * c, 3.0 * s, 0.0], [-s, c, 0.0], [0.0, 0.0, 0.5]];
        assert!((crate::largest_singular_value(&f) - 3.0).abs() < 1e-9);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let rank1 = [[h * 2.0, -h * 2.0, 0.0], [-h * 2.0, h * 2.0, 0.0], [0.0; 3]];
        assert!((crate::largest_singular_value(&rank1) - 2.0 * 2f64.sqrt()).abs() < 1e-9);
        assert_eq!(crate::largest_singular_value(&[[0.0; 3]; 3]), 0.0);
    }

    /// The far-field centre is the level-1 nodes' flux-weighted centroid
    /// (empty, unlit and non-finite nodes left out), and none without a
    /// full tree or without flux.
    #[test]
    fn far_field_centre_is_the_flux_weighted_centroid() {
        let node = |p: [f32; 3], f: f32| crate::VplRecord {
            position: p,
            area: 1.0,
            normal: [0.0, 1.0, 0.0],
            texels: 1,
            flux: [f; 3],
            map: crate::NO_MAP,
        };
        let mut nodes = vec![node([9.0; 3], 0.0); crate::NODES_PER_VPL];
        assert_eq!(crate::far_field_centre(&nodes), None);
        assert_eq!(crate::far_field_centre(&nodes[..4]), None);
        nodes[0] = node([0.0, 0.0, 0.0], 3.0);
        nodes[1] = node([4.0, 0.0, 0.0], 1.0);
        nodes[2] = node([100.0, 0.0, 0.0], f32::NAN);
        nodes[3] = crate::VplRecord {
            texels: 0,
            ..node([-100.0, 0.0, 0.0], 5.0)
        };
        // Deeper nodes do not count.
        nodes[4] = node([50.0, 50.0, 50.0], 7.0);
        assert_eq!(crate::far_field_centre(&nodes), Some([1.0, 0.0, 0.0]));
    }

    use super::*;

    /// Each VPL's texel shares add up to the whole VPL (to within the
    /// rounding of each); texels of no VPL, or of an unlit one, hold none.
    #[test]
    fn flux_shares_split_each_vpl() {
        let flux = [
            [1.0, 0.0, 0.0],
            [0.5, 0.5, 1.0],
            [3.0, 0.0, 0.0],
            [2.0; 3],
            [0.0; 3],
        ];
        let vpl = vec![0, 0, 1, u32::MAX, 2];
        let r = RsmData::from_flux(1, vec![1.0; 5], &flux, vpl, 3);
        assert_eq!(
            r.share,
            [SHARE_ONE / 3, 2 * SHARE_ONE / 3 + 1, SHARE_ONE, 0, 0]
        );
        assert!(r.share[0] + r.share[1] - SHARE_ONE <= 1);
    }
}

/// What changed from the lights `was` to the lights `now`, one line per change, lights matched by name: added, removed,
/// or which of kind, position, direction, colour, cones and range changed
/// (compared exactly, as the static-scene hash does; the VPL counts, a
/// result, are not compared). Empty when equal;
/// used by the up-to-date check and `diff`.
pub fn light_changes(was: &[LightRecord], now: &[LightRecord]) -> Vec<String> {
    let mut out = Vec::new();
    for w in was {
        match now.iter().find(|n| n.name == w.name) {
            None => out.push(format!("light '{}' ({}) removed", w.name, w.kind_name())),
            Some(n) => {
                let mut what = Vec::new();
                if n.kind != w.kind {
                    what.push(format!("kind {} → {}", w.kind_name(), n.kind_name()));
                }
                for (field, a, b) in [
                    ("position", w.position, n.position),
                    ("direction", w.direction, n.direction),
                    ("colour × intensity", w.color, n.color),
                ] {
                    if a != b {
                        what.push(format!("{field} {a:?} → {b:?}"));
                    }
                }
                for (field, a, b) in [
                    ("inner cone", w.inner_cone, n.inner_cone),
                    ("outer cone", w.outer_cone, n.outer_cone),
                    ("range", w.range, n.range),
                ] {
                    if a.to_bits() != b.to_bits() {
                        what.push(format!("{field} {a} → {b}"));
                    }
                }
                if !what.is_empty() {
                    out.push(format!("light '{}' changed: {}", w.name, what.join(", ")));
                }
            }
        }
    }
    for n in now {
        if !was.iter().any(|w| w.name == n.name) {
            out.push(format!("light '{}' ({}) added", n.name, n.kind_name()));
        }
    }
    // (The VPL counts are results, not inputs: not compared.)
    if out.is_empty() && !was.iter().map(|l| &l.name).eq(now.iter().map(|l| &l.name)) {
        out.push("the lights' order changed".into());
    }
    out
}

#[cfg(test)]
mod light_change_tests {
    use super::*;

    fn lamp(name: &str, kind: u8, x: f32) -> LightRecord {
        LightRecord {
            name: name.into(),
            kind,
            color: [1.0, 2.0, 3.0],
            position: [x, 1.0, 0.0],
            direction: [0.0, -1.0, 0.0],
            inner_cone: 0.0,
            outer_cone: 0.0,
            range: 0.0,
            vpls: 1,
        }
    }

    /// Each kind of change is named with the light; nothing for equal sets.
    #[test]
    fn light_changes_name_what_changed() {
        let was = vec![lamp("A", LIGHT_POINT, 0.0), lamp("B", LIGHT_SPOT, 1.0)];
        assert!(light_changes(&was, &was).is_empty());
        let mut rebaked = was.clone();
        rebaked[0].vpls = 99;
        assert!(
            light_changes(&was, &rebaked).is_empty(),
            "VPL counts are results"
        );
        let mut now = was.clone();
        now[0].position[0] = 0.5;
        now[1].range = 4.0;
        now.push(lamp("C", LIGHT_DIRECTIONAL, 0.0));
        let c = light_changes(&was, &now);
        assert_eq!(c.len(), 3, "{c:?}");
        assert!(c[0].starts_with("light 'A' changed: position"), "{c:?}");
        assert!(c[1].contains("'B' changed: range 0 → 4"), "{c:?}");
        assert_eq!(c[2], "light 'C' (directional) added");
        let c = light_changes(&now, &was[..1]);
        assert!(c.iter().any(|l| l == "light 'B' (spot) removed"), "{c:?}");
        let swapped = vec![was[1].clone(), was[0].clone()];
        assert_eq!(light_changes(&was, &swapped), ["the lights' order changed"]);
    }
}
