// other_lights.wgsl — the lights after the first, for shade.wgsl (needs
// light.wgsl, projection.wgsl): their records, their views and shadow maps
// (other_lights.rs uploads them), and the visibility of one of them. A
// scene with one light uses other_lights_none.wgsl instead: no binding.

struct OtherLight {       // GpuOtherLight in other_lights.rs
    light: PrimaryLight,
    views: vec4<u32>,     // x first view in other_views, y view count (6: cube faces)
}

struct OtherView {        // GpuOtherView in other_lights.rs
    view: LightView,
    tile: vec4<i32>,      // xy the static map's origin in light_maps (−1: none);
                          // zw the moving objects' map's in light_moving (−1: none)
}

@group(1) @binding(21) var<storage, read> other_lights: array<OtherLight>;
@group(1) @binding(22) var<storage, read> other_views: array<OtherView>;
@group(1) @binding(23) var light_maps: texture_2d<f32>;
@group(1) @binding(24) var light_moving: texture_2d<f32>;

// Light k after the first.
fn other_light(k: u32) -> PrimaryLight {
    return other_lights[k].light;
}

// Visibility of light k after the first: its one view, or for a point
// light the cube face of the receiver's direction (the face of the largest
// absolute component, +X, −X, +Y, −Y, +Z, −Z as baked); the static map,
// merged (z-min) with the moving objects' map when they touch the view
// this frame. A view with neither holds no surface: nothing shadows there.
fn other_visibility(k: u32, p: vec3<f32>, ng: vec3<f32>, wi: vec3<f32>) -> f32 {
    let l = other_lights[k];
    var face = 0u;
    if (l.views.y == 6u) {
        let d = p - l.light.position.xyz;
        let a = abs(d);
        if (a.x >= a.y && a.x >= a.z) {
            face = select(1u, 0u, d.x >= 0.0);
        } else if (a.y >= a.z) {
            face = select(3u, 2u, d.y >= 0.0);
        } else {
            face = select(5u, 4u, d.z >= 0.0);
        }
    }
    let v = other_views[l.views.x + face];
    let stored = v.tile.x >= 0;
    let moving = v.tile.z >= 0;
    if (stored) {
        return lv_visibility(v.view, light_maps, light_moving, moving, v.tile, p, ng, wi);
    }
    if (moving) {
        return lv_visibility(v.view, light_moving, light_moving, false, v.tile.zwzw, p, ng, wi);
    }
    return 1.0;
}
