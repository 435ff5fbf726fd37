//! [`diff`]: compares two assets under a [`Tolerance`] (settings, scene hash,
//! light view, VPL sets, their near-field trees and coherences, every map)
//! and reports what differs
//! ([`DiffReport`], `Display` + `Serialize`); [`write_diff_images`] writes
//! `|A − B|` EXRs of the maps that differ.

use std::collections::HashMap;
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::MapAtlas;
use crate::exrio::{self, Samples};
use crate::{Asset, AssetError, NO_MAP, VplRecord};

/// How far apart two assets may be and still count as equal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tolerance {
    /// Relative tolerance per map texel: `|a − b| ≤ map_rel · max(|a|, |b|)`
    /// passes (also used for the light view's numbers).
    pub map_rel: f32,
    /// Absolute tolerance per map texel (in the map's units) that always
    /// passes, whatever `map_rel` says. Maps are in scene units, so keep it 0
    /// for scale-invariant comparisons.
    pub map_abs_texels: f32,
    /// VPL position tolerance, relative to the scene diagonal (the diagonal
    /// of the bounding box of all VPL positions of both assets).
    pub vpl_position_rel: f32,
    /// VPL normal tolerance (angle, degrees).
    pub vpl_normal_deg: f32,
    /// VPL flux (and area) tolerance, relative: `‖Φa − Φb‖ / max(‖Φa‖, ‖Φb‖)`.
    pub vpl_flux_rel: f32,
    /// Fraction of a map's texels that may be over tolerance (0 = none).
    pub max_texels_over: f64,
    /// Count provenance differences (adapter, driver, baker version) as
    /// differences; by default they are only reported.
    pub strict_provenance: bool,
}

impl Tolerance {
    /// Everything exact: the same scene, settings and adapter must give
    /// byte-identical assets, so any difference counts.
    pub fn same_machine() -> Tolerance {
        Tolerance {
            map_rel: 0.0,
            map_abs_texels: 0.0,
            vpl_position_rel: 0.0,
            vpl_normal_deg: 0.0,
            vpl_flux_rel: 0.0,
            max_texels_over: 0.0,
            strict_provenance: false,
        }
    }

    /// For a bake on another GPU or driver: maps within 1e-3 relative with at
    /// most 0.5 % of texels over; VPL positions within 1e-3 of the scene
    /// diagonal, normals within 1°, flux within 1e-3 relative.
    pub fn another_gpu() -> Tolerance {
        Tolerance {
            map_rel: 1e-3,
            map_abs_texels: 0.0,
            vpl_position_rel: 1e-3,
            vpl_normal_deg: 1.0,
            vpl_flux_rel: 1e-3,
            max_texels_over: 0.005,
            strict_provenance: false,
        }
    }
}

impl Default for Tolerance {
    fn default() -> Self {
        Tolerance::same_machine()
    }
}

/// One field that differs.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FieldDiff {
    /// Field name.
    pub field: String,
    /// Value in A.
    pub a: String,
    /// Value in B.
    pub b: String,
}

/// A VPL that is unmatched or over tolerance.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VplMismatch {
    /// Index in A (`None`: only in B).
    pub a: Option<usize>,
    /// Index in B (`None`: only in A).
    pub b: Option<usize>,
    /// Position (A's when matched or only in A, else B's).
    pub position: [f32; 3],
    /// Position difference relative to the scene diagonal (0 when unmatched).
    pub position_rel: f64,
    /// Normal difference, degrees.
    pub normal_deg: f64,
    /// Relative flux difference.
    pub flux_rel: f64,
    /// Relative area difference.
    pub area_rel: f64,
}

/// Comparison of the VPL sets.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VplDiff {
    /// VPLs in A.
    pub count_a: usize,
    /// VPLs in B.
    pub count_b: usize,
    /// `"index"` (same count, every pair close) or `"nearest"` (mutual
    /// nearest neighbours within 2 % of the scene diagonal).
    pub matching: String,
    /// Matched pairs.
    pub matched: usize,
    /// VPLs of A with no partner in B.
    pub unmatched_a: usize,
    /// VPLs of B with no partner in A.
    pub unmatched_b: usize,
    /// Scene diagonal used to normalise positions.
    pub scene_diagonal: f64,
    /// Largest position difference of a pair, relative to the diagonal.
    pub max_position_rel: f64,
    /// RMS position difference, relative to the diagonal.
    pub rms_position_rel: f64,
    /// Largest normal difference (degrees).
    pub max_normal_deg: f64,
    /// RMS normal difference (degrees).
    pub rms_normal_deg: f64,
    /// Largest relative flux difference.
    pub max_flux_rel: f64,
    /// RMS relative flux difference.
    pub rms_flux_rel: f64,
    /// Largest relative area difference.
    pub max_area_rel: f64,
    /// Pairs whose RSM texel counts differ (reported only).
    pub texel_count_differs: usize,
    /// Matched pairs over tolerance.
    pub over_tolerance: usize,
    /// The worst VPLs (unmatched first), at most 10.
    pub worst: Vec<VplMismatch>,
    /// No unmatched VPL and no pair over tolerance.
    pub within_tolerance: bool,
}

/// Comparison of the matched VPLs' near-field trees (`vpl_nodes.bin`) and
/// their level-3 nodes' texel coherences (`vpl_coherence.bin`): shading
/// draws a VPL near a receiver from these, so two bakes whose VPLs agree
/// but whose trees do not render differently. Node records are held to the
/// VPL tolerances (position against the scene diagonal, normal, flux and
/// area); a coherence to `map_rel` (`|a − b| ≤ map_rel · max(|a|, |b|)`).
/// An asset without coherences (format 4.0, 4.1) counts as all 1, as it
/// renders.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TreeDiff {
    /// Whether both assets have a tree for every VPL (else see `note`).
    pub comparable: bool,
    /// Matched VPL pairs whose trees were compared.
    pub pairs: usize,
    /// Node records compared.
    pub nodes: u64,
    /// Node records over tolerance.
    pub nodes_over: u64,
    /// Largest position difference of a node, relative to the diagonal.
    pub max_position_rel: f64,
    /// Largest normal difference of a node (degrees; nodes with texels).
    pub max_normal_deg: f64,
    /// Largest relative flux (or area) difference of a node.
    pub max_flux_rel: f64,
    /// Level-3 coherences compared.
    pub coherences: u64,
    /// Coherences over tolerance.
    pub coherences_over: u64,
    /// Largest absolute coherence difference.
    pub max_coherence_diff: f64,
    /// The A index of the VPL with the most nodes and coherences over
    /// tolerance (`None` when none is).
    pub worst_vpl: Option<usize>,
    /// Nodes and coherences over tolerance in that VPL.
    pub worst_vpl_over: u64,
    /// Why not comparable, if so.
    pub note: String,
    /// Comparable and nothing over tolerance.
    pub within_tolerance: bool,
}

