// other_lights.wgsl — the lights after the first, for shade.wgsl (needs
// light.wgsl, projection.wgsl): their records, their views and shadow maps
// (other_lights.rs uploads them), and the visibility of one of them. A
// scene with one light uses other_lights_none.wgsl instead: no binding.

struct OtherLight {       // GpuOtherLight in other_lights.rs
    light: PrimaryLight,
    views: vec4<u32>,     // x first view in other_views, y view count (6: cube faces)
}

struct OtherView {        // GpuOtherView in other_lights.rs
    view: LightView,
    tile: vec4<i32>,      // xy the static map's origin in light_maps (−1: none);
                          // zw the moving objects' map's in light_moving (−1: none)
}

@group(1) @binding(21) var<storage, read> other_lights: array<OtherLight>;
@group(1) @binding(22) var<storage, read> other_views: array<OtherView>;
@group(1) @binding(23) var light_maps: texture_2d<f32>;
@group(1) @binding(24) var light_moving: texture_2d<f32>;

// Light k after the first.
fn other_light(k: u32) -> PrimaryLight {
    return other_lights[k].light;
}

// Visibility of light k after the first: its one view, or for a point
// light the cube face of the receiver's direction (the face of the largest
// absolute component, +X, −X, +Y, −Y, +Z, −Z as baked); the static map,
// merged (z-min) with the moving objects' map when they touch the view
// this frame. A view with neither holds no surface: nothing shadows there.
fn other_visibility(k: u32, p: vec3<f32>, ng: vec3<f32>, wi: vec3<f32>) -> f32 {
    let l = other_lights[k];
    var face = 0u;
    if (l.views.y == 6u) {
        let d = p - l.light.position.xyz;
        let a = abs(d);
        if (a.x >= a.y && a.x >= a.z) {
            face = select(1u, 0u, d.x >= 0.0);
        } else if (a.y >= a.z) {
            face = select(3u, 2u, d.y >= 0.0);
        } else {
            face = select(5u, 4u, d.z >= 0.0);
        }
    }
    let v = other_views[l.views.x + face];
    let stored = v.tile.x >= 0;
    let moving = v.tile.z >= 0;
    if (stored) {
        return lv_visibility(v.view, light_maps, light_moving, moving, v.tile, p, ng, wi);
    }
    if (moving) {
        return lv_visibility(v.view, light_moving, light_moving, false, v.tile.zwzw, p, ng, wi);
    }
    return 1.0;
}

// Light culling (FLAG_CULL_LIGHTS, planned where some light after the
// first has a range or is a spot): shading's 8×8 workgroup is a tile (8×8
// neighbouring pixels; at interleave N, 8×8 pixels N apart: shade.rs,
// workgroups()). Its invocations take the box of the tile's surface points
// (ordered-bits atomics), then test each light against it (may_reach): a light whose
// range ends before the box — its window saturate(1 − (d/range)⁴) is 0 at
// every pixel of the tile — or a spot whose cone misses it is left out of
// the tile's mask. Exact: a culled light adds exactly 0 there. Lights past
// CULL_WORDS · 32 are not culled (always shaded).
const CULL_WORDS: u32 = 64u;
// Relative margin on the range: a point this little beyond it is still
// outside it after the f32 rounding of its distance.
const CULL_RANGE_MARGIN: f32 = 1.0e-4;
// Angular margin (radians) on a spot's cone, against the f32 rounding of
// the receiver's direction.
const CULL_CONE_MARGIN: f32 = 1.0e-3;

var<workgroup> cull_lo: array<atomic<u32>, 3>;
var<workgroup> cull_hi: array<atomic<u32>, 3>;
var<workgroup> cull_mask: array<atomic<u32>, CULL_WORDS>;

// f32 → u32 with the same order (negatives flipped), and back.
fn order_bits(f: f32) -> u32 {
    let b = bitcast<u32>(f);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

fn unorder_bits(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u & 0x7fffffffu, (u & 0x80000000u) != 0u));
}

