// dynamic_vpl.wgsl — the moving objects' VPLs, clustered on the GPU with
// the bake's quadtree rule (needs common.wgsl, light.wgsl, projection.wgsl, dyn_vpl.wgsl,
// moving.wgsl).
// CPU twin: gibake_bake::cluster::cluster_cut (see crates/bake/src/cluster.rs
// for the rule, the moments and the slot order).
//
// The quadtree of a P × P window of the map (P = 2^L, from texel
// params.origin: the moving objects' footprint this frame, or the whole map
// rounded up to a power of two; texels past the RSM are empty) is stored
// level by level in `nodes`, level d (0 = root) at
// offset (4^d − 1)/3, in Morton order within the level, for d < L; level L
// (single texels) is computed from the RSM where it is read.
//   cs_reduce: node i of level params.level from its four children 4i..4i+3
//              (one dispatch per level, bottom-up; fixed merge order), for
//              the levels of 4096 nodes and more;
//   cs_reduce_top: levels params.level … 0 (at most 1024 nodes each) in
//              one workgroup, the same merges, a barrier between levels.
//   cs_slots:  one invocation per slot (every node of depth 0..=max_depth):
//              is it a leaf of the cut? Writes the VPL or an empty slot.
// No atomics: every value is a fixed-order f32 reduction, so the result is
// bit-identical from run to run.

struct Params {
    level: u32,       // cs_reduce: the level written
    levels: u32,      // L: P = 2^L
    size: u32,        // RSM size (texels at x or y ≥ size are empty)
    max_depth: u32,   // deepest slot level (≤ L)
    slots: u32,       // (4^(max_depth + 1) − 1) / 3
    threshold: f32,
    base: u32,        // this view's first slot in `vpls` (views one after another)
    _pad1: u32,
    origin: vec2<u32>, // the window's first texel: the quadtree is the 2^levels
                       // square from here (the moving objects' footprint)
    _pad2: vec2<u32>,
}

// Moments of a node over its lit texels (see cluster.rs, "Per-node
// statistics"); the VPL sums ride along. 80 bytes.
struct Node {
    lit: u32,             // lit texels
    mean: f32,            // mean metric
    m2: f32,              // Σ (metric − mean)²
    footprint: f32,       // Σ footprint
    normal: vec3<f32>,    // Σ normal
    area: f32,            // Σ area
    flux: vec3<f32>,      // Σ flux
    w: f32,               // Σ (flux.r + flux.g + flux.b)
    wp: vec3<f32>,        // Σ w · position
    wn: vec3<f32>,        // Σ w · normal
}

@group(0) @binding(0) var dyn_position: texture_2d<f32>;
@group(0) @binding(1) var dyn_albedo: texture_2d<f32>;
@group(0) @binding(2) var dyn_normal: texture_2d<f32>;
@group(0) @binding(3) var static_metric: texture_2d<f32>;
@group(0) @binding(4) var<uniform> view: LightView;
@group(0) @binding(5) var<uniform> light: PrimaryLight;
@group(0) @binding(6) var<storage, read_write> nodes: array<Node>;
@group(0) @binding(7) var<storage, read_write> vpls: array<DynVpl>;
@group(0) @binding(8) var<uniform> params: Params;

// As gibake_bake::rsm::MIN_AREA_COSINE.
const MIN_AREA_COSINE: f32 = 0.05;
// The dynamic RSM's clear value of the metric is 3e38: no moving surface.
const EMPTY_METRIC: f32 = 1.0e38;

fn empty_node() -> Node {
    var n: Node;
    n.lit = 0u;
    n.mean = 0.0;
    n.m2 = 0.0;
    n.footprint = 0.0;
    n.normal = vec3<f32>(0.0);
    n.area = 0.0;
    n.flux = vec3<f32>(0.0);
    n.w = 0.0;
    n.wp = vec3<f32>(0.0);
    n.wn = vec3<f32>(0.0);
    return n;
}

