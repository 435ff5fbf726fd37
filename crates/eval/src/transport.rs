//! CPU twin of the runtime shading's VPL transport (`runtime/src/shade.wgsl`): the irradiance a
//! static VPL sends to a receiver before visibility, from one disk far away
//! and from its near-field tree up close (`gibake_bake::near_field`). Tests
//! compare the GPU image with sums made from these functions.

use gibake_asset::{Facing, NODES_PER_VPL, VplRecord};
use glam::Vec3;

/// A finest near-field node's own near field, in its disk radii `√(A/π)`
/// (must match `NEAR_FIELD_RATIO` in shade.wgsl): nearer than this its
/// light skips the map test ([`open_weight`]) and a receiver across a
/// crease from it takes the square's exact form factor
/// ([`near_node_irradiance`]). At 4 radii a disk's point approximation is
/// within a few per cent; measured in docs/method.md ("Near field").
pub const NEAR_FIELD_RATIO: f32 = 4.0;

/// A VPL or a level-1 or level-2 node is replaced by its children where the
/// receiver is nearer than this many of its disk radii (the runtime's
/// default `RenderSettings::near_field_descent`, checked by the constants
/// test below). Twice [`NEAR_FIELD_RATIO`] since
/// session 19: beyond the disk's own near field, a cluster's parts still
/// send their light from where each is and the way each faces (the cosine
/// at the receiver varies across the cluster), which the parent's one
/// disk misses: in this twin with exact visibility the error fell on six
/// of eleven scenes and rose on two (the arena, the cave) for 1.4–1.9× the
/// disk evaluations (docs/method.md, "Descent ratio"). The twin draws
/// only this default.
pub const DESCENT_RATIO: f32 = 2.0 * NEAR_FIELD_RATIO;

/// A static VPL is drawn as one disk only beyond this many of its disk
/// radii (twice the descent, shade.wgsl `in_far_field`); nearer, as its
/// near-field tree, whose level-1 nodes stand for it between
/// [`DESCENT_RATIO`] and this. Twice the descent: a cluster of
/// texels facing different ways (a crown, a rock) sends its light from
/// where each part is and the way each faces, which one disk misses there
/// (docs/method.md, "Node lobes").
pub const FAR_FIELD_RATIO: f32 = 2.0 * DESCENT_RATIO;

/// [`DESCENT_RATIO`] for the later bounces' VPLs (the runtime's default
/// `RenderSettings::later_near_field_descent`, checked by the constants
/// test below): half the first bounce's. A later VPL stands for a wide
/// stretch of wall, so at the first bounce's descent its tree descends at
/// nearly every pixel of a room; at half of it the every-bounce figures of
/// the real levels stay within 1.8 points of it (the arena's 4 nearer)
/// for about 0.55–0.6× the later VPLs' share of the frame (docs/method.md,
/// "Every bounce" → "Frame cost").
pub const LATER_DESCENT_RATIO: f32 = 0.5 * DESCENT_RATIO;

/// Irradiance at `x` (shading normal `ns`, geometric `ng`) from a disk-like
/// emitter at `origin` with normal `nv`, area `a`, flux `phi`:
/// `Φ/π · cosθ_v cosθ_r / √(d⁴ + (A/π)²)` (shade.wgsl `vpl_irradiance`).
pub fn disk_irradiance(
    origin: Vec3,
    nv: Vec3,
    a: f32,
    phi: Vec3,
    x: Vec3,
    ns: Vec3,
    ng: Vec3,
) -> Vec3 {
    lobe_irradiance(origin, nv, 1.0, a, phi, x, ns, ng)
}

/// Irradiance at `x` from a VPL seen from afar: the disk of
/// [`disk_irradiance`] with the far-field lobe [`far_lobe`]`(c, cos θ_v)/π`
/// per unit flux (`c`: [`gibake_asset::lobe_coherence`]) in place of the
/// cosine lobe, below the normal's horizon too; `c = 1` gives
/// [`disk_irradiance`] (shade.wgsl `vpl_lobe_irradiance`).
#[allow(clippy::too_many_arguments)]
pub fn lobe_irradiance(
    origin: Vec3,
    nv: Vec3,
    c: f32,
    a: f32,
    phi: Vec3,
    x: Vec3,
    ns: Vec3,
    ng: Vec3,
) -> Vec3 {
    let dv = x - origin;
    let d2 = dv.length_squared();
    if d2 <= 0.0 {
        return Vec3::ZERO;
    }
    let dir = dv / d2.sqrt();
    let cr = ns.dot(-dir);
    if cr <= 0.0 || ng.dot(-dir) <= 0.0 {
        return Vec3::ZERO;
    }
    let lobe = far_lobe(c, nv.dot(dir));
    if lobe <= 0.0 {
        return Vec3::ZERO;
    }
    let r2 = a / std::f32::consts::PI;
    let e = phi * (lobe * cr / std::f32::consts::PI / (d2 * d2 + r2 * r2).sqrt());
    if e.is_finite() { e } else { Vec3::ZERO }
}

/// The far-field lobe of a cluster whose texels' normals have coherence
/// `c` about its normal, at `mu = n·ω` (per unit flux, times `1/π`):
/// `(2c − 1)·max(μ, 0) + (1 − c)(1 + μ)/2` for `c ≥ ½`, `(1 + 2cμ)/4`
/// below (shade.wgsl `far_lobe`, which says why). `far_lobe(1, μ) =
/// max(μ, 0)`, the cosine lobe.
pub fn far_lobe(c: f32, mu: f32) -> f32 {
    let c = if c.is_nan() { 1.0 } else { c.clamp(0.0, 1.0) };
    if c >= 0.5 {
        (2.0 * c - 1.0) * mu.max(0.0) + (1.0 - c) * (1.0 + mu) * 0.5
    } else {
        (1.0 + 2.0 * c * mu) * 0.25
    }
}

/// Whether `x` is in the near field of a disk at `p` of area `a`.
pub fn is_near(x: Vec3, p: Vec3, a: f32) -> bool {
    within(x, p, a, NEAR_FIELD_RATIO)
}

/// Whether a node (or VPL) of area `a` at `p` is drawn as its children at
/// `x` ([`DESCENT_RATIO`]; shade.wgsl `descends`).
pub fn descends(x: Vec3, p: Vec3, a: f32) -> bool {
    within(x, p, a, DESCENT_RATIO)
}

/// [`descends`] at another descent ratio.
fn descends_at(x: Vec3, p: Vec3, a: f32, descent: f32) -> bool {
    within(x, p, a, descent)
}