/// Comparison of one map (or one RSM channel, or all hemisphere maps).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapDiff {
    /// `primary_depth`, `vpl_maps`, `vpl_lower_maps` (the second maps of
    /// the matched VPLs, format 4.7; only when either asset stores one),
    /// `light_maps`, `rsm.D`, `rsm.share`,
    /// `rsm.vpl` (the RSM's VPL-index channel is compared through the VPL
    /// matching), `view_rsms.Z`, `view_rsms.share`, `view_rsms.vpl` (every
    /// view RSM, tile by tile; `view_rsms` when not comparable).
    pub name: String,
    /// Whether both exist with the same dimensions (else see `note`).
    pub comparable: bool,
    /// Texels compared.
    pub texels: u64,
    /// Largest absolute difference over texels finite in both.
    pub max_abs: f64,
    /// RMS difference over texels finite in both.
    pub rmse: f64,
    /// Texels over tolerance (including infinite vs finite).
    pub over: u64,
    /// `over / texels`.
    pub over_fraction: f64,
    /// Texels infinite (no surface) in one and finite in the other.
    pub inf_mismatch: u64,
    /// For `vpl_maps` (`vpl_lower_maps`): the A index of the VPL whose
    /// map is worst.
    pub worst_vpl: Option<usize>,
    /// For `vpl_maps` (`vpl_lower_maps`): texels over tolerance in that
    /// worst map.
    pub worst_layer_over: u64,
    /// For `vpl_maps` (`vpl_lower_maps`): largest absolute difference in
    /// that worst map.
    pub worst_layer_max_abs: f64,
    /// Why not comparable, if so.
    pub note: String,
    /// Comparable and `over_fraction ≤ max_texels_over`.
    pub within_tolerance: bool,
}

/// What [`diff`] found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiffReport {
    /// The tolerance used.
    pub tolerance: Tolerance,
    /// Settings that differ.
    pub settings: Vec<FieldDiff>,
    /// Provenance fields that differ (differences only with
    /// `strict_provenance`).
    pub provenance: Vec<FieldDiff>,
    /// Static scene hash, when it differs.
    pub static_scene_hash: Option<FieldDiff>,
    /// How the baked lights differ ([`crate::light_changes`]; both assets
    /// 3.1 or later), one line each.
    pub lights: Vec<String>,
    /// The scene options the bakes applied ([`crate::Manifest::scene_options`],
    /// as the bake's flags), when they differ; a difference only when both
    /// assets record them (format 4.4), else reported only.
    pub scene_options: Option<FieldDiff>,
    /// How the bounces after the first differ ([`crate::Manifest::later`],
    /// format 4.6): what was asked and kept exactly, the light each bounce
    /// carries within `vpl_flux_rel` of the largest.
    pub later: Vec<FieldDiff>,
    /// Light view fields that differ beyond `map_rel`.
    pub light_view: Vec<FieldDiff>,
    /// The VPL sets.
    pub vpls: VplDiff,
    /// The matched VPLs' near-field trees and coherences.
    pub trees: TreeDiff,
    /// Every map.
    pub maps: Vec<MapDiff>,
    /// One line per difference that counts; empty when equal.
    pub differences: Vec<String>,
}

impl DiffReport {
    /// True when nothing differs beyond the tolerance.
    pub fn equal(&self) -> bool {
        self.differences.is_empty()
    }
}

// ---------------------------------------------------------------- VPL matching

/// Matching radius, relative to the scene diagonal.
const MATCH_RADIUS: f64 = 0.02;

struct Matching {
    pairs: Vec<(usize, usize)>,
    unmatched_a: Vec<usize>,
    unmatched_b: Vec<usize>,
    by_index: bool,
    diag: f64,
}

fn pos(v: &VplRecord) -> [f64; 3] {
    v.position.map(|x| x as f64)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// The scene's diagonal, the yardstick of VPL positions: the diagonal of
/// the volume the light view of A covers (its clip volume mapped back to
/// world space; the light view is fitted to the scene's bounds, whatever the
/// bake's settings), so two bakes of one scene get the same yardstick.
/// Falls back to the bounding box of both assets' VPLs when the light view
/// cannot be inverted.
fn scene_diagonal(view: &crate::LightViewRecord, a: &[VplRecord], b: &[VplRecord]) -> f64 {
    if let Some(d) = light_volume_diagonal(&view.view_proj) {
        return d;
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for v in a.iter().chain(b) {
        for k in 0..3 {
            let p = v.position[k] as f64;
            if p.is_finite() {
                lo[k] = lo[k].min(p);
                hi[k] = hi[k].max(p);
            }
        }
    }
    let d = dist(lo, hi);
    if d.is_finite() && d > 0.0 { d } else { 1.0 }
}

/// Inverse of a 4×4 column-major matrix (Gauss–Jordan with partial
/// pivoting, f64), `None` when singular or not finite.
fn invert4(m: &[f32; 16]) -> Option<[[f64; 4]; 4]> {
    // a[row][col]
    let mut a = [[0f64; 8]; 4];
    for (r, row) in a.iter_mut().enumerate() {
        for c in 0..4 {
            row[c] = m[c * 4 + r] as f64;
        }
        row[4 + r] = 1.0;
    }
    for c in 0..4 {
        let p = (c..4).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        let pivot = a[p][c];
        if pivot.is_nan() || pivot.abs() <= 1e-300 || !pivot.is_finite() {
            return None;
        }
        a.swap(c, p);
        let d = a[c][c];
        for x in a[c].iter_mut() {
            *x /= d;
        }
        let pivot_row = a[c];
        for (r, row) in a.iter_mut().enumerate() {
            if r != c {
                let f = row[c];
                for (x, p) in row.iter_mut().zip(pivot_row) {
                    *x -= f * p;
                }
            }
        }
    }
    let mut inv = [[0f64; 4]; 4];
    for r in 0..4 {
        for c in 0..4 {
            inv[r][c] = a[r][4 + c];
        }
    }
    Some(inv)
}

/// Diagonal of the bounding box of the light view's clip volume (x, y in
/// [−1, 1], depth in [0, 1]) in world space.
fn light_volume_diagonal(view_proj: &[f32; 16]) -> Option<f64> {
    let inv = invert4(view_proj)?;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for corner in 0..8 {
        let clip = [
            if corner & 1 == 0 { -1.0 } else { 1.0 },
            if corner & 2 == 0 { -1.0 } else { 1.0 },
            if corner & 4 == 0 { 0.0 } else { 1.0 },
            1.0,
        ];
        let mut w = [0f64; 4];
        for (r, out) in w.iter_mut().enumerate() {
            *out = (0..4).map(|c| inv[r][c] * clip[c]).sum();
        }
        if w[3].is_nan() || w[3].abs() <= 1e-300 {
            return None;
        }
        for k in 0..3 {
            let p = w[k] / w[3];
            lo[k] = lo[k].min(p);
            hi[k] = hi[k].max(p);
        }
    }
    let d = dist(lo, hi);
    (d.is_finite() && d > 0.0).then_some(d)
}

/// Nearest point of `to` (restricted to `live`) within `radius` of `p`,
/// ties to the lowest index.
struct Grid {
    cell: f64,
    origin: [f64; 3],
    cells: HashMap<[i64; 3], Vec<usize>>,
}

impl Grid {
    fn key(&self, p: [f64; 3]) -> [i64; 3] {
        [0, 1, 2].map(|k| ((p[k] - self.origin[k]) / self.cell).floor() as i64)
    }

    fn new(points: &[VplRecord], live: &[bool], cell: f64, origin: [f64; 3]) -> Grid {
        let mut g = Grid {
            cell,
            origin,
            cells: HashMap::new(),
        };
        for (i, v) in points.iter().enumerate() {
            if live[i] {
                let k = g.key(pos(v));
                g.cells.entry(k).or_default().push(i);
            }
        }
        g
    }

    fn nearest(&self, points: &[VplRecord], p: [f64; 3], radius: f64) -> Option<usize> {
        let k = self.key(p);
        let mut best: Option<(f64, usize)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = [
                        k[0].wrapping_add(dx),
                        k[1].wrapping_add(dy),
                        k[2].wrapping_add(dz),
                    ];
                    for &j in self.cells.get(&key).map(Vec::as_slice).unwrap_or(&[]) {
                        let d = dist(p, pos(&points[j]));
                        if d <= radius && best.is_none_or(|(bd, bj)| (d, j) < (bd, bj)) {
                            best = Some((d, j));
                        }
                    }
                }
            }
        }
        best.map(|(_, j)| j)
    }
}

