//! The second origin of a VPL's light below its horizon
//! (`gibake_bake::horizon`): on a roof round a hole it lies in the hole,
//! below the roof's top, and sees the room under it; a flat cluster has
//! none; on a convex corner it lies outside the solid, though the centroid
//! of the texels that send the light is inside; the same at every scene
//! scale. And a bake stores second origins and maps (format 4.7).

use gibake_bake::horizon::{MIN_BELOW_SHARE, below_share, lower_origin};
use gibake_bake::rsm::Rsm;
use gibake_gpu::LightView;
use gibake_raycast::RayScene;
use gibake_scene::{LoadOptions, Scene};
use gibake_scenegen::geom::{aabox, quad_facing};
use gibake_scenegen::gltf::Builder;
use glam::{DVec3, Vec3};

/// Loads what `b` built (a sun and a camera added).
fn load(mut b: Builder, name: &str) -> Scene {
    b.directional(
        "sun",
        DVec3::new(0.0, 50.0, 0.0),
        DVec3::new(0.3, -1.0, 0.2),
        [1.0; 3],
        3.0,
    );
    b.perspective(
        "camera",
        DVec3::new(2.0, 1.0, 2.0),
        DVec3::ZERO,
        1.2,
        0.01,
        100.0,
    );
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join(format!("{name}.glb"));
    std::fs::write(&path, b.finish()).expect("write the scene");
    gibake_scene::load(&path, &LoadOptions::default()).expect("load the scene")
}

/// A floor at y = 0 under a 0.4 m roof slab (y from 2 to 2.4) over
/// [−3, 3]² with a 0.4 m square hole at its centre, at scale `s`.
fn roof_with_hole(s: f64) -> Scene {
    let mut b = Builder::new(s, "none");
    let floor = quad_facing(
        DVec3::new(-3.0, 0.0, -3.0),
        DVec3::new(6.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 6.0),
        1,
        DVec3::Y,
    );
    b.static_mesh("floor", &floor, [0.5; 3]);
    let (h, lo, hi) = (0.2, 2.0, 2.4);
    for (k, (min, max)) in [
        ((-3.0, -3.0), (-h, 3.0)),
        ((h, -3.0), (3.0, 3.0)),
        ((-h, -3.0), (h, -h)),
        ((-h, h), (h, 3.0)),
    ]
    .into_iter()
    .enumerate()
    {
        let g = aabox(
            DVec3::new(min.0, lo, min.1),
            DVec3::new(max.0, hi, max.1),
            1,
            true,
        );
        b.static_mesh(&format!("roof{k}"), &g, [0.8; 3]);
    }
    load(b, "roof_with_hole")
}

/// An empty 64² RSM (its view is not used).
fn rsm() -> Rsm {
    let view = LightView::directional(Vec3::new(0.0, -1.0, 0.0), Vec3::splat(-1.0), Vec3::ONE, 64);
    Rsm::empty(64, view)
}

/// The whole of [`rsm`].
const ALL: (u32, u32, u32, u32) = (0, 64, 0, 64);

/// Lights texel `t` of `rsm` at `p` (normal `n`, flux `f`, area `a`).
fn lit(rsm: &mut Rsm, t: usize, p: Vec3, n: Vec3, f: f32, a: f32) {
    rsm.metric[t] = 1.0;
    rsm.position[t] = p;
    rsm.normal[t] = n;
    rsm.flux[t] = Vec3::splat(f);
    rsm.area[t] = a;
}

/// A cluster of the roof's top round the hole (48 × 48 texels of 2.5 cm
/// at y = 2.4, the hole left out) and, with `wall`, the lit wall of the
/// hole facing +x (x = −0.2, y from 2 to 2.4), at scale `s`; its mean
/// normal.
fn roof_cluster(s: f32, wall: bool) -> (Rsm, Vec3) {
    let mut r = rsm();
    let step = 0.025;
    let mut t = 0;
    let mut wn = Vec3::ZERO;
    for j in 0..48 {
        for i in 0..48 {
            let (x, z) = (
                -0.6 + step * (i as f32 + 0.5),
                -0.6 + step * (j as f32 + 0.5),
            );
            if x.abs() < 0.2 && z.abs() < 0.2 {
                continue;
            }
            lit(
                &mut r,
                t,
                Vec3::new(x, 2.4, z) * s,
                Vec3::Y,
                1.0,
                step * step * s * s,
            );
            wn += Vec3::Y;
            t += 1;
        }
    }
    if wall {
        for j in 0..16 {
            for i in 0..16 {
                let (y, z) = (
                    2.0 + step * (j as f32 + 0.5),
                    -0.2 + step * (i as f32 + 0.5),
                );
                lit(
                    &mut r,
                    t,
                    Vec3::new(-0.2, y, z) * s,
                    Vec3::X,
                    1.0,
                    step * step * s * s,
                );
                wn += Vec3::X;
                t += 1;
            }
        }
    }
    (r, wn.normalize())
}

