//! A ray direction with a −0.0 component (a sun travelling along
//! (−1, −1, −0)/√2, as a glTF node rotation gives) hits what the same
//! direction with +0.0 hits.

use gibake_raycast::RayScene;
use gibake_scene::{Animator, Light, LightKind, Material, Mesh, Scene};
use glam::Vec3;

#[test]
fn negative_zero_direction_components_hit() {
    let floor = Mesh {
        name: "floor".into(),
        positions: vec![
            Vec3::new(-3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, 3.0),
            Vec3::new(3.0, 0.0, -3.0),
            Vec3::new(-3.0, 0.0, -3.0),
        ],
        normals: vec![Vec3::Y; 4],
        uvs: None,
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    };
    let scene = Scene {
        source: "negative zero".into(),
        lights: vec![Light {
            name: "sun".into(),
            kind: LightKind::Directional,
            color: Vec3::ONE,
            position: Vec3::ZERO,
            direction: Vec3::NEG_Y,
            range: None,
        }],
        camera: None,
        materials: vec![Material::opaque("grey", Vec3::splat(0.5), None)],
        textures: vec![],
        static_meshes: vec![floor],
        dynamic_meshes: vec![],
        dynamic_objects: vec![],
        animator: Animator::default(),
        warnings: vec![],
        bake_volume: None,
    };
    let rays = RayScene::build(&scene, 0.0);
    let o = Vec3::new(3.1, 2.0, 2.2);
    for z in [0.0f32, -0.0] {
        let s = std::f32::consts::FRAC_1_SQRT_2;
        let d = Vec3::new(-s, -s, z);
        let hit = rays.intersect(o, d, f32::INFINITY);
        let p = hit
            .unwrap_or_else(|| panic!("direction {d:?} misses the floor"))
            .position;
        assert!((p - Vec3::new(1.1, 0.0, 2.2)).length() < 1e-5, "{p}");
        assert!(rays.occluded(o, d, f32::INFINITY), "{d:?}");
    }
}
