//! Quadtree clustering of RSM texels into VPLs (Ki & Oh 2008, "A GPU-based
//! light hierarchy"), made scale-invariant.
//!
//! # The quadtree
//!
//! The root is the whole `size × size` map. A node is a texel rectangle
//! `[x0, x1) × [y0, y1)`; it splits at the floor midpoints
//! `xm = x0 + (x1 − x0) / 2` (same for y) into up to four children, in
//! Morton order: top-left, top-right, bottom-left, bottom-right (row 0 is
//! the top). An axis one texel wide does not split (two children), and a
//! single texel is always a leaf. Any size works; for a power of two this
//! is the usual mip pyramid. Since both axes split alike, depth `d` is a
//! regular grid of `m_d × m_d` nodes, whose per-axis texel ranges come from
//! recursively halving `[0, size)`.
//!
//! # Per-node statistics (bottom-up)
//!
//! Each node stores, over its texels (a texel is *valid* iff its metric is
//! finite), with **unit weight per texel**:
//!
//! | field           | meaning                                               |
//! |-----------------|-------------------------------------------------------|
//! | `total`         | number of texels                                      |
//! | `valid`         | number of valid texels                                |
//! | `mean_metric`   | mean metric over valid texels                         |
//! | `m2_metric`     | `Σ (metric − mean)²` over valid texels                |
//! | `sum_normal`    | `Σ normal` (vec3) over valid texels                   |
//! | `sum_footprint` | `Σ footprint` over valid texels ([`Rsm::footprint`])  |
//! | `sum_flux`      | `Σ (r + g + b)` of flux over valid texels             |
//!
//! A texel is `total = 1`, `valid = 0|1`, `mean = metric`, `m2 = 0`. A
//! parent folds its children in Morton order with the pairwise merge of
//! Chan, Golub & LeVeque: `n = na + nb`, `δ = mean_b − mean_a`,
//! `mean = mean_a + δ·nb/n`, `m2 = m2_a + m2_b + δ²·na·nb/n` (a side with
//! no valid texel is taken as is); the other fields add. This is `Σ1`,
//! `Σmetric`, `Σmetric²` in a form that keeps its precision in `f32`, so a
//! compute shader can build the same pyramid level by level (one 2×2 or 1×2
//! reduction per node). The CPU evaluates everything in `f64`.
//!
//! # The split criterion (dimensionless)
//!
//! With `N = valid`, `Var = m2_metric / N`, `F = sum_footprint / N`:
//!
//! - **mixed** node (`0 < valid < total`): score `+∞`, it always splits, so
//!   the surface/void boundary is resolved down to single texels;
//! - **empty** node (`valid = 0`) or single texel: never splits, yields no
//!   VPL (empty) or a one-texel VPL;
//! - **full** node: `score = max(D, Nn)` with the depth term
//!   `D = Var / (size · F)²` and the normal term `Nn = 1 − |sum_normal| / N`
//!   (clamped to `≥ 0`; `≈ half the angular variance of the normals`).
//!
//! The node splits iff `score ≥ threshold`; below the threshold it becomes
//! one VPL. This is the paper's rule ("variance of depth and of normal at or
//! above a threshold") with the depth variance measured in units of
//! `size · F`, the world-space width of the whole light view at the node's
//! depth (for a spot light `2·tan(half angle)·distance`; for a directional
//! light the map's width): depth is measured relative to the view, as a
//! normalised projection depth would be, never in scene units.
//!
//! **Scale invariance.** Scaling the scene by `s` scales metric by `s`,
//! `Var` by `s²` and footprints by `s`; normals are unchanged. Both terms,
//! hence every score and every split, are unchanged: the same scene in
//! millimetres or kilometres gives the same VPLs. The depth term is also
//! independent of the map resolution (`size · F` does not depend on
//! `size`), so a threshold means the same at every RSM size.
//!
//! Why not normalise by the node's own width (`(x1 − x0) · F`)? Then a flat
//! tilted plane scores `tan²θ / 12` at every node size: it would be split
//! either not at all or down to single texels. Normalising by the view width
//! makes both terms fall like `(node width)²` on smooth surfaces (a plane
//! tilted by `θ`: `D ≈ tan²θ · (w/W)² / 12`; a surface of curvature radius
//! `R`: `Nn ≈ (w/R)² / 24` per curved axis), so refinement converges and is
//! balanced between flat-but-tilted and curved regions.
//!
//! **Discontinuities.** A depth step of height `h` scores about
//! `p(1−p)·h² / (size·F)²` and a crease between faces whose normals differ
//! by `φ` up to `1 − cos(φ/2)`, whatever the node size (`p`: the fraction
//! on one side). So, as in the paper, once the threshold falls below such a
//! score the whole edge refines to single texels at once, and with small
//! budgets most VPLs lie along silhouettes and creases while smooth regions
//! stay coarse.
//!
//! # VPLs
//!
//! A leaf with valid texels becomes one [`Cluster`]: flux-weighted (weight
//! `r + g + b` of the texel's flux) mean position and normal (normalised),
//! summed flux and area, texel count; all accumulated in `f64` over the
//! leaf's texels in row-major order. Zero-flux leaves are dropped, so a
//! kept leaf's weights sum to a positive value (area weighting is only the
//! fallback should that sum overflow); if the weighted normals cancel, the
//! normal is the area-weighted one, else the first texel's. Texels of
//! dropped leaves map to [`NO_VPL`], as do empty texels. VPLs are emitted in
//! depth-first (Morton) order of the leaves, so identical input gives
//! bit-identical output. Everything is sequential.
//!
//! # Budget (`ClusterTarget::Count(n)`): greedy priority refinement
//!
//! Each node gets the *capped* score `e(node) = min(score(node),
//! e(parent))` (`e(root) = score(root)`). A node splits under
//! `Threshold(t)` iff it and all its ancestors score `≥ t`, i.e. iff
//! `e(node) ≥ t`: thresholding is exactly "split all nodes with `e ≥ t`".
//! `Count(n)` keeps a max-heap of splittable leaves keyed by `e` (ties:
//! shallower node first, then the smaller Morton code of its grid cell), so
//! nodes are split in non-increasing `e`. It first splits every `+∞`
//! (mixed) node, then pops the top leaf while fewer than `n` leaves carry
//! flux, except that a split that would overshoot `n` by at least as much as
//! the current count falls short is not made (a split adds at most three
//! VPLs, so the result is within one VPL of `n`). If the forced splits of
//! mixed nodes alone give more than `n` VPLs, that is the result; if the map
//! has fewer than `n` texels with flux, every texel becomes a VPL.
//!
//! The reported [`Clustering::threshold`] is `e_last`, the capped score of
//! the last split, or the next `f32` above it, whichever makes
//! `Threshold(t)` give the VPL count nearer to the one returned (the two
//! differ only when the refinement stopped inside a run of equal `e`). If it
//! stopped at the end of such a run, `Threshold(t)` reproduces the result
//! exactly. With no finite split, it is the next `f32` above the largest
//! unsplit `e` (`+∞` if none).
//!
//! # Porting to a GPU
//!
//! Build the moment pyramid bottom-up as above, compute `score` per node
//! from its moments, then traverse top-down: a node is split iff it is mixed
//! or (`total > 1`, full and `score ≥ threshold`); a non-split node with
//! `valid > 0` and `sum_flux > 0` is a VPL. (The CPU rounds the `f64` score
//! to `f32` before comparing; an `f32` GPU pyramid agrees except for nodes
//! whose score is within rounding of the threshold.) Leaf order and the VPL
//! sums (flux-weighted position and normal, flux, area, count) can come from
//! the same pyramid with extra fields (`Σ w·p`, `Σ w·n`, `Σ flux`,
//! `Σ area`).

