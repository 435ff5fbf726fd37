//! Valid scenes: light, camera, flattening, dynamic objects, materials, geometry.

use crate::common;

use common::{Builder, basic, png, spot_light};
use gibake_scene::{LightKind, LoadOptions, Projection};
use glam::{Mat4, Vec3};
use serde_json::json;

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn simple_scene_light_camera_geometry() {
    let s = basic().load().unwrap();
    assert_eq!(s.light().name, "Key");
    assert!(
        close(s.light().color, Vec3::new(10.0, 5.0, 2.5)),
        "{}",
        s.light().color
    );
    assert!(close(s.light().position, Vec3::new(0.0, 5.0, 0.0)));
    assert!(
        close(s.light().direction, Vec3::NEG_Y),
        "{}",
        s.light().direction
    );
    match &s.light().kind {
        LightKind::Spot {
            inner_cone,
            outer_cone,
        } => {
            assert!((inner_cone - 0.2).abs() < 1e-6);
            assert!((outer_cone - 0.5).abs() < 1e-6);
        }
        k => panic!("expected a spot light, got {k:?}"),
    }
    let cam = s.camera.as_ref().expect("camera");
    assert_eq!(cam.name, "Cam");
    assert_eq!(cam.node, 2);
    assert_eq!(
        cam.projection,
        Projection::Perspective {
            yfov: 0.8,
            znear: 0.1,
            zfar: Some(100.0)
        }
    );
    let ct = s.camera_transform(0.0).unwrap();
    assert!(close(
        ct.transform_point3(Vec3::ZERO),
        Vec3::new(0.0, 1.0, 5.0)
    ));
    assert_eq!(s.triangle_counts(), (2, 0));
    assert_eq!(s.static_meshes[0].name, "FloorNode/Floor/0");
    assert_eq!(s.materials.len(), 1);
    assert_eq!(s.materials[0].base_color, Vec3::ONE);
    assert_eq!(s.materials[0].texture, None);
    assert!(s.dynamic_objects.is_empty());
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.animator.time_range(), None);
    assert_eq!(s.source, std::path::PathBuf::from("test_scene.gltf"));
}

#[test]
fn glb_loads_like_gltf() {
    let b = basic();
    let from_glb = gibake_scene::load_from_slice(
        &b.glb(),
        std::path::Path::new("x.glb"),
        &LoadOptions::default(),
    )
    .unwrap();
    let from_gltf = b.load().unwrap();
    assert_eq!(from_glb.static_meshes, from_gltf.static_meshes);
    assert_eq!(from_glb.lights, from_gltf.lights);
}

#[test]
fn load_from_disk_with_external_buffer() {
    let b = basic();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("data file.bin"), &b.bin).unwrap();
    let mut j = b.json.clone();
    j["buffers"] = json!([{ "byteLength": b.bin.len(), "uri": "data%20file.bin" }]);
    let path = dir.path().join("scene.gltf");
    std::fs::write(&path, serde_json::to_vec(&j).unwrap()).unwrap();
    let s = gibake_scene::load(&path, &LoadOptions::default()).unwrap();
    assert_eq!(s.triangle_counts(), (2, 0));
    // And a .glb on disk.
    let gpath = dir.path().join("scene.glb");
    std::fs::write(&gpath, b.glb()).unwrap();
    assert_eq!(
        gibake_scene::load(&gpath, &LoadOptions::default())
            .unwrap()
            .triangle_counts(),
        (2, 0)
    );
}

#[test]
fn directional_light_and_orthographic_camera() {
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("F", q);
    b.light_node(
        json!({ "type": "directional", "color": [1.0, 1.0, 1.0], "intensity": 3.0 }),
        json!({ "name": "Sun" }),
    );
    let c = b.camera(json!({ "type": "orthographic", "orthographic": { "xmag": 2.0, "ymag": 1.5, "znear": 0.0, "zfar": 10.0 } }));
    let n = b.node(json!({ "camera": c }));
    b.root(n);
    let s = b.load().unwrap();
    assert_eq!(s.light().kind, LightKind::Directional);
    assert_eq!(s.light().name, "light #0");
    assert!(close(s.light().color, Vec3::splat(3.0)));
    assert!(close(s.light().direction, Vec3::NEG_Z));
    assert_eq!(
        s.camera.unwrap().projection,
        Projection::Orthographic {
            xmag: 2.0,
            ymag: 1.5,
            znear: 0.0,
            zfar: 10.0
        }
    );
}

