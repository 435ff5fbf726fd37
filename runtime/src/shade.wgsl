// shade.wgsl — deferred shading (needs common.wgsl, light.wgsl, projection.wgsl).
// One invocation per pixel: direct light from the primary light with the
// merged shadow map. Accumulates in f32, writes linear radiance.

struct ShadeParams {
    size: vec2<u32>,
    flags: u32,      // bit 0: direct
    _pad: u32,
}

const FLAG_DIRECT: u32 = 1u;

@group(0) @binding(0) var g_position: texture_2d<f32>;
@group(0) @binding(1) var g_normals: texture_2d<f32>;
@group(0) @binding(2) var g_albedo: texture_2d<f32>;
@group(0) @binding(3) var shadow_map: texture_2d<f32>;
@group(0) @binding(4) var<uniform> light: PrimaryLight;
@group(0) @binding(5) var<uniform> light_view: LightView;
@group(0) @binding(6) var<uniform> params: ShadeParams;
@group(0) @binding(7) var out_radiance: texture_storage_2d<rgba32float, write>;

fn direct_radiance(p: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    let inc = light_incident(light, p);
    let cos_g = dot(ng, inc.wi);
    if (cos_g <= 0.0) {
        return vec3<f32>(0.0);
    }
    let cos_s = max(dot(ns, inc.wi), 0.0);
    if (cos_s <= 0.0 || all(inc.irradiance == vec3<f32>(0.0))) {
        return vec3<f32>(0.0);
    }
    let vis = lv_visibility(light_view, shadow_map, p, ng, inc.wi);
    return albedo * INV_PI * inc.irradiance * (cos_s * vis);
}

@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (any(gid.xy >= params.size)) {
        return;
    }
    let px = vec2<i32>(gid.xy);
    let pos = textureLoad(g_position, px, 0);
    var radiance = vec3<f32>(0.0);
    if (pos.w > 0.5) {
        let nn = textureLoad(g_normals, px, 0);
        let ns = oct_decode(nn.xy);
        let ng = oct_decode(nn.zw);
        let albedo = textureLoad(g_albedo, px, 0).rgb;
        if ((params.flags & FLAG_DIRECT) != 0u) {
            radiance += direct_radiance(pos.xyz, ns, ng, albedo);
        }
    }
    textureStore(out_radiance, px, vec4<f32>(finite_or_zero3(radiance), 1.0));
}
