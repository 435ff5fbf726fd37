//! Near-field trees: how a VPL keeps the light of its texels near its
//! receivers.
//!
//! A VPL stands for every lit texel of its quadtree node. Seen from far away
//! (distance `d` well beyond its disk radius `R = √(A/π)`) one point with the
//! summed flux is an accurate stand-in. Near it — a floor beside a lit wall,
//! the ground at the foot of a lit box, a crease — it is not: the cosine
//! towards the receiver and the distance vary over the cluster, and one
//! point gives too little light (a wall cluster next to the floor sends its
//! light almost parallel to the floor from its centre, while its lower
//! texels face the floor at a steep angle and are close). Measured on random
//! scenes at 664 VPLs, this *transport* error, not visibility, was the main
//! reason the indirect light was too dark (docs/method.md, "Near field").
//!
//! So each VPL also stores a small tree: its node's texel rectangle is
//! halved recursively (the quadtree's own rule: floor midpoints) for
//! [`NEAR_FIELD_LEVELS`] more levels, and each sub-node holds the same
//! aggregate as a VPL (flux-weighted centroid and normal, summed flux and
//! area, lit texel count). Shading (`shade.wgsl`) descends into a node's
//! children only where the receiver is nearer than
//! `NEAR_FIELD_RATIO × R_node`; all nodes use the VPL's one hemisphere map
//! for visibility, so the cost of visibility does not change. The ratio is
//! dimensionless: the tree and the descent are scale-invariant.
//!
//! Layout ([`NODES_PER_VPL`] records per VPL): level 1 (2×2 nodes), level 2
//! (4×4), level 3 (8×8), each level row-major (`j · 2^l + i`); node
//! `(l, i, j)` has the children `(l + 1, 2i + a, 2j + b)`, `a, b ∈ {0, 1}`.
//! A node without lit texels is all zeros (and `map = NO_MAP`).

use gibake_asset::{NEAR_FIELD_LEVELS, NODES_PER_VPL, VplRecord};
use glam::{DVec3, Vec3};

use crate::cluster::Clustering;
use crate::rsm::Rsm;

/// Offset of level `l` (1-based) in a VPL's node block.
pub const fn level_offset(l: u32) -> usize {
    // 4 + 16 + … + 4^(l−1)
    ((1usize << (2 * l)) - 4) / 3
}

/// Cell index (0..2^levels) of coordinate `x` in `[lo, hi)` after `levels`
/// recursive halvings at the floor midpoint (the quadtree's rule; a range
/// one texel wide sends its texel to the upper half).
fn cell(x: u32, mut lo: u32, mut hi: u32, levels: u32) -> usize {
    let mut idx = 0usize;
    for _ in 0..levels {
        let mid = lo + (hi - lo) / 2;
        if x < mid {
            hi = mid;
            idx *= 2;
        } else {
            lo = mid;
            idx = 2 * idx + 1;
        }
    }
    idx
}

/// A member's weight in its node: the channel sum of its flux; none if
/// that is not positive and finite (the member is left out).
fn member_weight(flux: Vec3) -> Option<f64> {
    let w = f64::from(flux.x) + f64::from(flux.y) + f64::from(flux.z);
    (w > 0.0 && w.is_finite()).then_some(w)
}

/// The aggregate of a node's members (texels, or surfels for the later
/// bounces' VPLs): weights are the channel sum of each member's flux.
#[derive(Clone, Copy, Default)]
pub(crate) struct Sums {
    pub(crate) w: f64,
    pub(crate) wp: DVec3,
    pub(crate) wn: DVec3,
    pub(crate) flux: DVec3,
    pub(crate) area: f64,
    pub(crate) count: u32,
}

impl Sums {
    /// Adds one member at `p` with normal `n`, flux `flux` and area `area`
    /// (none if its flux is not positive and finite).
    pub(crate) fn push(&mut self, p: Vec3, n: Vec3, flux: Vec3, area: f32) {
        let Some(w) = member_weight(flux) else {
            return;
        };
        self.w += w;
        self.wp += p.as_dvec3() * w;
        self.wn += n.as_dvec3() * w;
        self.flux += flux.as_dvec3();
        self.area += f64::from(area);
        self.count += 1;
    }