#[test]
fn spot_defaults_and_range() {
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("F", q);
    // The range is in the node's space: a uniform scale of 2 doubles it.
    b.light_node(
        json!({ "name": "S", "type": "spot", "range": 5.0, "spot": {} }),
        json!({ "scale": [2.0, 2.0, 2.0] }),
    );
    let s = b.load().unwrap();
    assert_eq!(
        s.light().kind,
        LightKind::Spot {
            inner_cone: 0.0,
            outer_cone: std::f32::consts::FRAC_PI_4
        }
    );
    assert!(close(s.light().color, Vec3::ONE));
    assert_eq!(s.light().range, Some(10.0));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(s.camera.is_none());
    // The window: 1 at the light, 0 at and beyond the range.
    assert_eq!(s.light().range_window(0.0), 1.0);
    assert_eq!(s.light().range_window(10.0), 0.0);
    assert_eq!(s.light().range_window(1e30), 0.0);
    assert!((s.light().range_window(5.0) - (1.0 - 0.0625)).abs() < 1e-6);
}

#[test]
fn first_camera_in_depth_first_order() {
    let mut b = basic();
    // basic() already has CamNode as the third root; put another camera in a
    // subtree of the first root: it comes first depth-first.
    let c = b.camera(json!({ "name": "Early", "type": "perspective", "perspective": { "yfov": 1.0, "znear": 0.5 } }));
    let n = b.node(json!({ "name": "EarlyNode", "camera": c }));
    b.child(0, n);
    let s = b.load().unwrap();
    let cam = s.camera.unwrap();
    assert_eq!(cam.name, "Early");
    assert_eq!(cam.node, n);
    assert_eq!(
        cam.projection,
        Projection::Perspective {
            yfov: 1.0,
            znear: 0.5,
            zfar: None
        }
    );
}

#[test]
fn flattening_with_parent_transform_and_negative_scale() {
    let mut b = basic();
    let q = b.quad("Mirrored", true);
    let child = b.node(json!({ "name": "Child", "mesh": q, "translation": [3.0, 0.0, 0.0], "scale": [-1.0, 1.0, 1.0] }));
    let parent = b.node(
        json!({ "name": "Parent", "translation": [0.0, 1.0, 0.0], "scale": [2.0, 2.0, 2.0] }),
    );
    b.child(parent, child);
    b.root(parent);
    let s = b.load().unwrap();
    assert_eq!(s.static_meshes.len(), 2);
    let m = s
        .static_meshes
        .iter()
        .find(|m| m.name == "Child/Mirrored/0")
        .expect("mirrored mesh");
    // (-1,0,-1) → child: (1,0,-1)+(3,0,0) → parent: ×2 + (0,1,0).
    assert!(
        close(m.positions[0], Vec3::new(8.0, 1.0, -2.0)),
        "{}",
        m.positions[0]
    );
    assert!(
        close(m.positions[2], Vec3::new(4.0, 1.0, 2.0)),
        "{}",
        m.positions[2]
    );
    for n in &m.normals {
        assert!(close(*n, Vec3::Y), "{n}");
    }
    // Winding flipped so the geometric normal still agrees with the shading normal.
    for t in m.indices.chunks_exact(3) {
        let (a, b2, c) = (
            m.positions[t[0] as usize],
            m.positions[t[1] as usize],
            m.positions[t[2] as usize],
        );
        let g = (b2 - a).cross(c - a);
        assert!(g.dot(Vec3::Y) > 0.0, "triangle {t:?} faces {g}");
    }
    // The unmirrored floor keeps its winding.
    let f = &s.static_meshes[0];
    assert_eq!(f.indices, vec![0, 1, 2, 0, 2, 3]);
}

#[test]
fn node_matrix_is_used() {
    let mut b = basic();
    let q = b.quad("M", true);
    let m = Mat4::from_translation(Vec3::new(0.0, 0.0, 7.0))
        * Mat4::from_rotation_z(std::f32::consts::PI);
    let n = b.node(json!({ "name": "MatNode", "mesh": q, "matrix": m.to_cols_array() }));
    b.root(n);
    let s = b.load().unwrap();
    let mesh = s
        .static_meshes
        .iter()
        .find(|x| x.name.starts_with("MatNode"))
        .unwrap();
    assert!(
        close(mesh.positions[0], Vec3::new(1.0, 0.0, 6.0)),
        "{}",
        mesh.positions[0]
    );
    assert!(close(mesh.normals[0], Vec3::NEG_Y), "{}", mesh.normals[0]);
}