#[test]
fn a_roofs_second_origin_lies_in_its_hole_and_sees_the_room() {
    for s in [1e-3f64, 1.0, 1e3] {
        let scene = roof_with_hole(s);
        let rays = RayScene::build(&scene, 0.0);
        let sf = s as f32;
        let (r, n) = roof_cluster(sf, true);
        let o = lower_origin(&rays, &r, ALL, n, |_| true).unwrap_or_else(|| {
            panic!("scale {s}: the roof and its hole's wall have a second origin")
        });
        let p = o / sf;
        assert!(
            p.x > -0.2 && p.x < 0.2 && p.z.abs() < 0.2 && p.y > 2.0 && p.y < 2.4,
            "scale {s}: the second origin {p} is not in the hole"
        );
        // The lift is one radius of the wall (0.23 m) but at most halfway
        // across the hole (0.2 m).
        assert!(
            p.x.abs() < 5e-3,
            "scale {s}: {p} is not halfway across the hole"
        );
        // It sees the floor under the hole, where the roof's map origin,
        // above the roof, sees the roof.
        let down = rays
            .intersect(rays.offset_point(o, -Vec3::Y), -Vec3::Y, f32::INFINITY)
            .expect("the floor");
        assert!(
            down.position.y.abs() < 1e-3 * sf,
            "scale {s}: {}",
            down.position
        );
        assert!(rays.visible(o, -n, Vec3::new(1.0, 0.0, 0.5) * sf, Vec3::Y));
    }
}

#[test]
fn a_flat_cluster_has_no_second_origin() {
    let scene = roof_with_hole(1.0);
    let rays = RayScene::build(&scene, 0.0);
    let (r, n) = roof_cluster(1.0, false);
    assert_eq!(n, Vec3::Y);
    assert_eq!(lower_origin(&rays, &r, ALL, n, |_| true), None);
    // Its texels send nothing below its horizon; a texel across it half.
    assert_eq!(below_share(Vec3::Y, n), 0.0);
    assert!((below_share(Vec3::X, n) - 0.5).abs() < 1e-12);
    const { assert!(MIN_BELOW_SHARE > 0.0) };
}

#[test]
fn a_convex_corners_second_origin_is_outside_the_solid() {
    let mut b = Builder::new(1.0, "none");
    b.static_mesh(
        "pillar",
        &aabox(DVec3::ZERO, DVec3::new(1.0, 2.0, 1.0), 1, false),
        [0.8; 3],
    );
    let scene = load(b, "pillar");
    let rays = RayScene::build(&scene, 0.0);
    // The pillar's +x and +z faces near their common edge (x = z = 1).
    let mut r = rsm();
    let mut t = 0;
    for j in 0..8 {
        for i in 0..8 {
            let (u, y) = (1.0 - 0.05 * (i as f32 + 0.5), 0.5 + 0.05 * j as f32);
            lit(&mut r, t, Vec3::new(1.0, y, u), Vec3::X, 1.0, 0.0025);
            lit(&mut r, t + 1, Vec3::new(u, y, 1.0), Vec3::Z, 1.0, 0.0025);
            t += 2;
        }
    }
    let n = Vec3::new(1.0, 0.0, 1.0).normalize();
    let o = lower_origin(&rays, &r, ALL, n, |_| true).expect("a second origin");
    // The texels' centroid (0.8, y, 0.8) is inside the pillar; the origin
    // is not.
    let inside = o.x < 1.0 && o.z < 1.0 && o.x > 0.0 && o.z > 0.0 && o.y > 0.0 && o.y < 2.0;
    assert!(!inside, "the second origin {o} is inside the pillar");
}