fn match_vpls(view: &crate::LightViewRecord, a: &[VplRecord], b: &[VplRecord]) -> Matching {
    let diag = scene_diagonal(view, a, b);
    let radius = MATCH_RADIUS * diag;
    if a.len() == b.len() && a.iter().zip(b).all(|(x, y)| dist(pos(x), pos(y)) <= radius) {
        return Matching {
            pairs: (0..a.len()).map(|i| (i, i)).collect(),
            unmatched_a: vec![],
            unmatched_b: vec![],
            by_index: true,
            diag,
        };
    }
    let origin = a.first().or(b.first()).map(pos).unwrap_or([0.0; 3]);
    let (mut live_a, mut live_b) = (vec![true; a.len()], vec![true; b.len()]);
    let mut pairs = Vec::new();
    // Mutual nearest neighbours, repeated on what is left.
    for _round in 0..8 {
        let ga = Grid::new(a, &live_a, radius, origin);
        let gb = Grid::new(b, &live_b, radius, origin);
        let mut new = Vec::new();
        for i in (0..a.len()).filter(|&i| live_a[i]) {
            let Some(j) = gb.nearest(b, pos(&a[i]), radius) else {
                continue;
            };
            if ga.nearest(a, pos(&b[j]), radius) == Some(i) {
                new.push((i, j));
            }
        }
        if new.is_empty() {
            break;
        }
        for &(i, j) in &new {
            live_a[i] = false;
            live_b[j] = false;
        }
        pairs.extend(new);
    }
    pairs.sort_unstable();
    Matching {
        pairs,
        unmatched_a: (0..a.len()).filter(|&i| live_a[i]).collect(),
        unmatched_b: (0..b.len()).filter(|&j| live_b[j]).collect(),
        by_index: false,
        diag,
    }
}

fn rel(a: f64, b: f64) -> f64 {
    let m = a.abs().max(b.abs());
    if m == 0.0 { 0.0 } else { (a - b).abs() / m }
}

fn rel3(a: [f32; 3], b: [f32; 3]) -> f64 {
    let (a, b) = (a.map(|x| x as f64), b.map(|x| x as f64));
    let norm = |v: [f64; 3]| dist(v, [0.0; 3]);
    let m = norm(a).max(norm(b));
    if m == 0.0 { 0.0 } else { dist(a, b) / m }
}

fn angle_deg(a: [f32; 3], b: [f32; 3]) -> f64 {
    let (a, b) = (a.map(|x| x as f64), b.map(|x| x as f64));
    let (na, nb) = (dist(a, [0.0; 3]), dist(b, [0.0; 3]));
    if na == 0.0 || nb == 0.0 {
        return if na == nb { 0.0 } else { 90.0 };
    }
    // atan2(|a×b|, a·b) is exact for equal vectors (acos of a rounded
    // cosine is not) and accurate for small angles.
    let cross = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    dist(cross, [0.0; 3]).atan2(dot).to_degrees()
}

/// How far apart two VPL or near-field node records are: position
/// (relative to the scene diagonal), normal (degrees), flux and area
/// (relative); the VPL tolerances judge all four.
struct RecordDelta {
    position: f64,
    normal: f64,
    flux: f64,
    area: f64,
}

impl RecordDelta {
    fn of(a: &VplRecord, b: &VplRecord, diag: f64) -> Self {
        RecordDelta {
            position: dist(pos(a), pos(b)) / diag,
            normal: angle_deg(a.normal, b.normal),
            flux: rel3(a.flux, b.flux),
            area: rel(a.area as f64, b.area as f64),
        }
    }

    fn over(&self, tol: &Tolerance) -> bool {
        self.position > tol.vpl_position_rel as f64
            || self.normal > tol.vpl_normal_deg as f64
            || self.flux > tol.vpl_flux_rel as f64
            || self.area > tol.vpl_flux_rel as f64
    }
}

fn compare_vpls(a: &[VplRecord], b: &[VplRecord], m: &Matching, tol: &Tolerance) -> VplDiff {
    let mut d = VplDiff {
        count_a: a.len(),
        count_b: b.len(),
        matching: if m.by_index { "index" } else { "nearest" }.into(),
        matched: m.pairs.len(),
        unmatched_a: m.unmatched_a.len(),
        unmatched_b: m.unmatched_b.len(),
        scene_diagonal: m.diag,
        max_position_rel: 0.0,
        rms_position_rel: 0.0,
        max_normal_deg: 0.0,
        rms_normal_deg: 0.0,
        max_flux_rel: 0.0,
        rms_flux_rel: 0.0,
        max_area_rel: 0.0,
        texel_count_differs: 0,
        over_tolerance: 0,
        worst: vec![],
        within_tolerance: true,
    };
    let mut worst = Vec::new();
    for &i in &m.unmatched_a {
        worst.push((f64::INFINITY, mismatch(Some(i), None, a[i].position)));
    }
    for &j in &m.unmatched_b {
        worst.push((f64::INFINITY, mismatch(None, Some(j), b[j].position)));
    }
    let (mut sp, mut sn, mut sf) = (0.0, 0.0, 0.0);
    let score = |x: f64, t: f32| {
        if x == 0.0 {
            0.0
        } else {
            x / (t as f64).max(1e-12)
        }
    };
    for &(i, j) in &m.pairs {
        let (va, vb) = (&a[i], &b[j]);
        let delta = RecordDelta::of(va, vb, m.diag);
        let (p, n, f, ar) = (delta.position, delta.normal, delta.flux, delta.area);
        d.max_position_rel = d.max_position_rel.max(p);
        d.max_normal_deg = d.max_normal_deg.max(n);
        d.max_flux_rel = d.max_flux_rel.max(f);
        d.max_area_rel = d.max_area_rel.max(ar);
        (sp, sn, sf) = (sp + p * p, sn + n * n, sf + f * f);
        if va.texels != vb.texels {
            d.texel_count_differs += 1;
        }
        if delta.over(tol) {
            d.over_tolerance += 1;
            let s = score(p, tol.vpl_position_rel)
                .max(score(n, tol.vpl_normal_deg))
                .max(score(f, tol.vpl_flux_rel))
                .max(score(ar, tol.vpl_flux_rel));
            let mut mm = mismatch(Some(i), Some(j), va.position);
            (mm.position_rel, mm.normal_deg, mm.flux_rel, mm.area_rel) = (p, n, f, ar);
            worst.push((s, mm));
        }
    }
    let k = m.pairs.len().max(1) as f64;
    (d.rms_position_rel, d.rms_normal_deg, d.rms_flux_rel) =
        ((sp / k).sqrt(), (sn / k).sqrt(), (sf / k).sqrt());
    // Stable: unmatched (infinite score) first in index order, then worst first.
    worst.sort_by(|x, y| y.0.total_cmp(&x.0));
    d.worst = worst.into_iter().take(10).map(|(_, m)| m).collect();
    d.within_tolerance = d.unmatched_a == 0 && d.unmatched_b == 0 && d.over_tolerance == 0;
    d
}

fn mismatch(a: Option<usize>, b: Option<usize>, position: [f32; 3]) -> VplMismatch {
    VplMismatch {
        a,
        b,
        position,
        position_rel: 0.0,
        normal_deg: 0.0,
        flux_rel: 0.0,
        area_rel: 0.0,
    }
}

// ---------------------------------------------------------------- trees

