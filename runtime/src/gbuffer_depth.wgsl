// gbuffer_depth.wgsl — the normals and albedo of gibake's G-buffer rebuilt
// from an engine's own (needs common.wgsl, gbuffer_layout.wgsl): its normal
// buffer turned to face the viewer (the viewer's side found with the world
// point rebuilt from the engine's depth) and its albedo, packed into
// gibake's layout. The engine's depth is read by shading as it is. One
// invocation per pixel.

struct DepthParams {
    inv_view_proj: mat4x4<f32>,
    position: vec4<f32>,   // xyz eye; w = 1 orthographic
    forward: vec4<f32>,    // xyz view direction
    size: vec2<u32>,
    far_depth: f32,        // the depth of "no surface" (0 reversed Z, 1 standard)
    normals: u32,          // 0: octahedral pair, 1: world xyz, 2: world xyz · 0.5 + 0.5
}

@group(0) @binding(0) var depth_tex: DEPTH_TEXTURE;
@group(0) @binding(1) var normal_tex: texture_2d<f32>;
@group(0) @binding(2) var albedo_tex: texture_2d<f32>;
@group(0) @binding(3) var<uniform> p: DepthParams;
@group(0) @binding(5) var out_normals: texture_storage_2d<rg32uint, write>;
@group(0) @binding(6) var out_albedo: texture_storage_2d<r32uint, write>;

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (any(gid.xy >= p.size)) {
        return;
    }
    let px = vec2<i32>(gid.xy);
    let depth = DEPTH_LOAD;
    if (depth == p.far_depth) {
        textureStore(out_normals, px, vec4<u32>(0u));
        textureStore(out_albedo, px, vec4<u32>(0u));
        return;
    }
    let raw = textureLoad(normal_tex, px, 0);
    var ns = oct_decode(raw.xy);
    var ng = oct_decode(raw.zw);
    if (p.normals != 0u) {
        var n = raw.xyz;
        if (p.normals == 2u) {
            n = n * 2.0 - 1.0;
        }
        n = normalize(n);
        let x = gbuffer_position(p.inv_view_proj, p.size, px, depth);
        var to_eye = p.position.xyz - x;
        if (p.position.w > 0.5) {
            to_eye = -p.forward.xyz;
        }
        if (dot(n, to_eye) < 0.0) {
            n = -n;
        }
        ns = n;
        ng = n;
    }
    textureStore(out_normals, px, vec4<u32>(gbuffer_pack_normals(ns, ng), 0u, 0u));
    let albedo = textureLoad(albedo_tex, px, 0).rgb;
    textureStore(out_albedo, px, vec4<u32>(gbuffer_pack_albedo(albedo), 0u, 0u, 0u));
}
