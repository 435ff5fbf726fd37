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
//! # Lit texels
//!
//! A texel is **lit** iff it sees a surface (finite metric) and reflects
//! light: `flux.r + flux.g + flux.b > 0` (finite; summed in `f64`). Every
//! other texel — no surface, or a surface outside the spot cone, black, or
//! facing away — counts as *empty*: it reflects nothing, belongs to no VPL
//! and maps to [`NO_VPL`].
//!
//! # Per-node statistics (bottom-up)
//!
//! Each node stores, over its texels, with **unit weight per texel**:
//!
//! | field           | meaning                                               |
//! |-----------------|-------------------------------------------------------|
//! | `total`         | number of texels                                      |
//! | `lit`           | number of lit texels                                  |
//! | `mean_metric`   | mean metric over lit texels                           |
//! | `m2_metric`     | `Σ (metric − mean)²` over lit texels                  |
//! | `sum_normal`    | `Σ normal` (vec3) over lit texels                     |
//! | `sum_footprint` | `Σ footprint` over lit texels ([`Rsm::footprint`])    |
//! | `sum_flux`      | `Σ (r + g + b)` of flux over lit texels               |
//! | `sum_reaching`  | `Σ (r + g + b) · reach` over lit texels               |
//!
//! A texel is `total = 1`, `lit = 0|1`, `mean = metric`, `m2 = 0`. A
//! parent folds its children in Morton order with the pairwise merge of
//! Chan, Golub & LeVeque: `n = na + nb`, `δ = mean_b − mean_a`,
//! `mean = mean_a + δ·nb/n`, `m2 = m2_a + m2_b + δ²·na·nb/n` (a side with
//! no lit texel is taken as is); the other fields add. This is `Σ1`,
//! `Σmetric`, `Σmetric²` in a form that keeps its precision in `f32`, so a
//! compute shader can build the same pyramid level by level (one 2×2 or 1×2
//! reduction per node; the runtime's dynamic VPLs do). The CPU evaluates
//! everything in `f64`.
//!
//! # The split criterion (dimensionless)
//!
//! A node with one texel, or with no lit texel, never splits. Otherwise,
//! with `N = lit`, `Var = m2_metric / N`, `F = sum_footprint / N`:
//!
//! ```text
//! S = max(D, Nn, M) · share²
//!   D     = Var / (size · F)²             depth spread
//!   Nn    = max(0, 1 − |sum_normal| / N)  normal spread (≈ half the
//!                                         angular variance of the normals)
//!   M     = 1 if the node also holds non-lit texels, else 0
//!   share = sum_reaching / Σ(whole map)   the node's part of the light
//!                                         that reaches a surface
//! ```
//!
//! (`f64`, rounded to `f32`; NaN counts as `+∞`.) Under
//! `Threshold(t)` the node splits iff its *capped* score (below) is `≥ t`;
//! otherwise, if it has lit texels, it becomes one VPL.
//!
//! **Why this rule.** The previous rule split every *mixed* node (surface
//! and void) unconditionally, down to single texels, and compared
//! `max(D, Nn)` alone with the threshold. On the bundled
//! `data/corner_bunny.glb` (spot light, RSM 512²) `--vpls 664` then gave
//! **1488 VPLs, median 4 texels per VPL**: the forced splits alone
//! overshot the budget, which went to the bunny's silhouette against empty
//! space and to the rim of the spot cone, where the texels carry little or
//! no light, while the walls that light the scene stayed coarse.
//!
//! `S` is an estimate of the error a node makes when it is replaced by one
//! VPL: `max(D, Nn, M)` says how badly one point with one normal represents
//! the node's texels (depth spread, normal spread, or coverage — a node that
//! is partly empty puts its light at a centroid that may lie off its
//! surface), and `share` weighs that by how much of the reflected light the
//! error affects. A silhouette of a node carrying `10⁻⁵` of the flux costs
//! at most `10⁻⁵`, a bright smooth wall is refined as soon as its spread
//! times its light exceeds that. Mixed nodes are no longer special: their
//! term is bounded (`M = 1`), like `Nn ≤ 1`.
//!
//! The depth spread is measured in units of `size · F`, the world-space width
//! of the whole light view at the node's depth (for a spot light
//! `2·tan(half angle)·distance`; for a directional light the map's width):
//! relative to the view, as a normalised projection depth would be, never in
//! scene units.
//!
//! **Why share squared.** The first version weighed by `share`. Once VPLs
//! got near-field trees (`near_field`), a large smooth cluster stopped
//! costing accuracy next to its receivers, and measured on 8 scenes
//! (`vpl_diag`, docs/method.md) `share²` spent the budget better: the
//! indirect error fell on every scene (e.g. `sun` 0.153 → 0.111, a random
//! wall scene 0.134 → 0.027, a bunny among boxes 0.339 → 0.261), `share^0.5`
//! and `share^0.75` made every scene worse, and `share³` was no better than
//! `share²`. Squaring favours the bright: a node splits when its spread is
//! large *and* it carries much light, and the dim silhouettes and cone rims
//! stay coarser still.
//!
//! **VPLs where the light goes (reaching flux).** `reach` is the fraction
//! of a texel's cosine-distributed hemisphere that meets the static
//! geometry or the moving objects' swept bounds ([`crate::reach`], 4 rays
//! per lit texel); `share` counts only that reaching part. On a level lit
//! from outside — an arena whose roof takes most of the sun, a town whose
//! open ground faces the sky — the flux on surfaces that bounce into the sky
//! no longer decides where the budget goes: a small sunlit patch inside,
//! whose light all lands on walls, gets VPLs in proportion to the light it
//! bounces (measured in docs/method.md, "Real levels"). When nothing in the
//! map reaches a surface at all, `share` falls back to the flux. The
//! clusters' flux, position and normal are still those of all their texels
//! (the light is what it is; only the budget moved), and a VPL whose
//! hemisphere then sees nothing is dropped by the bake.
//!
//! **Scale invariance.** Scaling the scene by `s` scales metric by `s`,
//! `Var` by `s²` and footprints by `s`; normals, flux and hence `share` are
//! unchanged. Every term, hence every score and every split, is unchanged:
//! the same scene in millimetres or kilometres gives the same VPLs. `D` is
//! also independent of the map resolution (`size · F` does not depend on
//! `size`), and so is `share` (a ratio of fluxes), so a threshold means about
//! the same at every RSM size.
//!
//! **How it refines.** For a node `w` texels wide with evenly spread light,
//! `share² ∝ w⁴`. On smooth surfaces `D` and `Nn` fall like `w²` (a plane
//! tilted by `θ`: `D ≈ tan²θ · (w/W)² / 12`; curvature radius `R`:
//! `Nn ≈ (w/R)² / 24` per curved axis), so `S ∝ w⁶`. Across a depth step of
//! height `h` (`D ≈ p(1−p)·h²/(size·F)²`, `p` the fraction on one side), a
//! crease (`Nn` up to `1 − cos(φ/2)`) or a coverage edge (`M = 1`) the first
//! factor does not shrink, so `S ∝ w⁴`: edges still refine before smooth
//! regions, as in the paper, but only down to the node size at which the
//! node's light falls below the threshold, and bright edges first.
//!
//! # VPLs
//!
//! A leaf with lit texels becomes one [`Cluster`]: flux-weighted (weight
//! `r + g + b` of the texel's flux) mean position and normal (normalised),
//! summed flux and area, count of its lit texels; all accumulated in `f64`
//! over the leaf's lit texels in row-major order. The weights of a leaf sum
//! to a positive value (area weighting is only the fallback should that sum
//! overflow); if the weighted normals cancel, the normal is the
//! area-weighted one, else the first lit texel's. Lit texels map to their
//! leaf's VPL, all others to [`NO_VPL`]. [`cluster`] emits VPLs in
//! depth-first (Morton) order of the leaves, so identical input gives
//! bit-identical output. Everything is sequential.
//!
//! # Budget (`ClusterTarget::Count(n)`): greedy priority refinement
//!
//! Each node gets the *capped* score `e(node) = min(S(node), e(parent))`
//! (`e(root) = S(root)`). A node splits under `Threshold(t)` iff it and all
//! its ancestors score `≥ t`, i.e. iff `e(node) ≥ t`: thresholding is
//! exactly "split all nodes with `e ≥ t`". `Count(n)` keeps one max-heap of
//! the splittable leaves of **every map clustered together** keyed by `e`
//! (ties: shallower node first, then the earlier map, then the smaller
//! Morton code of its grid cell), so nodes are split in non-increasing `e`.
//! It pops the top leaf while fewer than `n` VPLs are **kept**, except that
//! a split that would overshoot `n` by at least as much as the current
//! count falls short is not made: the count ends within a split's change
//! of `n` (one to three VPLs, more only where a split adds depth layers).
//!
//! *Kept* is the bake's own rule, given as a [`Keep`]: a leaf makes one VPL
//! per depth layer (below), and the bake keeps a VPL whose light reaches a
//! surface by its texels' rays, or whose origin's rays see something
//! (`gibake_bake::reach::Reach::keeps`). Each node's kept VPLs as a leaf
//! are counted once, when it first becomes a candidate, so a split's change
//! is exact and the asset holds the VPLs the budget counted. Leaves whose
//! VPLs the bake drops are still emitted (the bake drops them), but they
//! take no useful VPL's place, and a node none of whose light reaches
//! anything is never split, in either mode (its score is `None`): on a
//! town whose ground faces the sky splitting them made ~120 k VPLs.
//!
//! Until method revision 6 the budget counted the leaves whose texels'
//! light reaches something, reran the refinement for a target moved by the
//! depth layers' miss, and joint budgets bisected on the threshold instead
//! of refining. Three things broke it on levels the project had not seen
//! (issue 49): the VPLs kept by their origin's rays alone (far ground,
//! outer rings) came on top of the budget — 1175 VPLs at `--vpls 664` on a
//! hall under a skylight on a wide ground (`gibake_scenegen::skylight_gallery`),
//! 722 on the Blenvy level; a threshold cannot cut inside a run of equal
//! scores (flat, evenly lit floors and walls: every node of a level alike),
//! so the bisection jumped a whole level of nodes — a gallery under an
//! open skylight baked 10 / 230 / 80 / 183 VPLs for `--vpls` 64 / 128 /
//! 200 / 256; and the count of depth layers beyond the leaves was an
//! estimate (the city at `--vpls 64`: 42). The greedy refinement over every
//! map with exact kept counts has none of the three.
//!
//! The reported [`Clustering::threshold`] reproduces the result with
//! `Threshold(t)` when the refinement stopped at the end of a run of equal
//! `e`: any `t` in `(e_next, e_last]` does (`e_next` the largest unsplit
//! `e`), and the reported `t` is the geometric middle of that gap, so that
//! a score moved by rounding (the same scene in other units) still falls
//! on the same side; if it stopped inside a run, `t` is in the gap above
//! or below the run, whichever gives the count nearer to the one returned
//! (no threshold gives a count inside a run). With no split, it is above
//! the largest unsplit `e` (`+∞` if none).
//!
//! # Depth layers
//!
//! [`cluster`] makes one VPL per **depth layer** of a leaf (`leaf_layers`):
//! its lit texels sorted by metric, cut wherever two consecutive metrics
//! differ by more than `max(20, w)` mean texel footprints (`w` the leaf's
//! longer side in texels). A continuous surface changes its metric by at
//! most 20 footprints per texel (the RSM's area clamp, cos ≥ 0.05), so
//! only a step between surfaces larger than the leaf is wide cuts it: a
//! roof's edge and the floor seen through its opening. Layers are in
//! increasing metric and share the leaf's rectangle in
//! [`Clustering::rects`]; a leaf of one layer sums exactly as before. A
//! budget counts every kept layer (above).
//! [`cluster_cut`] (the dynamic VPLs' GPU twin) stays one VPL per leaf.
//!
//! # Slot order and [`cluster_cut`] (the GPU twin)
//!
//! For a power-of-two map, depth `d` is a `2^d × 2^d` grid. The node at
//! column `ix`, row `iy` of depth `d` has the **slot**
//! `(4^d − 1)/3 + morton(ix, iy)` (`morton`: the bits of `ix` in the even
//! positions, of `iy` in the odd ones): all nodes of depth 0, then all of
//! depth 1, …, each level in Morton order. [`cluster_cut`] is `Threshold(t)`
//! with a depth limit (a node at depth `max_depth` never splits) and
//! returns the VPLs sorted by slot. The runtime's dynamic VPLs
//! (`runtime/src/dynamic_vpl.rs`) evaluate the same cut on the GPU, one
//! invocation per slot, with `f32` sums: a slot holds a VPL iff all its
//! ancestors split, it does not split (or is at `max_depth`), and it has lit
//! texels.
//!
//! # Porting to a GPU
//!
//! Build the moment pyramid bottom-up as above, plus `Σ w·p`, `Σ w·n`,
//! `Σ flux` (rgb) and `Σ area` over lit texels for the VPLs; take the total
//! flux from the root; compute `S` per node; a node is split iff it and all
//! its ancestors have `S ≥ t`. (The CPU rounds the `f64` score to `f32`
//! before comparing; an `f32` GPU pyramid agrees except for nodes whose
//! score is within rounding of the threshold.)

