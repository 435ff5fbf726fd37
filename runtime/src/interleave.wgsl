// interleave.wgsl — reconstruction of interleaved VPL sampling (needs
// common.wgsl, gbuffer_layout.wgsl: the view's ViewParams and G-buffer
// reads, shared with shade.wgsl). Input: shade.wgsl's 2·width-wide texture, direct radiance at
// (x, y) and the pixel's irradiance estimate (its VPL subset × N²) at
// (x + width, y). Each pixel's irradiance is a geometry-weighted tent over
// the (2N−1)² neighbours around it: the tent's weights (N − |dx|)(N − |dy|)
// give every one of the N² subsets the same total weight N², so where every
// neighbour matches the pixel's surface the result is the full VPL sum's
// expectation. A neighbour counts by the similarity of its shading normal
// and by how far it lies off the pixel's tangent plane relative to its
// distance from the pixel (a sine: the same at every scene scale). The
// pixel's own estimate always counts, so an isolated pixel keeps it.
// Writes radiance = direct + albedo/π · filtered irradiance.
// With the later bounces at half resolution (view.later_half, shade.wgsl
// cs_later): cs_later_filter first filters their estimates the same way on
// the half-resolution grid (its samples' G-buffer at pixel (2i, 2j)), and
// cs_main adds them brought up to the pixel (later_upsampled).

// Neighbour weights: normal similarity cos^NORMAL_POWER, plane offset
// exp(−(sinθ / PLANE_SIN)²) with sinθ = |n·(x_q − x_p)| / |x_q − x_p|
// (a neighbour across a depth step, sinθ ≈ 1, weighs e⁻⁴). Loose on
// purpose: at 64² (tests/interleave.rs) stricter weights (cos¹⁶, 0.1) leave
// curved surfaces (the bunny) with their own 1/16 sample and nearly double
// the error against the reference; cos², 0.5 keeps it within 1.11×.
const NORMAL_POWER: f32 = 2.0;
const PLANE_SIN: f32 = 0.5;

@group(0) @binding(0) var g_depth: texture_2d<f32>;
@group(0) @binding(1) var g_normals: texture_2d<u32>;
@group(0) @binding(2) var g_albedo: texture_2d<u32>;
// cs_main: shade.wgsl's direct | irradiance texture; cs_later_filter: the
// later bounces' half-resolution estimates (shade.wgsl out_later).
@group(0) @binding(3) var shaded: texture_2d<f32>;
@group(0) @binding(4) var<uniform> params: ViewParams;
// cs_main: the radiance; cs_later_filter: the filtered later bounces.
@group(0) @binding(5) var out_radiance: texture_storage_2d<rgba32float, write>;
// cs_main: the filtered later bounces (a 1×1 stand-in without them).
@group(0) @binding(6) var later_in: texture_2d<f32>;