    pub(crate) fn add(&mut self, o: &Sums) {
        self.w += o.w;
        self.wp += o.wp;
        self.wn += o.wn;
        self.flux += o.flux;
        self.area += o.area;
        self.count += o.count;
    }

    /// `|Σ w n| / Σ w` in `[0, 1]`; 1 without texels.
    fn coherence(&self) -> f32 {
        if self.count == 0 || !(self.w > 0.0 && self.w.is_finite()) {
            return 1.0;
        }
        let c = self.wn.length() / self.w;
        if c.is_finite() {
            c.clamp(0.0, 1.0) as f32
        } else {
            1.0
        }
    }

    pub(crate) fn record(&self) -> VplRecord {
        let empty = VplRecord::EMPTY_NODE;
        if self.count == 0 || !(self.w > 0.0 && self.w.is_finite()) {
            return empty;
        }
        let p = (self.wp / self.w).as_vec3();
        // Normalized in f64: the weighted sum overflows f32's squared length
        // for very bright lights (1e20 W/sr).
        let n = self.wn.normalize_or_zero().as_vec3();
        let flux = self.flux.as_vec3();
        if !(p.is_finite() && flux.is_finite() && (self.area as f32).is_finite()) {
            return empty;
        }
        VplRecord {
            position: p.to_array(),
            area: self.area as f32,
            normal: n.to_array(),
            texels: self.count,
            flux: flux.to_array(),
            map: gibake_asset::NO_MAP,
        }
    }
}

/// The near-field tree of VPL `i` of `clusters`: its leaf's rectangle, its
/// own depth layer's texels ([`vpl_nodes`]).
pub fn tree_of(rsm: &Rsm, clusters: &Clustering, i: usize) -> Vec<VplRecord> {
    tree_and_coherence_of(rsm, clusters, i).0
}

/// [`tree_of`] and its level-3 nodes' texel coherences
/// ([`vpl_nodes_and_coherence`]).
pub fn tree_and_coherence_of(
    rsm: &Rsm,
    clusters: &Clustering,
    i: usize,
) -> (Vec<VplRecord>, Vec<f32>) {
    vpl_nodes_and_coherence(rsm, clusters.rects[i], |t| {
        clusters.texel_vpl[t] == i as u32
    })
}

/// The near-field tree of the VPL made of the lit texels of `rect`
/// (`(x0, x1, y0, y1)`, half-open) for which `member(texel index)` holds
/// (the VPL's own depth layer of its leaf: `Clustering::texel_vpl`):
/// [`NODES_PER_VPL`] records. Sums are in `f64` in row-major texel order
/// (deterministic).
pub fn vpl_nodes(
    rsm: &Rsm,
    rect: (u32, u32, u32, u32),
    member: impl Fn(usize) -> bool,
) -> Vec<VplRecord> {
    vpl_nodes_and_coherence(rsm, rect, member).0
}

/// [`vpl_nodes`] and, for each of its [`gibake_asset::LEVEL3_NODES`] level-3 nodes in
/// tree order, the coherence of its texels' normals `|Σ w n| / Σ w` (`w`
/// the channel sum of a texel's flux; 1 for an empty node): how far the
/// node's one normal stands for its texels, which shading uses for the
/// node's lobe (`gibake_asset::Asset::vpl_coherence`; docs/method.md,
/// "Texel coherence").
pub fn vpl_nodes_and_coherence(
    rsm: &Rsm,
    (x0, x1, y0, y1): (u32, u32, u32, u32),
    member: impl Fn(usize) -> bool,
) -> (Vec<VplRecord>, Vec<f32>) {
    let levels = NEAR_FIELD_LEVELS;
    let side = 1usize << levels;
    let mut leaf = vec![Sums::default(); side * side];
    let mut anchors = Anchors::new(side * side);
    for y in y0..y1 {
        let j = cell(y, y0, y1, levels);
        for x in x0..x1 {
            let t = (y * rsm.size + x) as usize;
            if !(rsm.metric[t].is_finite() && member(t)) {
                continue;
            }
            let i = cell(x, x0, x1, levels);
            leaf[j * side + i].push(rsm.position[t], rsm.normal[t], rsm.flux[t], rsm.area[t]);
            anchors.push(j * side + i, rsm.position[t], rsm.flux[t]);
        }
    }
    let (mut nodes, coherence) = tree_of_cells(leaf);
    anchors.apply(&mut nodes);
    (nodes, coherence)
}

