// shade.wgsl — deferred shading (needs common.wgsl, light.wgsl,
// projection.wgsl, hemisphere.wgsl, cascades.wgsl, gbuffer_layout.wgsl (its
// ViewParams and G-buffer reads), and other_lights.wgsl or,
// for a scene with one light, other_lights_none.wgsl). One invocation per
// pixel:
//   direct light with the merged primary shadow map (static ∪ moving),
//   and of every other light with its static shadow map (with
//   FLAG_CULL_LIGHTS only the lights that may reach the pixel's 8×8 tile:
//   other_lights.wgsl),
// + every static VPL with its merged hemisphere map, its flux scaled by the
//   lit fraction of its own RSM texels,
// + every dynamic VPL, unshadowed, with its far-field lobe (far_lobe).
// VPL transport has no singularity: a VPL is a small disk of its texels'
// area A, E = Φ/π · cosθ_v cosθ_r / sqrt(d⁴ + (A/π)²): at contact this is
// the disk's exitance Φ/A, beyond the disk's radius R it is the point
// light's 1/d² to within (R/d)⁴/2 (1/(d² + A/π) would be 25% low at 2R).
// Accumulates in f32; writes linear radiance.
// Interleaved (view.interleave = N > 1): pixel (x, y) shades only the VPLs
// i ≡ k (mod N²), k = (x mod N) + N·(y mod N), scaled by N² (VPLs are in
// quadtree Morton order, so every subset is an even spread over the RSM), and
// writes direct radiance at (x, y) and that irradiance estimate at
// (x + width, y) of a 2·width-wide texture; interleave.wgsl filters it.
// With view.later_half (interleaved, an asset with later-bounce VPLs,
// RenderSettings::later_full_resolution off) cs_main leaves the later
// bounces' VPLs out and cs_later shades them on the half-resolution grid
// (sample (i, j) = pixel (2i, 2j)), interleaved the same way, into
// out_later; interleave.wgsl filters that grid and brings it up to full
// resolution.

struct GiParams {         // GpuGiParams in shade.rs
    flags: u32,           // ShadeFlag bits (FLAG_* generated from shade flags in plan.rs)
    n_static: u32,
    map_size: u32,
    atlas_cols: u32,
    n_dynamic: u32,
    static_cols: u32,     // tiles per row of the baked map atlas
    n_other_lights: u32,  // lights after the first (other_lights)
    descent: u32,         // near-field descent in disk radii (RenderSettings::near_field_descent)
    lower_cols: u32,      // tiles per row of the second maps' atlas
    lower_row: u32,       // texel row of static_maps where the second maps' atlas starts
    first_later: u32,     // index of the first later-bounce VPL (n_static: none)
    later_descent: u32,   // their near-field descent (RenderSettings::later_near_field_descent; 0: one disk)
    later_scale: vec4<f32>,   // rgb: their flux scale this frame, what moving objects absorb (later_absorb.rs)
}

const NONE: u32 = 0xffffffffu;
const OCCL_ONE: f32 = 16777216.0;     // 2^24: fixed-point 1.0 of occlusion sums

// Hemisphere-map biases, in texel footprints at the receiver: the depth
// bias, and how much nearer than x a tap's point on the receiver's plane
// may be (a plane seen at a grazing angle).
const VPL_DEPTH_BIAS: f32 = 0.5;
const VPL_MAX_SLOPE: f32 = 10.0;

// Group 0: the view (its G-buffer: gbuffer_layout.wgsl).
@group(0) @binding(0) var g_depth: texture_2d<f32>;
@group(0) @binding(1) var g_normals: texture_2d<u32>;
@group(0) @binding(2) var g_albedo: texture_2d<u32>;
@group(0) @binding(3) var<uniform> view: ViewParams;
@group(0) @binding(4) var out_radiance: texture_storage_2d<rgba32float, write>;
// The later bounces' irradiance estimates on the half-resolution grid
// (cs_later; a 1×1 stand-in where the view has none).
@group(0) @binding(5) var out_later: texture_storage_2d<rgba32float, write>;

// Group 1: light and GI data, shared by every view.
@group(1) @binding(0) var<storage, read> vpls: array<Vpl>;   // n_static VPLs, their near-field trees, their far-field records
@group(1) @binding(1) var<storage, read> occlusion: array<u32>;
@group(1) @binding(2) var<storage, read> vpl_tile: array<u32>;
@group(1) @binding(3) var static_maps: texture_2d<f32>;
@group(1) @binding(4) var atlas: texture_2d<f32>;
@group(1) @binding(5) var<storage, read> dyn_vpls: array<DynVpl>;
@group(1) @binding(7) var primary_static: texture_2d<f32>;
@group(1) @binding(8) var primary_dynamic: texture_2d<f32>;
@group(1) @binding(9) var<uniform> light: PrimaryLight;
@group(1) @binding(10) var<uniform> light_view: LightView;
@group(1) @binding(11) var<uniform> params: GiParams;