mod pyramid;

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::Vec3;

use crate::rsm::Rsm;
use pyramid::{Node, Pyramid, is_lit, morton, texel_weight, vec3};

/// One VPL made from a quadtree node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cluster {
    /// Flux-weighted mean position of its texels.
    pub position: Vec3,
    /// The position of its lit texel nearest to `position` (the first in
    /// row-major order on a tie): a point on the cluster's own surface,
    /// where its hemisphere map is centred. The centroid of a cluster that
    /// spans a convex edge or two depth layers lies in mid-air or inside an
    /// object, and a map from there sees what its texels do not.
    pub anchor: Vec3,
    /// Flux-weighted mean normal of its texels (unit).
    pub normal: Vec3,
    /// Summed flux (W, linear RGB).
    pub flux: Vec3,
    /// Summed surface area of its texels.
    pub area: f32,
    /// Number of (lit) texels.
    pub texels: u32,
}

impl Cluster {
    /// The asset's record of this VPL: at its anchor (on its own surface),
    /// no hemisphere map yet ([`gibake_asset::NO_MAP`]).
    pub fn record(&self) -> gibake_asset::VplRecord {
        gibake_asset::VplRecord {
            position: self.anchor.to_array(),
            area: self.area,
            normal: self.normal.to_array(),
            texels: self.texels,
            flux: self.flux.to_array(),
            map: gibake_asset::NO_MAP,
        }
    }
}

