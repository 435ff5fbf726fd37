// gbuffer.wgsl — camera G-buffer of all geometry (needs common.wgsl,
// mesh.wgsl, gbuffer_layout.wgsl). Alpha-masked surfaces are cut
// (alpha_keeps): the camera sees through holes. The depth attachment holds
// the depth (the world position is rebuilt from it); targets: 0 both normals,
// facing the viewer (gbuffer_pack_normals), 1 albedo (gbuffer_pack_albedo). Textures are sampled trilinearly from their mip
// chain with the fragment's own derivatives.

struct Camera {
    view_proj: mat4x4<f32>,
    position: vec4<f32>,   // w = 1 orthographic
    forward: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> draws: array<DrawData>;
@group(0) @binding(1) var<uniform> camera: Camera;
@group(1) @binding(0) var albedo_tex: texture_2d<f32>;
@group(1) @binding(1) var albedo_smp: sampler;

@vertex
fn vs_main(v: VertexIn) -> MeshVarying {
    return mesh_vertex(v, draws[v.draw], camera.view_proj);
}

struct FsOut {
    @location(0) normals: vec2<u32>,
    @location(1) albedo: u32,
}

@fragment
fn fs_main(i: MeshVarying, @builtin(front_facing) front: bool) -> FsOut {
    let d = draws[i.draw];
    // Albedo trilinear from the mip chain (implicit derivatives, uniform
    // control flow); the alpha test reads the finest level as every map does.
    let texel = textureSample(albedo_tex, albedo_smp, i.uv);
    if (!alpha_keeps(d, mask_texel_alpha(albedo_tex, albedo_smp, i.uv))) {
        discard;
    }
    let albedo = draw_albedo(d, texel.rgb);
    var to_eye = camera.position.xyz - i.world;
    if (camera.position.w > 0.5) {
        to_eye = -camera.forward.xyz;
    }
    var ns = normalize(i.normal);
    if (!front) {
        ns = -ns;
    }
    // Flat geometric normal from screen derivatives (exact per triangle).
    let c = cross(dpdx(i.world), dpdy(i.world));
    var ng = ns;
    if (dot(c, c) > 0.0) {
        ng = normalize(c);
    }
    if (dot(ng, to_eye) < 0.0) {
        ng = -ng;
    }
    // The shading normal on the geometric normal's side, whatever the
    // winding: a mesh wound clockwise, or drawn under a mirroring transform
    // (which turns front faces into back faces), shades like the original
    // (gibake_raycast::Hit does the same for the bake and the reference).
    if (dot(ns, ng) < 0.0) {
        ns = -ns;
    }
    var o: FsOut;
    o.normals = gbuffer_pack_normals(ns, ng);
    o.albedo = gbuffer_pack_albedo(albedo);
    return o;
}