// Near field (gibake_bake::near_field): a level-1 or level-2 node of a
// VPL's tree whose receiver is nearer than params.descent × its disk radius
// √(A/π) is replaced by its four children, down to level 3 (8×8 nodes), and
// a VPL by its level-1 nodes nearer than twice that of its own
// (RenderSettings::near_field_descent, 8 by default; docs/method.md,
// "Descent ratio"); a level-3 node's own near field, NEAR_FIELD_RATIO of
// its radii, is where its light skips the map test (open_weight) and the
// crease kernel applies (near_node_irradiance). Dimensionless: the same at
// every scene scale. Must match gibake_eval::transport::{NEAR_FIELD_RATIO,
// DESCENT_RATIO, FAR_FIELD_RATIO} at the default.
const NEAR_FIELD_RATIO: f32 = 4.0;
// The crease kernel's blend (near_node_irradiance); must match
// gibake_eval::transport.
const CREASE_LO: f32 = 0.4;
const CREASE_HI: f32 = 0.6;
const NODES_PER_VPL: u32 = 84u;
// Facing-shift records per static VPL after the far-field records: its
// level-1 and level-2 nodes' (gibake_asset::FACINGS_PER_VPL − 1, the VPL's
// own being in its far-field record; checked by gibake_eval::transport's
// constants test).
const FACING_NODES: u32 = 20u;

fn has(f: u32) -> bool {
    return (params.flags & f) != 0u;
}

// Merged primary-map visibility: 2×2 PCF over min(static, moving), in the
// finest cascade that holds p when there are cascades (cascades.wgsl).
fn primary_visibility(p: vec3<f32>, ng: vec3<f32>, wi: vec3<f32>) -> f32 {
    // Cascades where the primary map's texel is coarser than a fraction of
    // the pixel (CASCADE_PIXEL_FRACTION: a shadow edge moves by a few
    // texels of PCF and bias); elsewhere the primary map resolves it.
    var pixel = -view.eye.w;
    if (view.eye.w > 0.0) {
        pixel = length(p - view.eye.xyz) * view.eye.w;
    }
    if (has(FLAG_CASCADES) && lv_footprint(light_view, p) > pixel * CASCADE_PIXEL_FRACTION) {
        let c = cascade_index(p);
        if (c < cascades.count) {
            return cascade_visibility(c, p, ng, wi);
        }
    }
    return lv_visibility(light_view, primary_static, primary_dynamic, has(FLAG_DYN_PRIMARY), vec4<i32>(0), p, ng, wi);
}

// Direct light of one light with the shading normal's cosine, as engines
// shade: a light behind the geometric plane but in front of the shading
// normal (a smooth low-poly terminator) lights the point if the shadow map
// says so (lv_visibility treats such a receiver as the far side of a solid).
// `other`: NONE for the primary light (its merged map and cascades), else
// the index of a light after the first.
fn light_radiance(l: PrimaryLight, other: u32, p: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    let inc = light_incident(l, p);
    let cos_s = max(dot(ns, inc.wi), 0.0);
    if (cos_s <= 0.0 || all(inc.irradiance == vec3<f32>(0.0))) {
        return vec3<f32>(0.0);
    }
    var vis: f32;
    if (other == NONE) {
        vis = primary_visibility(p, ng, inc.wi);
    } else {
        vis = other_visibility(other, p, ng, inc.wi);
    }
    return albedo * INV_PI * inc.irradiance * (cos_s * vis);
}

// Direct light of every light.
fn direct_radiance(p: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    return light_radiance(light, NONE, p, ns, ng, albedo) + other_lights_radiance(p, ns, ng, albedo);
}

// Distance stored in direction texel c of a map (min of its baked map,
// tile `map` of the first maps' atlas or, `lower`, of the second maps' atlas
// below it, and its moving-object tile; +inf when neither exists).
fn vpl_map_distance(map: u32, tile: u32, lower: bool, c: vec2<i32>) -> f32 {
    var s = 3.0e38;
    let n = i32(params.map_size);
    if (map != NONE && !has(FLAG_ATLAS_ONLY)) {
        var scols = i32(params.static_cols);
        var row = 0;
        if (lower) {
            scols = i32(params.lower_cols);
            row = i32(params.lower_row);
        }
        let origin = vec2<i32>(i32(map) % scols, i32(map) / scols) * n + vec2<i32>(0, row);
        s = textureLoad(static_maps, origin + c, 0).r;
    }
    if (tile != NONE) {
        let cols = i32(params.atlas_cols);
        let origin = vec2<i32>(i32(tile) % cols, i32(tile) / cols) * n;
        s = min(s, textureLoad(atlas, origin + c, 0).r);
    }
    return s;
}