/// The result of clustering.
#[derive(Clone, Debug, PartialEq)]
pub struct Clustering {
    /// VPLs in depth-first quadtree (Morton) order of their leaves.
    pub vpls: Vec<Cluster>,
    /// Per RSM texel: index into `vpls`, or [`NO_VPL`] (texels that are
    /// not lit).
    pub texel_vpl: Vec<u32>,
    /// Per VPL: its quadtree node's texel rectangle `(x0, x1, y0, y1)`
    /// (half-open), for its near-field tree ([`crate::near_field`]).
    pub rects: Vec<(u32, u32, u32, u32)>,
    /// The threshold used (for `--vpls N`: the one that was found).
    pub threshold: f32,
}

impl Clustering {
    /// Per VPL: the reaching flux `Σ (r + g + b) · reach` of its texels in
    /// `rsm` (the map it was clustered from).
    pub fn reaching_flux(&self, rsm: &Rsm) -> Vec<f64> {
        let mut out = vec![0.0f64; self.vpls.len()];
        for (t, &v) in self.texel_vpl.iter().enumerate() {
            if v != NO_VPL {
                let f = rsm.flux[t];
                out[v as usize] += f64::from((f.x + f.y + f.z) * rsm.reach[t]);
            }
        }
        out
    }

    /// Keeps the VPLs for which `keep(index, vpl)` holds, in order; the
    /// texels of the others map to [`NO_VPL`]. Returns how many were removed.
    pub fn retain(&mut self, mut keep: impl FnMut(usize, &Cluster) -> bool) -> usize {
        let mut new_index = vec![NO_VPL; self.vpls.len()];
        let mut next = 0u32;
        for (i, v) in self.vpls.iter().enumerate() {
            if keep(i, v) {
                new_index[i] = next;
                next += 1;
            }
        }
        let removed = self.vpls.len() - next as usize;
        if removed == 0 {
            return 0;
        }
        let mut i = 0;
        self.vpls.retain(|_| {
            i += 1;
            new_index[i - 1] != NO_VPL
        });
        let mut i = 0;
        self.rects.retain(|_| {
            i += 1;
            new_index[i - 1] != NO_VPL
        });
        for t in &mut self.texel_vpl {
            if *t != NO_VPL {
                *t = new_index[*t as usize];
            }
        }
        removed
    }
}