// Whether light l may light a point of the box [lo, hi]: false only where
// its light is exactly 0 on the whole box — beyond its range (the box's
// nearest point farther than it), or, for a spot, outside its outer cone
// (the box's bounding sphere, seen from the light, wholly outside the cone
// widened by CULL_CONE_MARGIN; a spot's falloff saturate(cd·scale +
// offset)² is 0 wherever cd ≤ cos(outer) = −offset/scale).
fn may_reach(l: PrimaryLight, lo: vec3<f32>, hi: vec3<f32>) -> bool {
    if (l.position.w > 0.5) {
        return true;
    }
    let range = l.spot.z;
    if (range > 0.0) {
        let d = max(max(lo - l.position.xyz, l.position.xyz - hi), vec3<f32>(0.0));
        let r = range * (1.0 + CULL_RANGE_MARGIN);
        if (dot(d, d) >= r * r) {
            return false;
        }
    }
    if (l.spot.x > 0.0) {
        let outer = acos(clamp(-l.spot.y / l.spot.x, -1.0, 1.0));
        let v = 0.5 * (lo + hi) - l.position.xyz;
        let dist = length(v);
        let radius = 0.5 * length(hi - lo);
        if (dist > radius) {
            let edge = outer + asin(radius / dist) + CULL_CONE_MARGIN;
            if (edge < 3.14159 && dot(l.direction.xyz, v) < dist * cos(edge)) {
                return false;
            }
        }
    }
    return true;
}

// The tile's mask of lights. Every invocation of the workgroup calls it
// (it has barriers): `lid` its local index, `surface` whether its pixel
// holds a surface at x.
fn cull_other_lights(lid: u32, surface: bool, x: vec3<f32>) {
    if (lid < 3u) {
        atomicStore(&cull_lo[lid], 0xffffffffu);
        atomicStore(&cull_hi[lid], 0u);
    }
    for (var w = lid; w < CULL_WORDS; w += 64u) {
        atomicStore(&cull_mask[w], 0u);
    }
    workgroupBarrier();
    if (surface) {
        for (var a = 0u; a < 3u; a++) {
            atomicMin(&cull_lo[a], order_bits(x[a]));
            atomicMax(&cull_hi[a], order_bits(x[a]));
        }
    }
    workgroupBarrier();
    if (atomicLoad(&cull_lo[0]) != 0xffffffffu) {
        let lo = vec3<f32>(unorder_bits(atomicLoad(&cull_lo[0])), unorder_bits(atomicLoad(&cull_lo[1])), unorder_bits(atomicLoad(&cull_lo[2])));
        let hi = vec3<f32>(unorder_bits(atomicLoad(&cull_hi[0])), unorder_bits(atomicLoad(&cull_hi[1])), unorder_bits(atomicLoad(&cull_hi[2])));
        let n = min(params.n_other_lights, CULL_WORDS * 32u);
        for (var k = lid; k < n; k += 64u) {
            if (may_reach(other_lights[k].light, lo, hi)) {
                atomicOr(&cull_mask[k / 32u], 1u << (k % 32u));
            }
        }
    }
    workgroupBarrier();
}

// Direct light of every light after the first at p: with culling, the
// tile's mask in light order (then the lights past the mask), else all.
fn other_lights_radiance(p: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    var r = vec3<f32>(0.0);
    let n = params.n_other_lights;
    var first_unculled = 0u;
    if (has(FLAG_CULL_LIGHTS)) {
        first_unculled = min(n, CULL_WORDS * 32u);
        for (var w = 0u; w * 32u < first_unculled; w++) {
            var bits = atomicLoad(&cull_mask[w]);
            while (bits != 0u) {
                let k = w * 32u + firstTrailingBit(bits);
                bits &= bits - 1u;
                r += light_radiance(other_light(k), k, p, ns, ng, albedo);
            }
        }
    }
    for (var k = first_unculled; k < n; k++) {
        r += light_radiance(other_light(k), k, p, ns, ng, albedo);
    }
    return r;
}