/// Whether a static VPL of area `a` drawn from `p` is one disk at `x`
/// (beyond [`FAR_FIELD_RATIO`] radii).
pub fn is_far(x: Vec3, p: Vec3, a: f32) -> bool {
    !within(x, p, a, FAR_FIELD_RATIO)
}

/// Whether `x` is nearer to `p` than `ratio` radii `√(a/π)`.
fn within(x: Vec3, p: Vec3, a: f32, ratio: f32) -> bool {
    (x - p).length_squared() < ratio * ratio * a / std::f32::consts::PI
}

/// What shading holds for one static VPL's far-field disks, each computed
/// once at load (`baked.rs`): the far-field lobe coherences — its own
/// ([`gibake_asset::lobe_coherence`]) and its level-1 and level-2 nodes'
/// ([`gibake_asset::node_lobe_coherences`]) — and the facing shifts of the
/// same ([`gibake_asset::facings`]). The default (all 1, no shift) is
/// cosine lobes drawn from the centroids.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VplLobes {
    /// The VPL's, where it is drawn as one disk.
    pub vpl: f32,
    /// Its level-1 and level-2 nodes', in tree order.
    pub nodes: [f32; 4 + 16],
    /// Facing shifts: the VPL's, then its level-1 and level-2 nodes' in
    /// tree order.
    pub facings: [Facing; gibake_asset::FACINGS_PER_VPL],
    /// Its level-3 nodes' texel coherences, in tree order
    /// ([`gibake_asset::Asset::vpl_coherence`]; 1: a cosine lobe).
    pub level3: [f32; gibake_asset::LEVEL3_NODES],
}

impl Default for VplLobes {
    fn default() -> Self {
        VplLobes {
            vpl: 1.0,
            nodes: [1.0; 4 + 16],
            facings: [Facing::NONE; gibake_asset::FACINGS_PER_VPL],
            level3: [1.0; gibake_asset::LEVEL3_NODES],
        }
    }
}

impl VplLobes {
    /// The coherences and facing shifts of a VPL whose near-field tree is
    /// `tree` and whose level-3 nodes' texel coherences are `coherence`
    /// (empty: 1): [`gibake_asset::tree_lobes`], as `baked.rs` computes
    /// them at load.
    pub fn of_tree(tree: &[VplRecord], coherence: &[f32]) -> Self {
        let l = gibake_asset::tree_lobes(tree, coherence);
        let mut level3 = [1.0; gibake_asset::LEVEL3_NODES];
        if coherence.len() == level3.len() {
            level3.copy_from_slice(coherence);
        }
        VplLobes {
            vpl: l.vpl,
            nodes: l.nodes,
            facings: l.facings,
            level3,
        }
    }
}

/// Where a cluster drawn at `p` with facing shift `f` sends its light to a
/// receiver at `x` from: `p + F·ω`, `ω` the unit direction from `p` to `x`
/// ([`Facing::shift`]; `p` itself at `x = p`). shade.wgsl `facing_point`.
pub fn facing_point(p: Vec3, f: &Facing, x: Vec3) -> Vec3 {
    let w = (x - p).normalize_or_zero();
    p + Vec3::from_array(f.shift(w.to_array()))
}

/// Irradiance at `x` from a level-1 or level-2 near-field node `n` beyond
/// its own near field: its disk with the far-field lobe at coherence `c`,
/// its level-3 nodes' ([`VplLobes::nodes`]; none from an empty node;
/// shade.wgsl `node_lobe_irradiance`).
pub fn node_lobe_irradiance(n: &VplRecord, c: f32, x: Vec3, ns: Vec3, ng: Vec3) -> Vec3 {
    if n.texels == 0 {
        return Vec3::ZERO;
    }
    lobe_irradiance(
        Vec3::from_array(n.position),
        Vec3::from_array(n.normal),
        c,
        n.area,
        Vec3::from_array(n.flux),
        x,
        ns,
        ng,
    )
}

/// Near-field node `n` drawn towards `x` from its [`facing_point`].
fn facing_node(n: &VplRecord, f: &Facing, x: Vec3) -> VplRecord {
    VplRecord {
        position: facing_point(Vec3::from_array(n.position), f, x).to_array(),
        ..*n
    }
}

/// Irradiance at `x` from one near-field node `n` drawn as a disk with
/// its own normal and cosine lobe (none from an empty node).
pub fn node_irradiance(n: &VplRecord, x: Vec3, ns: Vec3, ng: Vec3) -> Vec3 {
    if n.texels == 0 {
        return Vec3::ZERO;
    }
    disk_irradiance(
        Vec3::from_array(n.position),
        Vec3::from_array(n.normal),
        n.area,
        Vec3::from_array(n.flux),
        x,
        ns,
        ng,
    )
}

/// `|ns·nv|` below which a finest near-field node is drawn as its exact
/// square alone (shade.wgsl `CREASE_LO`, which must match).
pub const CREASE_LO: f32 = 0.4;
/// `|ns·nv|` from which it is its one disk (shade.wgsl `CREASE_HI`).
pub const CREASE_HI: f32 = 0.6;

/// Lambert's term of the polygon edge `a → b` (relative to the receiver):
/// the angle it subtends times the cosine of its plane's normal with `n`
/// (shade.wgsl `edge_term`).
fn edge_term(a: Vec3, b: Vec3, n: Vec3) -> f32 {
    let (ua, ub) = (a.normalize(), b.normalize());
    let c = ua.cross(ub);
    let l = c.length();
    if l.is_nan() || l <= 1e-12 {
        return 0.0;
    }
    ua.dot(ub).clamp(-1.0, 1.0).acos() * c.dot(n) / l
}

/// Form factor from a receiver at the origin with normal `n` to the
/// square `c ± t ± b` (relative to the receiver), clipped to the
/// receiver's hemisphere: Lambert's formula `(1/2π)|Σ θᵢ (n·γᵢ)|`
/// (shade.wgsl `square_form_factor`, the same straight-line clipping).
pub fn square_form_factor(c: Vec3, t: Vec3, b: Vec3, n: Vec3) -> f32 {
    let corner = |k: u32| {
        let st = if k == 1 || k == 2 { 1.0 } else { -1.0 };
        let sb = if k >= 2 { 1.0 } else { -1.0 };
        c + t * st + b * sb
    };
    let (mut sum, mut exit, mut entry, mut clipped) = (0.0, Vec3::ZERO, Vec3::ZERO, false);
    for k in 0..4 {
        let (a, bq) = (corner(k), corner((k + 1) % 4));
        let (ha, hb) = (a.dot(n), bq.dot(n));
        if ha >= 0.0 && hb >= 0.0 {
            sum += edge_term(a, bq, n);
        } else if ha >= 0.0 && hb < 0.0 {
            let p = a + (bq - a) * (ha / (ha - hb));
            sum += edge_term(a, p, n);
            exit = p;
            clipped = true;
        } else if ha < 0.0 && hb >= 0.0 {
            let p = a + (bq - a) * (ha / (ha - hb));
            sum += edge_term(p, bq, n);
            entry = p;
            clipped = true;
        }
    }
    if clipped {
        sum += edge_term(exit, entry, n);
    }
    sum.abs() * (0.5 / std::f32::consts::PI)
}

