//! Hand-built scenes for tests and for the Mitsuba validation: meshes (quads,
//! boxes, spheres), lights (spot, point, directional), a scene wrapper, and
//! the validation scenes (one light, three of different kinds, and a closed
//! room lit through a window for every bounce).
//!
//! Scenes built here have no camera node (the importer's node hierarchy is
//! not needed); they are rendered with [`crate::render_view`] and an explicit
//! [`View`]. They have no dynamic objects.

use gibake_scene::{Animator, Light, LightKind, Material, Mesh, Projection, Scene};
use glam::Vec3;

use crate::View;

/// A planar quad `corner, corner+u, corner+u+v, corner+v` (two triangles,
/// counter-clockwise about `u × v`, flat normals).
pub fn quad(name: &str, corner: Vec3, u: Vec3, v: Vec3, material: usize) -> Mesh {
    let n = u.cross(v).normalize_or_zero();
    Mesh {
        name: name.to_owned(),
        positions: vec![corner, corner + u, corner + u + v, corner + v],
        normals: vec![n; 4],
        uvs: None,
        indices: vec![0, 1, 2, 0, 2, 3],
        material,
    }
}

/// An axis-aligned box from `min` to `max`, outward faces, flat normals
/// (24 vertices, 12 triangles).
pub fn cuboid(name: &str, min: Vec3, max: Vec3, material: usize) -> Mesh {
    let d = max - min;
    let faces = [
        (
            Vec3::new(min.x, min.y, max.z),
            Vec3::new(d.x, 0.0, 0.0),
            Vec3::new(0.0, d.y, 0.0),
        ), // +Z
        (
            Vec3::new(max.x, min.y, min.z),
            Vec3::new(-d.x, 0.0, 0.0),
            Vec3::new(0.0, d.y, 0.0),
        ), // −Z
        (
            Vec3::new(max.x, min.y, max.z),
            Vec3::new(0.0, 0.0, -d.z),
            Vec3::new(0.0, d.y, 0.0),
        ), // +X
        (
            Vec3::new(min.x, min.y, min.z),
            Vec3::new(0.0, 0.0, d.z),
            Vec3::new(0.0, d.y, 0.0),
        ), // −X
        (
            Vec3::new(min.x, max.y, max.z),
            Vec3::new(d.x, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -d.z),
        ), // +Y
        (
            Vec3::new(min.x, min.y, min.z),
            Vec3::new(d.x, 0.0, 0.0),
            Vec3::new(0.0, 0.0, d.z),
        ), // −Y
    ];
    let mut mesh = Mesh {
        name: name.to_owned(),
        positions: vec![],
        normals: vec![],
        uvs: None,
        indices: vec![],
        material,
    };
    for (c, u, v) in faces {
        let q = quad(name, c, u, v, material);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(q.positions);
        mesh.normals.extend(q.normals);
        mesh.indices.extend(q.indices.iter().map(|i| i + base));
    }
    mesh
}

/// A UV sphere with smooth (analytic) vertex normals: `segments` around,
/// `rings` from pole to pole (`2·segments·(rings−1)` triangles).
pub fn uv_sphere(
    name: &str,
    center: Vec3,
    radius: f32,
    segments: u32,
    rings: u32,
    material: usize,
) -> Mesh {
    let (segments, rings) = (segments.max(3), rings.max(2));
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            );
            positions.push(center + radius * n);
            normals.push(n);
        }
    }
    let row = segments + 1;
    let mut indices = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (
                r * row + s,
                r * row + s + 1,
                (r + 1) * row + s + 1,
                (r + 1) * row + s,
            );
            if r != 0 {
                indices.extend([a, d, b]);
            }
            if r != rings - 1 {
                indices.extend([b, d, c]);
            }
        }
    }
    Mesh {
        name: name.to_owned(),
        positions,
        normals,
        uvs: None,
        indices,
        material,
    }
}

/// A material with a constant albedo.
pub fn material(name: &str, albedo: Vec3) -> Material {
    Material::opaque(name, albedo, None)
}

/// A spot light at `position` pointing along `direction` with intensity `intensity` W/sr.
pub fn spot(
    position: Vec3,
    direction: Vec3,
    intensity: Vec3,
    inner_cone: f32,
    outer_cone: f32,
) -> Light {
    Light {
        name: "spot".into(),
        kind: LightKind::Spot {
            inner_cone,
            outer_cone,
        },
        color: intensity,
        position,
        direction: direction.normalize(),
        range: None,
    }
}

/// A point light at `position` with intensity `intensity` W/sr in every
/// direction (no range).
pub fn point(position: Vec3, intensity: Vec3) -> Light {
    Light {
        name: "point".into(),
        kind: LightKind::Point,
        color: intensity,
        position,
        direction: Vec3::NEG_Y,
        range: None,
    }
}