// Fraction of VPL i's light that reaches x (2×2 PCF of its hemisphere map),
// with a receiver-plane test: a map texel stores the distance along the ray
// through its centre (baked by exactly that ray, merged by exact
// rasterization), so a tap whose ray meets the receiver's plane (x, ng)
// nearer than x compares its stored distance with that point, not with
// x's own distance, and a tap whose ray meets the plane beyond x (or not
// at all) with x's distance. On a plane that is exact at any angle, so the
// bias is half a texel footprint (float error, the bend between adjacent
// triangles). The earlier normal offset and depth bias of 1 + tanθ
// footprints (up to 11) let light through occluders that near the receiver:
// 1–14% more light than exact rays on real levels (`map_visibility`,
// docs/method.md "Real levels"). Known issue: a receiver within one
// footprint of a concave crease is partly shadowed by the tap that sees
// the crease's other side (as before, somewhat more). A receiver whose
// plane has the origin behind it is not map-tested (below). A receiver below the
// VPL's horizon is looked up in its second map where it has one
// (lower_record); else on the map's rim: the map holds nothing below its
// horizon. CPU twin: gibake_eval::transport::map_visibility.
fn vpl_visibility(i: u32, v: Vpl, origin: vec3<f32>, x: vec3<f32>, ng: vec3<f32>) -> f32 {
    // The map to look up: the first, or below the horizon the second where
    // the VPL has one (lower_record), chosen first so that one lookup runs
    // whichever it is (no divergent second lookup in a SIMD group).
    var map = v.map;
    var slot = i;
    var lower = false;
    var normal = v.normal;
    var o = origin;
    if (dot(v.normal, x - origin) < 0.0) {
        let lo = lower_record(i);
        if (lo.texels != 0u) {
            map = lo.map;
            slot = params.n_static + i;
            lower = true;
            normal = lo.normal;
            o = lo.position;
        }
    }
    var tile = NONE;
    if (has(FLAG_TILES)) {
        tile = vpl_tile[slot];
    }
    return hemi_visibility(map, tile, lower, normal, o, x, ng);
}

// A static VPL's second-map record (baked.rs): after the VPLs, their trees,
// far-field records and nodes' facing records; `position` its second
// origin, `normal` the opposite of its normal, `map` its tile in the second
// maps' atlas (NONE: it sees no surface), `texels` 0 for a VPL without one.
// The light a cluster sends below its own horizon leaves from its texels
// tilted away from its normal (a roof's with the walls of a hole in it, a
// wall face's with a window's sill and jambs), which see what its lifted
// map origin does not: through the hole, the window. A VPL with enough of
// it has a second origin on those texels and a second map around the
// opposite of its normal from there (gibake_bake::horizon), which
// vpl_visibility looks up for a receiver below the VPL's horizon: the
// first map's rim sees the open sky along the roof (over-lit), and its
// origin's exact ray crosses the roof (over-darkened). Its moving-object
// tile is the merge's `n_static + i`. Measured in docs/method.md, "Below
// the horizon". CPU twin: gibake_eval::transport::TwinMaps::visibility.
fn lower_record(i: u32) -> Vpl {
    return vpls[params.n_static * (2u + NODES_PER_VPL + FACING_NODES) + i];
}

// Fraction of the light of a map (baked tile `map`, of the second maps'
// atlas with `lower`; moving-object tile `tile`) centred at `origin` around
// `normal` that reaches x (geometric normal ng): vpl_visibility's test.
fn hemi_visibility(map: u32, tile: u32, lower: bool, normal: vec3<f32>, origin: vec3<f32>, x: vec3<f32>, ng: vec3<f32>) -> f32 {
    if ((map == NONE || has(FLAG_ATLAS_ONLY)) && tile == NONE) {
        return 1.0;
    }
    let n = f32(params.map_size);
    let dx = x - origin;
    let d = length(dx);
    if (!(d > 0.0)) {
        return 1.0;
    }
    // Texel footprint at x: the hemi-octahedral texel subtends at most
    // ~2√2/n radians.
    let w = d * (2.83 / n);
    // Height of the map origin above the receiver's plane (> 0 in front).
    let h = -dot(dx, ng);
    // The origin behind the receiver's plane: what lights x are the VPL's
    // parts in front of that plane (the transport's cosine leaves the
    // rest out), and the origin's ray to x passes through x's own surface
    // (the far side of a ball or a block from a VPL on the ground round
    // it), so the map cannot tell: no map test (docs/method.md, "Origin
    // behind the receiver").
    if (!(h > 0.0)) {
        return 1.0;
    }
    let tc = hemi_texel_coords(normal, dx / d, n) - vec2<f32>(0.5);
    let i0 = vec2<i32>(floor(tc));
    let f = tc - floor(tc);
    let tb = basis_t(normal);
    let bb = basis_b(normal);
    let t_min = d - w * VPL_MAX_SLOPE;
    var lit = vec4<f32>(0.0);
    let offs = array<vec2<i32>, 4>(vec2<i32>(0, 0), vec2<i32>(1, 0), vec2<i32>(0, 1), vec2<i32>(1, 1));
    let size = i32(params.map_size);
    for (var k = 0; k < 4; k++) {
        let c = clamp(i0 + offs[k], vec2<i32>(0), vec2<i32>(size - 1));
        // The tap's ray (through its texel centre) and where it meets the plane.
        let l = hemi_decode((vec2<f32>(c) + vec2<f32>(0.5)) * (2.0 / n) - vec2<f32>(1.0));
        let u = tb * l.x + bb * l.y + normal * l.z;
        let cu = -dot(u, ng);
        var t = d;
        if (h > 0.0 && cu * d > h) {
            t = max(h / cu, t_min);
        }
        lit[k] = select(0.0, 1.0, t <= vpl_map_distance(map, tile, lower, c) + w * VPL_DEPTH_BIAS);
    }
    return mix(mix(lit.x, lit.y, f.x), mix(lit.z, lit.w, f.x), f.y);
}

