// shadow.wgsl — light-view metric map (needs common.wgsl, projection.wgsl, mesh.wgsl).
// Writes the projection's metric (distance to a spot light, depth along a
// directional one) to an R32Float target; the depth buffer keeps the nearest.
// Alpha-masked surfaces cut holes (alpha_keeps): leaves cast dappled shadows.

@group(0) @binding(0) var<storage, read> draws: array<DrawData>;
@group(0) @binding(1) var<uniform> view: LightView;
@group(1) @binding(0) var albedo_tex: texture_2d<f32>;
@group(1) @binding(1) var albedo_smp: sampler;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) @interpolate(flat) draw: u32,
}

@vertex
fn vs_main(v: VertexIn) -> VsOut {
    let world = (draws[v.draw].model * vec4<f32>(v.position, 1.0)).xyz;
    var o: VsOut;
    o.clip = view.view_proj * vec4<f32>(world, 1.0);
    o.world = world;
    o.uv = v.uv;
    o.draw = v.draw;
    return o;
}

@fragment
fn fs_main(i: VsOut) -> @location(0) vec4<f32> {
    let texel_alpha = mask_texel_alpha(albedo_tex, albedo_smp, i.uv);
    if (!alpha_keeps(draws[i.draw], texel_alpha)) {
        discard;
    }
    return vec4<f32>(lv_metric(view, i.world), 0.0, 0.0, 0.0);
}
