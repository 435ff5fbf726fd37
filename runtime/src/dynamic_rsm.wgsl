// dynamic_rsm.wgsl — the moving objects' reflective shadow map (needs
// common.wgsl, projection.wgsl, mesh.wgsl). Drawn from the primary light at
// the bake's RSM resolution into cleared targets; a texel counts as a moving
// surface only where it is nearer the light than the baked static RSM
// (tested where it is read), which is the paper's "depth buffer starts as
// the static depth" without copying the static depth each frame.
// Targets: 0 world position + metric (w = 3e38 where empty), 1 albedo,
// 2 oct(geometric normal) in xy and oct(shading normal) in zw, both facing
// the light: a texel emits about its facet's normal, and its irradiance
// (its flux) takes the shading normal's cosine, as the bake's RSM
// (gibake_bake::rsm::Rsm::normal). Alpha-masked surfaces are cut (alpha_keeps).

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
    // The triangle's own normal from the position's screen derivatives
    // (taken before the discard, in uniform control flow).
    let g = cross(dpdx(i.world), dpdy(i.world));
    if (!alpha_keeps(d, mask_texel_alpha(albedo_tex, albedo_smp, i.uv))) {
        discard;
    }
    let albedo = draw_albedo(d, texel.rgb);
    var to_light = -view.direction.xyz;
    if (view.origin.w < 0.5) {
        to_light = normalize(view.origin.xyz - i.world);
    }
    var ns = normalize(i.normal);
    if (!front) {
        ns = -ns;
    }
    var ng = ns;
    if (dot(g, g) > 0.0 && is_finite_f32(dot(g, g))) {
        ng = normalize(g);
    }
    if (dot(ng, to_light) < 0.0) {
        ng = -ng;
    }
    // The shading normal on the geometric normal's side (Conventions).
    if (dot(ns, ng) < 0.0) {
        ns = -ns;
    }
    var o: FsOut;
    o.position = vec4<f32>(i.world, lv_metric(view, i.world));
    o.albedo = vec4<f32>(albedo, 1.0);
    o.normal = vec4<f32>(oct_encode(ng), oct_encode(ns));
    return o;
}