// Irradiance from a disk-like VPL at `origin` (normal nv, area a, flux phi)
// with its cosine lobe: vpl_lobe_irradiance with coherence 1 (far_lobe(1, μ)
// = max(μ, 0)).
fn vpl_irradiance(origin: vec3<f32>, nv: vec3<f32>, a: f32, phi: vec3<f32>, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    return vpl_lobe_irradiance(origin, nv, 1.0, a, phi, x, ns, ng);
}

// A VPL seen from afar (a static VPL beyond twice the descent, a level-1 or
// level-2 node beyond its own near field, every
// dynamic VPL): the disk of vpl_irradiance with the lobe far_lobe(c, cosθ_v)/π
// per unit flux in place of its cosine lobe, c its texels' flux-weighted
// normal coherence (gibake_asset::lobe_coherence; a dynamic VPL's own
// texels'). CPU twin: gibake_eval::transport::lobe_irradiance.
fn vpl_lobe_irradiance(p: vec3<f32>, nv: vec3<f32>, coherence: f32, a: f32, phi: vec3<f32>, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    let dv = x - p;
    let d2 = dot(dv, dv);
    if (d2 <= 0.0) {
        return vec3<f32>(0.0);
    }
    let dir = dv * inverseSqrt(d2);
    let cos_r = dot(ns, -dir);
    if (cos_r <= 0.0 || dot(ng, -dir) <= 0.0) {
        return vec3<f32>(0.0);
    }
    let lobe = far_lobe(coherence, dot(nv, dir));
    if (lobe <= 0.0) {
        return vec3<f32>(0.0);
    }
    // sqrt(d⁴ + (A/π)²): equals the disk's irradiance at contact (Φ/A),
    // and 1/d² within (A/π)²/(2d⁴) beyond the disk's radius.
    let r2 = a * INV_PI;
    return finite_or_zero3(phi * (INV_PI * lobe * cos_r * inverseSqrt(d2 * d2 + r2 * r2)));
}

// The lobe of a cluster of Lambertian texels whose flux-weighted normals
// have coherence c = |Σw·n| / Σw about the unit normal n, as a function
// of μ = n·ω (per unit flux, times 1/π; over the whole sphere, integral π):
//   c ≥ ½: (2c − 1)·max(μ, 0) + (1 − c)·(1 + μ)/2
//   c < ½: (1 + 2c·μ)/4
// — texels all facing n (max(μ, 0), c = 1) mixed with texels whose normals
// are spread evenly over n's hemisphere ((1 + μ)/4: the mean of
// max(m·ω, 0) over those normals m, c = ½), and below ½ with normals spread
// over the whole sphere (¼, c = 0). Its first moment (2c/3 along n), hence
// its odd part c·μ/2, is the texels' own for every c; it is exact for
// texels facing one way and for texels facing every way of a hemisphere
// (a lit crown, a ball's lit cap: every lit texel faces the light), whose
// light goes below their mean normal's horizon too, onto the ground under
// the crown: a quarter of it at c = ½. Below a static VPL's horizon its
// visibility is looked up on its map's rim (vpl_visibility). Measured in
// docs/method.md, "Far-field lobe".
fn far_lobe(c_in: f32, mu: f32) -> f32 {
    let c = clamp(c_in, 0.0, 1.0);
    if (c >= 0.5) {
        return (2.0 * c - 1.0) * max(mu, 0.0) + (1.0 - c) * (1.0 + mu) * 0.5;
    }
    return (1.0 + 2.0 * c * mu) * 0.25;
}

