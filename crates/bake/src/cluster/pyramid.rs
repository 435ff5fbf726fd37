//! The per-node moment pyramid of the clustering quadtree (see the docs of
//! [`crate::cluster`] for the rule it serves).
//!
//! The quadtree splits a node's texel rectangle at the (floor) midpoints of
//! both axes; an axis that is one texel wide is not split. Because the map
//! is square and both axes split the same way, the nodes at depth `d` are the
//! products of a per-axis list of intervals (`intervals[d]`), which makes
//! every depth a regular `m_d × m_d` grid: a mip level. For a power-of-two
//! map this is exactly the usual mip pyramid (`m_d = 2^d`).

use glam::Vec3;

use crate::rsm::Rsm;

/// Whether texel `i` is *lit*: it sees a surface (finite metric) and
/// reflects light (`flux.r + flux.g + flux.b` positive and finite, summed in
/// `f64`). Every other texel counts as empty: it reflects nothing.
pub(crate) fn is_lit(rsm: &Rsm, i: usize) -> bool {
    rsm.is_valid(i) && {
        let w = texel_weight(rsm, i);
        w > 0.0 && w.is_finite()
    }
}

/// `flux.r + flux.g + flux.b` of texel `i`, in `f64`: the texel's weight.
pub(crate) fn texel_weight(rsm: &Rsm, i: usize) -> f64 {
    let f = rsm.flux[i];
    f64::from(f.x) + f64::from(f.y) + f64::from(f.z)
}

/// Statistics of one node's texels, merged bottom-up. Every split statistic
/// is unweighted (weight = texel count) and covers the node's *lit* texels
/// only ([`is_lit`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Moments {
    /// Texels in the node.
    pub total: u32,
    /// Lit texels.
    pub lit: u32,
    /// Mean of the metric over lit texels.
    pub mean_metric: f64,
    /// `Σ (metric − mean)²` over lit texels (Chan et al.'s `M2`).
    pub m2_metric: f64,
    /// `Σ normal` over lit texels.
    pub sum_normal: [f64; 3],
    /// `Σ footprint` (world size of one texel) over lit texels.
    pub sum_footprint: f64,
    /// `Σ (flux.r + flux.g + flux.b)` over lit texels.
    pub sum_flux: f64,
    /// `Σ (flux.r + flux.g + flux.b) · reach` over lit texels: the flux
    /// that reaches a surface ([`Rsm::reach`]); what the score weighs.
    pub sum_reaching: f64,
}

impl Moments {
    /// The moments of the single texel `i`.
    pub fn texel(rsm: &Rsm, i: usize) -> Moments {
        if !is_lit(rsm, i) {
            return Moments {
                total: 1,
                ..Moments::default()
            };
        }
        let n = rsm.normal[i];
        Moments {
            total: 1,
            lit: 1,
            mean_metric: f64::from(rsm.metric[i]),
            m2_metric: 0.0,
            sum_normal: [f64::from(n.x), f64::from(n.y), f64::from(n.z)],
            sum_footprint: f64::from(rsm.footprint(i)),
            sum_flux: texel_weight(rsm, i),
            sum_reaching: texel_weight(rsm, i)
                * f64::from(rsm.reach.get(i).copied().unwrap_or(1.0)),
        }
    }

    /// The moments of the union of two disjoint nodes (the mean/`M2` merge
    /// of Chan, Golub & LeVeque, which stays accurate in `f32` too).
    pub fn merge(self, o: Moments) -> Moments {
        let total = self.total + o.total;
        let (mean_metric, m2_metric) = match (self.lit, o.lit) {
            (0, _) => (o.mean_metric, o.m2_metric),
            (_, 0) => (self.mean_metric, self.m2_metric),
            (na, nb) => {
                let (na, nb) = (f64::from(na), f64::from(nb));
                let n = na + nb;
                let delta = o.mean_metric - self.mean_metric;
                (
                    self.mean_metric + delta * (nb / n),
                    self.m2_metric + o.m2_metric + delta * delta * (na * nb / n),
                )
            }
        };
        Moments {
            total,
            lit: self.lit + o.lit,
            mean_metric,
            m2_metric,
            sum_normal: [
                self.sum_normal[0] + o.sum_normal[0],
                self.sum_normal[1] + o.sum_normal[1],
                self.sum_normal[2] + o.sum_normal[2],
            ],
            sum_footprint: self.sum_footprint + o.sum_footprint,
            sum_flux: self.sum_flux + o.sum_flux,
            sum_reaching: self.sum_reaching + o.sum_reaching,
        }
    }