/// A directional light travelling along `direction` with irradiance `irradiance` W/m².
pub fn directional(direction: Vec3, irradiance: Vec3) -> Light {
    Light {
        name: "sun".into(),
        kind: LightKind::Directional,
        color: irradiance,
        position: Vec3::ZERO,
        direction: direction.normalize(),
        range: None,
    }
}

/// A scene of static meshes (no camera, no dynamic objects).
pub fn static_scene(
    name: &str,
    light: Light,
    materials: Vec<Material>,
    meshes: Vec<Mesh>,
) -> Scene {
    Scene {
        source: name.into(),
        lights: vec![light],
        camera: None,
        materials,
        textures: vec![],
        static_meshes: meshes,
        dynamic_meshes: vec![],
        dynamic_objects: vec![],
        animator: Animator::default(),
        warnings: vec![],
        bake_volume: None,
    }
}

/// The Mitsuba validation scene: an open corner (grey floor, red back wall,
/// green left wall, 2 × 2 × 2 units), a blue-grey block and a smooth yellow
/// sphere (`sphere_segments` around, half as many rings; 48 → ~4.5k
/// triangles, 100 → ~10k), lit by a directional light of irradiance 3 W/m²
/// from the upper front right, seen by a 45° perspective camera.
pub fn validation_corner(sphere_segments: u32) -> (Scene, View) {
    let materials = vec![
        material("floor", Vec3::new(0.7, 0.7, 0.7)),
        material("red", Vec3::new(0.75, 0.15, 0.1)),
        material("green", Vec3::new(0.15, 0.6, 0.15)),
        material("block", Vec3::new(0.5, 0.55, 0.8)),
        material("sphere", Vec3::new(0.85, 0.7, 0.25)),
    ];
    let meshes = vec![
        quad(
            "floor",
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -2.0),
            0,
        ),
        quad(
            "back",
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            1,
        ),
        quad(
            "left",
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, -2.0),
            Vec3::new(0.0, 2.0, 0.0),
            2,
        ),
        cuboid(
            "block",
            Vec3::new(-0.05, 0.0, -0.45),
            Vec3::new(0.45, 0.7, 0.05),
            3,
        ),
        uv_sphere(
            "sphere",
            Vec3::new(-0.45, 0.3, 0.35),
            0.3,
            sphere_segments,
            (sphere_segments / 2).max(2),
            4,
        ),
    ];
    let light = directional(Vec3::new(-0.5, -1.0, -0.7), Vec3::splat(3.0));
    let scene = static_scene("validation_corner", light, materials, meshes);
    let view = View::look_at(
        Vec3::new(1.7, 1.4, 2.6),
        Vec3::new(-0.15, 0.45, -0.25),
        Vec3::Y,
        Projection::Perspective {
            yfov: 45f32.to_radians(),
            znear: 0.05,
            zfar: None,
        },
    );
    (scene, view)
}

/// The many-lights variant of [`validation_corner`] (the Mitsuba validation's
/// `--multi`): the same geometry and camera lit by three lights of distinct
/// colours and kinds, all without a range (Mitsuba has none):
///
/// - the corner's directional light, from the same direction, tinted warm
///   white (2.4, 2.1, 1.6) W/m²;
/// - a blue point light of (0.3, 0.5, 1.2) W/sr at (0.6, 1.1, 0.6), above
///   the floor in front of the block;
/// - an orange hard-edged spot (glTF inner = outer = 25°, so Mitsuba's
///   linear falloff band is ~0.1° wide) of (5, 2.5, 0.8) W/sr at
///   (−0.7, 1.8, 1.2), aimed at (0.1, 0.3, −0.6) (the block's left side and
///   the back wall).
///
/// The lights are in that order in [`Scene::lights`].
pub fn validation_corner_multi(sphere_segments: u32) -> (Scene, View) {
    let (mut scene, view) = validation_corner(sphere_segments);
    let sun = scene.lights[0].direction;
    scene.source = "validation_corner_multi".into();
    let spot_pos = Vec3::new(-0.7, 1.8, 1.2);
    let cone = 25f32.to_radians();
    scene.lights = vec![
        directional(sun, Vec3::new(2.4, 2.1, 1.6)),
        point(Vec3::new(0.6, 1.1, 0.6), Vec3::new(0.3, 0.5, 1.2)),
        spot(
            spot_pos,
            Vec3::new(0.1, 0.3, -0.6) - spot_pos,
            Vec3::new(5.0, 2.5, 0.8),
            cone,
            cone,
        ),
    ];
    (scene, view)
}