fn compare_trees(a: &Asset, b: &Asset, m: &Matching, tol: &Tolerance) -> TreeDiff {
    let mut d = TreeDiff {
        comparable: true,
        pairs: 0,
        nodes: 0,
        nodes_over: 0,
        max_position_rel: 0.0,
        max_normal_deg: 0.0,
        max_flux_rel: 0.0,
        coherences: 0,
        coherences_over: 0,
        max_coherence_diff: 0.0,
        worst_vpl: None,
        worst_vpl_over: 0,
        note: String::new(),
        within_tolerance: true,
    };
    let has_trees = |x: &Asset| x.vpl_nodes.len() == x.vpls.len() * crate::NODES_PER_VPL;
    match (has_trees(a), has_trees(b)) {
        (true, true) => {}
        _ if a.vpl_nodes.is_empty() && b.vpl_nodes.is_empty() => {
            // Neither has trees: nothing to compare, nothing differs.
            d.note = "neither asset has near-field trees".into();
            return d;
        }
        (ta, tb) => {
            d.comparable = false;
            d.within_tolerance = false;
            let side = |t: bool| {
                if t {
                    "a tree per VPL"
                } else {
                    "no tree per VPL"
                }
            };
            d.note = format!("A has {}, B {}", side(ta), side(tb));
            return d;
        }
    }
    // Missing coherences read as 1 (a 4.0 or 4.1 asset renders so).
    let coherence =
        |x: &Asset, i: usize, k: usize| x.level3_coherence(i).get(k).copied().unwrap_or(1.0);
    for &(i, j) in &m.pairs {
        d.pairs += 1;
        let mut over = 0u64;
        for (na, nb) in a.tree(i).iter().zip(b.tree(j)) {
            d.nodes += 1;
            let mut delta = RecordDelta::of(na, nb, m.diag);
            if na.texels == 0 && nb.texels == 0 {
                // Two empty nodes: their normals mean nothing.
                delta.normal = 0.0;
            }
            d.max_position_rel = d.max_position_rel.max(delta.position);
            d.max_normal_deg = d.max_normal_deg.max(delta.normal);
            d.max_flux_rel = d.max_flux_rel.max(delta.flux.max(delta.area));
            if delta.over(tol) {
                over += 1;
            }
        }
        d.nodes_over += over;
        for k in 0..crate::LEVEL3_NODES {
            let (ca, cb) = (coherence(a, i, k), coherence(b, j, k));
            d.coherences += 1;
            let diff = (f64::from(ca) - f64::from(cb)).abs();
            d.max_coherence_diff = d.max_coherence_diff.max(diff);
            if diff > f64::from(tol.map_rel) * f64::from(ca.abs().max(cb.abs())) {
                d.coherences_over += 1;
                over += 1;
            }
        }
        if over > d.worst_vpl_over {
            (d.worst_vpl, d.worst_vpl_over) = (Some(i), over);
        }
    }
    d.within_tolerance = d.nodes_over == 0 && d.coherences_over == 0;
    d
}

// ---------------------------------------------------------------- maps

#[derive(Default, Clone, Copy)]
struct Acc {
    texels: u64,
    finite: u64,
    sum_sq: f64,
    max_abs: f64,
    over: u64,
    inf_mismatch: u64,
}

impl Acc {
    fn add(&mut self, a: f32, b: f32, tol: &Tolerance) {
        self.texels += 1;
        if a.is_finite() && b.is_finite() {
            let d = (a as f64 - b as f64).abs();
            self.finite += 1;
            self.sum_sq += d * d;
            self.max_abs = self.max_abs.max(d);
            let allowed = (tol.map_abs_texels as f64)
                .max(tol.map_rel as f64 * (a.abs() as f64).max(b.abs() as f64));
            if d > allowed {
                self.over += 1;
            }
        } else if a == b || (a.is_nan() && b.is_nan()) {
            // Same infinity (or both NaN): equal.
        } else {
            self.over += 1;
            if a.is_finite() != b.is_finite() {
                self.inf_mismatch += 1;
            }
        }
    }

    fn merge(&mut self, o: &Acc) {
        self.texels += o.texels;
        self.finite += o.finite;
        self.sum_sq += o.sum_sq;
        self.max_abs = self.max_abs.max(o.max_abs);
        self.over += o.over;
        self.inf_mismatch += o.inf_mismatch;
    }

    fn report(&self, name: &str, tol: &Tolerance) -> MapDiff {
        let over_fraction = if self.texels == 0 {
            0.0
        } else {
            self.over as f64 / self.texels as f64
        };
        MapDiff {
            name: name.into(),
            comparable: true,
            texels: self.texels,
            max_abs: self.max_abs,
            rmse: if self.finite == 0 {
                0.0
            } else {
                (self.sum_sq / self.finite as f64).sqrt()
            },
            over: self.over,
            over_fraction,
            inf_mismatch: self.inf_mismatch,
            worst_vpl: None,
            worst_layer_over: 0,
            worst_layer_max_abs: 0.0,
            note: String::new(),
            within_tolerance: self.over as f64 <= tol.max_texels_over * self.texels as f64,
        }
    }
}

/// `rsm.vpl` holds VPL indices, not quantities: its numbers are not
/// differenced. A texel agrees when both are empty, or when its VPL in A is
/// matched (by the VPL matching) to its VPL in B; the rest are counted
/// "over" (no maximum or RMS difference: they would mean nothing).
fn compare_index_maps(name: &str, a: &[u32], b: &[u32], m: &Matching, tol: &Tolerance) -> MapDiff {
    let mut partner: HashMap<u32, u32> = HashMap::with_capacity(m.pairs.len());
    for &(i, j) in &m.pairs {
        partner.insert(i as u32, j as u32);
    }
    let mut acc = Acc::default();
    for (&x, &y) in a.iter().zip(b) {
        acc.texels += 1;
        let same = if x == u32::MAX || y == u32::MAX {
            x == y
        } else {
            partner.get(&x) == Some(&y)
        };
        if !same {
            acc.over += 1;
        }
    }
    let mut r = acc.report(name, tol);
    r.note = "VPL indices: compared through the VPL matching, not as numbers".into();
    r
}

fn not_comparable(name: &str, note: String) -> MapDiff {
    MapDiff {
        name: name.into(),
        comparable: false,
        texels: 0,
        max_abs: 0.0,
        rmse: 0.0,
        over: 0,
        over_fraction: 0.0,
        inf_mismatch: 0,
        worst_vpl: None,
        worst_layer_over: 0,
        worst_layer_max_abs: 0.0,
        note,
        within_tolerance: false,
    }
}

/// A fixed-point flux share as a fraction of its VPL.
fn share_fraction(s: u32) -> f32 {
    (f64::from(s) / f64::from(crate::SHARE_ONE)) as f32
}

fn compare_slices(a: &[f32], b: &[f32], tol: &Tolerance) -> Acc {
    let mut acc = Acc::default();
    for (&x, &y) in a.iter().zip(b) {
        acc.add(x, y, tol);
    }
    acc
}

/// `(A's VPL index, A's map, B's map)`; `None`: not stored (all infinite).
type MapPair = (usize, Option<Vec<f32>>, Option<Vec<f32>>);

/// The hemisphere map pairs to compare: for each matched VPL pair where at
/// least one side stores a map, `(A index, A map or None, B map or None)`,
/// copied out of the atlases one pair at a time.
fn map_pairs<'a>(
    a: &'a Asset,
    b: &'a Asset,
    m: &'a Matching,
) -> impl Iterator<Item = MapPair> + 'a {
    m.pairs
        .iter()
        .filter(|&&(i, j)| a.vpls[i].map != NO_MAP || b.vpls[j].map != NO_MAP)
        .map(|&(i, j)| (i, a.vpl_map_of(i), b.vpl_map_of(j)))
}

