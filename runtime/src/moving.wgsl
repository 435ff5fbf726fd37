// moving.wgsl — whether a moving object is in front of the static surface
// at a texel of the moving objects' RSM: one definition for the partial
// occlusion pass (occlusion.wgsl) and the dynamic VPLs (dynamic_vpl.wgsl).
// The including pass declares `dyn_position` (xyz position, w metric of the
// moving surfaces), `static_metric` (the baked RSM's metric) and `view`
// (their LightView). Needs projection.wgsl.

// Depth margin in texel footprints (scale-invariant).
const OCCLUSION_BIAS: f32 = 0.5;

// Whether the moving surface at texel c is in front of the static one.
fn moving_in_front(c: vec2<i32>) -> bool {
    let dm = textureLoad(dyn_position, c, 0).w;
    let sm = textureLoad(static_metric, c, 0).r;
    var w = view.direction.w;
    if (view.origin.w < 0.5) {
        w = min(dm, sm) * view.direction.w;
    }
    return dm < sm - OCCLUSION_BIAS * w;
}