#[test]
fn dynamic_by_extras_on_ancestor() {
    let mut b = basic();
    let q = b.quad("BallMesh", true);
    let ball = b.node(json!({ "name": "Ball", "mesh": q, "translation": [1.0, 0.0, 0.0] }));
    let mover = b.node(
        json!({ "name": "Mover", "translation": [0.0, 2.0, 0.0], "extras": { "dynamic": true } }),
    );
    b.child(mover, ball);
    b.root(mover);
    // extras dynamic: false, or other extras, stay static.
    let q2 = b.quad("Still", true);
    let still =
        b.node(json!({ "name": "Still", "mesh": q2, "extras": { "dynamic": false, "note": 1 } }));
    b.root(still);
    let s = b.load().unwrap();
    assert_eq!(s.dynamic_objects.len(), 1);
    let o = &s.dynamic_objects[0];
    assert_eq!(o.name, "Ball");
    assert_eq!(o.node, ball);
    assert_eq!(o.meshes, vec![0]);
    assert!(close(o.local_bounds.min, Vec3::new(-1.0, 0.0, -1.0)));
    assert!(close(o.local_bounds.max, Vec3::new(1.0, 0.0, 1.0)));
    // Local space kept.
    assert!(close(
        s.dynamic_meshes[0].positions[0],
        Vec3::new(-1.0, 0.0, -1.0)
    ));
    let w = s.dynamic_transform(0, 0.0);
    assert!(close(
        w.transform_point3(Vec3::ZERO),
        Vec3::new(1.0, 2.0, 0.0)
    ));
    assert_eq!(s.triangle_counts(), (4, 2));
    assert!(!s.animator.is_animated(ball));
    let wb = s.dynamic_bounds(0, 0.0);
    assert!(close(wb.min, Vec3::new(0.0, 2.0, -1.0)));
    assert_eq!(s.meshes_at(0.0).len(), 3);
}

fn translation_anim(
    node: usize,
    b: &mut Builder,
    interp: &str,
    times: &[f32],
    xs: &[f32],
) -> serde_json::Value {
    let input = b.floats(times, "SCALAR");
    let vals: Vec<f32> = xs.iter().flat_map(|&x| [x, 0.0, 0.0]).collect();
    let output = b.floats(&vals, "VEC3");
    json!({
        "samplers": [{ "input": input, "output": output, "interpolation": interp }],
        "channels": [{ "sampler": 0, "target": { "node": node, "path": "translation" } }]
    })
}

#[test]
fn dynamic_by_animation() {
    let mut b = basic();
    let q = b.quad("BoxMesh", false);
    let boxn = b.node(json!({ "name": "Box", "mesh": q }));
    let arm = b.node(json!({ "name": "Arm" }));
    b.child(arm, boxn);
    b.root(arm);
    let a = translation_anim(arm, &mut b, "LINEAR", &[0.0, 2.0], &[0.0, 10.0]);
    b.animation(a);
    let s = b.load().unwrap();
    assert_eq!(s.dynamic_objects.len(), 1);
    assert_eq!(s.dynamic_objects[0].name, "Box");
    assert!(s.animator.is_animated(boxn));
    assert!(s.animator.is_animated(arm));
    assert!(!s.animator.is_animated(0));
    assert_eq!(s.animator.time_range(), Some((0.0, 2.0)));
    let p = |t: f32| s.dynamic_transform(0, t).transform_point3(Vec3::ZERO);
    assert!(close(p(1.0), Vec3::new(5.0, 0.0, 0.0)));
    assert!(close(p(-1.0), Vec3::ZERO));
    assert!(close(p(9.0), Vec3::new(10.0, 0.0, 0.0)));
    let swept = s.dynamic_swept_bounds();
    assert!(
        close(swept.min, Vec3::new(-1.0, 0.0, -1.0)) && close(swept.max, Vec3::new(11.0, 0.0, 1.0))
    );
    assert!(s.full_bounds().max.x >= 11.0);
    // Computed normals in local space.
    assert!(
        s.dynamic_meshes[0]
            .normals
            .iter()
            .all(|n| close(*n, Vec3::Y))
    );
}