/// Where each level-3 node of a VPL sits: its members' flux-weighted
/// centroid, or, where its members lie on surfaces a step apart, on the
/// one that carries most of its light. A cell holds the members of one
/// VPL, and a VPL may span two surfaces a step apart where its leaf is
/// wide (a small budget: a roof's top and the floor seen through its
/// opening, [`crate::cluster`]'s depth gap growing with the leaf). Their
/// centroid is then in mid-air or inside the roof slab, facing up, and at
/// a receiver beside it — the ceiling next to the opening, the opening's
/// own sides — its light is near-field light no map darkens (shade.wgsl
/// `open_weight`): the room lit through roof holes got hot spots of 3.3×
/// the reference's brightest pixel at 64 VPLs (docs/method.md, "Finest
/// nodes across a step"). So where its members' depths along the node's
/// normal leave a gap wider than its disk radius `√(A/π)` — two surfaces
/// a step apart — the node moves along its normal to their flux-weighted
/// median depth: onto the surface most of its light comes from. On one
/// surface, flat or curved, and across a crease (a floor and a wall),
/// the depths run on without a gap: nothing moves.
pub(crate) struct Anchors {
    /// Per level-3 cell: its members' (weight, position).
    members: Vec<Vec<(f64, Vec3)>>,
}

impl Anchors {
    /// No members yet in `cells` level-3 cells.
    pub(crate) fn new(cells: usize) -> Anchors {
        Anchors {
            members: vec![Vec::new(); cells],
        }
    }

    /// A member of cell `k` at `p` with flux `flux` (left out where
    /// [`Sums::push`] leaves it out).
    pub(crate) fn push(&mut self, k: usize, p: Vec3, flux: Vec3) {
        if let (Some(m), Some(w)) = (self.members.get_mut(k), member_weight(flux)) {
            m.push((w, p));
        }
    }

    /// Places the level-3 nodes of a later bounce's VPL (one VPL's
    /// [`NODES_PER_VPL`]; `crate::later::secondary`), whose members are
    /// surfels a spacing or more apart rather than a surface's texels:
    /// each node on its member nearest its centroid (on a surface, as the
    /// VPL itself sits on its surfel nearest its centroid), with the disk
    /// its members spread over where that is wider than the disk of their
    /// area — radius `√2 · s`, `s` their flux-weighted RMS distance from
    /// the node across its normal (a uniform disk's RMS radius is its
    /// radius over √2). A cell of a VPL spread over a garden's canopies
    /// held a few surfels of leaves a metre apart: their centroid in
    /// mid-air and the disk of their area a third of their spread, a
    /// bright spot at the receiver next to it (docs/method.md, "The
    /// surfels' share, the later VPLs' open share and their finest
    /// nodes")). The flux stays whole; the parents are not
    /// moved. This replaces the step rule ([`Anchors::apply`]) for them:
    /// a node on a member is on one of the surfaces.
    pub(crate) fn onto_surfels(&self, nodes: &mut [VplRecord]) {
        let level3 = level_offset(NEAR_FIELD_LEVELS);
        for (node, members) in nodes.iter_mut().skip(level3).zip(&self.members) {
            if node.texels == 0 || members.is_empty() {
                continue;
            }
            let c = Vec3::from_array(node.position);
            let mut best = (f32::INFINITY, c);
            for &(_, p) in members {
                let d = (p - c).length_squared();
                if d < best.0 {
                    best = (d, p);
                }
            }
            node.position = best.1.to_array();
            let (c, n) = (best.1.as_dvec3(), Vec3::from_array(node.normal).as_dvec3());
            let (mut sw, mut s2) = (0.0f64, 0.0f64);
            for &(w, p) in members {
                let d = p.as_dvec3() - c;
                sw += w;
                s2 += w * (d - n * n.dot(d)).length_squared();
            }
            let a = (std::f64::consts::PI * 2.0 * s2 / sw) as f32;
            if a.is_finite() && a > node.area {
                node.area = a;
            }
        }
    }

