//! The later bounces' VPLs: the surfels' re-emitted light — each passes on
//! `albedo · E · area` of the light it received from the first bounce on —
//! clustered into VPLs the runtime shades as it shades the first bounce's
//! (hemisphere map, near-field tree, far-field lobe).
//!
//! The surfels with light are split as a binary tree: a node splits at the
//! median of its widest key — a position axis, or a normal axis times the
//! node's diagonal, so that a corner's floor and wall part before its two
//! halves do. Nodes are split greedily in non-increasing capped score
//! `S = max(D, Nn) · share²` (the RSM clustering's rule, crate::cluster):
//! `D` the positions' variance over the level's diagonal squared, `Nn =
//! 1 − |Σ w n| / Σ w`, `share` the node's part of the light; until the
//! budget is met. A cluster is a VPL at its surfel nearest its flux-
//! weighted centroid (on its own surface, as a first-bounce VPL's anchor),
//! its near-field tree an `8 × 8` grid over its surfels in its own tangent
//! plane (the layout of `crate::near_field`), each finest node on a surfel
//! with the disk its surfels spread over (`Anchors::onto_surfels`).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use gibake_asset::VplRecord;
use gibake_raycast::RayScene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::surfels::Surfels;
use crate::near_field::{Anchors, Sums, tree_of_cells};

/// One later-bounce VPL: its record and near-field tree.
pub struct Secondary {
    /// The VPLs (no map yet).
    pub vpls: Vec<VplRecord>,
    /// Their near-field trees, `gibake_asset::NODES_PER_VPL` each.
    pub nodes: Vec<VplRecord>,
    /// Their level-3 nodes' coherences.
    pub coherence: Vec<f32>,
    /// Per surfel: its VPL (an index into `vpls`), or `u32::MAX` (no light,
    /// or its VPL was empty).
    pub surfel_vpl: Vec<u32>,
}

#[derive(Clone, Copy, Default)]
struct Stats {
    w: f64,
    wp: DVec3,
    /// `Σ w p pᵀ`.
    wpp: glam::DMat3,
    wn: DVec3,
}

impl Stats {
    /// `S = max(size, depth, Nn, hidden) · share²` (module docs): `size` the
    /// positions' variance over the level's diagonal squared, `depth` the
    /// share of it along the mean normal (0 for one surface, up to 1 for
    /// floors stacked at several heights), `Nn = 1 − |Σ w n| / Σ w`,
    /// `hidden` the share of the light of the surfels that do not see the
    /// node's origin (two rooms' floors, coplanar, a wall between them).
    fn score(&self, diag2: f64, total: f64, hidden: f64) -> f32 {
        if !super::gt(self.w, 0.0) {
            return 0.0;
        }
        let mean = self.wp / self.w;
        let cov = self.wpp * (1.0 / self.w)
            - glam::DMat3::from_cols(mean * mean.x, mean * mean.y, mean * mean.z);
        let trace = (cov.x_axis.x + cov.y_axis.y + cov.z_axis.z).max(0.0);
        let n = self.wn.normalize_or_zero();
        let along = n.dot(cov * n).clamp(0.0, trace);
        let depth = if trace > 0.0 { along / trace } else { 0.0 };
        let size = trace / diag2;
        let nn = (1.0 - self.wn.length() / self.w).max(0.0);
        let share = self.w / total;
        let s = size.max(depth).max(nn).max(hidden) * share * share;
        if s.is_nan() {
            f32::INFINITY
        } else {
            // To 11 bits of mantissa: a score moved by rounding (the same
            // level in other units) keeps its place among the others.
            f32::from_bits((s as f32).to_bits() & !0xfff)
        }
    }
}

#[derive(Clone, Copy)]
struct Entry {
    e: f32,
    node: usize,
    /// Where the node's surfels start in the clustering's order: a tie
    /// breaks by place in the tree, not by when the node was made.
    lo: usize,
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    /// Larger `e` first, then the node earlier in the tree.
    fn cmp(&self, o: &Self) -> Ordering {
        self.e.total_cmp(&o.e).then(o.lo.cmp(&self.lo))
    }
}