mod pyramid;

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::Vec3;

use crate::rsm::Rsm;
use pyramid::{Moments, Node, Pyramid, morton, vec3};

/// One VPL made from a quadtree node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cluster {
    /// Flux-weighted mean position of its texels.
    pub position: Vec3,
    /// Flux-weighted mean normal of its texels (unit).
    pub normal: Vec3,
    /// Summed flux (W, linear RGB).
    pub flux: Vec3,
    /// Summed surface area of its texels.
    pub area: f32,
    /// Number of texels.
    pub texels: u32,
}

/// The result of clustering.
#[derive(Clone, Debug, PartialEq)]
pub struct Clustering {
    /// VPLs in quadtree (Morton) order; zero-flux clusters are dropped.
    pub vpls: Vec<Cluster>,
    /// Per RSM texel: index into `vpls`, or [`NO_VPL`].
    pub texel_vpl: Vec<u32>,
    /// The threshold used (for `--vpls N`: the one that was found).
    pub threshold: f32,
}

/// `texel_vpl` value of texels that belong to no VPL.
pub const NO_VPL: u32 = u32::MAX;

/// How to ask for VPLs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClusterTarget {
    /// Split while the (dimensionless) variance score is ≥ this.
    Threshold(f32),
    /// About this many VPLs (±2%).
    Count(u32),
}