    /// The node's split score, or `None` if it can never be split (a single
    /// texel, no lit texel, or — under `by_reach` — no lit texel whose light
    /// reaches anything: none of its descendants could count, so splitting
    /// it would only make VPLs the probe drops or the budget ignores).
    /// `S = max(D, Nn, M) · share²` with
    ///
    /// - depth term `D = Var(metric) / (map_size · mean footprint)²`,
    /// - normal term `Nn = 1 − |Σ normal| / lit`,
    /// - mixed term `M = 1` if the node also holds texels that are not lit,
    /// - `share = sum_reaching / total` (`total`: the whole map's; the flux
    ///   instead when nothing in the map reaches a surface),
    ///
    /// all over lit texels, evaluated in `f64` and rounded to `f32` (NaN
    /// counts as `+∞`).
    pub fn score(&self, map_size: u32, total_flux: f64, by_reach: bool) -> Option<f32> {
        if self.total <= 1 || self.lit == 0 || (by_reach && self.sum_reaching <= 0.0) {
            return None;
        }
        let n = f64::from(self.lit);
        let var = (self.m2_metric / n).max(0.0);
        let width = f64::from(map_size) * (self.sum_footprint / n);
        let depth = if width > 0.0 {
            var / (width * width)
        } else if var > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        let [x, y, z] = self.sum_normal;
        let normal = (1.0 - (x * x + y * y + z * z).sqrt() / n).max(0.0);
        let mixed = if self.lit < self.total { 1.0 } else { 0.0 };
        let share = if by_reach {
            self.sum_reaching
        } else {
            self.sum_flux
        } / total_flux;
        // share², not share: see "Why share squared" in cluster.rs.
        let s = depth.max(normal).max(mixed) * share * share;
        Some(if s.is_nan() { f32::INFINITY } else { s as f32 })
    }
}

/// A quadtree node: depth `level` (0 = root) and its column/row in that
/// level's grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Node {
    /// Depth; [`Pyramid::texel_level`] is the level of single texels.
    pub level: u32,
    /// Column in the level's grid.
    pub ix: u32,
    /// Row in the level's grid.
    pub iy: u32,
}

/// The quadtree of an `size × size` map with the moments of every node
/// above the texel level.
pub(crate) struct Pyramid {
    size: u32,
    /// `intervals[d][i]`: the texel range `[start, end)` of column (and
    /// row) `i` at depth `d`. The last level is single texels.
    intervals: Vec<Vec<(u32, u32)>>,
    /// `children[d][i]`: `(first, count)` of interval `i`'s children at
    /// depth `d + 1` (`count` is 1 for a one-texel interval, else 2).
    children: Vec<Vec<(u32, u32)>>,
    /// `moments[d]`: row-major `m_d × m_d` grid, for `d` above the texel
    /// level (texel moments are read from the RSM on demand).
    moments: Vec<Vec<Moments>>,
    /// `Σ (flux.r + flux.g + flux.b)` over all lit texels (the root's).
    total_flux: f64,
    /// Whether scores weigh the reaching flux (else the flux: nothing in
    /// the map reaches a surface).
    by_reach: bool,
    /// The view's width in texels that the depth spread is measured in
    /// (`size`, or the whole map's for a window of it).
    score_width: u32,
}

impl Pyramid {
    /// Builds the quadtree of `rsm` and its moments bottom-up. `rsm.size`
    /// must be at least 1.
    pub fn new(rsm: &Rsm) -> Pyramid {
        let size = rsm.size;
        let mut intervals = vec![vec![(0u32, size)]];
        let mut children = Vec::new();
        while intervals
            .last()
            .is_some_and(|l| l.iter().any(|&(a, b)| b - a > 1))
        {
            let level = intervals.last().expect("non-empty");
            let mut next = Vec::with_capacity(level.len() * 2);
            let mut kids = Vec::with_capacity(level.len());
            for &(a, b) in level {
                let first = next.len() as u32;
                if b - a > 1 {
                    let m = a + (b - a) / 2;
                    next.push((a, m));
                    next.push((m, b));
                    kids.push((first, 2));
                } else {
                    next.push((a, b));
                    kids.push((first, 1));
                }
            }
            children.push(kids);
            intervals.push(next);
        }
        let mut pyramid = Pyramid {
            size,
            intervals,
            children,
            moments: Vec::new(),
            total_flux: 0.0,
            by_reach: true,
            score_width: size,
        };
        let texel_level = pyramid.texel_level();
        let mut moments: Vec<Vec<Moments>> = vec![Vec::new(); texel_level as usize];
        for level in (0..texel_level).rev() {
            let m = pyramid.intervals[level as usize].len() as u32;
            let mut grid = Vec::with_capacity((m * m) as usize);
            for iy in 0..m {
                for ix in 0..m {
                    let node = Node { level, ix, iy };
                    let mut acc: Option<Moments> = None;
                    for child in pyramid.children(node) {
                        let c = if child.level == texel_level {
                            Moments::texel(rsm, (child.iy * size + child.ix) as usize)
                        } else {
                            let cm = pyramid.intervals[child.level as usize].len() as u32;
                            moments[child.level as usize][(child.iy * cm + child.ix) as usize]
                        };
                        acc = Some(match acc {
                            None => c,
                            Some(a) => a.merge(c),
                        });
                    }
                    grid.push(acc.expect("every node has a child"));
                }
            }
            moments[level as usize] = grid;
        }
        pyramid.moments = moments;
        let root = pyramid.moments(rsm, pyramid.root());
        // Nothing reaches anything (a lone floor under the sun): weigh by
        // flux, so the rule still spreads the VPLs.
        pyramid.by_reach = root.sum_reaching > 0.0;
        pyramid.total_flux = if pyramid.by_reach {
            root.sum_reaching
        } else {
            root.sum_flux
        };
        pyramid
    }