#[test]
fn missing_normals_are_computed() {
    let mut b = Builder::new();
    let q = b.quad("Floor", false);
    b.root_mesh_node("F", q);
    b.light_node(spot_light(), json!({}));
    let s = b.load().unwrap();
    assert!(
        s.static_meshes[0]
            .normals
            .iter()
            .all(|n| close(*n, Vec3::Y))
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn zero_normals_are_recomputed_with_warning_and_degenerates_are_dropped() {
    let mut b = Builder::new();
    let pos = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
    ];
    let nrm = [[0.0, 0.0, 0.0]; 4];
    // Triangle 2 is degenerate (collinear, zero area); vertex 3 only belongs to it.
    let m = b.mesh("Tri", &pos, Some(&[0, 1, 2, 0, 2, 3]), Some(&nrm), None);
    b.root_mesh_node("T", m);
    b.light_node(spot_light(), json!({}));
    let s = b.load().unwrap();
    let mesh = &s.static_meshes[0];
    assert_eq!(mesh.indices.len(), 3, "degenerate triangle dropped");
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("skipped 1 degenerate triangle")),
        "{:?}",
        s.warnings
    );
    for n in &mesh.normals {
        assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-5, "{n}");
    }
    assert!(close(mesh.normals[0], Vec3::Y));
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("NORMAL") && w.contains("recomputed")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn non_indexed_strips_fans_and_skipped_modes() {
    let mut b = basic();
    let pos = [
        [0.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
    ];
    let p = b.vec3s(&pos);
    let strip = b.mesh_raw(
        "Strip",
        json!({ "attributes": { "POSITION": p }, "mode": 5 }),
    );
    let fan = b.mesh_raw("Fan", json!({ "attributes": { "POSITION": p }, "mode": 6 }));
    let lines = b.mesh_raw(
        "Lines",
        json!({ "attributes": { "POSITION": p }, "mode": 1 }),
    );
    let plain = b.mesh_raw("Plain", json!({ "attributes": { "POSITION": p } }));
    for (name, m) in [("S", strip), ("Fa", fan), ("L", lines), ("P", plain)] {
        b.root_mesh_node(name, m);
    }
    let s = b.load().unwrap();
    let get = |n: &str| {
        s.static_meshes
            .iter()
            .find(|m| m.name.starts_with(n))
            .map(|m| m.indices.clone())
    };
    assert_eq!(get("S/").unwrap(), vec![0, 1, 2, 1, 3, 2]);
    assert_eq!(get("Fa/").unwrap(), vec![1, 2, 0, 2, 3, 0]);
    assert_eq!(get("P/").unwrap(), vec![0, 1, 2]); // 4 vertices: the last one ignored
    assert!(get("L/").is_none());
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("Lines") && w.contains("skipped")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn materials_and_textures() {
    let mut b = basic();
    let tex = b.png_texture(&png(2, 1, 3, &[255, 0, 0, 0, 255, 0]));
    let m0 = b.material(json!({ "name": "Painted", "pbrMetallicRoughness": {
        "baseColorFactor": [0.5, 1.0, 1.0, 1.0], "baseColorTexture": { "index": tex } } }));
    let m1 = b.material(json!({ "name": "AlsoPainted", "pbrMetallicRoughness": {
        "baseColorTexture": { "index": tex } }, "emissiveFactor": [1.0, 0.0, 0.0] }));
    let m2 = b.material(json!({ "name": "Plain", "pbrMetallicRoughness": { "baseColorFactor": [0.2, 0.3, 0.4, 1.0] } }));
    let pos = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]];
    let p = b.vec3s(&pos);
    let uv = b.floats(&[0.0, 0.0, 0.0, 1.0, 1.0, 0.0], "VEC2");
    let prims = json!([
        { "attributes": { "POSITION": p, "TEXCOORD_0": uv }, "material": m0 },
        { "attributes": { "POSITION": p, "TEXCOORD_0": uv }, "material": m1 },
        { "attributes": { "POSITION": p }, "material": m0 },
        { "attributes": { "POSITION": p }, "material": m2 },
    ]);
    let mesh = {
        let i = b.mesh_raw("Multi", json!({}));
        b.json["meshes"][i] = json!({ "name": "Multi", "primitives": prims });
        i
    };
    b.root_mesh_node("MultiNode", mesh);
    let s = b.load().unwrap();
    assert_eq!(s.textures.len(), 1, "one texture, deduplicated by image");
    let t = &s.textures[0];
    assert_eq!((t.width, t.height), (2, 1));
    assert_eq!(t.rgba8_srgb, vec![255, 0, 0, 255, 0, 255, 0, 255]);
    let meshes: Vec<_> = s
        .static_meshes
        .iter()
        .filter(|m| m.name.starts_with("MultiNode/Multi/"))
        .collect();
    assert_eq!(meshes.len(), 4);
    let mat = |i: usize| &s.materials[meshes[i].material];
    assert_eq!(mat(0).texture, Some(0));
    assert_eq!(mat(0).base_color, Vec3::new(0.5, 1.0, 1.0));
    assert_eq!(mat(1).texture, Some(0));
    assert!(meshes[0].uvs.is_some() && meshes[1].uvs.is_some());
    // Textured material without TEXCOORD_0: warned, drawn untextured.
    assert_eq!(mat(2).texture, None);
    assert!(meshes[2].uvs.is_none());
    assert_eq!(mat(2).base_color, Vec3::new(0.5, 1.0, 1.0));
    assert_eq!(mat(3).base_color, Vec3::new(0.2, 0.3, 0.4));
    assert!(
        s.warnings.iter().any(|w| w.contains("TEXCOORD_0")),
        "{:?}",
        s.warnings
    );
    // Ignored inputs: one warning per glTF material, naming it and them.
    let ignored: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("ignored") && w.contains("material '"))
        .collect();
    assert_eq!(ignored.len(), 3, "{ignored:?}");
    assert!(
        ignored
            .iter()
            .any(|w| w.contains("'AlsoPainted'") && w.contains("emissiveFactor [1.0, 0.0, 0.0]")),
        "{ignored:?}"
    );
    assert!(
        ignored.iter().all(|w| w.contains("metallicFactor 1")),
        "the default metallicFactor is 1: {ignored:?}"
    );
    // Albedo: texel 0 is pure red (sRGB 255 → linear 1), times the factor.
    let a = s.albedo(meshes[0].material, Some(glam::Vec2::new(0.25, 0.5)));
    assert!(close(a, Vec3::new(0.5, 0.0, 0.0)), "{a}");
}

