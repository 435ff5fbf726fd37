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

// Shadow-map test constants, in texel footprints at the receiver
// (scale-invariant): the receiver-plane test's depth bias and the steepest
// receiver plane it trusts (metric change per texel: 7 footprints is a
// plane 82° from facing the light), and the offset lookup's normal offset
// and depth bias.
const SHADOW_DEPTH_BIAS: f32 = 0.5;
const SHADOW_MAX_SLOPE: f32 = 7.0;
const SHADOW_NORMAL_OFFSET: f32 = 1.0;
const SHADOW_OFFSET_BIAS: f32 = 1.0;

// Fraction of the light that reaches p, by 2×2 bilinear percentage-closer
// filtering of a metric map: of `map`, or with `merge`, of min(map,
// moving) (the z-min merge of a static and a moving objects' map without
// copying). The maps' texels start at `origin.xy` of `map` and
// `origin.zw` of `moving` (tiles of atlases; 0 for whole textures). ng is
// p's geometric normal on either side, wi the unit direction to the
// light. Points outside the map are unshadowed.
//
// A receiver facing the light gets a **receiver-plane test**, as the VPL
// maps do (shade.wgsl, vpl_visibility): a texel stores the metric of the
// surface its centre's ray meets, so a tap whose ray meets the receiver's
// plane (p, ng) nearer to the light than p compares its stored metric with
// that point's, and a tap whose ray meets the plane beyond p with p's own;
// the bias is half a footprint. On a planar receiver that is exact at any
// angle: no normal offset, no slope-scaled bias. The plane's metric per
// texel comes from two steps along the plane (exact for a directional
// light's affine projection, to second order in the texel's angle for a
// spot's). Until issue 49 every receiver had a normal offset of sinθ
// footprints and a bias of one: together they hid a caster less than
// about two footprints above the receiver along the light, and a groove a
// texel or two deep lost most of its shadow (docs/method.md, "Narrow
// shadows").
//
// Two receivers keep that **offset lookup**: one facing away from the light
// (lit only through its shading normal, a smooth terminator), where the
// map cannot tell the far side of a solid (in shadow: the plane's
// extension toward the light runs inside the solid, past its lit side)
// from an open sheet seen from behind (lit), and a footprint's step toward
// the light moves the lookup into the solid, or off the sheet; and one
// nearly edge-on to the light (steeper than SHADOW_MAX_SLOPE), whose plane
// a tap meets many footprints away, where a real surface has long curved
// (the tap would see the receiver's own surface ahead of the plane: acne
// on the cave's smooth-shaded rock). Measured: docs/method.md.
fn lv_visibility(v: LightView, map: texture_2d<f32>, moving: texture_2d<f32>, merge: bool, origin: vec4<i32>, p: vec3<f32>, ng: vec3<f32>, wi: vec3<f32>) -> f32 {
    let w = lv_footprint(v, p);
    let cos_g = dot(ng, wi);
    var tc = lv_texel_coords(v, p);
    var d = lv_metric(v, p);
    // The receiver's plane: metric change per texel offset, g = J⁻ᵀ·m for
    // the texel offsets J and metric changes m of one footprint along two
    // tangents.
    var g = vec2<f32>(0.0);
    var plane = false;
    if (cos_g >= 0.0 && tc.z > 0.0) {
        var t1 = cross(ng, vec3<f32>(0.0, 1.0, 0.0));
        if (dot(t1, t1) < 0.01) {
            t1 = cross(ng, vec3<f32>(1.0, 0.0, 0.0));
        }
        t1 = normalize(t1) * w;
        let t2 = normalize(cross(ng, t1)) * w;
        let ja = lv_texel_coords(v, p + t1).xy - tc.xy;
        let jb = lv_texel_coords(v, p + t2).xy - tc.xy;
        let m = vec2<f32>(lv_metric(v, p + t1) - d, lv_metric(v, p + t2) - d);
        let det = ja.x * jb.y - ja.y * jb.x;
        if (abs(det) > 1e-6) {
            g = vec2<f32>(jb.y * m.x - ja.y * m.y, ja.x * m.y - jb.x * m.x) / det;
            plane = length(g) <= w * SHADOW_MAX_SLOPE;
        }
    }
    var bias = w * SHADOW_DEPTH_BIAS;
    if (!plane) {
        // The offset lookup: a footprint toward the light along the normal
        // on the light's side, growing toward grazing angles.
        let n = select(ng, -ng, cos_g < 0.0);
        let sin_t = sqrt(max(1.0 - cos_g * cos_g, 0.0));
        let q = p + n * (w * SHADOW_NORMAL_OFFSET * sin_t);
        tc = lv_texel_coords(v, q);
        d = lv_metric(v, q);
        g = vec2<f32>(0.0);
        bias = w * SHADOW_OFFSET_BIAS;
    }
    if (tc.z <= 0.0 || any(tc.xy < vec2<f32>(0.0)) || any(tc.xy > vec2<f32>(v.params.x))) {
        return 1.0;
    }
    let size = i32(v.params.x);
    let t = tc.xy - vec2<f32>(0.5);
    let i0 = vec2<i32>(floor(t));
    let f = t - floor(t);
    var lit = vec4<f32>(0.0);
    let offs = array<vec2<i32>, 4>(vec2<i32>(0, 0), vec2<i32>(1, 0), vec2<i32>(0, 1), vec2<i32>(1, 1));
    for (var k = 0; k < 4; k++) {
        let c = clamp(i0 + offs[k], vec2<i32>(0), vec2<i32>(size - 1));
        var s = textureLoad(map, origin.xy + c, 0).r;
        if (merge) {
            s = min(s, textureLoad(moving, origin.zw + c, 0).r);
        }
        // Where the tap's ray meets the receiver's plane, if nearer than p
        // (p itself for the offset lookup: g = 0).
        let dk = min(d + dot(g, vec2<f32>(c) + vec2<f32>(0.5) - tc.xy), d);
        lit[k] = select(0.0, 1.0, dk <= s + bias);
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