fn within(x: vec3<f32>, p: vec3<f32>, a: f32, ratio: f32) -> bool {
    let d = x - p;
    return dot(d, d) < ratio * ratio * a * INV_PI;
}

fn is_near(x: vec3<f32>, p: vec3<f32>, a: f32) -> bool {
    return within(x, p, a, NEAR_FIELD_RATIO);
}

// Whether a level-1 or level-2 node is drawn as its children at x
// (descent: in its radii).
fn descends(x: vec3<f32>, p: vec3<f32>, a: f32, descent: f32) -> bool {
    return within(x, p, a, descent);
}

// Whether a static VPL is drawn as its tree at x (twice the descent: its
// level-1 nodes stand for it out there; descent 0: never).
fn in_far_field(x: vec3<f32>, p: vec3<f32>, a: f32, descent: f32) -> bool {
    return !within(x, p, a, 2.0 * descent);
}

// Static VPL i's near-field descent: the first bounce's, or the later
// bounces' for their VPLs (the last ones).
fn vpl_descent(i: u32) -> f32 {
    if (i >= params.first_later) {
        return f32(params.later_descent);
    }
    return f32(params.descent);
}

// A level-1 or level-2 node beyond its own near field: its disk with the
// far-field lobe at its level-3 nodes' coherence, which its record carries
// in `texels` (fixed point, at least 1; 0: an empty node; baked.rs,
// gibake_gpu::vpl::GpuVpl::texels). CPU twin:
// gibake_eval::transport::node_lobe_irradiance.
fn node_lobe_irradiance(n: Vpl, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    if (n.texels == 0u) {
        return vec3<f32>(0.0);
    }
    return vpl_lobe_irradiance(n.position, n.normal, f32(n.texels) / LOBE_ONE, n.area, n.flux, x, ns, ng);
}

// Where a cluster drawn at p sends its light to x from: p + F·ω, ω the
// unit direction from p to x, F its facing shift (gibake_asset::facing:
// scaled at load so that no shift leaves the cluster; none where not
// finite). The parts of a cluster that face ω send its light that way: the
// near side of a crown, a crease's wall rather than its floor
// (docs/method.md, "Facing shift"). CPU twin:
// gibake_eval::transport::facing_point.
fn facing_point(p: vec3<f32>, f: mat3x3<f32>, x: vec3<f32>) -> vec3<f32> {
    let d = x - p;
    let l2 = dot(d, d);
    if (!(l2 > 0.0)) {
        return p;
    }
    let s = f * (d * inverseSqrt(l2));
    if (!(abs(s.x) <= 3.40282347e38 && abs(s.y) <= 3.40282347e38 && abs(s.z) <= 3.40282347e38)) {
        return p;
    }
    return p + s;
}

// A static VPL's own facing shift, from its far-field record r (F by
// columns in normal, flux and area/texels/map as f32 bits: baked.rs).
fn far_facing(r: Vpl) -> mat3x3<f32> {
    return mat3x3<f32>(r.normal, r.flux, vec3<f32>(r.area, bitcast<f32>(r.texels), bitcast<f32>(r.map)));
}

// Static VPL i's level-1 or level-2 node k's facing shift (k: its index in
// the tree, 0–19), F by columns in position, normal, flux (baked.rs).
fn node_facing(i: u32, k: u32) -> mat3x3<f32> {
    let r = vpls[params.n_static * (2u + NODES_PER_VPL) + i * FACING_NODES + k];
    return mat3x3<f32>(r.position, r.normal, r.flux);
}

// Lambert's term of the polygon edge a → b (relative to the receiver):
// the angle it subtends times the cosine of its plane's normal with n.
fn edge_term(a: vec3<f32>, b: vec3<f32>, n: vec3<f32>) -> f32 {
    let ua = normalize(a);
    let ub = normalize(b);
    let c = cross(ua, ub);
    let l = length(c);
    if (!(l > 1.0e-12)) {
        return 0.0;
    }
    return acos(clamp(dot(ua, ub), -1.0, 1.0)) * dot(c, n) / l;
}

// Corner k (0..3, in order round it) of the square c ± t ± b.
fn square_corner(c: vec3<f32>, t: vec3<f32>, b: vec3<f32>, k: u32) -> vec3<f32> {
    let st = select(-1.0, 1.0, k == 1u || k == 2u);
    let sb = select(-1.0, 1.0, k >= 2u);
    return c + t * st + b * sb;
}