    /// The root's reaching and total flux, `(Σ flux·reach, Σ flux)`.
    pub fn root_totals(&self, rsm: &Rsm) -> (f64, f64) {
        let root = self.moments(rsm, self.root());
        (root.sum_reaching, root.sum_flux)
    }

    /// Scores against a denominator shared by several maps (every light's
    /// views, [`crate::cluster::cluster_joint`]): `total_flux` is the sum
    /// over all of them, `by_reach` whether any of them reaches a surface.
    pub fn share_with(&mut self, total_flux: f64, by_reach: bool) {
        self.total_flux = total_flux;
        self.by_reach = by_reach;
    }

    /// Measures the depth spread against a view `width` texels wide: the
    /// whole map's when this pyramid is over a window of it.
    pub fn set_score_width(&mut self, width: u32) {
        self.score_width = width;
    }

    /// The split score of `node` ([`Moments::score`] with this map's width
    /// and total flux).
    pub fn score(&self, rsm: &Rsm, node: Node) -> Option<f32> {
        self.moments(rsm, node)
            .score(self.score_width, self.total_flux, self.by_reach)
    }

    /// Number of columns (= rows) of the grid at `level`.
    pub fn cells(&self, level: u32) -> u32 {
        self.intervals[level as usize].len() as u32
    }

    /// The level of single-texel nodes (the deepest).
    pub fn texel_level(&self) -> u32 {
        (self.intervals.len() - 1) as u32
    }

    /// The root node.
    pub fn root(&self) -> Node {
        Node {
            level: 0,
            ix: 0,
            iy: 0,
        }
    }

    /// The texel rectangle `(x0, x1, y0, y1)` of `node` (half-open).
    pub fn rect(&self, node: Node) -> (u32, u32, u32, u32) {
        let l = &self.intervals[node.level as usize];
        let (x0, x1) = l[node.ix as usize];
        let (y0, y1) = l[node.iy as usize];
        (x0, x1, y0, y1)
    }

    /// The moments of `node`.
    pub fn moments(&self, rsm: &Rsm, node: Node) -> Moments {
        if node.level == self.texel_level() {
            Moments::texel(rsm, (node.iy * self.size + node.ix) as usize)
        } else {
            let m = self.intervals[node.level as usize].len() as u32;
            self.moments[node.level as usize][(node.iy * m + node.ix) as usize]
        }
    }

    /// The children of `node` in Morton order (row by row, left to right:
    /// top-left, top-right, bottom-left, bottom-right); empty for a texel.
    pub fn children(&self, node: Node) -> impl Iterator<Item = Node> + use<> {
        let (cx, cy) = if node.level >= self.texel_level() {
            ((0, 0), (0, 0))
        } else {
            let k = &self.children[node.level as usize];
            (k[node.ix as usize], k[node.iy as usize])
        };
        let level = node.level + 1;
        (cy.0..cy.0 + cy.1)
            .flat_map(move |iy| (cx.0..cx.0 + cx.1).map(move |ix| Node { level, ix, iy }))
    }
}

/// Interleaves the bits of `x` and `y` (x in the even bits): the Morton
/// code of a grid cell.
pub(crate) fn morton(x: u32, y: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = u64::from(v);
        v = (v | (v << 16)) & 0x0000_ffff_0000_ffff;
        v = (v | (v << 8)) & 0x00ff_00ff_00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        v = (v | (v << 1)) & 0x5555_5555_5555_5555;
        v
    }
    spread(x) | (spread(y) << 1)
}

/// `Vec3` of an `f64` accumulator.
pub(crate) fn vec3(v: [f64; 3]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}