/// Irradiance at `x` from a finest (level-3) near-field node whose texels
/// have coherence `c` ([`gibake_asset::Asset::vpl_coherence`]; 1: all
/// facing its normal): its disk with the far-field lobe at `c`
/// ([`node_lobe_irradiance`]), or, where `x` is in its near field, in
/// front of it and across its normal (`|ns·nv| <` [`CREASE_HI`]), the node
/// as a uniformly emitting square of its area about its centre with
/// Lambert's exact formula ([`square_form_factor`]), blended with the disk
/// by a smoothstep between [`CREASE_LO`] and [`CREASE_HI`] (shade.wgsl
/// `near_node_irradiance`, which says why).
pub fn near_node_irradiance(n: &VplRecord, c: f32, x: Vec3, ns: Vec3, ng: Vec3) -> Vec3 {
    if n.texels == 0 {
        return Vec3::ZERO;
    }
    let (p, nv) = (Vec3::from_array(n.position), Vec3::from_array(n.normal));
    let s = ns.dot(nv).abs();
    if s >= CREASE_HI || !is_near(x, p, n.area) {
        return node_lobe_irradiance(n, c, x, ns, ng);
    }
    let half = 0.5 * n.area.max(0.0).sqrt();
    let mut e = Vec3::ZERO;
    if nv.dot(x - p) > 0.0 && n.area > 0.0 {
        let t = gibake_gpu::hemisphere::to_world(nv, Vec3::X) * half;
        let b = gibake_gpu::hemisphere::to_world(nv, Vec3::Y) * half;
        let f = square_form_factor(p - x, t, b, ns);
        e = Vec3::from_array(n.flux) * (f / n.area);
        if !e.is_finite() {
            e = Vec3::ZERO;
        }
    }
    if s <= CREASE_LO {
        return e;
    }
    let u = ((s - CREASE_LO) / (CREASE_HI - CREASE_LO)).clamp(0.0, 1.0);
    e.lerp(
        node_lobe_irradiance(n, c, x, ns, ng),
        u * u * (3.0 - 2.0 * u),
    )
}

/// How far (in a finest node's radii) its light skips the map test at a
/// VPL of near-field descent `descent`: half the descent, at most
/// [`NEAR_FIELD_RATIO`] — the first bounce's 4 at its default 8, a later
/// bounce's 2 at its 4. A finest node stands for its parent's light out to
/// the parent's descent edge, `2 · descent` of its own radii, and its open
/// share fades to 0 at twice `ratio`: at half the descent that is the
/// inner half of its reach, and a map-tested disk the outer half. At the
/// first bounce's reach a later VPL's open share spanned the whole of it:
/// its finest nodes' light was never map-tested in full (the white arena's
/// later VPLs kept 68% of their light where their surfels' own visibility
/// keeps 49%; docs/method.md, "The later VPLs' open share"). shade.wgsl
/// `open_ratio`.
pub fn open_ratio(descent: f32) -> f32 {
    NEAR_FIELD_RATIO.min(0.5 * descent)
}

/// How much of a finest near-field node's light at `x` skips the map
/// test: 1 within `ratio` of the node's radii ([`open_ratio`]: its own
/// near field), 0 from twice that (where its own disk, map-tested, goes
/// on to its parent's descent edge), smoothstep between (shade.wgsl
/// `open_weight`).
pub fn open_weight(x: Vec3, p: Vec3, a: f32, ratio: f32) -> f32 {
    let r = ratio * (a.max(0.0) / std::f32::consts::PI).sqrt();
    let d = (x - p).length();
    if r.is_nan() || r <= 0.0 || d.is_nan() {
        return 0.0;
    }
    let u = ((d - r) / r).clamp(0.0, 1.0);
    1.0 - u * u * (3.0 - 2.0 * u)
}

/// A static VPL's unshadowed irradiance at a receiver in two parts: what
/// its hemisphere map shadows, and what reaches the receiver without a map
/// test (the [`open_weight`] share of a finest near-field node's light at
/// a receiver in that node's own near field). shade.wgsl `VplTerms`,
/// which says why.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VplTerms {
    /// Irradiance the VPL's visibility applies to.
    pub shadowed: Vec3,
    /// Irradiance no map test darkens (finest near-field nodes, near).
    pub open: Vec3,
}

impl VplTerms {
    /// Both parts, unshadowed.
    pub fn total(&self) -> Vec3 {
        self.shadowed + self.open
    }

    /// The irradiance with visibility `vis` on the shadowed part.
    pub fn with_visibility(&self, vis: f32) -> Vec3 {
        self.shadowed * vis + self.open
    }
}

/// Unshadowed irradiance at `x` from VPL `v` drawn from `origin` (its
/// far-field centre, [`gibake_asset::far_field_centre`], where it has a
/// tree; else its map origin),
/// whose near-field tree is `nodes` ([`NODES_PER_VPL`] records; none: one
/// disk at every distance) and whose far-field lobes are `lobes`
/// ([`VplLobes::of_tree`], computed once per VPL as the runtime does at
/// load): [`static_vpl_terms`] summed.
#[allow(clippy::too_many_arguments)]
pub fn static_vpl_irradiance(
    v: &VplRecord,
    origin: Vec3,
    nodes: &[VplRecord],
    lobes: &VplLobes,
    x: Vec3,
    ns: Vec3,
    ng: Vec3,
) -> Vec3 {
    static_vpl_terms(v, origin, nodes, lobes, x, ns, ng).total()
}

/// [`static_vpl_irradiance`] split into what the VPL's map shadows and
/// what it does not ([`VplTerms`]; shade.wgsl `static_vpl_terms`).
#[allow(clippy::too_many_arguments)]
pub fn static_vpl_terms(
    v: &VplRecord,
    origin: Vec3,
    nodes: &[VplRecord],
    lobes: &VplLobes,
    x: Vec3,
    ns: Vec3,
    ng: Vec3,
) -> VplTerms {
    static_vpl_terms_at(v, origin, nodes, lobes, x, ns, ng, DESCENT_RATIO)
}

