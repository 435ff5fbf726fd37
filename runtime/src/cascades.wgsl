// cascades.wgsl — cascaded shadow maps of the primary directional light
// (needs projection.wgsl; bound in shading's group 1). Written by the
// cascade passes of cascades.rs: per cascade a map of the static draws and,
// with moving objects, a map of them (min-merged here, as the primary map).
// The finest cascade whose map holds the point (with a margin for the
// offset lookup and the 2×2 PCF) shadows it, through the one lv_visibility
// of projection.wgsl; none holds it: the caller uses the primary map.

struct Cascades {         // GpuCascades in cascades.rs (must match)
    views: array<LightView, 4>,
    count: u32,           // cascades in use this frame (0: none)
    merge: u32,           // 1: moving objects have their own maps
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(12) var<uniform> cascades: Cascades;
@group(1) @binding(13) var cascade_static0: texture_2d<f32>;
@group(1) @binding(14) var cascade_static1: texture_2d<f32>;
@group(1) @binding(15) var cascade_static2: texture_2d<f32>;
@group(1) @binding(16) var cascade_static3: texture_2d<f32>;
@group(1) @binding(17) var cascade_moving0: texture_2d<f32>;
@group(1) @binding(18) var cascade_moving1: texture_2d<f32>;
@group(1) @binding(19) var cascade_moving2: texture_2d<f32>;
@group(1) @binding(20) var cascade_moving3: texture_2d<f32>;

// Cascades shade a point where the primary map's texel exceeds this
// fraction of the camera pixel's footprint there (shade.wgsl).
const CASCADE_PIXEL_FRACTION: f32 = 0.25;

// Texels kept clear of a cascade's edge: the offset lookup's normal offset
// (at most one texel; lv_visibility) and the PCF footprint (two).
const CASCADE_MARGIN: f32 = 3.0;

// The finest cascade whose map holds p, or `cascades.count` if none does.
fn cascade_index(p: vec3<f32>) -> u32 {
    for (var k = 0u; k < cascades.count; k++) {
        let v = cascades.views[k];
        let tc = lv_texel_coords(v, p);
        let hi = v.params.x - CASCADE_MARGIN;
        if (all(tc.xy >= vec2<f32>(CASCADE_MARGIN)) && all(tc.xy <= vec2<f32>(hi))) {
            return k;
        }
    }
    return cascades.count;
}

// Visibility of p in cascade k (k < cascades.count).
fn cascade_visibility(k: u32, p: vec3<f32>, ng: vec3<f32>, wi: vec3<f32>) -> f32 {
    let v = cascades.views[k];
    let m = cascades.merge != 0u;
    switch k {
        case 0u: { return lv_visibility(v, cascade_static0, cascade_moving0, m, vec4<i32>(0), p, ng, wi); }
        case 1u: { return lv_visibility(v, cascade_static1, cascade_moving1, m, vec4<i32>(0), p, ng, wi); }
        case 2u: { return lv_visibility(v, cascade_static2, cascade_moving2, m, vec4<i32>(0), p, ng, wi); }
        default: { return lv_visibility(v, cascade_static3, cascade_moving3, m, vec4<i32>(0), p, ng, wi); }
    }
}