/// `texel_vpl` value of texels that belong to no VPL.
pub const NO_VPL: u32 = u32::MAX;

/// How to ask for VPLs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClusterTarget {
    /// Split while the (dimensionless) capped score `S` is ≥ this.
    Threshold(f32),
    /// About this many VPLs (±2%).
    Count(u32),
}

/// Whether the bake keeps a would-be VPL; a `Count` budget counts exactly
/// the VPLs it keeps ("Budget" in the module docs).
/// `keep(map, rsm, texels, cluster, reaching)`: `map` is the index of its
/// RSM among those clustered together, `texels` its lit texels (row-major),
/// `cluster` the VPL they make and `reaching` their reaching flux
/// `Σ (r + g + b) · reach` (each texel's product in `f32`, summed in `f64`,
/// as [`Clustering::reaching_flux`]). The bake's rule is
/// `gibake_bake::reach::Reach::keeps` (its light reaches something by its
/// texels' rays, or its origin sees something); [`cluster`] and
/// [`cluster_joint`] keep a VPL whose light reaches something (any lit one
/// when nothing in the maps reaches anything).
pub type Keep<'a> = dyn Fn(usize, &Rsm, &[usize], &Cluster, f64) -> bool + Sync + 'a;

/// Clusters `rsm` into VPLs (see the module docs for the rule); a `Count`
/// budget counts the VPLs whose light reaches something.
pub fn cluster(rsm: &Rsm, target: ClusterTarget) -> Clustering {
    single(cluster_joint(&[rsm], target))
}

/// [`cluster`], with a `Count` budget counting the VPLs `keep` keeps.
pub fn cluster_keeping(rsm: &Rsm, target: ClusterTarget, keep: &Keep<'_>) -> Clustering {
    single(cluster_joint_keeping(&[rsm], target, keep))
}

/// The one map of a joint clustering of one map.
fn single(mut joint: JointClustering) -> Clustering {
    joint.maps.pop().expect("one clustering per map")
}

/// Panics unless every array of `rsm` holds `size²` texels.
fn check_arrays(rsm: &Rsm) {
    let texels = (rsm.size as usize) * (rsm.size as usize);
    assert!(
        rsm.metric.len() == texels
            && rsm.position.len() == texels
            && rsm.normal.len() == texels
            && rsm.flux.len() == texels
            && rsm.area.len() == texels,
        "RSM arrays must hold size² texels"
    );
}

/// Walks the quadtree depth-first, descending where `split` says so, and
/// turns each leaf into one VPL per depth layer ([`leaf_layers`]).
fn emit(rsm: &Rsm, pyramid: &Pyramid, split: impl Fn(Node) -> bool) -> Emitted {
    let mut vpls = Vec::new();
    let mut rects = Vec::new();
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
            continue;
        }
        let rect = pyramid.rect(node);
        for layer in leaf_layers(rsm, rect) {
            let Some(vpl) = cluster_of(rsm, &layer) else {
                continue;
            };
            let index = vpls.len() as u32;
            for &i in &layer {
                texel_vpl[i] = index;
            }
            vpls.push(vpl);
            rects.push(rect);
        }
    }
    (vpls, texel_vpl, rects)
}

/// VPLs, texel → VPL, each VPL's node rectangle.
type Emitted = (Vec<Cluster>, Vec<u32>, Vec<(u32, u32, u32, u32)>);

/// The reaching flux of a set of lit texels: `Σ (r + g + b) · reach`, as
/// [`Clustering::reaching_flux`] sums it.
fn reaching_of(rsm: &Rsm, texels: &[usize]) -> f64 {
    texels
        .iter()
        .map(|&t| {
            let f = rsm.flux[t];
            f64::from((f.x + f.y + f.z) * rsm.reach.get(t).copied().unwrap_or(1.0))
        })
        .sum()
}

/// A depth gap splits a leaf where it exceeds this many texel footprints
/// (and the leaf's own width): a continuous surface's metric changes by at
/// most `tan θ ≤ 20` footprints from one texel to the next (the RSM's
/// area clamp, cos ≥ 0.05), so only a step between two surfaces does.
const LAYER_GAP_FOOTPRINTS: f64 = 20.0;