fn compare_maps(a: &Asset, b: &Asset, m: &Matching, tol: &Tolerance) -> Vec<MapDiff> {
    let mut out = Vec::new();
    let (pa, pb) = (&a.primary_depth, &b.primary_depth);
    if pa.size != pb.size || pa.data.len() != pb.data.len() {
        out.push(not_comparable(
            "primary_depth",
            format!("size {}² vs {}²", pa.size, pb.size),
        ));
    } else {
        out.push(compare_slices(&pa.data, &pb.data, tol).report("primary_depth", tol));
    }

    let (sa, sb) = (
        a.manifest.settings.vpl_map_size,
        b.manifest.settings.vpl_map_size,
    );
    if sa != sb {
        out.push(not_comparable(
            "vpl_maps",
            format!("map size {sa}² vs {sb}²"),
        ));
    } else {
        let texels = sa as usize * sa as usize;
        let inf = vec![f32::INFINITY; texels];
        let mut total = Acc::default();
        let mut worst: Option<(usize, Acc)> = None;
        for (i, ma, mb) in map_pairs(a, b, m) {
            let (ma, mb) = (ma.as_deref().unwrap_or(&inf), mb.as_deref().unwrap_or(&inf));
            let acc = compare_slices(ma, mb, tol);
            total.merge(&acc);
            let better = |w: &(usize, Acc)| (acc.over, acc.max_abs) > (w.1.over, w.1.max_abs);
            if worst.as_ref().is_none_or(better) {
                worst = Some((i, acc));
            }
        }
        let mut r = total.report("vpl_maps", tol);
        if let Some((i, w)) = worst.filter(|(_, w)| w.over > 0 || w.max_abs > 0.0) {
            (r.worst_vpl, r.worst_layer_over, r.worst_layer_max_abs) = (Some(i), w.over, w.max_abs);
        }
        out.push(r);
        // The second maps (format 4.7), where either side stores one for a
        // matched pair (none: all +inf, as an open map reads).
        if !(a.vpl_lower_maps.is_empty() && b.vpl_lower_maps.is_empty()) {
            let (mut total, mut worst) = (Acc::default(), None::<(usize, Acc)>);
            for &(i, j) in &m.pairs {
                let (ma, mb) = (a.vpl_lower_map_of(i), b.vpl_lower_map_of(j));
                if ma.is_none() && mb.is_none() {
                    continue;
                }
                let (ma, mb) = (ma.as_deref().unwrap_or(&inf), mb.as_deref().unwrap_or(&inf));
                let acc = compare_slices(ma, mb, tol);
                total.merge(&acc);
                let better = |w: &(usize, Acc)| (acc.over, acc.max_abs) > (w.1.over, w.1.max_abs);
                if worst.as_ref().is_none_or(better) {
                    worst = Some((i, acc));
                }
            }
            let mut r = total.report("vpl_lower_maps", tol);
            if let Some((i, w)) = worst.filter(|(_, w)| w.over > 0 || w.max_abs > 0.0) {
                (r.worst_vpl, r.worst_layer_over, r.worst_layer_max_abs) =
                    (Some(i), w.over, w.max_abs);
            }
            out.push(r);
        }
    }

    // The other lights' shadow maps, view by view (a view that stores no
    // map counts as all-infinite), when both have the same views.
    let (va, vb) = (&a.manifest.views, &b.manifest.views);
    let (la, lb) = (a.manifest.light_map_size, b.manifest.light_map_size);
    if va.len() != vb.len() || (!va.is_empty() && la != lb) {
        out.push(not_comparable(
            "light_maps",
            format!("{} views of {la}² vs {} of {lb}²", va.len(), vb.len()),
        ));
    } else if !va.is_empty() {
        let inf = vec![f32::INFINITY; la as usize * la as usize];
        let map = |x: &Asset, tile: u32| {
            (tile != crate::NO_MAP)
                .then(|| x.light_maps.map(tile))
                .flatten()
                .unwrap_or_else(|| inf.clone())
        };
        let mut total = Acc::default();
        for (x, y) in va.iter().zip(vb) {
            total.merge(&compare_slices(&map(a, x.tile), &map(b, y.tile), tol));
        }
        out.push(total.report("light_maps", tol));
    }

    match (&a.rsm, &b.rsm) {
        (None, None) => {}
        (Some(_), None) => out.push(not_comparable("rsm", "stored in A only".into())),
        (None, Some(_)) => out.push(not_comparable("rsm", "stored in B only".into())),
        (Some(ra), Some(rb)) if ra.size != rb.size || ra.metric.len() != rb.metric.len() => out
            .push(not_comparable(
                "rsm",
                format!("size {}² vs {}²", ra.size, rb.size),
            )),
        (Some(ra), Some(rb)) => {
            out.push(compare_slices(&ra.metric, &rb.metric, tol).report("rsm.D", tol));
            // Flux shares as fractions of their VPL (map tolerances apply).
            let mut acc = Acc::default();
            for (&x, &y) in ra.share.iter().zip(&rb.share) {
                acc.add(share_fraction(x), share_fraction(y), tol);
            }
            out.push(acc.report("rsm.share", tol));
            out.push(compare_index_maps("rsm.vpl", &ra.vpl, &rb.vpl, m, tol));
        }
    }
    out.extend(compare_view_rsms(a, b, m, tol));
    out
}

/// The other lights' view RSMs (format 4.1), when both store the same
/// views' at the same size: each channel over every tile (`view_rsms.Z`,
/// `view_rsms.share`, `view_rsms.vpl`, as the RSM's), the note naming the
/// views whose RSM differs. One side only, or different views: not
/// comparable, saying which.
fn compare_view_rsms(a: &Asset, b: &Asset, m: &Matching, tol: &Tolerance) -> Vec<MapDiff> {
    let (va, vb) = (&a.manifest.view_rsms, &b.manifest.view_rsms);
    let name = "view_rsms";
    match (va.is_empty(), vb.is_empty()) {
        (true, true) => return Vec::new(),
        (false, true) => {
            return vec![not_comparable(
                name,
                format!("stored in A only (views {va:?})"),
            )];
        }
        (true, false) => {
            return vec![not_comparable(
                name,
                format!("stored in B only (views {vb:?})"),
            )];
        }
        (false, false) => {}
    }
    if va != vb {
        return vec![not_comparable(
            name,
            format!("A stores the RSMs of views {va:?}, B of views {vb:?}"),
        )];
    }
    let same_size = a.view_rsms.len() == b.view_rsms.len()
        && a.view_rsms
            .iter()
            .zip(&b.view_rsms)
            .all(|(x, y)| x.size == y.size && x.metric.len() == y.metric.len());
    if !same_size {
        let size = |x: &Asset| x.view_rsms.first().map_or(0, |r| r.size);
        return vec![not_comparable(
            name,
            format!("size {}² vs {}²", size(a), size(b)),
        )];
    }
    let (mut metric, mut share) = (Acc::default(), Acc::default());
    let (mut ia, mut ib) = (Vec::new(), Vec::new());
    let mut differ = Vec::new();
    for ((ra, rb), view) in a.view_rsms.iter().zip(&b.view_rsms).zip(va) {
        let acc = compare_slices(&ra.metric, &rb.metric, tol);
        let mut sh = Acc::default();
        for (&x, &y) in ra.share.iter().zip(&rb.share) {
            sh.add(share_fraction(x), share_fraction(y), tol);
        }
        if acc.over > 0 || acc.max_abs > 0.0 || sh.over > 0 || sh.max_abs > 0.0 || ra.vpl != rb.vpl
        {
            differ.push(*view);
        }
        metric.merge(&acc);
        share.merge(&sh);
        ia.extend_from_slice(&ra.vpl);
        ib.extend_from_slice(&rb.vpl);
    }
    let note = if differ.is_empty() {
        format!("{} views, identical", va.len())
    } else {
        format!("{} of {} views differ: {differ:?}", differ.len(), va.len())
    };
    let mut z = metric.report("view_rsms.Z", tol);
    z.note = note;
    let mut v = compare_index_maps("view_rsms.vpl", &ia, &ib, m, tol);
    v.note = format!("{}; per texel, {}", v.note, z.note);
    let mut sh = share.report("view_rsms.share", tol);
    sh.note = z.note.clone();
    vec![z, sh, v]
}