/// Clusters `rsm` into VPLs (see the module docs for the rule).
pub fn cluster(rsm: &Rsm, target: ClusterTarget) -> Clustering {
    let texels = (rsm.size as usize) * (rsm.size as usize);
    assert!(
        rsm.metric.len() == texels
            && rsm.position.len() == texels
            && rsm.normal.len() == texels
            && rsm.flux.len() == texels
            && rsm.area.len() == texels,
        "RSM arrays must hold size² texels"
    );
    if rsm.size == 0 {
        let threshold = match target {
            ClusterTarget::Threshold(t) => t,
            ClusterTarget::Count(_) => f32::INFINITY,
        };
        return Clustering {
            vpls: Vec::new(),
            texel_vpl: Vec::new(),
            threshold,
        };
    }
    let pyramid = Pyramid::new(rsm);
    match target {
        ClusterTarget::Threshold(t) => {
            let size = pyramid.size();
            let (vpls, texel_vpl) = emit(rsm, &pyramid, |node| {
                pyramid
                    .moments(rsm, node)
                    .score(size)
                    .is_some_and(|s| s == f32::INFINITY || s >= t)
            });
            Clustering {
                vpls,
                texel_vpl,
                threshold: t,
            }
        }
        ClusterTarget::Count(n) => cluster_count(rsm, &pyramid, n),
    }
}

/// Walks the quadtree depth-first, descending where `split` says so, and
/// turns each leaf into a VPL.
fn emit(rsm: &Rsm, pyramid: &Pyramid, split: impl Fn(Node) -> bool) -> (Vec<Cluster>, Vec<u32>) {
    let mut vpls = Vec::new();
    let mut texel_vpl = vec![NO_VPL; rsm.metric.len()];
    let texel_level = pyramid.texel_level();
    let mut stack = vec![pyramid.root()];
    let mut kids = Vec::with_capacity(4);
    while let Some(node) = stack.pop() {
        if node.level < texel_level && split(node) {
            kids.clear();
            kids.extend(pyramid.children(node));
            // Reverse so that the first child is visited first.
            stack.extend(kids.iter().rev());
        } else if let Some(vpl) = leaf_vpl(rsm, pyramid.rect(node)) {
            let index = vpls.len() as u32;
            let (x0, x1, y0, y1) = pyramid.rect(node);
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = (y * rsm.size + x) as usize;
                    if rsm.is_valid(i) {
                        texel_vpl[i] = index;
                    }
                }
            }
            vpls.push(vpl);
        }
    }
    (vpls, texel_vpl)
}

/// The VPL of a leaf rectangle, or `None` if it has no valid texel or no
/// flux.
fn leaf_vpl(rsm: &Rsm, (x0, x1, y0, y1): (u32, u32, u32, u32)) -> Option<Cluster> {
    let mut count = 0u32;
    let mut flux = [0.0f64; 3];
    let mut w_sum = 0.0f64;
    let mut wp = [0.0f64; 3];
    let mut wn = [0.0f64; 3];
    let mut area = 0.0f64;
    let mut ap = [0.0f64; 3];
    let mut an = [0.0f64; 3];
    let mut first_normal = None;
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * rsm.size + x) as usize;
            if !rsm.is_valid(i) {
                continue;
            }
            count += 1;
            let f = rsm.flux[i].to_array().map(f64::from);
            let p = rsm.position[i].to_array().map(f64::from);
            let n = rsm.normal[i].to_array().map(f64::from);
            let a = f64::from(rsm.area[i]);
            let w = f[0] + f[1] + f[2];
            first_normal.get_or_insert(rsm.normal[i]);
            w_sum += w;
            area += a;
            for k in 0..3 {
                flux[k] += f[k];
                wp[k] += w * p[k];
                wn[k] += w * n[k];
                ap[k] += a * p[k];
                an[k] += a * n[k];
            }
        }
    }
    if count == 0 || w_sum.partial_cmp(&0.0) != Some(Ordering::Greater) {
        return None;
    }
    let position = if w_sum.is_finite() {
        vec3(wp.map(|v| v / w_sum))
    } else if area > 0.0 {
        vec3(ap.map(|v| v / area))
    } else {
        return None;
    };
    let normal = [wn, an]
        .into_iter()
        .map(|v| vec3(v).normalize_or_zero())
        .find(|n| *n != Vec3::ZERO)
        .or(first_normal)
        .unwrap_or(Vec3::ZERO);
    Some(Cluster {
        position,
        normal,
        flux: vec3(flux),
        area: area as f32,
        texels: count,
    })
}