/// [`static_vpl_terms`] at near-field descent `descent` (radii; 0: one
/// disk everywhere): [`LATER_DESCENT_RATIO`] for a later bounce's VPL
/// (shade.wgsl `vpl_descent`).
#[allow(clippy::too_many_arguments)]
pub fn static_vpl_terms_at(
    v: &VplRecord,
    origin: Vec3,
    nodes: &[VplRecord],
    lobes: &VplLobes,
    x: Vec3,
    ns: Vec3,
    ng: Vec3,
    descent: f32,
) -> VplTerms {
    let nv = Vec3::from_array(v.normal);
    let open = open_ratio(descent);
    let mut t = VplTerms::default();
    if !within(x, origin, v.area, 2.0 * descent) || nodes.len() < NODES_PER_VPL {
        let phi = Vec3::from_array(v.flux);
        let p = facing_point(origin, &lobes.facings[0], x);
        t.shadowed = lobe_irradiance(p, nv, lobes.vpl, v.area, phi, x, ns, ng);
        return t;
    }
    for c1 in 0..4 {
        let (i1, j1) = (c1 % 2, c1 / 2);
        let n1 = &nodes[j1 * 2 + i1];
        if n1.texels == 0 {
            continue;
        }
        if !descends_at(x, Vec3::from_array(n1.position), n1.area, descent) {
            let k1 = j1 * 2 + i1;
            let n = facing_node(n1, &lobes.facings[1 + k1], x);
            t.shadowed += node_lobe_irradiance(&n, lobes.nodes[k1], x, ns, ng);
            continue;
        }
        for c2 in 0..4 {
            let (i2, j2) = (2 * i1 + c2 % 2, 2 * j1 + c2 / 2);
            let n2 = &nodes[4 + j2 * 4 + i2];
            if n2.texels == 0 {
                continue;
            }
            if !descends_at(x, Vec3::from_array(n2.position), n2.area, descent) {
                let k2 = 4 + j2 * 4 + i2;
                let n = facing_node(n2, &lobes.facings[1 + k2], x);
                t.shadowed += node_lobe_irradiance(&n, lobes.nodes[k2], x, ns, ng);
                continue;
            }
            for c3 in 0..4 {
                let (i3, j3) = (2 * i2 + c3 % 2, 2 * j2 + c3 / 2);
                let n3 = &nodes[20 + j3 * 8 + i3];
                let e3 = near_node_irradiance(n3, lobes.level3[j3 * 8 + i3], x, ns, ng);
                let w = open_weight(x, Vec3::from_array(n3.position), n3.area, open);
                t.open += e3 * w;
                t.shadowed += e3 * (1.0 - w);
            }
        }
    }
    t
}

/// The static VPLs' irradiance at a receiver `h`, summed by the CPU twin
/// of the shading (before the albedo): with exact ray-cast visibility
/// (what the GPU's hemisphere maps approximate), without visibility, and
/// with visibility but one disk per VPL (no near-field tree). One
/// visibility ray per VPL that sends anything.
#[derive(Clone, Copy, Debug, Default)]
pub struct TwinIrradiance {
    /// Near-field transport, ray-cast visibility (from the VPL's map
    /// origin, on [`VplTerms::shadowed`]; [`VplTerms::open`] unshadowed).
    pub visible: Vec3,
    /// Near-field transport, no visibility.
    pub unshadowed: Vec3,
    /// One disk per VPL, ray-cast visibility.
    pub visible_disk: Vec3,
}

/// Static VPLs as shading holds them after load (`baked.rs`): each VPL's
/// record and near-field tree, and, computed once per VPL, its lobe
/// coherences ([`VplLobes`]), its map origin (where its
/// visibility is tested), its second origin where it has one (where the
/// visibility of a receiver below its horizon is tested:
/// [`gibake_asset::LowerVpl`]) and its far-field centre
/// ([`gibake_asset::far_field_centre`], where its transport is drawn from;
/// its map origin without a full tree).
pub struct TwinVpls<'a> {
    /// The VPL records.
    pub vpls: &'a [VplRecord],
    /// Their near-field trees ([`NODES_PER_VPL`] each, in the same order).
    pub nodes: &'a [VplRecord],
    /// Per VPL: its lobe coherences and facing shifts.
    pub lobes: Vec<VplLobes>,
    /// Per VPL: its map origin.
    pub origins: Vec<Vec3>,
    /// Per VPL: its far-field centre.
    pub centres: Vec<Vec3>,
    /// Per VPL: its second origin, where it has one (empty: none has;
    /// [`TwinVpls::with_lower`]).
    pub lower: Vec<Option<Vec3>>,
    /// The index of the first later-bounce VPL, drawn at
    /// [`LATER_DESCENT_RATIO`] (the VPLs' count: none;
    /// [`TwinVpls::with_later`]).
    pub first_later: usize,
}

impl<'a> TwinVpls<'a> {
    /// From VPL records `vpls`, their trees `nodes` and their level-3
    /// coherences `coherence`: an asset's, or the every-light bake's before
    /// it is an asset.
    /// `ring[i]`: whether VPL `i` lies on an outer ring (its map origin,
    /// `gibake_gpu::hemisphere::record_origin`).
    pub fn new(
        vpls: &'a [VplRecord],
        ring: &[bool],
        nodes: &'a [VplRecord],
        coherence: &'a [f32],
    ) -> Self {
        assert_eq!(vpls.len(), ring.len(), "one ring flag per VPL");
        let origins: Vec<Vec3> = vpls
            .iter()
            .zip(ring)
            .map(|(v, &ring)| gibake_gpu::hemisphere::record_origin(v, ring))
            .collect();
        let mut twin = TwinVpls {
            vpls,
            nodes,
            lobes: Vec::new(),
            origins,
            centres: Vec::new(),
            lower: Vec::new(),
            first_later: vpls.len(),
        };
        twin.lobes = (0..vpls.len())
            .map(|i| {
                let c = coherence
                    .get(i * gibake_asset::LEVEL3_NODES..(i + 1) * gibake_asset::LEVEL3_NODES)
                    .unwrap_or(&[]);
                VplLobes::of_tree(twin.tree(i), c)
            })
            .collect();
        twin.centres = (0..vpls.len())
            .map(|i| {
                gibake_asset::far_field_centre(twin.tree(i))
                    .map_or(twin.origins[i], Vec3::from_array)
            })
            .collect();
        twin
    }