#[test]
fn rgba_png_texture_kept_as_is() {
    let mut b = basic();
    let tex = b.png_texture(&png(1, 2, 4, &[10, 20, 30, 40, 50, 60, 70, 80]));
    let m = b.material(json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": tex } } }));
    let p = b.vec3s(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    let uv = b.floats(&[0.0, 0.0, 0.0, 1.0, 1.0, 0.0], "VEC2");
    let mesh = b.mesh_raw(
        "T",
        json!({ "attributes": { "POSITION": p, "TEXCOORD_0": uv }, "material": m }),
    );
    b.root_mesh_node("TN", mesh);
    let s = b.load().unwrap();
    assert_eq!(
        s.textures[0].rgba8_srgb,
        vec![10, 20, 30, 40, 50, 60, 70, 80]
    );
    assert_eq!(
        s.materials
            .iter()
            .find(|x| x.texture.is_some())
            .unwrap()
            .name,
        "material #0"
    );
}

#[test]
fn skins_are_warnings_and_a_point_light_beside_the_primary_is_kept() {
    let mut b = basic();
    b.light_node(
        json!({ "name": "Bulb", "type": "point" }),
        json!({ "name": "BulbNode" }),
    );
    b.json["skins"] = json!([{ "joints": [2] }]);
    b.json["nodes"][0]["skin"] = json!(0);
    let s = b.load().unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("FloorNode") && w.contains("skin")),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.triangle_counts(), (2, 0), "skinned mesh rendered rigid");
    let names: Vec<&str> = s.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(
        names,
        ["Key", "Bulb"],
        "the spot leads, the point light is kept"
    );
    assert!(
        !s.warnings.iter().any(|w| w.contains("Bulb")),
        "{:?}",
        s.warnings
    );
}

/// A textured triangle whose image is described by `image` (raw JSON).
fn textured_with_image(b: &mut Builder, image: serde_json::Value) {
    b.json["images"] = json!([image]);
    b.json["textures"] = json!([{ "source": 0 }]);
    let m = b.material(json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }));
    let p = b.vec3s(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    let uv = b.floats(&[0.0, 0.0, 0.0, 1.0, 1.0, 0.0], "VEC2");
    let mesh = b.mesh_raw(
        "T",
        json!({ "attributes": { "POSITION": p, "TEXCOORD_0": uv }, "material": m }),
    );
    b.root_mesh_node("TN", mesh);
}

#[test]
fn images_from_buffer_views_and_external_files() {
    let bytes = png(1, 1, 3, &[1, 2, 3]);
    // bufferView image, in a .glb.
    let mut b = basic();
    let v = b.view(&bytes);
    textured_with_image(&mut b, json!({ "bufferView": v, "mimeType": "image/png" }));
    let s = gibake_scene::load_from_slice(
        &b.glb(),
        std::path::Path::new("v.glb"),
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(s.textures[0].rgba8_srgb, vec![1, 2, 3, 255]);
    // External file with an unusual extension and no mimeType.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("albedo.PNG"), &bytes).unwrap();
    let mut b = basic();
    textured_with_image(&mut b, json!({ "uri": "albedo.PNG" }));
    let path = dir.path().join("t.gltf");
    std::fs::write(&path, b.gltf()).unwrap();
    let s = gibake_scene::load(&path, &LoadOptions::default()).unwrap();
    assert_eq!(s.textures[0].rgba8_srgb, vec![1, 2, 3, 255]);
}