/// A splittable frontier node of the budget refinement.
#[derive(Clone, Copy, Debug)]
struct Entry {
    /// Capped score `min(score, e(parent))`.
    e: f32,
    node: Node,
    morton: u64,
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
    /// Larger `e` first, then shallower, then smaller Morton code.
    fn cmp(&self, o: &Self) -> Ordering {
        self.e
            .total_cmp(&o.e)
            .then(o.node.level.cmp(&self.node.level))
            .then(o.morton.cmp(&self.morton))
    }
}

/// State of the greedy refinement.
struct Greedy<'a> {
    rsm: &'a Rsm,
    pyramid: &'a Pyramid,
    /// `split[level][iy * m + ix]` for levels above the texels.
    split: Vec<Vec<bool>>,
    heap: BinaryHeap<Entry>,
    /// Leaves that carry flux (= VPLs).
    count: u64,
}

impl Greedy<'_> {
    fn moments(&self, node: Node) -> Moments {
        self.pyramid.moments(self.rsm, node)
    }

    fn push(&mut self, node: Node, parent_e: f32) {
        if let Some(s) = self.moments(node).score(self.pyramid.size()) {
            self.heap.push(Entry {
                e: s.min(parent_e),
                node,
                morton: morton(node.ix, node.iy),
            });
        }
    }

    /// Change in VPL count if `node` is split.
    fn delta(&self, node: Node) -> i64 {
        let kids = self
            .pyramid
            .children(node)
            .filter(|&c| self.moments(c).has_flux())
            .count() as i64;
        kids - i64::from(self.moments(node).has_flux())
    }

    fn split(&mut self, entry: Entry) {
        let node = entry.node;
        let m = self.pyramid.cells(node.level) as usize;
        self.split[node.level as usize][node.iy as usize * m + node.ix as usize] = true;
        self.count = self.count.wrapping_add_signed(self.delta(node));
        for child in self.pyramid.children(node) {
            self.push(child, entry.e);
        }
    }

    fn is_split(&self, node: Node) -> bool {
        let m = self.pyramid.cells(node.level) as usize;
        self.split[node.level as usize][node.iy as usize * m + node.ix as usize]
    }
}

/// `ClusterTarget::Count(n)`: greedy refinement (see the module docs).
fn cluster_count(rsm: &Rsm, pyramid: &Pyramid, n: u32) -> Clustering {
    let n = u64::from(n);
    let split = (0..pyramid.texel_level())
        .map(|level| {
            let m = pyramid.cells(level) as usize;
            vec![false; m * m]
        })
        .collect();
    let mut g = Greedy {
        rsm,
        pyramid,
        split,
        heap: BinaryHeap::new(),
        count: u64::from(pyramid.moments(rsm, pyramid.root()).has_flux()),
    };
    g.push(pyramid.root(), f32::INFINITY);

    // Forced splits of mixed nodes.
    while let Some(&top) = g.heap.peek() {
        if top.e != f32::INFINITY {
            break;
        }
        g.heap.pop();
        g.split(top);
    }

    // Budget splits, in non-increasing capped score.
    let mut last_e: Option<f32> = None;
    let mut group_start = g.count;
    while g.count < n {
        let Some(&top) = g.heap.peek() else { break };
        let after = g.count.saturating_add_signed(g.delta(top.node));
        if after > n && after - n >= n - g.count {
            break;
        }
        g.heap.pop();
        if last_e != Some(top.e) {
            last_e = Some(top.e);
            group_start = g.count;
        }
        g.split(top);
    }

    let (vpls, texel_vpl) = emit(rsm, pyramid, |node| g.is_split(node));
    let result = g.count;
    debug_assert_eq!(result, vpls.len() as u64);

    let threshold = match last_e {
        None => g.heap.peek().map_or(f32::INFINITY, |top| top.e.next_up()),
        Some(e) => {
            // Threshold(e) = finish the run of equal e; Threshold(next_up(e))
            // = the count before the run started.
            while let Some(&top) = g.heap.peek() {
                if top.e < e {
                    break;
                }
                g.heap.pop();
                g.split(top);
            }
            let with_run = g.count;
            if with_run.abs_diff(result) <= group_start.abs_diff(result) {
                e
            } else {
                e.next_up()
            }
        }
    };
    Clustering {
        vpls,
        texel_vpl,
        threshold,
    }
}