    /// The static VPLs of `asset`, with their second origins.
    pub fn of_asset(asset: &'a gibake_asset::Asset) -> Self {
        Self::new(
            &asset.vpls,
            &asset.manifest.origin_lift_flags(),
            &asset.vpl_nodes,
            &asset.vpl_coherence,
        )
        .with_lower(
            asset
                .vpl_lower
                .iter()
                .map(|l| l.is_some().then(|| Vec3::from_array(l.origin)))
                .collect(),
        )
        .with_later(asset.manifest.later_vpls() as usize)
    }

    /// The same VPLs with second origins `lower` (one per VPL, or none:
    /// every VPL without; `gibake_bake::horizon::lower_origin`).
    pub fn with_lower(mut self, lower: Vec<Option<Vec3>>) -> Self {
        assert!(
            lower.is_empty() || lower.len() == self.vpls.len(),
            "one second origin (or none) per VPL"
        );
        self.lower = lower;
        self
    }

    /// The same VPLs, the last `later` of them the later bounces' (drawn at
    /// [`LATER_DESCENT_RATIO`], as shade.wgsl `vpl_descent`).
    pub fn with_later(mut self, later: usize) -> Self {
        self.first_later = self.vpls.len().saturating_sub(later);
        self
    }

    /// VPL `i`'s near-field descent ratio.
    fn descent(&self, i: usize) -> f32 {
        if i >= self.first_later {
            LATER_DESCENT_RATIO
        } else {
            DESCENT_RATIO
        }
    }

    /// VPL `i`'s terms at `x` ([`static_vpl_terms_at`] at its descent).
    fn vpl_terms(&self, i: usize, x: Vec3, ns: Vec3, ng: Vec3) -> VplTerms {
        let (v, c) = (&self.vpls[i], &self.lobes[i]);
        static_vpl_terms_at(
            v,
            self.centres[i],
            self.tree(i),
            c,
            x,
            ns,
            ng,
            self.descent(i),
        )
    }

    /// VPL `i`'s second origin, if it has one.
    pub fn lower_origin(&self, i: usize) -> Option<Vec3> {
        self.lower.get(i).copied().flatten()
    }

    /// Where VPL `i`'s visibility of a receiver at `x` is tested from, and
    /// about which normal: from its second origin about the opposite of its
    /// normal where `x` is below its horizon (the plane through its map
    /// origin) and it has a second origin, else from its map origin
    /// (shade.wgsl, the static VPLs' loop).
    pub fn visibility_frame(&self, i: usize, x: Vec3) -> (Vec3, Vec3, bool) {
        let (o, n) = (self.origins[i], Vec3::from_array(self.vpls[i].normal));
        match self.lower_origin(i) {
            Some(l) if n.dot(x - o) < 0.0 => (l, -n, true),
            _ => (o, n, false),
        }
    }

    /// VPL `i`'s near-field tree (empty where the asset has none).
    pub fn tree(&self, i: usize) -> &'a [VplRecord] {
        self.nodes
            .get(i * NODES_PER_VPL..(i + 1) * NODES_PER_VPL)
            .unwrap_or(&[])
    }

    /// Each VPL's unshadowed irradiance at `x` (shading normal `ns`,
    /// geometric `ng`) as `(index, terms)`, VPLs that send nothing left
    /// out: the terms [`TwinVpls::irradiance`] sums.
    pub fn terms(
        &self,
        x: Vec3,
        ns: Vec3,
        ng: Vec3,
    ) -> impl Iterator<Item = (usize, VplTerms)> + '_ {
        (0..self.vpls.len()).filter_map(move |i| {
            let t = self.vpl_terms(i, x, ns, ng);
            (t != VplTerms::default()).then_some((i, t))
        })
    }

    /// [`TwinIrradiance`] at receiver `h`: transport from each VPL's
    /// far-field centre, visibility from its map origin (shade.wgsl
    /// `static_vpl_irradiance`).
    pub fn irradiance(
        &self,
        rays: &gibake_reference::RayScene,
        h: &gibake_reference::Hit,
    ) -> TwinIrradiance {
        let mut sum = TwinIrradiance::default();
        let (x, ns, ng) = (h.position, h.shading_normal, h.geometric_normal);
        for (i, v) in self.vpls.iter().enumerate() {
            let (centre, c) = (self.centres[i], &self.lobes[i]);
            let near = self.vpl_terms(i, x, ns, ng);
            let disk = static_vpl_irradiance(v, centre, &[], c, x, ns, ng);
            if near == VplTerms::default() && disk == Vec3::ZERO {
                continue;
            }
            sum.unshadowed += near.total();
            let (o, n, _) = self.visibility_frame(i, x);
            if !origin_in_front(o, x, ng) || rays.visible(o, n, x, ng) {
                sum.visible += near.total();
                sum.visible_disk += disk;
            } else {
                sum.visible += near.open;
            }
        }
        sum
    }
}

/// Whether a VPL's map origin is in front of the plane of a receiver at `x`
/// (geometric normal `ng`). Where it is not, the VPL's parts in front of
/// that plane are what light `x` (the transport's receiver cosine leaves
/// the rest out), and the origin's ray to `x` passes through `x`'s own
/// surface — the far side of a ball or a block from a VPL on the ground
/// round it — so its visibility says nothing: shading skips the map test
/// there (shade.wgsl `vpl_visibility`; docs/method.md, "Origin behind the
/// receiver"), and the twin's exact visibility does the same.
pub fn origin_in_front(origin: Vec3, x: Vec3, ng: Vec3) -> bool {
    (origin - x).dot(ng) > 0.0
}

/// An asset's hemisphere maps, for the CPU twin of the shader's lookup
/// ([`map_visibility`]).
pub struct TwinMaps {
    /// Per VPL its map (`None`: no stored map, every direction open).
    pub maps: Vec<Option<Vec<f32>>>,
    /// Per VPL its second map (`None`: none stored; empty: no VPL has one).
    pub lower: Vec<Option<Vec<f32>>>,
    /// The maps' side.
    pub size: u32,
}

impl TwinMaps {
    /// The maps of `asset`'s static VPLs.
    pub fn of_asset(asset: &gibake_asset::Asset) -> Self {
        TwinMaps {
            maps: (0..asset.vpls.len()).map(|i| asset.vpl_map_of(i)).collect(),
            lower: (0..asset.vpls.len())
                .map(|i| asset.vpl_lower_map_of(i))
                .collect(),
            size: asset.manifest.settings.vpl_map_size,
        }
    }

