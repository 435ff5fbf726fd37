// dynamic_rsm.wgsl — the moving objects' reflective shadow map (needs
// common.wgsl, projection.wgsl, mesh.wgsl). Drawn from the primary light at
// the bake's RSM resolution into cleared targets; a texel counts as a moving
// surface only where it is nearer the light than the baked static RSM
// (tested where it is read), which is the paper's "depth buffer starts as
// the static depth" without copying the static depth each frame.
// Targets: 0 world position + metric (w = 3e38 where empty), 1 albedo,
// 2 oct(normal facing the light). Alpha-masked surfaces are cut (alpha_keeps).

@group(0) @binding(0) var<storage, read> draws: array<DrawData>;
@group(0) @binding(1) var<uniform> view: LightView;
@group(1) @binding(0) var albedo_tex: texture_2d<f32>;
@group(1) @binding(1) var albedo_smp: sampler;

@vertex
fn vs_main(v: VertexIn) -> MeshVarying {
    return mesh_vertex(v, draws[v.draw], view.view_proj);
}

struct FsOut {
    @location(0) position: vec4<f32>,
    @location(1) albedo: vec4<f32>,
    @location(2) normal: vec4<f32>,
}

@fragment
fn fs_main(i: MeshVarying, @builtin(front_facing) front: bool) -> FsOut {
    let d = draws[i.draw];
    let texel = textureSample(albedo_tex, albedo_smp, i.uv);
    if (!alpha_keeps(d, texel.a)) {
        discard;
    }
    let albedo = draw_albedo(d, texel.rgb);
    var n = normalize(i.normal);
    if (!front) {
        n = -n;
    }
    var to_light = -view.direction.xyz;
    if (view.origin.w < 0.5) {
        to_light = normalize(view.origin.xyz - i.world);
    }
    if (dot(n, to_light) < 0.0) {
        n = -n;
    }
    var o: FsOut;
    o.position = vec4<f32>(i.world, lv_metric(view, i.world));
    o.albedo = vec4<f32>(albedo, 1.0);
    o.normal = vec4<f32>(oct_encode(n), 0.0, 0.0);
    return o;
}