    /// Moves the level-3 nodes of `nodes` (one VPL's [`NODES_PER_VPL`])
    /// whose members lie a step apart (see the type's docs).
    pub(crate) fn apply(&self, nodes: &mut [VplRecord]) {
        let level3 = level_offset(NEAR_FIELD_LEVELS);
        for (node, members) in nodes.iter_mut().skip(level3).zip(&self.members) {
            if node.texels == 0 || members.len() < 2 {
                continue;
            }
            let c = Vec3::from_array(node.position).as_dvec3();
            let n = Vec3::from_array(node.normal).as_dvec3();
            let mut depths: Vec<(f64, f64)> = members
                .iter()
                .map(|&(w, p)| (n.dot(p.as_dvec3() - c), w))
                .collect();
            let total: f64 = depths.iter().map(|d| d.1).sum();
            let r = (f64::from(node.area.max(0.0)) / std::f64::consts::PI).sqrt();
            depths.sort_by(|a, b| a.0.total_cmp(&b.0));
            let step = depths
                .windows(2)
                .map(|d| d[1].0 - d[0].0)
                .fold(0.0, f64::max);
            if !crate::later::gt(step, r) {
                continue;
            }
            let mut acc = 0.0;
            let mut median = depths[0].0;
            for &(d, w) in &depths {
                acc += w;
                median = d;
                if acc >= 0.5 * total {
                    break;
                }
            }
            let p = (c + n * median).as_vec3();
            if p.is_finite() {
                node.position = p.to_array();
            }
        }
    }
}

/// The near-field tree and level-3 coherences of a VPL whose members are
/// summed into its `8 × 8` level-3 cells `leaf` (row-major: `j · 8 + i`).
pub(crate) fn tree_of_cells(leaf: Vec<Sums>) -> (Vec<VplRecord>, Vec<f32>) {
    let levels = NEAR_FIELD_LEVELS;
    debug_assert_eq!(leaf.len(), 1 << (2 * levels));
    let mut coherence: Vec<f32> = leaf.iter().map(Sums::coherence).collect();
    let mut out = vec![Sums::default().record(); NODES_PER_VPL];
    let mut cur = leaf;
    for l in (1..=levels).rev() {
        let n = 1usize << l;
        for (k, s) in cur.iter().enumerate() {
            out[level_offset(l) + k] = s.record();
        }
        if l > 1 {
            let m = n / 2;
            let mut up = vec![Sums::default(); m * m];
            for j in 0..n {
                for i in 0..n {
                    up[(j / 2) * m + i / 2].add(&cur[j * n + i]);
                }
            }
            cur = up;
        }
    }
    // 1 for a node stored empty (whatever its sums), as the format asks.
    for (c, n) in coherence.iter_mut().zip(&out[level_offset(levels)..]) {
        if n.texels == 0 {
            *c = 1.0;
        }
    }
    (out, coherence)
}

