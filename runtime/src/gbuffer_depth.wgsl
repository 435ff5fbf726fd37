// gbuffer_depth.wgsl — gibake's G-buffer rebuilt from an engine's own
// (needs common.wgsl): world position from its depth and the frame's inverse
// view-projection, normals from its normal buffer (turned to face the
// viewer), albedo as it is. One invocation per pixel.

struct DepthParams {
    inv_view_proj: mat4x4<f32>,
    position: vec4<f32>,   // xyz eye; w = 1 orthographic
    forward: vec4<f32>,    // xyz view direction
    size: vec2<u32>,
    far_depth: f32,        // the depth of "no surface" (0 reversed Z, 1 standard)
    normals: u32,          // 0: gibake's octahedral pair, 1: world xyz, 2: world xyz · 0.5 + 0.5
}

@group(0) @binding(0) var depth_tex: DEPTH_TEXTURE;
@group(0) @binding(1) var normal_tex: texture_2d<f32>;
@group(0) @binding(2) var albedo_tex: texture_2d<f32>;
@group(0) @binding(3) var<uniform> p: DepthParams;
@group(0) @binding(4) var out_position: texture_storage_2d<rgba32float, write>;
@group(0) @binding(5) var out_normals: texture_storage_2d<rgba16float, write>;
@group(0) @binding(6) var out_albedo: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (any(gid.xy >= p.size)) {
        return;
    }
    let px = vec2<i32>(gid.xy);
    let depth = DEPTH_LOAD;
    let albedo = textureLoad(albedo_tex, px, 0);
    if (depth == p.far_depth) {
        textureStore(out_position, px, vec4<f32>(0.0));
        textureStore(out_normals, px, vec4<f32>(0.0));
        textureStore(out_albedo, px, vec4<f32>(0.0));
        return;
    }
    // The pixel's centre in NDC (row 0 at the top), then the world point.
    let uv = (vec2<f32>(gid.xy) + vec2<f32>(0.5)) / vec2<f32>(p.size);
    let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let w = p.inv_view_proj * ndc;
    let x = w.xyz / w.w;
    let raw = textureLoad(normal_tex, px, 0);
    var normals = raw;
    if (p.normals != 0u) {
        var n = raw.xyz;
        if (p.normals == 2u) {
            n = n * 2.0 - 1.0;
        }
        n = normalize(n);
        var to_eye = p.position.xyz - x;
        if (p.position.w > 0.5) {
            to_eye = -p.forward.xyz;
        }
        if (dot(n, to_eye) < 0.0) {
            n = -n;
        }
        let e = oct_encode(n);
        normals = vec4<f32>(e, e);
    }
    textureStore(out_position, px, vec4<f32>(x, 1.0));
    textureStore(out_normals, px, normals);
    textureStore(out_albedo, px, vec4<f32>(albedo.rgb, 1.0));
}