// ---------------------------------------------------------------- diff

fn field<T: fmt::Display + PartialEq>(out: &mut Vec<FieldDiff>, name: &str, a: &T, b: &T) {
    if a != b {
        out.push(FieldDiff {
            field: name.into(),
            a: a.to_string(),
            b: b.to_string(),
        });
    }
}

/// A VPL budget as the command line gives it.
fn budget(b: Option<u32>) -> String {
    b.map_or_else(|| "none (--threshold)".into(), |n| format!("--vpls {n}"))
}

/// Numbers as a bracketed, comma-separated list.
fn numbers(v: &[f32]) -> String {
    let items: Vec<String> = v.iter().map(|x| x.to_string()).collect();
    format!("[{}]", items.join(", "))
}

fn close_arrays(out: &mut Vec<FieldDiff>, name: &str, a: &[f32], b: &[f32], rel_tol: f32) {
    let scale = a.iter().chain(b).fold(0f32, |m, x| m.max(x.abs()));
    let ok = a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x == y || (x - y).abs() <= rel_tol * scale);
    if !ok {
        out.push(FieldDiff {
            field: name.into(),
            a: numbers(a),
            b: numbers(b),
        });
    }
}

/// Compares asset `a` with asset `b` under `tol`: settings, provenance
/// (reported; counted only with `strict_provenance`), static scene hash,
/// light view, the VPL sets (matched by index when the counts agree and every
/// pair is close, else by mutual nearest neighbours within 2 % of the scene
/// diagonal) and every map (`primary_depth`; the hemisphere maps of matched
/// VPLs, a missing map counting as all-infinite; each RSM channel). Infinity
/// equals infinity; infinite vs finite is over tolerance.
pub fn diff(a: &Asset, b: &Asset, tol: &Tolerance) -> DiffReport {
    let (ma, mb) = (&a.manifest, &b.manifest);
    let mut differences = Vec::new();

    let mut settings = Vec::new();
    let (sa, sb) = (&ma.settings, &mb.settings);
    field(&mut settings, "rsm_size", &sa.rsm_size, &sb.rsm_size);
    field(
        &mut settings,
        "vpl_map_size",
        &sa.vpl_map_size,
        &sb.vpl_map_size,
    );
    field(
        &mut settings,
        "shadow_map_size",
        &sa.shadow_map_size,
        &sb.shadow_map_size,
    );
    field(
        &mut settings,
        "threshold",
        &sa.threshold.to_bits(),
        &sb.threshold.to_bits(),
    );
    if let Some(f) = settings.last_mut().filter(|f| f.field == "threshold") {
        (f.a, f.b) = (sa.threshold.to_string(), sb.threshold.to_string());
    }
    field(
        &mut settings,
        "vpl_budget",
        &budget(sa.vpl_budget),
        &budget(sb.vpl_budget),
    );
    for f in &settings {
        differences.push(format!("settings: {} {} vs {}", f.field, f.a, f.b));
    }

    let mut provenance = Vec::new();
    let (pa, pb) = (&ma.provenance, &mb.provenance);
    field(
        &mut provenance,
        "baker_version",
        &pa.baker_version,
        &pb.baker_version,
    );
    field(
        &mut provenance,
        "scene_name",
        &pa.scene_name,
        &pb.scene_name,
    );
    field(&mut provenance, "adapter", &pa.adapter, &pb.adapter);
    field(&mut provenance, "backend", &pa.backend, &pb.backend);
    field(&mut provenance, "driver", &pa.driver, &pb.driver);
    if tol.strict_provenance {
        for f in &provenance {
            differences.push(format!("provenance: {} {} vs {}", f.field, f.a, f.b));
        }
    }

    let static_scene_hash = (ma.static_scene_hash != mb.static_scene_hash).then(|| {
        let hex = |h: &[u8; 32]| h.iter().map(|b| format!("{b:02x}")).collect::<String>();
        FieldDiff {
            field: "static_scene_hash".into(),
            a: hex(&ma.static_scene_hash),
            b: hex(&mb.static_scene_hash),
        }
    });
    let lights = if ma.lights.is_empty() || mb.lights.is_empty() {
        Vec::new()
    } else {
        crate::light_changes(&ma.lights, &mb.lights)
    };
    if static_scene_hash.is_some() {
        // First: every other difference follows from it.
        let how = if lights.is_empty() {
            String::new()
        } else {
            format!(" (lights: {})", lights.join("; "))
        };
        differences.insert(
            0,
            format!(
                "different scenes: A was baked from `{}`, B from `{}`, and their static parts differ (static-scene hash){how}; what follows compares two different scenes",
                pa.scene_name, pb.scene_name
            ),
        );
    }

    let flags = |o: &Option<crate::SceneOptions>| {
        o.as_ref()
            .map_or_else(|| "not recorded".to_string(), |o| o.flags_or_none())
    };
    let same_options = match (&ma.scene_options, &mb.scene_options) {
        (Some(x), Some(y)) => x.same(y),
        (x, y) => x.is_none() && y.is_none(),
    };
    let scene_options = (!same_options).then(|| FieldDiff {
        field: "scene_options".into(),
        a: flags(&ma.scene_options),
        b: flags(&mb.scene_options),
    });
    if let (Some(d), Some(_), Some(_)) = (&scene_options, &ma.scene_options, &mb.scene_options) {
        differences.push(format!(
            "scene flags: A was baked with {}, B with {}",
            d.a, d.b
        ));
    }

    let mut later = Vec::new();
    match (&ma.later, &mb.later) {
        (None, None) => {}
        (Some(x), Some(y)) => {
            field(&mut later, "later.bounces", &x.bounces, &y.bounces);
            field(&mut later, "later.vpl_budget", &x.vpl_budget, &y.vpl_budget);
            field(&mut later, "later.vpls", &x.vpls, &y.vpls);
            field(&mut later, "later.left_out", &x.left_out, &y.left_out);
            field(&mut later, "later.converged", &x.converged, &y.converged);
            let flat = |l: &crate::LaterRecord| -> Vec<f32> {
                l.direct
                    .iter()
                    .chain(l.per_bounce.iter().flatten())
                    .chain(&l.tail)
                    .copied()
                    .collect()
            };
            close_arrays(
                &mut later,
                "later light per bounce",
                &flat(x),
                &flat(y),
                tol.vpl_flux_rel,
            );
        }
        (x, y) => {
            let what = |l: &Option<crate::LaterRecord>| match l {
                None => "the first bounce alone".to_string(),
                Some(l) => format!("{} later VPLs", l.vpls),
            };
            later.push(FieldDiff {
                field: "later".into(),
                a: what(x),
                b: what(y),
            });
        }
    }
    // Where the later light came from (format 4.8): the groups exactly,
    // the weights within the flux tolerance.
    match (&ma.later_sources, &mb.later_sources) {
        (None, None) => {}
        (Some(x), Some(y)) => {
            let g = |s: &crate::LaterSources| -> Vec<u32> { s.first.iter().map(|f| f.0).collect() };
            if g(x) != g(y) {
                later.push(FieldDiff {
                    field: "later_sources.first".into(),
                    a: format!("{} VPLs' groups", x.first.len()),
                    b: format!("{} VPLs' groups (not the same)", y.first.len()),
                });
            } else {
                let w =
                    |s: &crate::LaterSources| -> Vec<f32> { s.first.iter().map(|f| f.1).collect() };
                close_arrays(
                    &mut later,
                    "later_sources.first",
                    &w(x),
                    &w(y),
                    tol.vpl_flux_rel,
                );
            }
            let groups =
                |s: &crate::LaterSources| -> Vec<u32> { s.weights.iter().map(|w| w.0).collect() };
            if groups(x) != groups(y) {
                later.push(FieldDiff {
                    field: "later_sources.weights".into(),
                    a: format!("{} pairs", x.weights.len()),
                    b: format!("{} pairs (other groups named)", y.weights.len()),
                });
            } else {
                let w = |s: &crate::LaterSources| -> Vec<f32> {
                    s.weights.iter().map(|w| w.1).collect()
                };
                close_arrays(
                    &mut later,
                    "later_sources.weights",
                    &w(x),
                    &w(y),
                    tol.vpl_flux_rel,
                );
            }
        }
        (x, y) => {
            let what = |s: &Option<crate::LaterSources>| match s {
                None => "not recorded".to_string(),
                Some(s) => format!(
                    "{} later VPLs' sources",
                    s.weights.len() / crate::SOURCES_PER_LATER_VPL
                ),
            };
            later.push(FieldDiff {
                field: "later_sources".into(),
                a: what(x),
                b: what(y),
            });
        }
    }
    for d in &later {
        differences.push(format!("later bounces: {} {} vs {}", d.field, d.a, d.b));
    }

    let mut light_view = Vec::new();
    let (la, lb) = (&ma.light_view, &mb.light_view);
    field(
        &mut light_view,
        "directional",
        &la.directional,
        &lb.directional,
    );
    close_arrays(
        &mut light_view,
        "view_proj",
        &la.view_proj,
        &lb.view_proj,
        tol.map_rel,
    );
    close_arrays(
        &mut light_view,
        "origin",
        &la.origin,
        &lb.origin,
        tol.map_rel,
    );
    close_arrays(
        &mut light_view,
        "direction",
        &la.direction,
        &lb.direction,
        tol.map_rel,
    );
    close_arrays(
        &mut light_view,
        "texel_scale",
        &[la.texel_scale],
        &[lb.texel_scale],
        tol.map_rel,
    );
    close_arrays(
        &mut light_view,
        "texel_area",
        &[la.texel_area],
        &[lb.texel_area],
        tol.map_rel,
    );
    for f in &light_view {
        differences.push(format!("light view: {} differs", f.field));
    }

    let matching = match_vpls(&ma.light_view, &a.vpls, &b.vpls);
    let vpls = compare_vpls(&a.vpls, &b.vpls, &matching, tol);
    if vpls.unmatched_a > 0 || vpls.unmatched_b > 0 {
        differences.push(format!(
            "VPLs: {} of A and {} of B unmatched (counts {} vs {})",
            vpls.unmatched_a, vpls.unmatched_b, vpls.count_a, vpls.count_b
        ));
    }
    if vpls.over_tolerance > 0 {
        differences.push(format!(
            "VPLs: {} matched pairs over tolerance (max position {:.3e} of the diagonal, normal {:.3}°, flux {:.3e})",
            vpls.over_tolerance, vpls.max_position_rel, vpls.max_normal_deg, vpls.max_flux_rel
        ));
    }

    let trees = compare_trees(a, b, &matching, tol);
    if !trees.comparable {
        differences.push(format!("near-field trees: not comparable ({})", trees.note));
    } else if !trees.within_tolerance {
        let worst = trees.worst_vpl.map_or(String::new(), |i| {
            format!("; worst VPL A#{i}, {} over", trees.worst_vpl_over)
        });
        differences.push(format!(
            "near-field trees of matched VPLs: {} of {} nodes and {} of {} level-3 coherences over tolerance (max position {:.3e} of the diagonal, normal {:.3}°, flux {:.3e}, coherence {:.3e}{worst})",
            trees.nodes_over,
            trees.nodes,
            trees.coherences_over,
            trees.coherences,
            trees.max_position_rel,
            trees.max_normal_deg,
            trees.max_flux_rel,
            trees.max_coherence_diff
        ));
    }

    let maps = compare_maps(a, b, &matching, tol);
    for m in maps.iter().filter(|m| !m.within_tolerance) {
        if m.comparable {
            // The view RSMs say which views differ.
            let which = if m.name.starts_with("view_rsms") {
                format!(" ({})", m.note)
            } else {
                String::new()
            };
            differences.push(format!(
                "map {}: {} of {} texels ({:.4}%) over tolerance (allowed {:.4}%), max abs diff {:.4e}{which}",
                m.name,
                m.over,
                m.texels,
                100.0 * m.over_fraction,
                100.0 * tol.max_texels_over,
                m.max_abs
            ));
        } else {
            differences.push(format!("map {}: not comparable ({})", m.name, m.note));
        }
    }

    DiffReport {
        tolerance: tol.clone(),
        settings,
        provenance,
        static_scene_hash,
        lights,
        scene_options,
        later,
        light_view,
        vpls,
        trees,
        maps,
        differences,
    }
}

