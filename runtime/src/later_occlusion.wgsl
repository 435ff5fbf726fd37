// later_occlusion.wgsl — the later bounces' VPLs (format 4.6: the last
// static VPLs, i >= first_later) under moving objects that block the
// lights. After the frame's occlusion passes have summed, per first-bounce
// VPL, the share of its flux the moving objects take off (occlusion.wgsl),
// one workgroup takes the flux-weighted mean of those shares and gives it
// to every later VPL: the later bounces pass on the first bounce's light,
// so they lose what it loses (first order: where it is lost does not move
// the later light; docs/method.md, "Moving objects and the later
// bounces"). Fixed order sums (strided, then a tree): deterministic.

struct LaterParams {      // GpuLaterParams in later_occlusion.rs
    first_later: u32,     // the first later VPL; the first bounce's before it
    n_static: u32,        // every static VPL
    _p0: u32,
    _p1: u32,
}

@group(0) @binding(0) var<storage, read> weight: array<f32>;   // per first-bounce VPL: its flux's luminance
@group(0) @binding(1) var<storage, read_write> occluded: array<atomic<u32>>;
@group(0) @binding(2) var<uniform> params: LaterParams;

const ONE: f32 = 16777216.0;   // 2^24: fixed-point 1.0 of occlusion sums
const SIZE: u32 = 256u;
var<workgroup> sums: array<vec2<f32>, 256>;

@compute @workgroup_size(256)
fn cs_main(@builtin(local_invocation_index) lid: u32) {
    var s = vec2<f32>(0.0);
    for (var i = lid; i < params.first_later; i += SIZE) {
        let w = weight[i];
        let o = min(f32(atomicLoad(&occluded[i])) / ONE, 1.0);
        s += vec2<f32>(w * o, w);
    }
    sums[lid] = s;
    workgroupBarrier();
    for (var half = SIZE / 2u; half > 0u; half = half / 2u) {
        if (lid < half) {
            sums[lid] += sums[lid + half];
        }
        workgroupBarrier();
    }
    let total = sums[0];
    var share = 0.0;
    if (total.y > 0.0) {
        share = clamp(total.x / total.y, 0.0, 1.0);
    }
    let v = u32(round(share * ONE));
    for (var j = params.first_later + lid; j < params.n_static; j += SIZE) {
        atomicStore(&occluded[j], v);
    }
}
