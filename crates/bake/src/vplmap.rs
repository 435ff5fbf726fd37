//! Hemisphere shadow maps of static VPLs, by ray casting one ray per texel
//! against the static geometry's BVH (exact for any triangle size — no
//! projection bends an edge — bit-identical on every machine, and
//! logarithmic in scene size). The projection is the hemi-octahedral map of
//! `gibake_gpu::hemisphere`, which the runtime's WGSL shares. A VPL with a
//! second origin for the light below its horizon ([`crate::horizon`]) also
//! gets a second map, around the opposite of its normal from that origin
//! ([`render_each_lower_map`]).

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
    vpls.par_iter()
        .zip(ring)
        .map(|(v, &ring)| {
            let n = Vec3::from_array(v.normal);
            let origin = hemisphere::record_origin(v, ring);
            let map = render_map(rays, rays.offset_point(origin, n), n, size);
            progress();
            map
        })
        .collect()
}

/// The second map of every VPL of `vpls` that has a second origin
/// (`lower[i]`, [`crate::horizon::lower_origin`]), in order: `size²`
/// distances from that origin around `−normal` (+inf = no surface), by one
/// ray per texel as [`render_each_vpl_map`]; `None` for a VPL without a
/// second origin, or whose second map sees no surface (not stored: every
/// direction open). `progress` is called once per VPL.
pub fn render_each_lower_map(
    rays: &RayScene<'_>,
    vpls: &[VplRecord],
    lower: &[Option<Vec3>],
    size: u32,
    progress: &(dyn Fn() + Sync),
) -> Vec<Option<Vec<f32>>> {
    assert_eq!(
        vpls.len(),
        lower.len(),
        "one second origin (or none) per VPL"
    );
    vpls.par_iter()
        .zip(lower)
        .map(|(v, o)| {
            let map = o.and_then(|o| {
                let n = -Vec3::from_array(v.normal);
                render_map(rays, rays.offset_point(o, n), n, size)
            });
            progress();
            map
        })
        .collect()
}

/// One `size²` map from `origin` around unit `n`; `None` when it sees no
/// surface.
fn render_map(rays: &RayScene<'_>, origin: Vec3, n: Vec3, size: u32) -> Option<Vec<f32>> {
    let mut map = Vec::with_capacity((size * size) as usize);
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
    any.then_some(map)
}