/// Sum of the flux of a VPL's level-`l` nodes (a check: every level holds
/// the VPL's whole flux).
pub fn level_flux(nodes: &[VplRecord], l: u32) -> Vec3 {
    let n = 1usize << (2 * l);
    nodes[level_offset(l)..level_offset(l) + n]
        .iter()
        .fold(Vec3::ZERO, |a, r| a + Vec3::from_array(r.flux))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_and_cells() {
        assert_eq!(level_offset(1), 0);
        assert_eq!(level_offset(2), 4);
        assert_eq!(level_offset(3), 20);
        assert_eq!(level_offset(4), NODES_PER_VPL);
        // [0, 8) halved three times: one texel per cell.
        for x in 0..8 {
            assert_eq!(cell(x, 0, 8, 3), x as usize);
        }
        // A one-texel range goes to the last cell.
        assert_eq!(cell(5, 5, 6, 3), 7);
    }

    /// An empty 16² RSM of a sun straight above.
    fn empty_rsm() -> Rsm {
        let view = gibake_gpu::LightView::directional(
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::splat(-1.0),
            Vec3::ONE,
            16,
        );
        Rsm::empty(16, view)
    }

    /// Each level-3 node's coherence is its texels' `|Σ w n| / Σ w`: 1 for
    /// texels facing one way, `cos 45°` for two equal texels 90° apart,
    /// weighted by flux; 1 for an empty node. Its record keeps the unit
    /// mean normal.
    #[test]
    fn level_3_coherence_of_texels_facing_two_ways() {
        let mut rsm = empty_rsm();
        let a = Vec3::new(1.0, 1.0, 0.0).normalize();
        let b = Vec3::new(-1.0, 1.0, 0.0).normalize();
        // Rectangle [0, 16)²: level-3 cells of 2×2 texels. Cell (0, 0): two
        // texels facing a, two facing b; cell (1, 0): all facing a; cell
        // (2, 0): one bright texel facing a, three dim facing b.
        let mut lit = |x: usize, y: usize, n: Vec3, f: f32| {
            let t = y * 16 + x;
            rsm.metric[t] = 1.0;
            rsm.position[t] = Vec3::new(x as f32, 0.0, y as f32);
            rsm.normal[t] = n;
            rsm.flux[t] = Vec3::splat(f);
            rsm.area[t] = 1.0;
        };
        lit(0, 0, a, 1.0);
        lit(1, 0, b, 1.0);
        lit(0, 1, a, 1.0);
        lit(1, 1, b, 1.0);
        for (x, y) in [(2, 0), (3, 0), (2, 1), (3, 1)] {
            lit(x, y, a, 1.0);
        }
        lit(4, 0, a, 3.0);
        lit(5, 0, b, 1.0);
        lit(4, 1, b, 1.0);
        lit(5, 1, b, 1.0);
        let (nodes, c) = vpl_nodes_and_coherence(&rsm, (0, 16, 0, 16), |_| true);
        assert_eq!(c.len(), gibake_asset::LEVEL3_NODES);
        assert!(
            (c[0] - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6,
            "{}",
            c[0]
        );
        assert!((c[1] - 1.0).abs() < 1e-6, "{}", c[1]);
        // (3a + 3b) / 6: cos 45°, as for two equal texels.
        assert!(
            (c[2] - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6,
            "{}",
            c[2]
        );
        assert_eq!(c[3], 1.0, "an empty node");
        let l3 = &nodes[level_offset(3)..];
        assert!((Vec3::from_array(l3[0].normal) - Vec3::Y).length() < 1e-6);
        assert_eq!(l3[3].texels, 0);
    }

    /// A finest node over two floors a step apart (a roof's top and the
    /// floor under its opening) moves onto the one carrying most of its
    /// light; one over a crease (a floor and a wall meeting) does not.
    #[test]
    fn a_finest_node_across_a_step_sits_on_its_brighter_surface() {
        let mut rsm = empty_rsm();
        let mut lit = |x: usize, y: usize, p: Vec3, n: Vec3| {
            let t = y * 16 + x;
            rsm.metric[t] = 1.0;
            rsm.position[t] = p;
            rsm.normal[t] = n;
            rsm.flux[t] = Vec3::ONE;
            rsm.area[t] = 0.01;
        };
        // Cell (0, 0) (texels x, y in 0..2): three on a roof at 4.4 m, one
        // on the floor 4.4 m below. Cell (1, 0) (x in 2..4): two on a floor,
        // two on the wall rising from its edge.
        let x = |k: usize| 0.1 * k as f32;
        lit(0, 0, Vec3::new(x(0), 4.4, 0.0), Vec3::Y);
        lit(1, 0, Vec3::new(x(1), 4.4, 0.0), Vec3::Y);
        lit(0, 1, Vec3::new(x(0), 4.4, 0.1), Vec3::Y);
        lit(1, 1, Vec3::new(x(1), 0.0, 0.1), Vec3::Y);
        lit(2, 0, Vec3::new(x(2), 0.0, 0.0), Vec3::Y);
        lit(2, 1, Vec3::new(x(2), 0.0, 0.1), Vec3::Y);
        lit(3, 0, Vec3::new(x(3), 0.05, 0.0), Vec3::NEG_X);
        lit(3, 1, Vec3::new(x(3), 0.05, 0.1), Vec3::NEG_X);
        let (nodes, _) = vpl_nodes_and_coherence(&rsm, (0, 16, 0, 16), |_| true);
        let l3 = &nodes[level_offset(3)..];
        // The step: on the roof, not at the centroid's 3.3 m.
        let step = Vec3::from_array(l3[0].position);
        assert!((step.y - 4.4).abs() < 1e-4, "{step}");
        assert_eq!(l3[0].texels, 4);
        assert!((Vec3::from_array(l3[0].flux) - Vec3::splat(4.0)).length() < 1e-5);
        // The crease: its centroid, as before.
        let crease = Vec3::from_array(l3[1].position);
        let centroid = Vec3::new((x(2) + x(3)) / 2.0, 0.025, 0.05);
        assert!(
            (crease - centroid).length() < 1e-5,
            "{crease} against {centroid}"
        );
    }

    /// A later VPL's finest nodes: three surfels of leaves a metre apart
    /// get a node on one of them with the disk they spread over, not the
    /// disk of their 0.03 m² at their mid-air centroid; a patch of sixteen
    /// surfels side by side keeps the disk of its area, and each flux is
    /// whole.
    #[test]
    fn a_later_vpls_finest_node_sits_on_a_surfel_with_its_members_spread() {
        let mut cells = vec![Sums::default(); 64];
        let mut anchors = Anchors::new(64);
        let mut add = |k: usize, p: Vec3| {
            cells[k].push(p, Vec3::Y, Vec3::ONE, 0.01);
            anchors.push(k, p, Vec3::ONE);
        };
        let sparse = [
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.0, 2.6, 0.0),
            Vec3::new(0.0, 2.2, 1.0),
        ];
        for p in sparse {
            add(0, p);
        }
        for j in 0..4 {
            for i in 0..4 {
                add(1, Vec3::new(5.0 + 0.1 * i as f32, 0.0, 0.1 * j as f32));
            }
        }
        let (mut nodes, _) = tree_of_cells(cells);
        let before: Vec<VplRecord> = nodes.clone();
        anchors.onto_surfels(&mut nodes);
        let l3 = level_offset(3);
        let (a, b) = (&nodes[l3], &nodes[l3 + 1]);
        let on = Vec3::from_array(a.position);
        assert!(
            sparse.iter().any(|p| (*p - on).length() < 1e-6),
            "{on} is not on a surfel"
        );
        // Their RMS distance across the normal from the surfel it sits on.
        let s2 = sparse
            .iter()
            .map(|p| {
                let d = *p - on;
                d.x * d.x + d.z * d.z
            })
            .sum::<f32>()
            / 3.0;
        let want = 2.0 * std::f32::consts::PI * s2;
        assert!(
            (a.area - want).abs() < 1e-4 * want,
            "{} against {want}",
            a.area
        );
        assert!(a.area > 10.0 * before[l3].area);
        assert!((b.area - before[l3 + 1].area).abs() < 0.35 * before[l3 + 1].area);
        assert!(
            (Vec3::from_array(b.position) - Vec3::from_array(before[l3 + 1].position)).length()
                < 0.1
        );
        for (n, m) in nodes.iter().zip(&before) {
            assert_eq!(n.flux, m.flux);
            assert_eq!(n.texels, m.texels);
        }
    }
}
