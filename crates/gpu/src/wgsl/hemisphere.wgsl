// hemisphere.wgsl — the VPL hemisphere-map projection (needs common.wgsl).
// CPU twin: crates/gpu/src/hemisphere.rs (a test checks they agree).
//
// Hemi-octahedral mapping (Engelhardt & Dachsbacher 2008): a direction d in
// the VPL's frame (t, b, n), d.z = dot(d, n) ≥ 0, maps to the full square
//   p = d.xy / (|d.x| + |d.y| + d.z),  e = (p.x + p.y, p.x − p.y) ∈ [−1, 1]²,
// texel coordinates (e·0.5 + 0.5)·size (x right, y down). Maps store the
// Euclidean distance from the VPL origin to the nearest surface (+inf: none).
// The VPL origin is its position moved along its normal by
// VPL_ORIGIN_OFFSET × its disk radius sqrt(area/π): scale-invariant, and it
// lifts clusters on curved surfaces off the surface they sit on.

const VPL_ORIGIN_OFFSET: f32 = 0.2;

fn hemi_encode(d_local: vec3<f32>) -> vec2<f32> {
    let z = max(d_local.z, 0.0);
    let p = d_local.xy / (abs(d_local.x) + abs(d_local.y) + z);
    return vec2<f32>(p.x + p.y, p.x - p.y);
}

fn hemi_decode(e: vec2<f32>) -> vec3<f32> {
    let p = vec2<f32>(e.x + e.y, e.x - e.y) * 0.5;
    return normalize(vec3<f32>(p, 1.0 - abs(p.x) - abs(p.y)));
}

// Orthonormal basis around unit n (Duff et al. 2017); must match
// orthonormal_basis in light_view.rs.
fn basis_t(n: vec3<f32>) -> vec3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
}

fn basis_b(n: vec3<f32>) -> vec3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(b, s + n.y * n.y * a, -n.y);
}

fn to_local(n: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(d, basis_t(n)), dot(d, basis_b(n)), dot(d, n));
}

fn vpl_origin(position: vec3<f32>, normal: vec3<f32>, area: f32) -> vec3<f32> {
    return position + normal * (VPL_ORIGIN_OFFSET * sqrt(max(area, 0.0) * INV_PI));
}

// Continuous texel coordinates of world direction d from a VPL with normal n.
fn hemi_texel_coords(n: vec3<f32>, d: vec3<f32>, size: f32) -> vec2<f32> {
    return (hemi_encode(to_local(n, d)) * 0.5 + 0.5) * size;
}
