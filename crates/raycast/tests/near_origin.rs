//! A ray that starts a hair's breadth from a surface and points at it hits
//! it, and a shadow ray there is occluded: obvhs 0.4 starts every box test
//! at 10⁻⁴ of the normalised scene, whatever the ray's `t_min`, and the ray
//! caster runs its traversal from behind the origin (`PULL_BACK`). Until
//! then, a bounce from beside a wall and a surfel's side test passed
//! through the wall (a white closed box leaked 5·10⁻⁵ of its light a
//! bounce; docs/reference.md, "Limitations").

use gibake_raycast::RayScene;
use gibake_scene::{Animator, Light, LightKind, Material, Mesh, Scene};
use glam::Vec3;

fn wall_scene(s: f32) -> Scene {
    // A wall x = 0 over y, z ∈ [−1, 1] · s, and a far floor so the scene
    // is large (the wall a small part of it).
    let quad = |name: &str, p: [Vec3; 4], n: Vec3| Mesh {
        name: name.into(),
        positions: p.to_vec(),
        normals: vec![n; 4],
        uvs: None,
        indices: vec![0, 1, 2, 0, 2, 3],
        material: 0,
    };
    let wall = quad(
        "wall",
        [
            Vec3::new(0.0, -1.0, -1.0) * s,
            Vec3::new(0.0, 1.0, -1.0) * s,
            Vec3::new(0.0, 1.0, 1.0) * s,
            Vec3::new(0.0, -1.0, 1.0) * s,
        ],
        Vec3::X,
    );
    let floor = quad(
        "floor",
        [
            Vec3::new(-50.0, -5.0, -50.0) * s,
            Vec3::new(-50.0, -5.0, 50.0) * s,
            Vec3::new(50.0, -5.0, 50.0) * s,
            Vec3::new(50.0, -5.0, -50.0) * s,
        ],
        Vec3::Y,
    );
    Scene {
        source: "near origin".into(),
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
        static_meshes: vec![wall, floor],
        dynamic_meshes: vec![],
        dynamic_objects: vec![],
        animator: Animator::default(),
        warnings: vec![],
        bake_volume: None,
    }
}

#[test]
fn a_ray_from_just_beside_a_surface_hits_it() {
    for s in [1e-3f32, 1.0, 1e3] {
        let scene = wall_scene(s);
        let rays = RayScene::build(&scene, 0.0);
        // 10⁻⁶ of the scene's size (about 140 s) off the wall: far below
        // obvhs' epsilon, far above the ray offsets' ULPs.
        for gap in [1e-6f32, 1e-5, 5e-5] {
            let o = Vec3::new(gap * 140.0 * s, 0.1 * s, 0.2 * s);
            for d in [Vec3::NEG_X, Vec3::new(-1.0, 0.3, 0.2).normalize()] {
                let h = rays
                    .intersect(o, d, f32::INFINITY)
                    .unwrap_or_else(|| panic!("×{s}, gap {gap}: {d} from {o} misses the wall"));
                assert!(
                    h.position.x.abs() <= 1e-5 * s,
                    "×{s}: hit at {}",
                    h.position
                );
                assert!(
                    rays.occluded(o, d, f32::INFINITY),
                    "×{s}, gap {gap}: not occluded"
                );
            }
        }
    }
}
