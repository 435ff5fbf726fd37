//! The VPL hemisphere-map projection: CPU twin of `wgsl/hemisphere.wgsl`
//! (hemi-octahedral mapping around the VPL normal, distance maps). The bake
//! ray-casts one ray per texel through [`texel_direction`]; the runtime
//! rasterizes moving objects with the WGSL version of [`encode`].

use glam::{Vec2, Vec3};

use crate::orthonormal_basis;

/// Fraction of the VPL's disk radius by which its origin sits off its
/// surface (must match `VPL_ORIGIN_OFFSET` in hemisphere.wgsl).
pub const VPL_ORIGIN_OFFSET: f32 = 0.2;

/// Direction in the VPL frame (z along the normal) → `[−1, 1]²`.
pub fn encode(d_local: Vec3) -> Vec2 {
    let z = d_local.z.max(0.0);
    let p = Vec2::new(d_local.x, d_local.y) / (d_local.x.abs() + d_local.y.abs() + z);
    Vec2::new(p.x + p.y, p.x - p.y)
}

/// `[−1, 1]²` → unit direction in the VPL frame (z ≥ 0).
pub fn decode(e: Vec2) -> Vec3 {
    let p = Vec2::new(e.x + e.y, e.x - e.y) * 0.5;
    Vec3::new(p.x, p.y, 1.0 - p.x.abs() - p.y.abs()).normalize()
}

/// World → VPL frame.
pub fn to_local(n: Vec3, d: Vec3) -> Vec3 {
    let (t, b) = orthonormal_basis(n);
    Vec3::new(d.dot(t), d.dot(b), d.dot(n))
}

/// VPL frame → world.
pub fn to_world(n: Vec3, l: Vec3) -> Vec3 {
    let (t, b) = orthonormal_basis(n);
    t * l.x + b * l.y + n * l.z
}

/// Where a VPL's map is centred (see the WGSL docs).
pub fn vpl_origin(position: Vec3, normal: Vec3, area: f32) -> Vec3 {
    position + normal * (VPL_ORIGIN_OFFSET * (area.max(0.0) / std::f32::consts::PI).sqrt())
}

/// Where the map of VPL record `v` is centred: [`vpl_origin`] lifted by
/// its own disk's radius, or by one texel's for a VPL on a light's outer
/// rings (`ring`, [`gibake_asset::Manifest::ring_vpls`];
/// [`gibake_asset::VplRecord::map_origin_area`]). The one rule the bake's
/// maps, the runtime and the CPU twin share.
pub fn record_origin(v: &gibake_asset::VplRecord, ring: bool) -> Vec3 {
    vpl_origin(
        Vec3::from_array(v.position),
        Vec3::from_array(v.normal),
        v.map_origin_area(ring),
    )
}

/// World direction through the centre of texel `(x, y)` of a `size²` map
/// around normal `n`.
pub fn texel_direction(n: Vec3, x: u32, y: u32, size: u32) -> Vec3 {
    let e = Vec2::new(
        (x as f32 + 0.5) / size as f32,
        (y as f32 + 0.5) / size as f32,
    ) * 2.0
        - Vec2::ONE;
    to_world(n, decode(e)).normalize()
}

/// Continuous texel coordinates of world direction `d` (CPU twin of
/// `hemi_texel_coords`).
pub fn texel_coords(n: Vec3, d: Vec3, size: u32) -> Vec2 {
    (encode(to_local(n, d)) * 0.5 + Vec2::splat(0.5)) * size as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_decode_round_trip_over_the_hemisphere() {
        for i in 0..64 {
            for j in 0..64 {
                let e = Vec2::new(i as f32 / 63.0, j as f32 / 63.0) * 2.0 - Vec2::ONE;
                let d = decode(e);
                assert!(d.z >= -1e-6 && (d.length() - 1.0).abs() < 1e-5);
                let e2 = encode(d);
                assert!((e - e2).length() < 1e-4, "{e} {e2}");
            }
        }
    }

    #[test]
    fn texel_direction_lands_in_its_texel() {
        for n in [Vec3::Y, -Vec3::Z, Vec3::new(0.3, -0.2, 0.9).normalize()] {
            for (x, y) in [(0, 0), (17, 100), (127, 127), (64, 3)] {
                let d = texel_direction(n, x, y, 128);
                assert!(d.dot(n) >= 0.0);
                let c = texel_coords(n, d, 128);
                assert!(
                    (c - Vec2::new(x as f32 + 0.5, y as f32 + 0.5)).length() < 1e-2,
                    "{c}"
                );
            }
        }
    }
}
