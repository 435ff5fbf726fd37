//! The reach probe's aimed rays (`gibake_bake::reach`, "Aimed rays"): a VPL
//! on open ground far from a small object is kept although the uniform
//! probe's directions all miss the object, at every scene scale; a VPL
//! facing away from everything is still found blind; the targets are each
//! mesh's box centre and half-way corners.

use gibake_bake::reach::{PROBE_SIZE, Reach, aim_targets};
use gibake_gpu::hemisphere;
use gibake_raycast::RayScene;
use gibake_scene::{Aabb, LoadOptions, Scene};
use gibake_scenegen::geom::{aabox, quad_facing};
use gibake_scenegen::gltf::Builder;
use glam::{DVec3, Vec3};

/// A 400 m × 400 m ground at y = 0 and a 1 m cube standing at the origin,
/// under a sun, at scene scale `s`.
fn ground_and_cube(s: f64) -> Scene {
    let mut b = Builder::new(s, "none");
    let g = quad_facing(
        DVec3::new(-200.0, 0.0, -200.0),
        DVec3::new(400.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 400.0),
        1,
        DVec3::Y,
    );
    b.static_mesh("ground", &g, [0.5; 3]);
    let cube = aabox(
        DVec3::new(-0.5, 0.0, -0.5),
        DVec3::new(0.5, 1.0, 0.5),
        1,
        false,
    );
    b.static_mesh("cube", &cube, [0.5; 3]);
    b.directional(
        "sun",
        DVec3::new(0.0, 50.0, 0.0),
        DVec3::new(0.3, -1.0, 0.2),
        [1.0; 3],
        1000.0,
    );
    b.perspective(
        "camera",
        DVec3::new(0.0, 20.0, 60.0),
        DVec3::ZERO,
        0.8,
        0.1,
        1000.0,
    );
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join("ground_and_cube.glb");
    std::fs::write(&path, b.finish()).expect("write the scene");
    gibake_scene::load(&path, &LoadOptions::default()).expect("load the scene")
}

/// Whether the uniform probe alone (the map projection's `PROBE_SIZE²`
/// directions from `origin`, offset as `sees_anything` does) meets anything.
fn uniform_probe_hits(rays: &RayScene<'_>, origin: Vec3, n: Vec3) -> bool {
    let o = rays.offset_point(origin, n);
    (0..PROBE_SIZE * PROBE_SIZE).any(|k| {
        let d = hemisphere::texel_direction(n, k % PROBE_SIZE, k / PROBE_SIZE, PROBE_SIZE);
        rays.occluded(o, d, f32::INFINITY)
    })
}

#[test]
fn a_vpl_on_far_ground_sees_a_small_object_by_its_aimed_rays() {
    for s in [1e-3, 1.0, 1e3] {
        let scene = ground_and_cube(s);
        let rays = RayScene::build(&scene, 0.0);
        let reach = Reach::new(&rays, Aabb::EMPTY);
        let sf = s as f32;
        // 60 m from the cube, one centimetre above the ground: the cube is
        // under a degree above its horizon.
        let origin = Vec3::new(60.0, 0.01, 5.0) * sf;
        assert!(
            !uniform_probe_hits(&rays, origin, Vec3::Y),
            "scale {s}: the uniform probe already sees the cube (the test's premise)"
        );
        assert!(
            reach.sees_anything(origin, Vec3::Y),
            "scale {s}: the aimed rays miss the cube 60 m away"
        );
        // Under the ground, facing down: nothing in front, dropped.
        let below = Vec3::new(60.0, -0.01, 5.0) * sf;
        assert!(
            !reach.sees_anything(below, Vec3::NEG_Y),
            "scale {s}: a VPL facing away from everything is not blind"
        );
    }
}

#[test]
fn aimed_targets_are_each_box_centre_and_its_corners_half_way_in() {
    let scene = ground_and_cube(1.0);
    let rays = RayScene::build(&scene, 0.0);
    let t = aim_targets(&rays, Aabb::EMPTY);
    assert_eq!(t.len(), 18, "two meshes, nine points each");
    let cube: Vec<Vec3> = t[9..].to_vec();
    assert!(
        (cube[0] - Vec3::new(0.0, 0.5, 0.0)).length() < 1e-5,
        "{:?}",
        cube[0]
    );
    for p in &cube[1..] {
        let d = (*p - cube[0]).abs();
        assert!((d - Vec3::splat(0.25)).abs().max_element() < 1e-5, "{p:?}");
    }
    let moving = Aabb {
        min: Vec3::new(10.0, 0.0, 10.0),
        max: Vec3::new(12.0, 2.0, 12.0),
    };
    let t = aim_targets(&rays, moving);
    assert_eq!(t.len(), 27, "and the moving objects' swept box");
    assert!((t[18] - Vec3::new(11.0, 1.0, 11.0)).length() < 1e-5);
}