// The node of texel (x, y) of the window (the map's texel origin + (x, y)),
// with the bake's RSM radiometry (gibake_bake::rsm::render_rsm): flux =
// albedo · color · att · measure · s, s = cos_s / cos_g (the shading
// normal's cosine over the geometric one, at most 1/MIN_AREA_COSINE),
// area = measure · d² / cos_g (spot) or measure / cos_g (directional),
// cos_g ≥ MIN_AREA_COSINE; the node's normal is the geometric one, which
// the texel emits about.
fn texel_node(wx: u32, wy: u32) -> Node {
    let x = wx + params.origin.x;
    let y = wy + params.origin.y;
    if (x >= params.size || y >= params.size) {
        return empty_node();
    }
    let c = vec2<i32>(i32(x), i32(y));
    let pm = textureLoad(dyn_position, c, 0);
    if (!(pm.w < EMPTY_METRIC) || !moving_in_front(c)) {
        return empty_node();
    }
    let p = pm.xyz;
    let albedo = textureLoad(dyn_albedo, c, 0).rgb;
    let normals = textureLoad(dyn_normal, c, 0);
    let nrm = oct_decode(normals.xy);
    let ns = oct_decode(normals.zw);
    var dir = light.direction.xyz;
    var att = 1.0;
    let directional = light.position.w > 0.5;
    if (!directional) {
        let from_light = p - light.position.xyz;
        let dist = length(from_light);
        dir = from_light / dist;
        att = light_attenuation(light, dir, dist);
    }
    let measure = lv_texel_measure(view, dir);
    let cos_g = max(dot(nrm, -dir), MIN_AREA_COSINE);
    let shading = min(max(dot(ns, -dir), 0.0) / max(dot(nrm, -dir), 1.0e-30), 1.0 / MIN_AREA_COSINE);
    var flux = albedo * light.color.rgb * (att * measure * shading);
    var area = measure / cos_g;
    if (!directional) {
        let d = length(p - light.position.xyz);
        area = measure * d * d / cos_g;
    }
    flux = finite_or_zero3(flux);
    if (!is_finite_f32(area)) {
        area = 0.0;
    }
    let w = flux.r + flux.g + flux.b;
    if (!(w > 0.0) || !is_finite_f32(w)) {
        return empty_node();
    }
    var n: Node;
    n.lit = 1u;
    n.mean = pm.w;
    n.m2 = 0.0;
    n.footprint = lv_footprint(view, p);
    n.normal = nrm;
    n.area = area;
    n.flux = flux;
    n.w = w;
    n.wp = w * p;
    n.wn = w * nrm;
    return n;
}

// Chan, Golub & LeVeque's pairwise merge (as Moments::merge).
fn merge(a: Node, b: Node) -> Node {
    var r: Node;
    r.lit = a.lit + b.lit;
    if (a.lit == 0u) {
        r.mean = b.mean;
        r.m2 = b.m2;
    } else if (b.lit == 0u) {
        r.mean = a.mean;
        r.m2 = a.m2;
    } else {
        let na = f32(a.lit);
        let nb = f32(b.lit);
        let n = na + nb;
        let delta = b.mean - a.mean;
        r.mean = a.mean + delta * (nb / n);
        r.m2 = a.m2 + b.m2 + delta * delta * (na * nb / n);
    }
    r.footprint = a.footprint + b.footprint;
    r.normal = a.normal + b.normal;
    r.area = a.area + b.area;
    r.flux = a.flux + b.flux;
    r.w = a.w + b.w;
    r.wp = a.wp + b.wp;
    r.wn = a.wn + b.wn;
    return r;
}

fn level_offset(d: u32) -> u32 {
    return ((1u << (2u * d)) - 1u) / 3u;
}

// The even bits of v, packed (inverse Morton).
fn compact1(v: u32) -> u32 {
    var x = v & 0x55555555u;
    x = (x | (x >> 1u)) & 0x33333333u;
    x = (x | (x >> 2u)) & 0x0f0f0f0fu;
    x = (x | (x >> 4u)) & 0x00ff00ffu;
    x = (x | (x >> 8u)) & 0x0000ffffu;
    return x;
}

// Node i (Morton index) of level d.
fn load_node(d: u32, i: u32) -> Node {
    if (d >= params.levels) {
        return texel_node(compact1(i), compact1(i >> 1u));
    }
    return nodes[level_offset(d) + i];
}

// The split score S = max(D, Nn, M) · share² of a node of level d with at
// least one lit texel (Moments::score, in f32). +∞ and NaN give F32_MAX,
// which `splits` compares with min(threshold, F32_MAX): the CPU's "+∞ ≥ t".
fn score(n: Node, d: u32, total_w: f32) -> f32 {
    let cnt = f32(n.lit);
    let v = max(n.m2 / cnt, 0.0);
    let width = f32(params.size) * (n.footprint / cnt);
    var depth = 0.0;
    if (width > 0.0) {
        depth = v / (width * width);
    } else if (v > 0.0) {
        depth = F32_MAX;
    }
    let nn = max(1.0 - length(n.normal) / cnt, 0.0);
    // Texels in the node: 4^(L − d) (may not fit a u32 count: compare as
    // "fewer lit than texels").
    let texels_log4 = params.levels - d;
    var mixed = 0.0;
    if (texels_log4 >= 16u || n.lit < (1u << (2u * texels_log4))) {
        mixed = 1.0;
    }
    let share = n.w / total_w;
    let s = max(max(depth, nn), mixed) * share * share;
    if (!(s <= F32_MAX)) {
        return F32_MAX;
    }
    return s;
}

