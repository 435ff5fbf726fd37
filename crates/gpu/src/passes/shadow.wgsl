// shadow.wgsl — light-view metric map (needs common.wgsl, projection.wgsl, mesh.wgsl).
// Writes the projection's metric (distance to a spot light, depth along a
// directional one) to an R32Float target; the depth buffer keeps the nearest.

@group(0) @binding(0) var<storage, read> draws: array<DrawData>;
@group(0) @binding(1) var<uniform> view: LightView;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
}

@vertex
fn vs_main(v: VertexIn) -> VsOut {
    let world = (draws[v.draw].model * vec4<f32>(v.position, 1.0)).xyz;
    var o: VsOut;
    o.clip = view.view_proj * vec4<f32>(world, 1.0);
    o.world = world;
    return o;
}

@fragment
fn fs_main(i: VsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(lv_metric(view, i.world), 0.0, 0.0, 0.0);
}