    /// The shader's visibility of VPL `i` of `twin` (the same VPLs) at `x`
    /// (geometric normal `ng`): its map's, or below its horizon its second
    /// map's where it has a second origin ([`TwinVpls::visibility_frame`]).
    pub fn visibility(&self, twin: &TwinVpls<'_>, i: usize, x: Vec3, ng: Vec3) -> f32 {
        let (o, n, lower) = twin.visibility_frame(i, x);
        let map = if lower {
            self.lower.get(i).and_then(Option::as_deref)
        } else {
            self.maps[i].as_deref()
        };
        map.map_or(1.0, |map| map_visibility(map, self.size, n, o, x, ng))
    }
}

/// Hemisphere-map biases of shade.wgsl `vpl_visibility`, in texel
/// footprints at the receiver (must match `VPL_DEPTH_BIAS` and
/// `VPL_MAX_SLOPE` there, as must the footprint factor 2.83 of
/// [`map_visibility`]; `tests/runtime_modes.rs`,
/// `map_lookup_twin_matches_the_gpu`, fails when they do not).
pub const VPL_DEPTH_BIAS: f32 = 0.5;
/// See [`VPL_DEPTH_BIAS`].
pub const VPL_MAX_SLOPE: f32 = 10.0;

/// CPU twin of shade.wgsl `vpl_visibility` on a baked map alone (no
/// moving-object tile): the fraction of a VPL's light that its `size²`
/// hemisphere map `map` (row-major distances, +inf = no surface, around
/// `normal`) lets reach `x` (geometric normal `ng`) from the map's
/// `origin` — the 2×2 PCF with the receiver-plane test. A receiver below
/// the VPL's horizon (`normal · (x − origin) < 0`, lit only by near-field
/// nodes facing it) is looked up on the map's rim, as on the GPU: the map
/// holds nothing below its horizon (docs/method.md, "Real levels"). A
/// receiver whose plane has the origin behind it is not map-tested (1):
/// see [`origin_in_front`].
pub fn map_visibility(
    map: &[f32],
    size: u32,
    normal: Vec3,
    origin: Vec3,
    x: Vec3,
    ng: Vec3,
) -> f32 {
    use gibake_gpu::hemisphere;
    let n = size as f32;
    let dx = x - origin;
    let d = dx.length();
    if d.is_nan() || d <= 0.0 || map.len() != (size * size) as usize {
        return 1.0;
    }
    let w = d * (2.83 / n);
    if !origin_in_front(origin, x, ng) {
        return 1.0;
    }
    let h = -dx.dot(ng);
    let tc = hemisphere::texel_coords(normal, dx / d, size) - glam::Vec2::splat(0.5);
    let i0 = tc.floor();
    let f = tc - i0;
    let t_min = d - w * VPL_MAX_SLOPE;
    let mut lit = [0f32; 4];
    for (k, (ox, oy)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
        let cx = (i0.x as i32 + ox).clamp(0, size as i32 - 1);
        let cy = (i0.y as i32 + oy).clamp(0, size as i32 - 1);
        let e = glam::Vec2::new(cx as f32 + 0.5, cy as f32 + 0.5) * (2.0 / n) - glam::Vec2::ONE;
        let u = hemisphere::to_world(normal, hemisphere::decode(e));
        let cu = -u.dot(ng);
        let mut t = d;
        if h > 0.0 && cu * d > h {
            t = (h / cu).max(t_min);
        }
        let stored = map[(cy as u32 * size + cx as u32) as usize];
        lit[k] = if t <= stored + w * VPL_DEPTH_BIAS {
            1.0
        } else {
            0.0
        };
    }
    let top = lit[0] + (lit[1] - lit[0]) * f.x;
    let bottom = lit[2] + (lit[3] - lit[2]) * f.x;
    top + (bottom - top) * f.y
}

#[cfg(test)]
mod tests {
    use super::{
        CREASE_HI, DESCENT_RATIO, LATER_DESCENT_RATIO, NEAR_FIELD_RATIO, disk_irradiance, far_lobe,
        near_node_irradiance, open_ratio, open_weight,
    };
    use gibake_asset::VplRecord;
    use glam::Vec3;

    /// A square of side `s` in the plane x = 0 facing +x, spanning y in
    /// [h, h + s] and z in [−s/2, s/2], emitting flux 1 (exitance 1/s²):
    /// its irradiance at `x` (normal `n`) by a 400×400 grid of point
    /// emitters — exact to well under 1% away from its edge.
    fn square_irradiance(s: f32, h: f32, x: Vec3, n: Vec3) -> f64 {
        let k = 400;
        let da = f64::from(s * s) / f64::from(k * k);
        let mut e = 0.0;
        for j in 0..k {
            for i in 0..k {
                let q = Vec3::new(
                    0.0,
                    h + (j as f32 + 0.5) * s / k as f32,
                    (i as f32 + 0.5) * s / k as f32 - s / 2.0,
                );
                let d = x - q;
                let d2 = f64::from(d.length_squared());
                let (ce, cr) = (f64::from(d.x) / d2.sqrt(), f64::from(n.dot(-d)) / d2.sqrt());
                if ce > 0.0 && cr > 0.0 {
                    e += da / f64::from(s * s) / std::f64::consts::PI * ce * cr / d2;
                }
            }
        }
        e
    }

    /// The constants this twin shares with shade.wgsl are the shader's.
    #[test]
    fn constants_match_the_shader() {
        let wgsl = include_str!("../../../runtime/src/shade.wgsl");
        let value = |name: &str| -> f32 {
            let line = wgsl
                .lines()
                .find(|l| l.starts_with(&format!("const {name}:")))
                .unwrap_or_else(|| panic!("shade.wgsl defines {name}"));
            let v = line.split('=').nth(1).expect("a value");
            let v = v.split("//").next().expect("a value");
            v.trim()
                .trim_end_matches(';')
                .trim_end_matches('u')
                .parse()
                .expect("a number")
        };
        assert_eq!(value("NEAR_FIELD_RATIO"), super::NEAR_FIELD_RATIO);
        // The descent is a setting; its default is the twin's.
        assert_eq!(
            gibake_runtime::RenderSettings::default().near_field_descent as f32,
            super::DESCENT_RATIO
        );
        assert_eq!(super::FAR_FIELD_RATIO, 2.0 * super::DESCENT_RATIO);
        assert_eq!(
            gibake_runtime::RenderSettings::default().later_near_field_descent as f32,
            super::LATER_DESCENT_RATIO
        );
        assert_eq!(value("VPL_DEPTH_BIAS"), super::VPL_DEPTH_BIAS);
        assert_eq!(value("VPL_MAX_SLOPE"), super::VPL_MAX_SLOPE);
        assert_eq!(value("CREASE_LO"), super::CREASE_LO);
        assert_eq!(value("CREASE_HI"), super::CREASE_HI);
        assert_eq!(
            value("FACING_NODES") as usize,
            gibake_asset::FACINGS_PER_VPL - 1
        );
        assert_eq!(value("NODES_PER_VPL") as usize, gibake_asset::NODES_PER_VPL);
    }

