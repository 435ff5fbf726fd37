//! Hemisphere shadow maps of static VPLs, by ray casting one ray per texel
//! against the static geometry's BVH (exact for any triangle size — no
//! projection bends an edge — bit-identical on every machine, and
//! logarithmic in scene size). The projection is the hemi-octahedral map of
//! `gibake_gpu::hemisphere`, which the runtime's WGSL shares.

use gibake_asset::VplRecord;
use gibake_gpu::hemisphere;
use gibake_raycast::RayScene;
use glam::Vec3;
use rayon::prelude::*;

/// The map of every VPL of `vpls`, in order (`size²` distances each, +inf
/// = no surface): `None` for a map that sees no surface (it is not stored;
/// [`gibake_asset::assign_map_tiles`] gives its VPL
/// [`NO_MAP`](gibake_asset::NO_MAP)). `ring[i]`: whether VPL `i` lies on an
/// outer ring (its map origin, [`hemisphere::record_origin`]). Each map
/// depends only on its own VPL and the static geometry, so any subset (a
/// shard) renders exactly the maps the whole bake renders. `progress` is
/// called once per finished VPL.
pub fn render_each_vpl_map(
    rays: &RayScene<'_>,
    vpls: &[VplRecord],
    ring: &[bool],
    size: u32,
    progress: &(dyn Fn() + Sync),
) -> Vec<Option<Vec<f32>>> {
    assert_eq!(vpls.len(), ring.len(), "one ring flag per VPL");
    let texels = (size * size) as usize;
    vpls.par_iter()
        .zip(ring)
        .map(|(v, &ring)| {
            let n = Vec3::from_array(v.normal);
            let origin = hemisphere::record_origin(v, ring);
            let origin = rays.offset_point(origin, n);
            let mut map = Vec::with_capacity(texels);
            let mut any = false;
            for y in 0..size {
                for x in 0..size {
                    let d = hemisphere::texel_direction(n, x, y, size);
                    let dist = match rays.intersect(origin, d, f32::INFINITY) {
                        Some(h) => {
                            any = true;
                            (h.position - origin).length()
                        }
                        None => f32::INFINITY,
                    };
                    map.push(dist);
                }
            }
            progress();
            any.then_some(map)
        })
        .collect()
}