// Whether a node of level d splits (its ancestors aside).
fn splits(n: Node, d: u32, total_w: f32) -> bool {
    return d < params.levels && n.lit > 0u && score(n, d, total_w) >= min(params.threshold, F32_MAX);
}

fn flat_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * 64u;
}

// Node i of level d from its four children 4i..4i+3, merged in that order.
fn reduce_node(d: u32, i: u32) {
    var acc = load_node(d + 1u, 4u * i);
    for (var k = 1u; k < 4u; k++) {
        acc = merge(acc, load_node(d + 1u, 4u * i + k));
    }
    nodes[level_offset(d) + i] = acc;
}

@compute @workgroup_size(64)
fn cs_reduce(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = flat_index(gid, groups);
    let d = params.level;
    if (i >= (1u << (2u * d))) {
        return;
    }
    reduce_node(d, i);
}

// Levels params.level … 0 in one workgroup (params.level < TOP_LEVELS, so
// level params.level has at most 1024 nodes, 16 per invocation): the same
// merges in the same order as cs_reduce once per level, with a barrier
// between levels instead of a dispatch (a fixed cost per dispatch
// dominated the pass on a CPU device, docs/results.md).
@compute @workgroup_size(64)
fn cs_reduce_top(@builtin(local_invocation_index) i: u32) {
    for (var l = 0u; l <= params.level; l++) {
        let d = params.level - l;
        for (var j = i; j < (1u << (2u * d)); j += 64u) {
            reduce_node(d, j);
        }
        storageBarrier();
    }
}

@compute @workgroup_size(64)
fn cs_slots(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = flat_index(gid, groups);
    if (s >= params.slots) {
        return;
    }
    // Past this frame's depth (a window smaller than the view's deepest
    // slots): an empty slot.
    if (s >= level_offset(params.max_depth + 1u)) {
        vpls[params.base + s] = DynVpl(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
        return;
    }
    var d = 0u;
    while (d < params.max_depth && level_offset(d + 1u) <= s) {
        d++;
    }
    let i = s - level_offset(d);
    let total_w = load_node(0u, 0u).w;
    var reached = true;
    for (var k = 0u; k < d; k++) {
        let a = load_node(k, i >> (2u * (d - k)));
        if (!splits(a, k, total_w)) {
            reached = false;
            break;
        }
    }
    let n = load_node(d, i);
    var out: DynVpl;
    out.position = vec4<f32>(0.0);
    out.normal = vec4<f32>(0.0);
    out.flux = vec4<f32>(0.0);
    let leaf = reached && n.lit > 0u && n.w > 0.0 && (d == params.max_depth || !splits(n, d, total_w));
    if (leaf) {
        // Divide by the weight first: dot(Σw·n, Σw·n) overflows f32 for
        // very bright lights (w ~ 1e20), and normalize() would give zero.
        var normal = n.wn / n.w;
        // Its far-field lobe's coherence |Σw·n| / Σw (shade.wgsl
        // far_lobe): a dynamic VPL is always drawn as one disk.
        var coherence = 1.0;
        if (dot(normal, normal) > 0.0) {
            coherence = clamp(length(normal), 0.0, 1.0);
            normal = normalize(normal);
        } else {
            normal = normalize(n.normal);
        }
        if (!is_finite_f32(coherence)) {
            coherence = 1.0;
        }
        let position = n.wp / n.w;
        let ok = is_finite_f32(position.x) && is_finite_f32(position.y) && is_finite_f32(position.z)
            && is_finite_f32(normal.x) && is_finite_f32(normal.y) && is_finite_f32(normal.z);
        if (ok) {
            var area = n.area;
            if (!is_finite_f32(area)) {
                area = 0.0;
            }
            out.position = vec4<f32>(position, area);
            out.normal = vec4<f32>(normal, 1.0);
            out.flux = vec4<f32>(finite_or_zero3(n.flux), coherence);
        }
    }
    vpls[params.base + s] = out;
}