/// Clusters the surfels with light (`emitted`: each one's re-emitted flux,
/// W RGB) into at most `budget` VPLs, `diag` the level's diagonal.
pub fn cluster(
    rays: &RayScene<'_>,
    surfels: &Surfels,
    emitted: &[Vec3],
    budget: u32,
    diag: f32,
) -> Secondary {
    let weight = |i: usize| {
        let f = emitted[i];
        f64::from(f.x) + f64::from(f.y) + f64::from(f.z)
    };
    let mut order: Vec<u32> = (0..surfels.len() as u32)
        .filter(|&i| {
            let w = weight(i as usize);
            w > 0.0 && w.is_finite()
        })
        .collect();
    let empty = Secondary {
        vpls: Vec::new(),
        nodes: Vec::new(),
        coherence: Vec::new(),
        surfel_vpl: vec![u32::MAX; surfels.len()],
    };
    if order.is_empty() || budget == 0 {
        return empty;
    }
    let stats = |ids: &[u32]| {
        let mut s = Stats::default();
        for &i in ids {
            let (w, p, n) = (
                weight(i as usize),
                surfels.position[i as usize].as_dvec3(),
                surfels.normal[i as usize].as_dvec3(),
            );
            s.w += w;
            s.wp += p * w;
            s.wpp += glam::DMat3::from_cols(p * p.x, p * p.y, p * p.z) * w;
            s.wn += n * w;
        }
        s
    };
    let total = stats(&order).w;
    let diag2 = f64::from(diag).powi(2).max(f64::MIN_POSITIVE);
    // The share of a node's light whose surfels do not see its origin (its
    // surfel nearest the flux-weighted centroid), each end a quarter of
    // the spacing off its surface (a segment along the surface itself
    // would graze its seams).
    let lift = 0.25 * surfels.spacing;
    let hidden = |ids: &[u32], st: &Stats| -> f64 {
        if !super::gt(st.w, 0.0) {
            return 0.0;
        }
        let c = (st.wp / st.w).as_vec3();
        let a = anchor_of(surfels, ids, c);
        let o = surfels.position[a as usize] + surfels.normal[a as usize] * lift;
        let seen: Vec<bool> = ids
            .par_iter()
            .map(|&i| {
                let p = surfels.position[i as usize] + surfels.normal[i as usize] * lift;
                let d = o - p;
                let l = d.length();
                !super::gt(l, 0.0) || !rays.occluded(p, d / l, l)
            })
            .collect();
        let mut h = 0.0;
        for (&i, &s) in ids.iter().zip(&seen) {
            if !s {
                h += weight(i as usize);
            }
        }
        h / st.w
    };
    // Nodes: ranges of `order`; leaves are the current clusters.
    // First by which way each surfel faces (the axis its normal is nearest,
    // and its sign): a VPL of surfels facing one way is a surface, as a
    // first-bounce VPL of RSM texels is, so its tree and its lobe stand for
    // it; a room's floor, walls and ceiling in one VPL sent light every way
    // from one disk (the white arena +37% at 64 later VPLs).
    let facing = |i: u32| {
        let n = surfels.normal[i as usize];
        let a = n.abs();
        let axis = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        2 * axis + usize::from(n[axis] < 0.0)
    };
    order.sort_by_key(|&i| (facing(i), i));
    let mut ranges: Vec<(usize, usize)> = Vec::new();
    let mut leaf = Vec::new();
    let mut lo = 0;
    while lo < order.len() {
        let f = facing(order[lo]);
        let mut hi = lo;
        while hi < order.len() && facing(order[hi]) == f {
            hi += 1;
        }
        ranges.push((lo, hi));
        leaf.push(true);
        lo = hi;
    }
    let mut heap = BinaryHeap::new();
    let score = |order: &[u32], lo: usize, hi: usize| {
        let ids = &order[lo..hi];
        let st = stats(ids);
        st.score(diag2, total, hidden(ids, &st))
    };
    for (node, &(lo, hi)) in ranges.iter().enumerate() {
        if hi - lo >= 2 {
            heap.push(Entry {
                e: score(&order, lo, hi),
                node,
                lo,
            });
        }
    }
    // More facings than the budget: the brightest ones.
    if ranges.len() > budget as usize {
        let mut by_light: Vec<usize> = (0..ranges.len()).collect();
        by_light.sort_by(|&a, &b| {
            let w = |n: usize| stats(&order[ranges[n].0..ranges[n].1]).w;
            w(b).total_cmp(&w(a)).then(a.cmp(&b))
        });
        for &n in &by_light[budget as usize..] {
            leaf[n] = false;
        }
        heap.clear();
    }
    let mut clusters = ranges.len().min(budget as usize);
    while clusters < budget as usize {
        let Some(top) = heap.pop() else { break };
        let (lo, hi) = ranges[top.node];
        // The widest key: the two axes across the node's mean normal, the
        // one along it eight times over (floors at two heights part before
        // one floor's halves do), or a normal component times the node's
        // size.
        let ids = &order[lo..hi];
        let mut wn = Vec3::ZERO;
        for &i in ids {
            wn += surfels.normal[i as usize] * weight(i as usize) as f32;
        }
        let nbar = wn.normalize_or_zero();
        let nbar = if nbar == Vec3::ZERO { Vec3::Y } else { nbar };
        let (t, b) = gibake_gpu::orthonormal_basis(nbar);
        let frame = [t, b, nbar];
        let (mut pmin, mut pmax) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        let (mut nmin, mut nmax) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for &i in ids {
            let (p, n) = (surfels.position[i as usize], surfels.normal[i as usize]);
            let q = Vec3::new(t.dot(p), b.dot(p), nbar.dot(p));
            pmin = pmin.min(q);
            pmax = pmax.max(q);
            nmin = nmin.min(n);
            nmax = nmax.max(n);
        }
        let size = (pmax - pmin).length();
        let extents = [
            pmax.x - pmin.x,
            pmax.y - pmin.y,
            (pmax.z - pmin.z) * 8.0,
            (nmax.x - nmin.x) * size,
            (nmax.y - nmin.y) * size,
            (nmax.z - nmin.z) * size,
        ];
        // (Compared to 11 bits of mantissa, as the scores: the same level
        // in other units picks the same axis.)
        let q = |x: f32| f32::from_bits(x.max(0.0).to_bits() & !0xfff);
        let axis = (0..6)
            .max_by(|&a, &b| q(extents[a]).total_cmp(&q(extents[b])).then(b.cmp(&a)))
            .unwrap_or(0);
        let key = |i: u32| {
            let (p, n) = (surfels.position[i as usize], surfels.normal[i as usize]);
            if axis < 3 {
                frame[axis].dot(p)
            } else {
                n[axis - 3]
            }
        };
        order[lo..hi].sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        let mid = lo + (hi - lo) / 2;
        leaf[top.node] = false;
        for (a, b) in [(lo, mid), (mid, hi)] {
            let node = ranges.len();
            ranges.push((a, b));
            leaf.push(true);
            if b - a >= 2 {
                heap.push(Entry {
                    e: score(&order, a, b).min(top.e),
                    node,
                    lo: a,
                });
            }
        }
        clusters += 1;
    }
    let mut out = empty;
    // In tree order (a leaf's surfels are a run of `order`; the runs in
    // order are a depth-first walk of the tree).
    let mut leaves: Vec<(usize, usize)> = ranges
        .iter()
        .zip(&leaf)
        .filter(|(_, l)| **l)
        .map(|(r, _)| *r)
        .collect();
    leaves.sort_unstable();
    for (lo, hi) in leaves {
        let ids = &order[lo..hi];
        let mut all = Sums::default();
        for &i in ids {
            let i = i as usize;
            all.push(
                surfels.position[i],
                surfels.normal[i],
                emitted[i],
                surfels.area[i],
            );
        }
        let mut record = all.record();
        if record.texels == 0 {
            continue;
        }
        // On its own surface: the surfel nearest the centroid.
        let c = Vec3::from_array(record.position);
        record.position = surfels.position[anchor_of(surfels, ids, c) as usize].to_array();
        // The near-field tree: an 8 × 8 grid in the cluster's tangent plane.
        let n = Vec3::from_array(record.normal);
        let (t, b) = gibake_gpu::orthonormal_basis(if n == Vec3::ZERO { Vec3::Y } else { n });
        let (mut lo_uv, mut hi_uv) = (glam::Vec2::splat(f32::MAX), glam::Vec2::splat(f32::MIN));
        for &i in ids {
            let p = surfels.position[i as usize];
            let uv = glam::Vec2::new(t.dot(p), b.dot(p));
            lo_uv = lo_uv.min(uv);
            hi_uv = hi_uv.max(uv);
        }
        let span = (hi_uv - lo_uv).max(glam::Vec2::splat(f32::MIN_POSITIVE));
        let mut cells = vec![Sums::default(); 64];
        let mut anchors = Anchors::new(cells.len());
        for &i in ids {
            let i = i as usize;
            let p = surfels.position[i];
            let uv = (glam::Vec2::new(t.dot(p), b.dot(p)) - lo_uv) / span * 8.0;
            let (ci, cj) = ((uv.x as usize).min(7), (uv.y as usize).min(7));
            cells[cj * 8 + ci].push(p, surfels.normal[i], emitted[i], surfels.area[i]);
            anchors.push(cj * 8 + ci, p, emitted[i]);
        }
        let (mut nodes, coherence) = tree_of_cells(cells);
        anchors.onto_surfels(&mut nodes);
        for &i in ids {
            out.surfel_vpl[i as usize] = out.vpls.len() as u32;
        }
        out.vpls.push(record);
        out.nodes.extend(nodes);
        out.coherence.extend(coherence);
    }
    out
}

/// Of the surfels `ids` (not empty), the one nearest `c` (the first on a
/// tie).
fn anchor_of(surfels: &Surfels, ids: &[u32], c: Vec3) -> u32 {
    let mut best = (f32::INFINITY, ids[0]);
    for &i in ids {
        let d = (surfels.position[i as usize] - c).length_squared();
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}
