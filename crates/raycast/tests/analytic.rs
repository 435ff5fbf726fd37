//! Analytic checks of the ray caster, independent of any renderer: hits on a
//! tilted triangle against the closed-form ray/plane intersection, the
//! barycentric reconstruction, normal orientation, misses outside the
//! triangle, any-hit/closest-hit agreement, and exact scale invariance under
//! a power-of-two change of unit.

use gibake_raycast::RayScene;
use gibake_scene::{Animator, Light, LightKind, Material, Mesh, Scene};
use glam::Vec3;

const A: Vec3 = Vec3::new(-1.0, 0.2, -0.5);
const B: Vec3 = Vec3::new(1.5, -0.3, 0.1);
const C: Vec3 = Vec3::new(0.1, 1.7, 0.4);

/// One triangle `a, b, c` (no vertex normals, so the shading normal falls
/// back to the geometric one), albedo 0.5, times `s`.
fn triangle_scene(s: f32) -> Scene {
    Scene {
        source: "analytic".into(),
        lights: vec![Light {
            name: "sun".into(),
            kind: LightKind::Directional,
            color: Vec3::ONE,
            position: Vec3::ZERO,
            direction: Vec3::NEG_Z,
            range: None,
        }],
        camera: None,
        materials: vec![Material::opaque("grey", Vec3::splat(0.5), None)],
        textures: vec![],
        static_meshes: vec![Mesh {
            name: "tri".into(),
            positions: vec![A * s, B * s, C * s],
            normals: vec![],
            uvs: None,
            indices: vec![0, 1, 2],
            material: 0,
        }],
        dynamic_meshes: vec![],
        dynamic_objects: vec![],
        animator: Animator::default(),
        warnings: vec![],
        bake_volume: None,
    }
}

/// Closed-form ray/plane distance in f64: `t = n·(a − o) / n·d`.
fn plane_t(o: Vec3, d: Vec3) -> f64 {
    let (a, b, c) = (A.as_dvec3(), B.as_dvec3(), C.as_dvec3());
    let n = (b - a).cross(c - a);
    n.dot(a - o.as_dvec3()) / n.dot(d.as_dvec3())
}

/// Rays from a fixed eye through a grid of points of the triangle's plane,
/// given by barycentrics `(u, v, 1 − u − v)` (some outside the triangle).
fn grid() -> Vec<(Vec3, Vec3, bool)> {
    let eye = Vec3::new(0.3, 0.4, 3.0);
    let mut out = Vec::new();
    for i in 0..=20 {
        for j in 0..=20 {
            let (u, v) = (i as f64 / 16.0 - 0.1, j as f64 / 16.0 - 0.1);
            let w = 1.0 - u - v;
            let p = A.as_dvec3() * w + B.as_dvec3() * u + C.as_dvec3() * v;
            // Keep clear of the edges, where either answer is right.
            let margin = u.min(v).min(w);
            if margin.abs() < 1e-3 {
                continue;
            }
            let d = (p - eye.as_dvec3()).normalize().as_vec3();
            out.push((eye, d, margin > 0.0));
        }
    }
    out
}

#[test]
fn hits_match_the_closed_form_plane_intersection() {
    let scene = triangle_scene(1.0);
    let rs = RayScene::build(&scene, 0.0);
    assert_eq!(rs.triangle_count(), 1);
    let n = (B - A).cross(C - A).normalize();
    let (mut hits, mut misses) = (0, 0);
    for (o, d, inside) in grid() {
        let hit = rs.intersect(o, d, f32::INFINITY);
        assert_eq!(hit.is_some(), inside, "ray {o} → {d}");
        assert_eq!(rs.occluded(o, d, f32::INFINITY), inside);
        let Some(h) = hit else {
            misses += 1;
            continue;
        };
        hits += 1;
        let t = plane_t(o, d);
        assert!((h.t as f64 - t).abs() < 1e-5 * t, "t {} vs {t}", h.t);
        // The position is rebuilt from the barycentrics and lies on the ray.
        let b = h.barycentrics;
        assert!((b.x + b.y + b.z - 1.0).abs() < 1e-5 && b.min_element() >= 0.0);
        let p = A * b.x + B * b.y + C * b.z;
        assert!((p - h.position).length() < 1e-5);
        let on_ray = o.as_dvec3() + d.as_dvec3() * t;
        assert!((on_ray - h.position.as_dvec3()).length() < 1e-5);
        // Both normals are the unit plane normal, turned toward the eye.
        let expect = if n.dot(-d) > 0.0 { n } else { -n };
        assert!((h.geometric_normal - expect).length() < 1e-6);
        assert!((h.shading_normal - expect).length() < 1e-6);
        assert_eq!(h.albedo, Vec3::splat(0.5));
        assert_eq!((h.triangle, h.mesh), (0, 0));
        // Stopping just before the plane misses; the any-hit query agrees.
        assert!(rs.intersect(o, d, h.t * 0.999).is_none());
        assert!(!rs.occluded(o, d, h.t * 0.999));
        // An offset hit point lies on the eye's side and sees the eye.
        let off = rs.offset_point(h.position, h.geometric_normal);
        assert!((off - h.position).dot(expect) > 0.0);
        assert!(rs.visible(h.position, h.geometric_normal, o, Vec3::ZERO));
        assert!(rs.intersect(off, -d, f32::INFINITY).is_none());
    }
    assert!(hits > 100 && misses > 50, "{hits} hits, {misses} misses");
}

