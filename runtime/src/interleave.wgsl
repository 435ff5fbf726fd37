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
@group(0) @binding(3) var shaded: texture_2d<f32>;
@group(0) @binding(4) var<uniform> params: ViewParams;
@group(0) @binding(5) var out_radiance: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (any(gid.xy >= params.size)) {
        return;
    }
    let px = vec2<i32>(gid.xy);
    let w = i32(params.size.x);
    let h = i32(params.size.y);
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
    let n = i32(max(params.interleave, 1u));
    let own = f32(n * n);
    var sum = textureLoad(shaded, px + vec2<i32>(w, 0), 0).rgb * own;
    var wsum = own;
    for (var dy = 1 - n; dy < n; dy++) {
        for (var dx = 1 - n; dx < n; dx++) {
            if (dx == 0 && dy == 0) {
                continue;
            }
            let q = px + vec2<i32>(dx, dy);
            if (q.x < 0 || q.y < 0 || q.x >= w || q.y >= h) {
                continue;
            }
            let dq = textureLoad(g_depth, q, 0).r;
            if (dq == params.far_depth) {
                continue;
            }
            let nq = gbuffer_normal(textureLoad(g_normals, q, 0).x);
            let c = max(dot(ns, nq), 0.0);
            if (c <= 0.0) {
                continue;
            }
            let d = gbuffer_position(params.inv_view_proj, params.size, q, dq) - x;
            let l2 = dot(d, d);
            var s = 0.0;
            if (l2 > 0.0) {
                s = abs(dot(ng, d)) * inverseSqrt(l2);
            }
            let t = s / PLANE_SIN;
            let wg = pow(c, NORMAL_POWER) * exp(-t * t);
            let wt = f32((n - abs(dx)) * (n - abs(dy))) * wg;
            sum += textureLoad(shaded, q + vec2<i32>(w, 0), 0).rgb * wt;
            wsum += wt;
        }
    }
    let e = sum / wsum;
    let radiance = direct + albedo * INV_PI * e;
    textureStore(out_radiance, px, vec4<f32>(finite_or_zero3(radiance), 1.0));
}