impl fmt::Display for DiffReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.equal() {
            writeln!(f, "EQUAL within tolerance")?;
        } else {
            let scenes = if self.static_scene_hash.is_some() {
                " (DIFFERENT SCENES)"
            } else {
                ""
            };
            writeln!(
                f,
                "DIFFERENT{scenes}: {} difference(s)",
                self.differences.len()
            )?;
            for d in &self.differences {
                writeln!(f, "  - {d}")?;
            }
        }
        let t = &self.tolerance;
        writeln!(
            f,
            "tolerance: map rel {} abs {}, texels over ≤ {}%, VPL position {} of diagonal, normal {}°, flux {}{}",
            t.map_rel,
            t.map_abs_texels,
            100.0 * t.max_texels_over,
            t.vpl_position_rel,
            t.vpl_normal_deg,
            t.vpl_flux_rel,
            if t.strict_provenance {
                ", strict provenance"
            } else {
                ""
            }
        )?;
        let list = |f: &mut fmt::Formatter<'_>, title: &str, v: &[FieldDiff]| -> fmt::Result {
            if v.is_empty() {
                return writeln!(f, "{title}: same");
            }
            writeln!(f, "{title}:")?;
            for d in v {
                writeln!(f, "  {}: {} vs {}", d.field, d.a, d.b)?;
            }
            Ok(())
        };
        list(f, "settings", &self.settings)?;
        let prov_title = if self.tolerance.strict_provenance {
            "provenance"
        } else {
            "provenance (reported only)"
        };
        list(f, prov_title, &self.provenance)?;
        match &self.static_scene_hash {
            None => writeln!(f, "static scene hash: same")?,
            Some(h) => writeln!(f, "static scene hash: {} vs {}", h.a, h.b)?,
        }
        for l in &self.lights {
            writeln!(f, "  {l}")?;
        }
        match &self.scene_options {
            None => writeln!(f, "scene flags: same")?,
            Some(d) => writeln!(f, "scene flags: {} vs {}", d.a, d.b)?,
        }
        list(f, "later bounces", &self.later)?;
        list(f, "light view", &self.light_view)?;
        let v = &self.vpls;
        writeln!(
            f,
            "VPLs: {} vs {}, matched {} by {}, unmatched {} in A / {} in B (scene diagonal {:.4})",
            v.count_a,
            v.count_b,
            v.matched,
            v.matching,
            v.unmatched_a,
            v.unmatched_b,
            v.scene_diagonal
        )?;
        writeln!(
            f,
            "  position max {:.3e} rms {:.3e} (of diagonal); normal max {:.3}° rms {:.3}°; flux max {:.3e} rms {:.3e}; area max {:.3e}",
            v.max_position_rel,
            v.rms_position_rel,
            v.max_normal_deg,
            v.rms_normal_deg,
            v.max_flux_rel,
            v.rms_flux_rel,
            v.max_area_rel
        )?;
        if v.texel_count_differs > 0 {
            writeln!(
                f,
                "  {} matched pairs cover different RSM texel counts",
                v.texel_count_differs
            )?;
        }
        for w in &v.worst {
            let idx = |x: Option<usize>| x.map_or("-".to_string(), |i| i.to_string());
            match (w.a, w.b) {
                (Some(_), Some(_)) => writeln!(
                    f,
                    "  VPL A#{} / B#{} at {:?}: position {:.3e}, normal {:.3}°, flux {:.3e}, area {:.3e}",
                    idx(w.a),
                    idx(w.b),
                    w.position,
                    w.position_rel,
                    w.normal_deg,
                    w.flux_rel,
                    w.area_rel
                )?,
                (Some(_), None) => {
                    writeln!(f, "  VPL A#{} at {:?}: no match in B", idx(w.a), w.position)?
                }
                _ => writeln!(f, "  VPL B#{} at {:?}: no match in A", idx(w.b), w.position)?,
            }
        }
        let t = &self.trees;
        if !t.comparable {
            writeln!(f, "near-field trees: not comparable: {}", t.note)?;
        } else if t.pairs > 0 {
            writeln!(
                f,
                "near-field trees: {} nodes of {} matched VPLs, over {}; position max {:.3e}, normal max {:.3}°, flux max {:.3e}; level-3 coherences {}, over {}, max diff {:.3e}  {}",
                t.nodes,
                t.pairs,
                t.nodes_over,
                t.max_position_rel,
                t.max_normal_deg,
                t.max_flux_rel,
                t.coherences,
                t.coherences_over,
                t.max_coherence_diff,
                if t.within_tolerance {
                    "ok"
                } else {
                    "DIFFERENT"
                }
            )?;
        }
        writeln!(f, "maps:")?;
        for m in &self.maps {
            if !m.comparable {
                writeln!(f, "  {:<14} not comparable: {}", m.name, m.note)?;
                continue;
            }
            writeln!(
                f,
                "  {:<14} {:>10} texels  max abs {:.4e}  rmse {:.4e}  over {} ({:.4}%), inf/finite {}  {}",
                m.name,
                m.texels,
                m.max_abs,
                m.rmse,
                m.over,
                100.0 * m.over_fraction,
                m.inf_mismatch,
                if m.within_tolerance {
                    "ok"
                } else {
                    "DIFFERENT"
                }
            )?;
            if let Some(i) = m.worst_vpl {
                writeln!(
                    f,
                    "  {:<14} worst: map of VPL A#{i}, {} texels over, max abs {:.4e}",
                    "", m.worst_layer_over, m.worst_layer_max_abs
                )?;
            }
        }
        Ok(())
    }
}