#[test]
fn power_of_two_scale_is_exact() {
    let base = triangle_scene(1.0);
    let base_rs = RayScene::build(&base, 0.0);
    for e in [-20, -3, 7, 30] {
        let s = 2f32.powi(e);
        let scene = triangle_scene(s);
        let rs = RayScene::build(&scene, 0.0);
        for (o, d, _) in grid() {
            let h0 = base_rs.intersect(o, d, f32::INFINITY);
            let h1 = rs.intersect(o * s, d, f32::INFINITY);
            match (h0, h1) {
                (None, None) => {}
                (Some(h0), Some(h1)) => {
                    assert_eq!(h1.t, h0.t * s, "scale 2^{e}");
                    assert_eq!(h1.position, h0.position * s);
                    assert_eq!(h1.barycentrics, h0.barycentrics);
                    assert_eq!(h1.geometric_normal, h0.geometric_normal);
                    let off0 = base_rs.offset_point(h0.position, h0.geometric_normal);
                    let off1 = rs.offset_point(h1.position, h1.geometric_normal);
                    assert_eq!(off1, off0 * s);
                }
                (a, b) => panic!("scale 2^{e}: {a:?} vs {b:?}"),
            }
        }
        assert_eq!(rs.end_margin(C * s), base_rs.end_margin(C) * s);
    }
}

#[test]
fn bad_rays_and_empty_scenes_never_hit() {
    let scene = triangle_scene(1.0);
    let rs = RayScene::build(&scene, 0.0);
    let o = Vec3::new(0.3, 0.4, 3.0);
    assert!(rs.intersect(o, Vec3::ZERO, f32::INFINITY).is_none());
    assert!(rs.intersect(o, Vec3::NAN, f32::INFINITY).is_none());
    assert!(
        rs.intersect(Vec3::NAN, Vec3::NEG_Z, f32::INFINITY)
            .is_none()
    );
    assert!(!rs.occluded(o, Vec3::NEG_Z, f32::NAN));
    let mut empty = triangle_scene(1.0);
    empty.static_meshes[0].positions[2] = empty.static_meshes[0].positions[0];
    let rs = RayScene::build(&empty, 0.0);
    assert_eq!(rs.triangle_count(), 0);
    assert!(rs.intersect(o, Vec3::NEG_Z, f32::INFINITY).is_none());
}

/// Directions with exact zero components (an axis-aligned ray, a sun at
/// azimuth 0) hit like any other: the BVH's slab tests once turned `0 · ∞`
/// into NaN and rejected every box, so a sun at azimuth 0 lit nothing.
#[test]
fn directions_with_zero_components_hit() {
    let scene = triangle_scene(1.0);
    let rays = RayScene::build(&scene, 0.0);
    let centroid = (A + B + C) / 3.0;
    for d in [
        Vec3::new(0.0, -0.6, -0.8),
        Vec3::new(-0.6, 0.0, -0.8),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(-0.0, -0.0, -1.0),
        Vec3::new(-0.0, -0.6, -0.8),
    ] {
        let o = centroid - d * 4.0;
        let hit = rays.intersect(o, d, f32::INFINITY);
        assert!(hit.is_some(), "direction {d} from {o} missed the triangle");
        let t = plane_t(o, d);
        assert!((f64::from(hit.unwrap().t) - t).abs() < 1e-4 * t, "{d}");
        assert!(rays.occluded(o, d, f32::INFINITY), "{d}: any-hit missed");
    }
}

/// A triangle wound clockwise (its winding normal points away from its
/// vertex normals, as under a mirroring transform) keeps its shading normal
/// on the viewer's side: it shades like the counter-clockwise original.
#[test]
fn clockwise_winding_keeps_the_shading_normal_facing_the_viewer() {
    let n = (B - A).cross(C - A).normalize();
    let mut ccw_scene = triangle_scene(1.0);
    ccw_scene.static_meshes[0].normals = vec![n; 3];
    let mut cw_scene = ccw_scene.clone();
    cw_scene.static_meshes[0].indices = vec![0, 2, 1];
    let ccw = RayScene::build(&ccw_scene, 0.0);
    let cw = RayScene::build(&cw_scene, 0.0);
    let centroid = (A + B + C) / 3.0;
    for side in [1.0f32, -1.0] {
        let o = centroid + n * (2.0 * side);
        let d = (centroid - o).normalize();
        let h1 = ccw.intersect(o, d, f32::INFINITY).unwrap();
        let h2 = cw.intersect(o, d, f32::INFINITY).unwrap();
        for h in [h1, h2] {
            assert!(
                h.geometric_normal.dot(-d) > 0.0,
                "geometric normal faces the ray"
            );
            assert!(
                h.shading_normal.dot(-d) > 0.99,
                "shading normal {} faces the ray",
                h.shading_normal
            );
        }
    }
}
