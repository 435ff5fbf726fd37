// projection.wgsl — the light view of shadow maps and RSMs (needs common.wgsl).
// CPU twin: LightView in light_view.rs (a test checks they agree).
// Must match GpuLightView in light_view.rs.

struct LightView {
    view_proj: mat4x4<f32>,
    origin: vec4<f32>,     // xyz origin; w = 1 directional, 0 spot
    direction: vec4<f32>,  // xyz direction; w = texel scale
    params: vec4<f32>,     // x size, y 1/size, z texel area
}

// The stored shadow metric: distance to a spot light, or depth along a
// directional light from the front plane.
fn lv_metric(v: LightView, p: vec3<f32>) -> f32 {
    if (v.origin.w > 0.5) {
        return dot(p - v.origin.xyz, v.direction.xyz);
    }
    return length(p - v.origin.xyz);
}

// World size of one texel at p.
fn lv_footprint(v: LightView, p: vec3<f32>) -> f32 {
    if (v.origin.w > 0.5) {
        return v.direction.w;
    }
    return lv_metric(v, p) * v.direction.w;
}

// Continuous texel coordinates (x right, y down; centres at half-integers).
// z < 0 means behind a spot light.
fn lv_texel_coords(v: LightView, p: vec3<f32>) -> vec3<f32> {
    let c = v.view_proj * vec4<f32>(p, 1.0);
    let ndc = c.xy / c.w;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    return vec3<f32>(uv * v.params.x, c.w);
}

// Shadow-map biases, in texel footprints at the receiver (scale-invariant).
const SHADOW_NORMAL_OFFSET: f32 = 1.0;
const SHADOW_DEPTH_BIAS: f32 = 1.0;

// Fraction of the light that reaches p (geometric normal ng facing the
// light), by 2×2 bilinear percentage-closer filtering of a metric map: of
// `map`, or with `merge`, of min(map, moving) (the z-min merge of a static
// and a moving objects' map without copying). The maps' texels start at
// `origin.xy` of `map` and `origin.zw` of `moving` (tiles of atlases; 0
// for whole textures).
// Points outside the map are unshadowed.
fn lv_visibility(v: LightView, map: texture_2d<f32>, moving: texture_2d<f32>, merge: bool, origin: vec4<i32>, p: vec3<f32>, ng: vec3<f32>, wi: vec3<f32>) -> f32 {
    let w = lv_footprint(v, p);
    let cos_t = clamp(dot(ng, wi), 0.0, 1.0);
    let sin_t = sqrt(max(1.0 - cos_t * cos_t, 0.0));
    // Normal offset grows toward grazing angles, where acne lives.
    let q = p + ng * (w * SHADOW_NORMAL_OFFSET * sin_t);
    let d = lv_metric(v, q);
    let tc = lv_texel_coords(v, q);
    if (tc.z <= 0.0 || any(tc.xy < vec2<f32>(0.0)) || any(tc.xy > vec2<f32>(v.params.x))) {
        return 1.0;
    }
    let size = i32(v.params.x);
    let t = tc.xy - vec2<f32>(0.5);
    let i0 = vec2<i32>(floor(t));
    let f = t - floor(t);
    let bias = w * SHADOW_DEPTH_BIAS;
    var lit = vec4<f32>(0.0);
    let offs = array<vec2<i32>, 4>(vec2<i32>(0, 0), vec2<i32>(1, 0), vec2<i32>(0, 1), vec2<i32>(1, 1));
    for (var k = 0; k < 4; k++) {
        let c = clamp(i0 + offs[k], vec2<i32>(0), vec2<i32>(size - 1));
        var s = textureLoad(map, origin.xy + c, 0).r;
        if (merge) {
            s = min(s, textureLoad(moving, origin.zw + c, 0).r);
        }
        lit[k] = select(0.0, 1.0, d <= s + bias);
    }
    return mix(mix(lit.x, lit.y, f.x), mix(lit.z, lit.w, f.x), f.y);
}

// Solid angle (spot) or perpendicular area (directional) of the texel whose
// ray has unit direction dir. CPU twin: LightView::texel_measure.
fn lv_texel_measure(v: LightView, dir: vec3<f32>) -> f32 {
    if (v.origin.w > 0.5) {
        return v.params.z;
    }
    let c = max(dot(dir, v.direction.xyz), 0.0);
    return v.params.z * c * c * c;
}