// ---------------------------------------------------------------- images

fn abs_diff(a: f32, b: f32) -> f32 {
    if a == b || (a.is_nan() && b.is_nan()) {
        0.0
    } else if a.is_finite() && b.is_finite() {
        (a - b).abs()
    } else {
        f32::INFINITY
    }
}

fn write_exr(
    dir: &Path,
    name: &str,
    w: usize,
    h: usize,
    channels: Vec<(&str, Samples)>,
) -> Result<PathBuf, AssetError> {
    let path = dir.join(name);
    let bytes = exrio::encode(w, h, channels)
        .map_err(|e| AssetError::invalid(&path, format!("cannot encode EXR: {e}")))?;
    // Through a temporary sibling and a rename, as every output: a full
    // disk leaves the old image (or none), never a short one under its name.
    let mut out = gibake_output::FileWriter::create(&path, &mut |_| {})?;
    out.file()
        .write_all(&bytes)
        .map_err(|e| AssetError::io(&path, e))?;
    out.commit()?;
    Ok(path)
}

/// Writes an EXR of `|A − B|` (channel `D`; infinity where one side is
/// infinite and the other not, 0 where both are infinite) into `dir` for
/// each map that differs and has the same size in both:
/// `primary_depth.diff.exr`; `vpl_maps.diff.exr`, an atlas (layout as in
/// `vpl_maps.exr`) with one tile per matched VPL pair where either side
/// stores a map, in A's VPL order (a missing map counts as all-infinite);
/// `rsm.diff.exr` with channels `Z`, `share` (the difference of the flux
/// shares, as fractions of their VPL) and `vpl` (1 where the VPL index
/// differs). Creates `dir` if needed; returns the
/// paths written (none when nothing differs).
pub fn write_diff_images(a: &Asset, b: &Asset, dir: &Path) -> Result<Vec<PathBuf>, AssetError> {
    std::fs::create_dir_all(dir).map_err(|e| AssetError::io(dir, e))?;
    let mut written = Vec::new();
    let diffs = |x: &[f32], y: &[f32]| -> Vec<f32> {
        x.iter().zip(y).map(|(&p, &q)| abs_diff(p, q)).collect()
    };
    let nonzero = |v: &[f32]| v.iter().any(|&x| x != 0.0);

    let (pa, pb) = (&a.primary_depth, &b.primary_depth);
    if pa.size == pb.size && pa.data.len() == pb.data.len() {
        let d = diffs(&pa.data, &pb.data);
        if nonzero(&d) {
            let n = pa.size as usize;
            let ch = vec![("Z", Samples::F32(d))];
            written.push(write_exr(dir, "primary_depth.diff.exr", n, n, ch)?);
        }
    }

    let size = a.manifest.settings.vpl_map_size;
    if size == b.manifest.settings.vpl_map_size {
        let matching = match_vpls(&a.manifest.light_view, &a.vpls, &b.vpls);
        let texels = size as usize * size as usize;
        let inf = vec![f32::INFINITY; texels];
        let tiles: Vec<Vec<f32>> = map_pairs(a, b, &matching)
            .map(|(_, ma, mb)| diffs(ma.as_deref().unwrap_or(&inf), mb.as_deref().unwrap_or(&inf)))
            .collect();
        let atlas = MapAtlas::from_maps(size, tiles.iter().map(|t| t.as_slice()));
        if let Some(atlas) = atlas.filter(|_| tiles.iter().any(|t| nonzero(t))) {
            let (w, h) = (atlas.width() as usize, atlas.height() as usize);
            let ch = vec![("Z", Samples::F32(atlas.texels().to_vec()))];
            written.push(write_exr(dir, "vpl_maps.diff.exr", w, h, ch)?);
        }
    }

    if let (Some(ra), Some(rb)) = (&a.rsm, &b.rsm)
        && ra.size == rb.size
        && ra.metric.len() == rb.metric.len()
    {
        let d = diffs(&ra.metric, &rb.metric);
        let share: Vec<f32> = ra
            .share
            .iter()
            .zip(&rb.share)
            .map(|(&x, &y)| abs_diff(share_fraction(x), share_fraction(y)))
            .collect();
        let v: Vec<f32> = ra
            .vpl
            .iter()
            .zip(&rb.vpl)
            .map(|(x, y)| if x == y { 0.0 } else { 1.0 })
            .collect();
        if [&d, &share, &v].iter().any(|c| nonzero(c)) {
            let n = ra.size as usize;
            let ch = vec![
                ("Z", Samples::F32(d)),
                ("share", Samples::F32(share)),
                ("vpl", Samples::F32(v)),
            ];
            written.push(write_exr(dir, "rsm.diff.exr", n, n, ch)?);
        }
    }
    Ok(written)
}