/// The lit texels of a leaf rectangle, split into **depth layers**. Its
/// texels first fall into *surfaces*: 4-connected pieces whose neighbours'
/// metrics differ by at most `gap = max(LAYER_GAP_FOOTPRINTS, width) · F`
/// (`F` the leaf's mean texel footprint, `width` its longer side in
/// texels): a continuous surface changes its metric by at most
/// `LAYER_GAP_FOOTPRINTS · F` from one texel to the next, so only a step
/// between surfaces larger than the leaf is wide separates two. The
/// surfaces, sorted by their mean metric, then start a new layer wherever
/// two consecutive means differ by more than `gap`: pieces of one depth
/// (leaves of a crown, two floor patches) stay one VPL, and surfaces a step
/// apart become two. A leaf that holds a roof's edge and the floor 12 m
/// below it through the roof's opening becomes two VPLs: one visibility
/// point cannot stand for both, and a point on the roof, whose hemisphere
/// is the sky, carried the floor's light nowhere (the arena:
/// docs/method.md, "Real levels").
///
/// Until method revision 6 the texels' own metrics were sorted and cut at
/// gaps over `gap`: a sloped roof's metrics in a wide leaf (a sun 70° up,
/// a 3 m leaf: 1.6 m of spread) closed the gap to the floor seen through
/// its holes, and the roof's light, merged with the floor patch's, was
/// drawn from a centroid inside the roof slab onto the ceiling below
/// (docs/method.md, bake section 3, "Depth layers").
///
/// Layers are in increasing mean metric; texels within one in row-major
/// order (so a leaf of one layer sums exactly as before). Empty: no lit
/// texel.
fn leaf_layers(rsm: &Rsm, (x0, x1, y0, y1): (u32, u32, u32, u32)) -> Vec<Vec<usize>> {
    let mut lit = Vec::new();
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * rsm.size + x) as usize;
            if is_lit(rsm, i) {
                lit.push(i);
            }
        }
    }
    if lit.len() < 2 {
        return if lit.is_empty() {
            Vec::new()
        } else {
            vec![lit]
        };
    }
    let footprint = lit
        .iter()
        .map(|&i| f64::from(rsm.footprint(i)))
        .sum::<f64>()
        / lit.len() as f64;
    let width = f64::from((x1 - x0).max(y1 - y0));
    let gap = footprint * LAYER_GAP_FOOTPRINTS.max(width);
    if !(gap.is_finite() && gap > 0.0) {
        return vec![lit];
    }
    // Surfaces: flood fill over 4-neighbours whose metrics are within `gap`,
    // seeded in row-major order.
    let (w, h) = ((x1 - x0) as usize, (y1 - y0) as usize);
    let local = |i: usize| {
        let (x, y) = (i as u32 % rsm.size, i as u32 / rsm.size);
        (y - y0) as usize * w + (x - x0) as usize
    };
    let mut surface = vec![u32::MAX; w * h];
    let mut surfaces: Vec<(f64, Vec<usize>)> = Vec::new();
    let mut stack = Vec::new();
    for &seed in &lit {
        if surface[local(seed)] != u32::MAX {
            continue;
        }
        let id = surfaces.len() as u32;
        surface[local(seed)] = id;
        stack.push(seed);
        let (mut sum, mut texels) = (0.0f64, Vec::new());
        while let Some(i) = stack.pop() {
            texels.push(i);
            let m = f64::from(rsm.metric[i]);
            sum += m;
            let (x, y) = (i as u32 % rsm.size, i as u32 / rsm.size);
            let neighbours = [
                (x > x0).then(|| i - 1),
                (x + 1 < x1).then(|| i + 1),
                (y > y0).then(|| i - rsm.size as usize),
                (y + 1 < y1).then(|| i + rsm.size as usize),
            ];
            for j in neighbours.into_iter().flatten() {
                if surface[local(j)] == u32::MAX
                    && is_lit(rsm, j)
                    && (f64::from(rsm.metric[j]) - m).abs() <= gap
                {
                    surface[local(j)] = id;
                    stack.push(j);
                }
            }
        }
        surfaces.push((sum / texels.len() as f64, texels));
    }
    if surfaces.len() == 1 {
        return vec![lit];
    }
    // Stable: surfaces of equal mean keep their seeds' row-major order.
    surfaces.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut layers: Vec<Vec<usize>> = Vec::new();
    let mut last = f64::NAN;
    for (mean, texels) in surfaces {
        match layers.last_mut() {
            Some(layer) if mean - last <= gap => layer.extend(texels),
            _ => layers.push(texels),
        }
        last = mean;
    }
    if layers.len() == 1 {
        return vec![lit];
    }
    for layer in &mut layers {
        layer.sort_unstable();
    }
    layers
}

/// The VPL of a leaf rectangle (over its lit texels, one layer), or `None`
/// if it has no lit texel: the dynamic VPLs' rule ([`cluster_cut`]).
fn leaf_vpl(rsm: &Rsm, (x0, x1, y0, y1): (u32, u32, u32, u32)) -> Option<Cluster> {
    let lit: Vec<usize> = (y0..y1)
        .flat_map(|y| (x0..x1).map(move |x| (y * rsm.size + x) as usize))
        .filter(|&i| is_lit(rsm, i))
        .collect();
    cluster_of(rsm, &lit)
}