    /// A VPL with a full tree is one disk with its far-field lobe beyond
    /// `FAR_FIELD_RATIO` radii, and its four level-1 nodes, each with the
    /// lobe at its own level-3 nodes' coherence, between `DESCENT_RATIO`
    /// and that.
    #[test]
    fn a_vpl_is_its_level_1_nodes_out_to_the_far_field() {
        use super::{
            DESCENT_RATIO, FAR_FIELD_RATIO, lobe_irradiance, node_irradiance, node_lobe_irradiance,
            static_vpl_terms,
        };
        let rec = |p: Vec3, n: Vec3, a: f32, f: f32, texels: u32| VplRecord {
            position: p.to_array(),
            area: a,
            normal: n.normalize().to_array(),
            texels,
            flux: [f; 3],
            map: gibake_asset::NO_MAP,
        };
        let area = 0.16f32;
        let radius = (area / std::f32::consts::PI).sqrt();
        // Four level-1 quadrants 0.1 apart, facing four ways; under
        // quadrant 0 the level-3 nodes face ±z by columns (coherence 0),
        // elsewhere their quadrant's way.
        let ways = [
            Vec3::new(0.3, 1.0, 0.0),
            Vec3::new(-0.3, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.3),
            Vec3::new(0.0, 1.0, -0.3),
        ];
        let centre = |q: usize| {
            Vec3::new(
                (q % 2) as f32 * 0.1 - 0.05,
                0.0,
                (q / 2) as f32 * 0.1 - 0.05,
            )
        };
        let mut tree = Vec::new();
        for (q, w) in ways.iter().enumerate() {
            tree.push(rec(centre(q), *w, area / 4.0, 1.0, 16));
        }
        for j in 0..4 {
            for i in 0..4 {
                let q = (j / 2) * 2 + i / 2;
                tree.push(rec(centre(q), ways[q], area / 16.0, 0.25, 4));
            }
        }
        for j in 0..8 {
            for i in 0..8 {
                let q = (j / 4) * 2 + i / 4;
                let n = if q == 0 {
                    Vec3::new(0.0, 0.0, if i % 2 == 0 { 1.0 } else { -1.0 })
                } else {
                    ways[q]
                };
                tree.push(rec(centre(q), n, area / 64.0, 1.0 / 16.0, 1));
            }
        }
        assert_eq!(tree.len(), gibake_asset::NODES_PER_VPL);
        let v = rec(Vec3::ZERO, Vec3::Y, area, 4.0, 64);
        let lobes = super::VplLobes::of_tree(&tree, &[]);
        let c = lobes.vpl;
        let (ns, dir) = (
            Vec3::new(0.2, -1.0, 0.1).normalize(),
            Vec3::new(0.6, 0.5, 0.62).normalize(),
        );
        let at = |k: f32| dir * (k * radius);
        for k in [8.5f32, 12.0, 15.9] {
            let x = at(k);
            let got = static_vpl_terms(&v, Vec3::ZERO, &tree, &lobes, x, ns, ns);
            let nodes: Vec3 = (0..4)
                .map(|q| node_lobe_irradiance(&tree[q], lobes.nodes[q], x, ns, ns))
                .sum();
            assert!(got.open == Vec3::ZERO, "{k} radii: all map-tested");
            assert!(
                (got.shadowed - nodes).abs().max_element() <= 1e-6 * nodes.max_element(),
                "{k} radii: {got:?} against the level-1 nodes' {nodes:?}"
            );
            // Quadrant 0's lobe is its texels' (coherence 0), not its cosine.
            let cosine = node_irradiance(&tree[0], x, ns, ns);
            let lobe = node_lobe_irradiance(&tree[0], lobes.nodes[0], x, ns, ns);
            let flat = lobe_irradiance(
                centre(0),
                ways[0].normalize(),
                0.0,
                area / 4.0,
                Vec3::ONE,
                x,
                ns,
                ns,
            );
            assert!(
                (lobe - flat).abs().max_element() <= 1e-6 * flat.max_element() && lobe != cosine,
                "{k} radii: {lobe:?}, {cosine:?}"
            );
        }
        for k in [16.1f32, 40.0] {
            let x = at(k);
            let got = static_vpl_terms(&v, Vec3::ZERO, &tree, &lobes, x, ns, ns);
            // Drawn from its facing point: its quadrants face four ways,
            // so it is off the centre (the level-1 nodes' are not: each
            // one's level-3 nodes share its centre).
            let p = super::facing_point(Vec3::ZERO, &lobes.facings[0], x);
            assert!(
                p.length() > 1e-3 && p.length() <= 0.05 * 2f32.sqrt() + 1e-6,
                "{p}"
            );
            assert_eq!(lobes.facings[1], gibake_asset::Facing::NONE);
            let disk = lobe_irradiance(p, Vec3::Y, c, area, Vec3::splat(4.0), x, ns, ns);
            assert_eq!(got.shadowed, disk, "{k} radii: one disk");
        }
        assert_eq!(FAR_FIELD_RATIO, 2.0 * DESCENT_RATIO);
        assert_eq!(DESCENT_RATIO, 2.0 * NEAR_FIELD_RATIO);
    }