// Form factor from a receiver at the origin with normal n to the square
// c ± t ± b (relative to the receiver), clipped to the receiver's
// hemisphere: Lambert's formula, (1/2π)|Σ θᵢ (n·γᵢ)|, straight-line code
// (the clipped polygon's edges one by one, and the edge along the plane
// from where it leaves to where it comes back).
fn square_form_factor(c: vec3<f32>, t: vec3<f32>, b: vec3<f32>, n: vec3<f32>) -> f32 {
    var sum = 0.0;
    var exit_p = vec3<f32>(0.0);
    var entry_p = vec3<f32>(0.0);
    var clipped = false;
    for (var k = 0u; k < 4u; k++) {
        let a = square_corner(c, t, b, k);
        let bq = square_corner(c, t, b, (k + 1u) % 4u);
        let ha = dot(a, n);
        let hb = dot(bq, n);
        if (ha >= 0.0 && hb >= 0.0) {
            sum += edge_term(a, bq, n);
        } else if (ha >= 0.0 && hb < 0.0) {
            let p = a + (bq - a) * (ha / (ha - hb));
            sum += edge_term(a, p, n);
            exit_p = p;
            clipped = true;
        } else if (ha < 0.0 && hb >= 0.0) {
            let p = a + (bq - a) * (ha / (ha - hb));
            sum += edge_term(p, bq, n);
            entry_p = p;
            clipped = true;
        }
    }
    if (clipped) {
        sum += edge_term(exit_p, entry_p, n);
    }
    return abs(sum) * (0.5 * INV_PI);
}

// A finest near-field node (level 3) at a receiver in its near field. The
// disk kernel takes both cosines at the node's centre; for a receiver
// across the node's normal (a floor beside a lit wall, the street under a
// façade: |ns·nv| small) the centre's cosines are small near contact while
// the part of the node nearest the receiver sends most of its light. There
// the node is drawn as what it stands for, a uniformly emitting square of
// its area about its centre in its plane (exitance Φ/A), with Lambert's
// exact formula clipped to the receiver's hemisphere
// (square_form_factor), blended with the one disk as |ns·nv| goes from
// CREASE_LO to CREASE_HI. Receivers facing the node or coplanar with it
// keep the disk: a node's centroid, off a curved or thin surface by a
// fraction of its radius, would put a flat emitter millimetres from them.
// Measured in docs/method.md, "Crease kernel". CPU twin:
// gibake_eval::transport::near_node_irradiance.
fn near_node_irradiance(n: Vpl, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    if (n.texels == 0u) {
        return vec3<f32>(0.0);
    }
    let s = abs(dot(ns, n.normal));
    if (s >= CREASE_HI || !is_near(x, n.position, n.area)) {
        return node_lobe_irradiance(n, x, ns, ng);
    }
    let half = 0.5 * sqrt(max(n.area, 0.0));
    var e = vec3<f32>(0.0);
    if (dot(n.normal, x - n.position) > 0.0 && n.area > 0.0) {
        let f = square_form_factor(n.position - x, basis_t(n.normal) * half, basis_b(n.normal) * half, ns);
        e = finite_or_zero3(n.flux * (f / n.area));
    }
    if (s <= CREASE_LO) {
        return e;
    }
    let disk = node_lobe_irradiance(n, x, ns, ng);
    return mix(e, disk, smoothstep(CREASE_LO, CREASE_HI, s));
}

// A static VPL's unshadowed irradiance at a receiver in two parts:
// `shadowed`, what its hemisphere map's visibility applies to, and `open`,
// what no map test darkens: the share open_weight of a finest (level-3)
// node's light at a receiver in that node's own near field. The map is
// taken from the VPL's one origin, lifted above its mean plane; a receiver
// next to a finest node (an eighth of the VPL's radius) sees it past
// surfaces that hide the origin (a curved rock or crown, a crease at a
// mech's foot), and at that range what stands between them is mostly the
// two surfaces themselves, which the kernel's cosines already take. The
// CPU twin with exact rays from each node measured what the origin's test
// lost there: 6–10 points of the city's and the garden's bounce light.
// Known cost: light through an occluder thinner than a few node radii
// (tests/stiff_cases.rs, thin_partition_between_lit_floors). Measured in
// docs/method.md, "Finest nodes near their receiver". CPU twin:
// gibake_eval::transport::VplTerms.
struct VplTerms {
    shadowed: vec3<f32>,
    open: vec3<f32>,
}

// How far, in a finest node's radii, its light skips the map test at a
// VPL of near-field descent `descent`: half the descent, at most
// NEAR_FIELD_RATIO (the first bounce's 4 at 8, a later VPL's 2 at 4): the
// inner half of the node's reach, its map-tested disk the outer half. CPU
// twin: gibake_eval::transport::open_ratio, which says why.
fn open_ratio(descent: f32) -> f32 {
    return min(NEAR_FIELD_RATIO, 0.5 * descent);
}