/// The VPL of a set of lit texels (in row-major order), or `None` if it
/// has none.
fn cluster_of(rsm: &Rsm, texels: &[usize]) -> Option<Cluster> {
    let mut count = 0u32;
    let mut flux = [0.0f64; 3];
    let mut w_sum = 0.0f64;
    let mut wp = [0.0f64; 3];
    let mut wn = [0.0f64; 3];
    let mut area = 0.0f64;
    let mut ap = [0.0f64; 3];
    let mut an = [0.0f64; 3];
    let mut first_normal = None;
    for &i in texels {
        count += 1;
        let f = rsm.flux[i].to_array().map(f64::from);
        let p = rsm.position[i].to_array().map(f64::from);
        let n = rsm.normal[i].to_array().map(f64::from);
        let a = f64::from(rsm.area[i]);
        let w = texel_weight(rsm, i);
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
    // Normalized in f64: a weighted sum's squared length overflows f32 for
    // very bright lights.
    let normal = [wn, an]
        .into_iter()
        .map(|v| glam::DVec3::from_array(v).normalize_or_zero().as_vec3())
        .find(|n| *n != Vec3::ZERO)
        .or(first_normal)
        .unwrap_or(Vec3::ZERO);
    // The lit texel nearest the centroid (f64 distances, first on a tie).
    let mut anchor = position;
    let mut best = f64::INFINITY;
    for &i in texels {
        let d = (rsm.position[i].as_dvec3() - position.as_dvec3()).length_squared();
        if d < best {
            best = d;
            anchor = rsm.position[i];
        }
    }
    Some(Cluster {
        position,
        anchor,
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
    /// Index of its map among those clustered together.
    map: u32,
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
    /// Larger `e` first, then shallower, then the earlier map, then the
    /// smaller Morton code.
    fn cmp(&self, o: &Self) -> Ordering {
        self.e
            .total_cmp(&o.e)
            .then(o.node.level.cmp(&self.node.level))
            .then(o.map.cmp(&self.map))
            .then(o.morton.cmp(&self.morton))
    }
}

/// One map of a refinement: its pyramid, which nodes are split, and how
/// many kept VPLs each node makes as a leaf (memoised).
struct MapCut<'a> {
    rsm: &'a Rsm,
    pyramid: Pyramid,
    /// `split[level][iy * m + ix]` for levels above the texels.
    split: Vec<Vec<bool>>,
    /// Per node, level by level, row-major within a level: the VPLs it
    /// makes as a leaf that `keep` keeps (`u32::MAX`: not yet known).
    kept: Vec<u32>,
    /// Where each level starts in `kept`.
    offsets: Vec<usize>,
}

impl<'a> MapCut<'a> {
    fn new(rsm: &'a Rsm, pyramid: Pyramid) -> Self {
        let texel_level = pyramid.texel_level();
        let split = (0..texel_level)
            .map(|level| vec![false; (pyramid.cells(level) as usize).pow(2)])
            .collect();
        let mut offsets = Vec::with_capacity(texel_level as usize + 1);
        let mut total = 0usize;
        for level in 0..=texel_level {
            offsets.push(total);
            total += (pyramid.cells(level) as usize).pow(2);
        }
        MapCut {
            rsm,
            pyramid,
            split,
            kept: vec![u32::MAX; total],
            offsets,
        }
    }

    /// The VPLs `node` makes as a leaf (one per depth layer) that `keep`
    /// keeps (`map`: this map's index).
    fn kept(&mut self, map: usize, node: Node, keep: &Keep<'_>) -> u32 {
        let slot = self.offsets[node.level as usize]
            + (node.iy * self.pyramid.cells(node.level) + node.ix) as usize;
        if self.kept[slot] == u32::MAX {
            let rsm = self.rsm;
            let n = leaf_layers(rsm, self.pyramid.rect(node))
                .iter()
                .filter(|layer| {
                    cluster_of(rsm, layer)
                        .is_some_and(|c| keep(map, rsm, layer, &c, reaching_of(rsm, layer)))
                })
                .count();
            self.kept[slot] = u32::try_from(n).unwrap_or(u32::MAX - 1);
        }
        self.kept[slot]
    }

    fn is_split(&self, node: Node) -> bool {
        let m = self.pyramid.cells(node.level) as usize;
        self.split[node.level as usize][node.iy as usize * m + node.ix as usize]
    }
}

/// The greedy refinement of a `Count` budget over every map at once
/// (module docs, "Budget"): frontier nodes by capped score, kept VPLs
/// counted exactly.
struct Refinement<'a, 'k> {
    maps: Vec<MapCut<'a>>,
    heap: BinaryHeap<Entry>,
    /// Kept VPLs of the current leaves.
    count: u64,
    keep: &'k Keep<'k>,
}

impl<'a, 'k> Refinement<'a, 'k> {
    fn new(maps: Vec<MapCut<'a>>, keep: &'k Keep<'k>) -> Self {
        let mut r = Refinement {
            maps,
            heap: BinaryHeap::new(),
            count: 0,
            keep,
        };
        for k in 0..r.maps.len() {
            let root = r.maps[k].pyramid.root();
            r.count += u64::from(r.maps[k].kept(k, root, keep));
            r.push(k, root, f32::INFINITY);
        }
        r
    }

    fn push(&mut self, map: usize, node: Node, parent_e: f32) {
        let m = &self.maps[map];
        if let Some(s) = m.pyramid.score(m.rsm, node) {
            self.heap.push(Entry {
                e: s.min(parent_e),
                node,
                map: map as u32,
                morton: morton(node.ix, node.iy),
            });
        }
    }

    /// Change in kept VPLs if `entry`'s node is split.
    fn delta(&mut self, entry: Entry) -> i64 {
        let (k, keep) = (entry.map as usize, self.keep);
        let map = &mut self.maps[k];
        let kids: Vec<Node> = map.pyramid.children(entry.node).collect();
        let after: i64 = kids.iter().map(|&c| i64::from(map.kept(k, c, keep))).sum();
        after - i64::from(map.kept(k, entry.node, keep))
    }

    fn split(&mut self, entry: Entry, delta: i64) {
        let (k, node) = (entry.map as usize, entry.node);
        let map = &mut self.maps[k];
        let m = map.pyramid.cells(node.level) as usize;
        map.split[node.level as usize][node.iy as usize * m + node.ix as usize] = true;
        self.count = self.count.saturating_add_signed(delta);
        let kids: Vec<Node> = map.pyramid.children(node).collect();
        for child in kids {
            self.push(k, child, entry.e);
        }
    }
}

/// The clustering of several maps under one budget: every light's views
/// ([`cluster_joint`]).
#[derive(Clone, Debug, PartialEq)]
pub struct JointClustering {
    /// One clustering per map, in the order given.
    pub maps: Vec<Clustering>,
    /// The threshold every map was cut with.
    pub threshold: f32,
}

impl JointClustering {
    /// VPLs over all maps.
    pub fn vpl_count(&self) -> usize {
        self.maps.iter().map(|c| c.vpls.len()).sum()
    }
}

/// Clusters several RSMs — every view of every light — as one: each node's
/// `share` is its reaching flux over the total of **all** maps, so one
/// threshold spends one budget where the light is, across lights, by the
/// same rule as within one map (module docs; a light whose bounce is a
/// millionth of the others' gets its root node and no splits).
/// `Threshold(t)` cuts every map at `t`; `Count(n)` is the greedy
/// refinement of the module docs over every map at once. A `Count` budget
/// counts the VPLs whose light reaches something ([`Keep`]); with one map
/// this is [`cluster`].
pub fn cluster_joint(rsms: &[&Rsm], target: ClusterTarget) -> JointClustering {
    for r in rsms {
        check_arrays(r);
    }
    // As the pyramids weigh: by the reaching flux if any lit texel's light
    // reaches a surface.
    let by_reach = rsms
        .iter()
        .any(|r| (0..r.metric.len()).any(|i| is_lit(r, i) && reaching_of(r, &[i]) > 0.0));
    let keep = move |_: usize, _: &Rsm, _: &[usize], _: &Cluster, reaching: f64| {
        reaching > 0.0 || !by_reach
    };
    cluster_joint_keeping(rsms, target, &keep)
}

/// [`cluster_joint`], with a `Count` budget counting the VPLs `keep` keeps
/// (`keep`'s map index is into `rsms`). Every VPL the clustering makes is
/// returned; the caller drops those `keep` does not keep.
pub fn cluster_joint_keeping(
    rsms: &[&Rsm],
    target: ClusterTarget,
    keep: &Keep<'_>,
) -> JointClustering {
    for r in rsms {
        check_arrays(r);
    }
    let live: Vec<(usize, Pyramid)> = rsms
        .iter()
        .enumerate()
        .filter(|(_, r)| r.size > 0)
        .map(|(i, r)| (i, Pyramid::new(r)))
        .collect();
    let (mut reaching, mut flux) = (0.0f64, 0.0f64);
    for (i, p) in &live {
        let (r, f) = p.root_totals(rsms[*i]);
        reaching += r;
        flux += f;
    }
    let by_reach = reaching > 0.0;
    let total = if by_reach { reaching } else { flux };
    let live: Vec<(usize, Pyramid)> = live
        .into_iter()
        .map(|(i, mut p)| {
            p.share_with(total, by_reach);
            (i, p)
        })
        .collect();
    let empty = |threshold: f32| Clustering {
        vpls: Vec::new(),
        texel_vpl: Vec::new(),
        rects: Vec::new(),
        threshold,
    };
    let mut out: Vec<Option<Emitted>> = vec![None; rsms.len()];
    let threshold = match target {
        ClusterTarget::Threshold(t) => {
            for (i, p) in &live {
                let rsm = rsms[*i];
                out[*i] = Some(emit(rsm, p, |node| {
                    p.score(rsm, node).is_some_and(|s| s >= t)
                }));
            }
            t
        }
        ClusterTarget::Count(n) => {
            let index: Vec<usize> = live.iter().map(|(i, _)| *i).collect();
            // The keep rule sees each map by its index into `rsms`.
            let keep_live = |k: usize, rsm: &Rsm, texels: &[usize], c: &Cluster, r: f64| {
                keep(index[k], rsm, texels, c, r)
            };
            let maps = live
                .into_iter()
                .map(|(i, p)| MapCut::new(rsms[i], p))
                .collect();
            let (r, threshold) = refine_count(maps, u64::from(n), &keep_live);
            for (k, e) in r.into_iter().enumerate() {
                out[index[k]] = Some(e);
            }
            threshold
        }
    };
    let maps = out
        .into_iter()
        .map(|e| match e {
            Some((vpls, texel_vpl, rects)) => Clustering {
                vpls,
                texel_vpl,
                rects,
                threshold,
            },
            None => empty(threshold),
        })
        .collect();
    JointClustering { maps, threshold }
}

/// `ClusterTarget::Count(n)` over `maps`: splits in non-increasing capped
/// score until `n` VPLs are kept (or the next split would overshoot by more
/// than stopping undershoots); each map's VPLs, and the threshold that
/// reproduces the cut (module docs, "Budget").
fn refine_count(maps: Vec<MapCut<'_>>, n: u64, keep: &Keep<'_>) -> (Vec<Emitted>, f32) {
    let mut r = Refinement::new(maps, keep);
    let mut last_e: Option<f32> = None;
    // The capped score of the run before the current one.
    let mut prev_e: Option<f32> = None;
    let mut group_start = r.count;
    while r.count < n {
        let Some(&top) = r.heap.peek() else { break };
        let delta = r.delta(top);
        let after = r.count.saturating_add_signed(delta);
        if after > n && after - n >= n - r.count {
            break;
        }
        r.heap.pop();
        if last_e != Some(top.e) {
            prev_e = last_e;
            last_e = Some(top.e);
            group_start = r.count;
        }
        r.split(top, delta);
    }
    let result = r.count;
    let emitted: Vec<Emitted> = r
        .maps
        .iter()
        .map(|m| emit(m.rsm, &m.pyramid, |node| m.is_split(node)))
        .collect();

    // Any threshold in the gap between two consecutive capped scores splits
    // the same nodes; the geometric middle of the gap keeps that true when a
    // score moves by rounding (the same scene in other units).
    let middle = |hi: f32, lo: f32| -> f32 {
        let m = if lo > 0.0 {
            (f64::from(hi) * f64::from(lo)).sqrt() as f32
        } else {
            hi * 0.5
        };
        if m > lo && m <= hi { m } else { hi }
    };
    let threshold = match last_e {
        None => r
            .heap
            .peek()
            .map_or(f32::INFINITY, |top| top.e.next_up().max(top.e * 2.0)),
        Some(e) => {
            // Finish the run of equal e: Threshold(t ≤ e) splits it whole;
            // a t above e stops before it.
            while let Some(&top) = r.heap.peek() {
                if top.e < e {
                    break;
                }
                r.heap.pop();
                let delta = r.delta(top);
                r.split(top, delta);
            }
            let with_run = r.count;
            if with_run.abs_diff(result) <= group_start.abs_diff(result) {
                let next = r.heap.peek().map_or(0.0, |top| top.e);
                middle(e, next)
            } else {
                match prev_e {
                    Some(p) => middle(p, e).max(e.next_up()),
                    None => e.next_up().max(e * 2.0),
                }
            }
        }
    };
    (emitted, threshold)
}

/// The slot of `node` in a power-of-two quadtree: `(4^level − 1)/3 +
/// morton(ix, iy)` (see the module docs).
fn slot(node: Node) -> u64 {
    ((1u64 << (2 * node.level)) - 1) / 3 + morton(node.ix, node.iy)
}

/// The cut of `Threshold(threshold)` with a depth limit, in slot order: the
/// CPU twin of the runtime's GPU clustering of dynamic VPLs.
///
/// A node splits iff its depth is below `max_depth` (the root has depth 0;
/// `max_depth` beyond the single-texel level changes nothing), it has at
/// least two texels and a lit one, and it and all its ancestors score
/// `S ≥ threshold`. Each non-split node that is reached (all ancestors split)
/// and has lit texels is a VPL, made as in [`cluster`].
///
/// **Slots.** The nodes of depth `0..=max_depth` are numbered level by
/// level, level 0 first, and within a level by the Morton code of the node's
/// cell (`ix` bits in the even positions, `iy` in the odd ones; row 0 at
/// the top): node `(d, ix, iy)` has slot `(4^d − 1)/3 + morton(ix, iy)`. The
/// result holds one [`Cluster`] per slot that is a VPL, in increasing slot
/// order, skipping the slots that are not.
///
/// Only power-of-two sizes are supported: any other size (or 0) gives an
/// empty result.
pub fn cluster_cut(rsm: &Rsm, threshold: f32, max_depth: u32) -> Vec<Cluster> {
    cut(rsm, threshold, max_depth, rsm.size)
}

/// [`cluster_cut`] over the `2^levels`-texel square of `rsm` from texel
/// `origin` (texels past the map are empty), the depth spread still
/// measured against the whole map's width: the CPU twin of the runtime's
/// clustering of the moving objects' footprint in a light view. Slots are
/// numbered within the window.
pub fn cluster_cut_window(
    rsm: &Rsm,
    threshold: f32,
    max_depth: u32,
    origin: [u32; 2],
    levels: u32,
) -> Vec<Cluster> {
    let side = 1u32 << levels.min(15);
    let mut w = Rsm::empty(side, rsm.view);
    for y in 0..side {
        for x in 0..side {
            let (mx, my) = (origin[0] + x, origin[1] + y);
            if mx >= rsm.size || my >= rsm.size {
                continue;
            }
            let (i, j) = ((y * side + x) as usize, (my * rsm.size + mx) as usize);
            w.metric[i] = rsm.metric[j];
            w.position[i] = rsm.position[j];
            w.normal[i] = rsm.normal[j];
            w.flux[i] = rsm.flux[j];
            w.area[i] = rsm.area[j];
            w.reach[i] = rsm.reach[j];
        }
    }
    cut(&w, threshold, max_depth, rsm.size)
}

/// [`cluster_cut`] with the depth spread measured against a view
/// `score_width` texels wide.
fn cut(rsm: &Rsm, threshold: f32, max_depth: u32, score_width: u32) -> Vec<Cluster> {
    if !rsm.size.is_power_of_two() {
        return Vec::new();
    }
    let texels = (rsm.size as usize) * (rsm.size as usize);
    assert!(
        rsm.metric.len() == texels
            && rsm.position.len() == texels
            && rsm.normal.len() == texels
            && rsm.flux.len() == texels
            && rsm.area.len() == texels,
        "RSM arrays must hold size² texels"
    );
    let mut pyramid = Pyramid::new(rsm);
    pyramid.set_score_width(score_width);
    let limit = max_depth.min(pyramid.texel_level());
    let mut out: Vec<(u64, Cluster)> = Vec::new();
    let mut stack = vec![pyramid.root()];
    while let Some(node) = stack.pop() {
        let split = node.level < limit && pyramid.score(rsm, node).is_some_and(|s| s >= threshold);
        if split {
            stack.extend(pyramid.children(node));
        } else if let Some(vpl) = leaf_vpl(rsm, pyramid.rect(node)) {
            out.push((slot(node), vpl));
        }
    }
    out.sort_by_key(|&(slot, _)| slot);
    out.into_iter().map(|(_, vpl)| vpl).collect()
}