/// The every-bounce validation scene: a closed room (4 × 2.5 × 4 units:
/// floor, ceiling and four walls, single two-sided quads) lit only by a sun
/// through a 1.2 × 1 window in its +X wall, with a red block and a blue
/// sphere (`sphere_segments` around) on the floor, seen from inside by a
/// 60° perspective camera facing the sunlit floor and the far corner.
/// Most of what the camera sees is lit by bounces alone, and the later
/// bounces add about as much again as the first (albedos 0.5–0.85).
pub fn validation_room(sphere_segments: u32) -> (Scene, View) {
    let materials = vec![
        material("floor", Vec3::new(0.6, 0.5, 0.4)),
        material("walls", Vec3::new(0.8, 0.8, 0.75)),
        material("ceiling", Vec3::new(0.85, 0.85, 0.85)),
        material("block", Vec3::new(0.7, 0.2, 0.15)),
        material("sphere", Vec3::new(0.3, 0.5, 0.8)),
    ];
    let (h, w) = (2.5f32, 2.0f32);
    // The window in the x = +2 wall: z in [−0.6, 0.6], y in [0.8, 1.8].
    let (wz, wy0, wy1) = (0.6f32, 0.8f32, 1.8f32);
    let x = Vec3::X;
    let mut meshes = vec![
        quad(
            "floor",
            Vec3::new(-w, 0.0, w),
            2.0 * w * x,
            Vec3::new(0.0, 0.0, -2.0 * w),
            0,
        ),
        quad(
            "ceiling",
            Vec3::new(-w, h, -w),
            2.0 * w * x,
            Vec3::new(0.0, 0.0, 2.0 * w),
            2,
        ),
        quad(
            "back",
            Vec3::new(-w, 0.0, -w),
            2.0 * w * x,
            Vec3::new(0.0, h, 0.0),
            1,
        ),
        quad(
            "front",
            Vec3::new(w, 0.0, w),
            -2.0 * w * x,
            Vec3::new(0.0, h, 0.0),
            1,
        ),
        quad(
            "left",
            Vec3::new(-w, 0.0, w),
            Vec3::new(0.0, 0.0, -2.0 * w),
            Vec3::new(0.0, h, 0.0),
            1,
        ),
    ];
    // The window wall in four pieces around the opening.
    let zn = Vec3::NEG_Z;
    meshes.push(quad(
        "wall_below",
        Vec3::new(w, 0.0, w),
        zn * 2.0 * w,
        Vec3::new(0.0, wy0, 0.0),
        1,
    ));
    meshes.push(quad(
        "wall_above",
        Vec3::new(w, wy1, w),
        zn * 2.0 * w,
        Vec3::new(0.0, h - wy1, 0.0),
        1,
    ));
    meshes.push(quad(
        "wall_side_a",
        Vec3::new(w, wy0, w),
        zn * (w - wz),
        Vec3::new(0.0, wy1 - wy0, 0.0),
        1,
    ));
    meshes.push(quad(
        "wall_side_b",
        Vec3::new(w, wy0, -wz),
        zn * (w - wz),
        Vec3::new(0.0, wy1 - wy0, 0.0),
        1,
    ));
    meshes.push(cuboid(
        "block",
        Vec3::new(-1.2, 0.0, -1.4),
        Vec3::new(-0.4, 0.9, -0.6),
        3,
    ));
    meshes.push(uv_sphere(
        "sphere",
        Vec3::new(-1.1, 0.45, 0.9),
        0.45,
        sphere_segments,
        (sphere_segments / 2).max(2),
        4,
    ));
    // The sun through the window, onto the floor's middle.
    let light = directional(Vec3::new(-1.0, -0.55, 0.15), Vec3::splat(4.0));
    let scene = static_scene("validation_room", light, materials, meshes);
    let view = View::look_at(
        Vec3::new(1.6, 1.6, 1.7),
        Vec3::new(-1.2, 0.4, -1.0),
        Vec3::Y,
        Projection::Perspective {
            yfov: 60f32.to_radians(),
            znear: 0.05,
            zfar: None,
        },
    );
    (scene, view)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meshes_are_consistent() {
        for m in [
            quad("q", Vec3::ZERO, Vec3::X, Vec3::Y, 0),
            cuboid("b", Vec3::ZERO, Vec3::ONE, 0),
            uv_sphere("s", Vec3::ZERO, 1.0, 12, 6, 0),
        ] {
            assert_eq!(m.indices.len() % 3, 0);
            assert!(m.indices.iter().all(|&i| (i as usize) < m.positions.len()));
            assert_eq!(m.positions.len(), m.normals.len());
            // Outward winding: the triangle normal agrees with the vertex normals.
            for t in m.indices.chunks(3) {
                let p: Vec<Vec3> = t.iter().map(|&i| m.positions[i as usize]).collect();
                let ng = (p[1] - p[0]).cross(p[2] - p[0]);
                let ns: Vec3 = t.iter().map(|&i| m.normals[i as usize]).sum();
                assert!(ng.dot(ns) > 0.0, "{}: inward triangle", m.name);
            }
        }
        assert_eq!(
            uv_sphere("s", Vec3::ZERO, 1.0, 12, 6, 0).indices.len() / 3,
            2 * 12 * 5
        );
    }
}