// The open share of a finest node's light at x: 1 within `ratio` of its
// radii (open_ratio), 0 from twice that, where its own disk is map-tested
// out to its parent's descent edge (no seam), smoothstep between. CPU twin:
// gibake_eval::transport::open_weight.
fn open_weight(x: vec3<f32>, p: vec3<f32>, a: f32, ratio: f32) -> f32 {
    let r = ratio * sqrt(max(a, 0.0) * INV_PI);
    if (!(r > 0.0)) {
        return 0.0;
    }
    let u = clamp((length(x - p) - r) / r, 0.0, 1.0);
    return 1.0 - u * u * (3.0 - 2.0 * u);
}

// Unshadowed irradiance at x from static VPL i (record v): one disk at
// its far-field centre (its texels' centroid: the record after the trees,
// baked.rs) beyond twice the descent, its near-field tree nearer, as VplTerms. CPU
// twin: gibake_eval::transport::static_vpl_terms.
fn static_vpl_terms(i: u32, v: Vpl, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> VplTerms {
    var t = VplTerms(vec3<f32>(0.0), vec3<f32>(0.0));
    let far = vpls[params.n_static * (1u + NODES_PER_VPL) + i];
    let centre = far.position;
    let dr = vpl_descent(i);
    if (in_far_field(x, centre, v.area, dr)) {
        // A static VPL's own record carries its lobe coherence in `texels`
        // (gibake_gpu::vpl::GpuVpl::texels), fixed point.
        let p = facing_point(centre, far_facing(far), x);
        t.shadowed = vpl_lobe_irradiance(p, v.normal, f32(v.texels) / LOBE_ONE, v.area, v.flux, x, ns, ng);
        return t;
    }
    let base = params.n_static + i * NODES_PER_VPL;   // its tree, after the VPLs
    let open = open_ratio(dr);
    for (var c1 = 0u; c1 < 4u; c1++) {
        let i1 = c1 % 2u;
        let j1 = c1 / 2u;
        let n1 = vpls[base + j1 * 2u + i1];
        if (n1.texels == 0u) {
            continue;
        }
        if (!descends(x, n1.position, n1.area, dr)) {
            var m1 = n1;
            m1.position = facing_point(n1.position, node_facing(i, j1 * 2u + i1), x);
            t.shadowed += node_lobe_irradiance(m1, x, ns, ng);
            continue;
        }
        for (var c2 = 0u; c2 < 4u; c2++) {
            let i2 = 2u * i1 + c2 % 2u;
            let j2 = 2u * j1 + c2 / 2u;
            let n2 = vpls[base + 4u + j2 * 4u + i2];
            if (n2.texels == 0u) {
                continue;
            }
            if (!descends(x, n2.position, n2.area, dr)) {
                var m2 = n2;
                m2.position = facing_point(n2.position, node_facing(i, 4u + j2 * 4u + i2), x);
                t.shadowed += node_lobe_irradiance(m2, x, ns, ng);
                continue;
            }
            for (var c3 = 0u; c3 < 4u; c3++) {
                let i3 = 2u * i2 + c3 % 2u;
                let j3 = 2u * j2 + c3 / 2u;
                let n3 = vpls[base + 20u + j3 * 8u + i3];
                let e3 = near_node_irradiance(n3, x, ns, ng);
                let w = open_weight(x, n3.position, n3.area, open);
                t.open += e3 * w;
                t.shadowed += e3 * (1.0 - w);
            }
        }
    }
    return t;
}

// Irradiance at x from static VPL i: its terms, the hemisphere map's
// visibility on their shadowed part, its lit fraction (partial occlusion).
fn static_vpl_irradiance(i: u32, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    let v = vpls[i];
    let origin = v.position;   // the map origin, lifted at load (baked.rs)
    let t = static_vpl_terms(i, v, x, ns, ng);
    if (all(t.shadowed == vec3<f32>(0.0)) && all(t.open == vec3<f32>(0.0))) {
        return vec3<f32>(0.0);
    }
    var ei = t.open;
    if (any(t.shadowed != vec3<f32>(0.0))) {
        var vis = 1.0;
        if (has(FLAG_VISIBILITY)) {
            vis = vpl_visibility(i, v, origin, x, ng);
        }
        ei += t.shadowed * vis;
    }
    if (has(FLAG_OCCLUSION)) {
        ei = ei * max(1.0 - f32(occlusion[i]) / OCCL_ONE, 0.0);
    }
    if (i >= params.first_later) {
        // What moving objects absorb (later_absorb.rs): the transfers
        // before its last, and, where the occlusion buffer carries them,
        // its own last one (after the occluded shares).
        var keep = params.later_scale.rgb;
        if (has(FLAG_OCCLUSION)) {
            let b = params.n_static + 4u * (i - params.first_later);
            keep *= vec3<f32>(bitcast<f32>(occlusion[b]), bitcast<f32>(occlusion[b + 1u]), bitcast<f32>(occlusion[b + 2u]));
        }
        ei = ei * keep;
    }
    return ei;
}

// The grid point of invocation gid in a deinterleaved grid of `size`
// points at interleave n (workgroups() in shade.rs): N × N planes of whole
// workgroups, plane a = gid / plane holding the points a + N·i that shade
// the same VPL subset.
fn deinterleaved(gid: vec2<u32>, size: vec2<u32>, n: u32) -> vec2<u32> {
    if (n <= 1u) {
        return gid;
    }
    let plane = ((size + vec2<u32>(n - 1u)) / n + vec2<u32>(7u)) / 8u * 8u;
    return gid / plane + n * (gid % plane);
}

// The later bounces' VPLs on the half-resolution grid (view.later_half):
// sample (i, j) is pixel (2i, 2j); it shades the later VPLs
// first_later + k + N²·m, k its interleave subset, scaled by N², and
// writes that irradiance estimate (0 where the pixel has no surface).
@compute @workgroup_size(8, 8)
fn cs_later(@builtin(global_invocation_id) gid: vec3<u32>) {
    let n = max(view.interleave, 1u);
    let half = (view.size + vec2<u32>(1u)) / 2u;
    let q = deinterleaved(gid.xy, half, n);
    if (any(q >= half)) {
        return;
    }
    let px = vec2<i32>(q * 2u);
    let depth = textureLoad(g_depth, px, 0).r;
    var e = vec3<f32>(0.0);
    if (depth != view.far_depth && has(FLAG_STATIC_VPL)) {
        let x = gbuffer_position(view.inv_view_proj, view.size, px, depth);
        let nn = textureLoad(g_normals, px, 0).xy;
        let ns = gbuffer_normal(nn.x);
        let ng = gbuffer_normal(nn.y);
        let stride = n * n;
        let k = (q.x % n) + n * (q.y % n);
        for (var i = params.first_later + k; i < params.n_static; i += stride) {
            e += static_vpl_irradiance(i, x, ns, ng);
        }
        e = e * f32(stride);
    }
    textureStore(out_later, vec2<i32>(q), vec4<f32>(finite_or_zero3(e), 1.0));
}

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let n = max(view.interleave, 1u);
    let p = deinterleaved(gid.xy, view.size, n);
    let inside = all(p < view.size);
    let px = vec2<i32>(p);
    var covered = false;
    var x = vec3<f32>(0.0);
    if (inside) {
        let depth = textureLoad(g_depth, px, 0).r;
        covered = depth != view.far_depth;
        if (covered) {
            x = gbuffer_position(view.inv_view_proj, view.size, px, depth);
        }
    }
    // Every invocation of the tile, before any returns (barriers).
    if (has(FLAG_CULL_LIGHTS)) {
        cull_other_lights(lid, covered, x);
    }
    if (!inside) {
        return;
    }
    let stride = n * n;
    let k = (p.x % n) + n * (p.y % n);
    var direct = vec3<f32>(0.0);
    var e = vec3<f32>(0.0);
    var albedo = vec3<f32>(0.0);
    if (covered) {
        let nn = textureLoad(g_normals, px, 0).xy;
        let ns = gbuffer_normal(nn.x);
        let ng = gbuffer_normal(nn.y);
        albedo = gbuffer_albedo(textureLoad(g_albedo, px, 0).x);
        if (has(FLAG_DIRECT)) {
            direct = direct_radiance(x, ns, ng, albedo);
        }
        if (has(FLAG_STATIC_VPL)) {
            // The later bounces' VPLs, where cs_later shades them, left out.
            let end = select(params.n_static, params.first_later, view.later_half != 0u);
            for (var i = k; i < end; i += stride) {
                e += static_vpl_irradiance(i, x, ns, ng);
            }
        }
        if (has(FLAG_DYNAMIC_VPL)) {
            for (var i = k; i < params.n_dynamic; i += stride) {
                let v = dyn_vpls[i];
                if (v.normal.w > 0.5) {
                    e += vpl_lobe_irradiance(v.position.xyz, v.normal.xyz, v.flux.w, v.position.w, v.flux.rgb, x, ns, ng);
                }
            }
        }
    }
    if (stride > 1u) {
        textureStore(out_radiance, px, vec4<f32>(finite_or_zero3(direct), 1.0));
        let ex = finite_or_zero3(e * f32(stride));
        textureStore(out_radiance, px + vec2<i32>(i32(view.size.x), 0), vec4<f32>(ex, 1.0));
        return;
    }
    var radiance = vec3<f32>(0.0);
    if (covered) {
        if (has(FLAG_DIRECT)) {
            radiance += direct;
        }
        radiance += albedo * INV_PI * e;
    }
    textureStore(out_radiance, px, vec4<f32>(finite_or_zero3(radiance), 1.0));
}