// How much neighbour sample q (its G-buffer at pixel g, depth dq: a
// surface's) counts for a receiver at x with normals ns, ng: 0 for a
// back-facing one.
fn neighbour_weight(g: vec2<i32>, dq: f32, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> f32 {
    let nq = gbuffer_normal(textureLoad(g_normals, g, 0).x);
    let c = max(dot(ns, nq), 0.0);
    if (c <= 0.0) {
        return 0.0;
    }
    let d = gbuffer_position(params.inv_view_proj, params.size, g, dq) - x;
    let l2 = dot(d, d);
    var s = 0.0;
    if (l2 > 0.0) {
        s = abs(dot(ng, d)) * inverseSqrt(l2);
    }
    let t = s / PLANE_SIN;
    return pow(c, NORMAL_POWER) * exp(-t * t);
}

// The filtered irradiance at grid point c of a `grid`-sized grid whose
// point q has its G-buffer sample at pixel q·step and its estimate at
// `shaded[base + q]`: the geometry-weighted tent over the (2N−1)²
// neighbours, the point's own estimate always counting.
fn tent(c: vec2<i32>, step: i32, grid: vec2<i32>, base: vec2<i32>, m: i32, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    let n = m * i32(max(params.interleave, 1u));
    let own = f32(n * n);
    var sum = textureLoad(shaded, base + c, 0).rgb * own;
    var wsum = own;
    for (var dy = 1 - n; dy < n; dy++) {
        for (var dx = 1 - n; dx < n; dx++) {
            if (dx == 0 && dy == 0) {
                continue;
            }
            let q = c + vec2<i32>(dx, dy);
            if (q.x < 0 || q.y < 0 || q.x >= grid.x || q.y >= grid.y) {
                continue;
            }
            let dq = textureLoad(g_depth, q * step, 0).r;
            if (dq == params.far_depth) {
                continue;
            }
            let wg = neighbour_weight(q * step, dq, x, ns, ng);
            if (wg <= 0.0) {
                continue;
            }
            let wt = f32((n - abs(dx)) * (n - abs(dy))) * wg;
            sum += textureLoad(shaded, base + q, 0).rgb * wt;
            wsum += wt;
        }
    }
    return sum / wsum;
}

// The later bounces' filtered irradiance at pixel px: the half-resolution
// samples around it (sample q at pixel 2q), bilinear weights times
// neighbour_weight; where none of them lies on the pixel's surface, their
// bilinear mean (a thin feature between samples takes its surroundings'
// smooth later light), 0 where none has a surface.
fn later_upsampled(px: vec2<i32>, x: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    let grid = (vec2<i32>(params.size) + vec2<i32>(1)) / 2;
    let q0 = px / 2;
    let t = vec2<f32>(px % vec2<i32>(2)) * 0.5;
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    var bsum = vec3<f32>(0.0);
    var bw = 0.0;
    for (var k = 0; k < 4; k++) {
        let o = vec2<i32>(k % 2, k / 2);
        let wb = select(1.0 - t.x, t.x, o.x == 1) * select(1.0 - t.y, t.y, o.y == 1);
        let q = min(q0 + o, grid - vec2<i32>(1));
        if (wb <= 0.0) {
            continue;
        }
        let dq = textureLoad(g_depth, q * 2, 0).r;
        if (dq == params.far_depth) {
            continue;
        }
        let e = textureLoad(later_in, q, 0).rgb;
        let w = wb * neighbour_weight(q * 2, dq, x, ns, ng);
        sum += e * w;
        wsum += w;
        bsum += e * wb;
        bw += wb;
    }
    if (wsum > 1.0e-3 * bw) {
        return sum / wsum;
    }
    if (bw > 0.0) {
        return bsum / bw;
    }
    return vec3<f32>(0.0);
}

const LATER_M: i32 = 2;
// The later bounces' half-resolution estimates filtered on their grid.
@compute @workgroup_size(8, 8)
fn cs_later_filter(@builtin(global_invocation_id) gid: vec3<u32>) {
    let grid = (params.size + vec2<u32>(1u)) / 2u;
    if (any(gid.xy >= grid)) {
        return;
    }
    let c = vec2<i32>(gid.xy);
    let px = c * 2;
    let depth = textureLoad(g_depth, px, 0).r;
    var e = vec3<f32>(0.0);
    if (depth != params.far_depth) {
        let x = gbuffer_position(params.inv_view_proj, params.size, px, depth);
        let nn = textureLoad(g_normals, px, 0).xy;
        e = tent(c, 2, vec2<i32>(grid), vec2<i32>(0), LATER_M, x, gbuffer_normal(nn.x), gbuffer_normal(nn.y));
    }
    textureStore(out_radiance, c, vec4<f32>(finite_or_zero3(e), 1.0));
}

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (any(gid.xy >= params.size)) {
        return;
    }
    let px = vec2<i32>(gid.xy);
    let w = i32(params.size.x);
    let direct = textureLoad(shaded, px, 0).rgb;
    let depth = textureLoad(g_depth, px, 0).r;
    if (depth == params.far_depth) {
        textureStore(out_radiance, px, vec4<f32>(finite_or_zero3(direct), 1.0));
        return;
    }
    let x = gbuffer_position(params.inv_view_proj, params.size, px, depth);
    let nn = textureLoad(g_normals, px, 0).xy;
    let ns = gbuffer_normal(nn.x);
    let ng = gbuffer_normal(nn.y);
    let albedo = gbuffer_albedo(textureLoad(g_albedo, px, 0).x);
    var e = tent(px, 1, vec2<i32>(params.size), vec2<i32>(w, 0), 1, x, ns, ng);
    if (params.later_half != 0u) {
        e += later_upsampled(px, x, ns, ng);
    }
    let radiance = direct + albedo * INV_PI * e;
    textureStore(out_radiance, px, vec4<f32>(finite_or_zero3(radiance), 1.0));
}
