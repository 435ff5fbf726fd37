// later_occlusion.wgsl — the later bounces' VPLs (format 4.6: the last
// static VPLs, i >= first_later) under moving objects that block the
// lights. After the frame's occlusion passes have summed, per first-bounce
// VPL, the share of its flux the moving objects take off (occlusion.wgsl),
// one workgroup takes the flux-weighted mean of those shares over the
// level, and over each source group (format 4.8: the first bounce's VPLs
// whose direct light the later VPLs' light came from) their mean weighted
// by the light each passes on, and gives every
// later VPL its groups' shares by its weights and the level's for the rest:
// the later bounces pass on the first bounce's light, so they lose what it
// loses where it went (docs/method.md, "Where the later light came from").
// Fixed order sums (strided, then a tree; each group by one thread in its
// members' order): deterministic.

struct LaterParams {      // GpuLaterParams in later_occlusion.rs
    first_later: u32,     // the first later VPL; the first bounce's before it
    n_static: u32,        // every static VPL
    groups: u32,          // source groups (0: the level's mean for all)
    _p0: u32,
}

struct Weighted {         // GpuWeighted in later_occlusion.rs: an index and its weight
    index: u32,
    weight: f32,
}

@group(0) @binding(0) var<storage, read> weight: array<f32>;   // per first-bounce VPL: its flux's luminance
@group(0) @binding(1) var<storage, read_write> occluded: array<atomic<u32>>;
@group(0) @binding(2) var<uniform> params: LaterParams;
// groups + 1 offsets into members (later_occlusion.rs group_members)
@group(0) @binding(3) var<storage, read> offsets: array<u32>;
// the first-bounce VPLs by group: index and weight in the group's mean
@group(0) @binding(4) var<storage, read> members: array<Weighted>;
// per later VPL, SOURCES of its groups (index) and weights
@group(0) @binding(5) var<storage, read> sources: array<Weighted>;

const ONE: f32 = 16777216.0;   // 2^24: fixed-point 1.0 of occlusion sums
const SIZE: u32 = 256u;        // also gibake_asset::MAX_SOURCE_GROUPS
const SOURCES: u32 = 8u;       // gibake_asset::SOURCES_PER_LATER_VPL
var<workgroup> sums: array<vec2<f32>, 256>;
var<workgroup> group_share: array<f32, 256>;

fn occluded_share(i: u32) -> f32 {
    return min(f32(atomicLoad(&occluded[i])) / ONE, 1.0);
}

@compute @workgroup_size(256)
fn cs_main(@builtin(local_invocation_index) lid: u32) {
    var s = vec2<f32>(0.0);
    for (var i = lid; i < params.first_later; i += SIZE) {
        let w = weight[i];
        s += vec2<f32>(w * occluded_share(i), w);
    }
    // Each source group's mean weighted by the light its VPLs pass on,
    // one thread a group.
    var g = vec2<f32>(0.0);
    if (lid < params.groups) {
        for (var k = offsets[lid]; k < offsets[lid + 1u]; k += 1u) {
            let m = members[k];
            if (m.index < params.first_later) {
                g += vec2<f32>(m.weight * occluded_share(m.index), m.weight);
            }
        }
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
    // A group without flux takes the level's share.
    group_share[lid] = share;
    if (g.y > 0.0) {
        group_share[lid] = clamp(g.x / g.y, 0.0, 1.0);
    }
    workgroupBarrier();
    for (var j = params.first_later + lid; j < params.n_static; j += SIZE) {
        var o = 0.0;
        var w = 0.0;
        if (params.groups > 0u) {
            let at = (j - params.first_later) * SOURCES;
            for (var k = 0u; k < SOURCES; k += 1u) {
                let src = sources[at + k];
                o += src.weight * group_share[min(src.index, SIZE - 1u)];
                w += src.weight;
            }
        }
        o += max(1.0 - w, 0.0) * share;
        atomicStore(&occluded[j], u32(round(clamp(o, 0.0, 1.0) * ONE)));
    }
}