    /// The open share of a finest node's light is 1 in its own near field,
    /// 0 from twice that (where its own disk is map-tested),
    /// continuous and falling between, and 0 for a node without area.
    #[test]
    fn open_weight_fades_from_the_nodes_near_field_to_its_parents() {
        let (p, a) = (Vec3::new(1.0, 2.0, 3.0), 0.04);
        let r = NEAR_FIELD_RATIO * (a / std::f32::consts::PI).sqrt();
        let at = |d: f32| open_weight(p + Vec3::new(0.6, 0.0, 0.8) * d, p, a, NEAR_FIELD_RATIO);
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(0.999 * r), 1.0);
        assert_eq!(at(2.0 * r), 0.0);
        assert_eq!(at(10.0 * r), 0.0);
        assert!((at(1.5 * r) - 0.5).abs() < 1e-5);
        let mut last = 1.0;
        for k in 0..=100 {
            let w = at(r * (1.0 + k as f32 / 100.0));
            assert!(w <= last + 1e-6 && (last - w) < 0.02, "{k}: {last} → {w}");
            last = w;
        }
        assert_eq!(open_weight(p, p, 0.0, NEAR_FIELD_RATIO), 0.0);
        assert_eq!(open_weight(Vec3::NAN, p, a, NEAR_FIELD_RATIO), 0.0);
        assert_eq!(open_ratio(DESCENT_RATIO), NEAR_FIELD_RATIO);
        assert_eq!(open_ratio(LATER_DESCENT_RATIO), 2.0);
        assert_eq!(open_ratio(32.0), NEAR_FIELD_RATIO);
        assert_eq!(open_ratio(0.0), 0.0);
    }

    /// A finest node across its receiver (a wall node above a floor
    /// point near the crease, or a node crossing the floor's plane) is
    /// drawn as its square with Lambert's formula: the numerically
    /// integrated square's irradiance within 0.2%, where its one disk is
    /// up to 3× off; a receiver facing the node keeps the disk exactly.
    #[test]
    fn crease_kernel_is_the_exact_square() {
        let s = 1.0f32;
        // Above the floor, and crossing it (clipped to the hemisphere).
        for h in [0.05f32, -0.3] {
            let node = VplRecord {
                position: [0.0, h + s / 2.0, 0.0],
                area: s * s,
                normal: [1.0, 0.0, 0.0],
                texels: 64,
                flux: [1.0; 3],
                map: 0,
            };
            let p = Vec3::from_array(node.position);
            for x in [
                Vec3::new(0.1, 0.0, 0.0),
                Vec3::new(0.3, 0.0, 0.2),
                Vec3::new(0.6, 0.0, -0.3),
            ] {
                let n = Vec3::Y;
                let exact = square_irradiance(s, h, x, n);
                let kernel = f64::from(near_node_irradiance(&node, 1.0, x, n, n).x);
                let disk = f64::from(disk_irradiance(p, Vec3::X, s * s, Vec3::ONE, x, n, n).x);
                assert!(
                    (kernel / exact - 1.0).abs() < 2e-3,
                    "h {h}, receiver {x}: exact {exact}, crease kernel {kernel}, disk {disk}"
                );
                // Near contact the one disk is far off (what the kernel fixes).
                if h > 0.0 && x.x < 0.2 {
                    assert!(disk < 0.5 * exact, "disk {disk}, exact {exact}");
                }
            }
        }
        let node = VplRecord {
            position: [0.0, 0.55, 0.0],
            area: 1.0,
            normal: [1.0, 0.0, 0.0],
            texels: 64,
            flux: [1.0; 3],
            map: 0,
        };
        let (p, nv) = (Vec3::from_array(node.position), Vec3::X);
        // Facing the node (|ns·nv| ≥ CREASE_HI): the one disk.
        let (x, n) = (Vec3::new(0.4, 0.5, 0.1), Vec3::new(-1.0, 0.0, 0.0));
        assert!(n.dot(nv).abs() >= CREASE_HI);
        assert_eq!(
            near_node_irradiance(&node, 1.0, x, n, n),
            disk_irradiance(p, nv, node.area, Vec3::ONE, x, n, n)
        );
    }

    /// `∫ f(μ) dω = 2π ∫₋₁¹ f(μ) dμ` by the midpoint rule.
    fn sphere_integral(f: impl Fn(f64) -> f64) -> f64 {
        let n = 20_000;
        let h = 2.0 / n as f64;
        2.0 * std::f64::consts::PI
            * (0..n)
                .map(|k| f(-1.0 + (k as f64 + 0.5) * h) * h)
                .sum::<f64>()
    }

    #[test]
    fn far_lobe_keeps_the_flux_and_the_texels_first_moment() {
        for k in 0..=20 {
            let c = k as f32 / 20.0;
            let lobe = |mu: f64| f64::from(far_lobe(c, mu as f32));
            // Per unit flux the lobe is far_lobe/π: it integrates to π.
            let flux = sphere_integral(lobe);
            assert!(
                (flux / std::f64::consts::PI - 1.0).abs() < 1e-4,
                "c {c}: flux {flux}"
            );
            // First moment along the normal, per unit flux: 2c/3.
            let moment = sphere_integral(|mu| mu * lobe(mu)) / std::f64::consts::PI;
            assert!(
                (moment - 2.0 * f64::from(c) / 3.0).abs() < 1e-4,
                "c {c}: moment {moment}"
            );
            assert!(
                (0..=200).all(|k| lobe(-1.0 + k as f64 / 100.0) >= 0.0),
                "c {c}: negative lobe"
            );
        }
        for mu in [-1.0f32, -0.3, 0.0, 0.4, 1.0] {
            assert_eq!(far_lobe(1.0, mu), mu.max(0.0), "c = 1 is the cosine lobe");
            assert!((far_lobe(0.5, mu) - (1.0 + mu) / 4.0).abs() < 1e-7);
            assert_eq!(far_lobe(0.0, mu), 0.25);
        }
        assert_eq!(far_lobe(f32::NAN, 0.5), 0.5);
        assert_eq!(far_lobe(2.0, 0.5), 0.5);
    }

    /// Texels whose normals are spread evenly over a hemisphere (a lit
    /// crown): the mean of their clamped cosines is the lobe at c = ½.
    #[test]
    fn far_lobe_is_exact_for_normals_spread_over_a_hemisphere() {
        // Deterministic stratified normals over the upper hemisphere.
        let (nt, np) = (200, 400);
        let mut normals = Vec::new();
        for i in 0..nt {
            let z = (i as f64 + 0.5) / nt as f64; // uniform in cos θ: uniform on the hemisphere
            let r = (1.0 - z * z).sqrt();
            for j in 0..np {
                let p = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                normals.push([r * p.cos(), r * p.sin(), z]);
            }
        }
        let coherence = normals.iter().map(|n| n[2]).sum::<f64>() / normals.len() as f64;
        assert!((coherence - 0.5).abs() < 1e-4);
        for mu in [-0.9f64, -0.5, 0.0, 0.5, 1.0] {
            let w = [(1.0 - mu * mu).sqrt(), 0.0, mu];
            let mean = normals
                .iter()
                .map(|n| (n[0] * w[0] + n[1] * w[1] + n[2] * w[2]).max(0.0))
                .sum::<f64>()
                / normals.len() as f64;
            let lobe = f64::from(far_lobe(coherence as f32, mu as f32));
            assert!(
                (mean - lobe).abs() < 2e-3,
                "μ {mu}: texels {mean}, lobe {lobe}"
            );
        }
    }
}
