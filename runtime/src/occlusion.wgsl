// occlusion.wgsl — partial occlusion of static VPLs (needs common.wgsl,
// projection.wgsl, moving.wgsl). One invocation per RSM texel of the moving
// objects' windows: if a moving object is now
// nearer the light than the texel's static surface, the texel's share of its
// VPL's flux (fixed point, 2^24 = the whole VPL) is added to that VPL's
// occluded sum with an integer atomic: order-independent, so deterministic.

@group(0) @binding(0) var static_metric: texture_2d<f32>;
@group(0) @binding(1) var dyn_position: texture_2d<f32>;
@group(0) @binding(2) var<storage, read> texel_info: array<vec2<u32>>;   // (vpl, share)
@group(0) @binding(3) var<storage, read_write> occluded: array<atomic<u32>>;
@group(0) @binding(4) var<uniform> view: LightView;
// The windows this frame tests (`Windows` in dynamic_rsm.rs, must match
// `GpuOcclusionWindows`): the moving objects' footprint, one square or up
// to four disjoint ones (xy: first texel, z: side; `count.x` in use); no
// texel outside them has a moving surface. Invocation z tests window z.
struct OcclusionWindows {
    w: array<vec4<u32>, 4>,
    count: vec4<u32>,
}
@group(0) @binding(5) var<uniform> windows: OcclusionWindows;

const NONE: u32 = 0xffffffffu;
@compute @workgroup_size(8, 8)
fn cs_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = u32(view.params.x);
    if (gid.z >= min(windows.count.x, 4u)) {
        return;
    }
    let window = windows.w[gid.z];
    if (gid.x >= window.z || gid.y >= window.z) {
        return;
    }
    let t = gid.xy + window.xy;
    if (t.x >= size || t.y >= size) {
        return;
    }
    let info = texel_info[t.y * size + t.x];
    if (info.x == NONE) {
        return;
    }
    if (moving_in_front(vec2<i32>(t))) {
        atomicAdd(&occluded[info.x], info.y);
    }
}
