//! Bad input: every case is an `Err` naming the file and what is wrong, never a panic.

use crate::common;

use std::path::Path;

use common::{Builder, assert_err_contains, basic, spot_light};
use gibake_scene::{LightKind, LoadOptions, SceneError, load_from_slice};
use serde_json::json;

const FILE: &str = "test_scene.gltf";

fn load_bytes(bytes: &[u8], name: &str) -> Result<gibake_scene::Scene, SceneError> {
    load_from_slice(bytes, Path::new(name), &LoadOptions::default())
}

#[test]
fn broken_json() {
    let e = assert_err_contains(
        load_bytes(b"{ \"asset\": { \"version\": ", "broken.gltf"),
        &["broken.gltf", "glTF"],
    );
    assert!(matches!(e, SceneError::Gltf { .. }), "{e:?}");
}

#[test]
fn json_with_wrong_types() {
    let j = br#"{ "asset": { "version": "2.0" }, "nodes": "not an array" }"#;
    let e = assert_err_contains(load_bytes(j, "types.gltf"), &["types.gltf"]);
    assert!(matches!(e, SceneError::Gltf { .. }), "{e:?}");
    let j = br#"{ "asset": { "version": "2.0" }, "scenes": [ { "nodes": [ 5 ] } ] }"#;
    assert_err_contains(load_bytes(j, "index.gltf"), &["index.gltf"]);
}

#[test]
fn garbage_bytes() {
    let bytes: Vec<u8> = (0..1000u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    assert_err_contains(load_bytes(&bytes, "garbage.glb"), &["garbage.glb"]);
    assert_err_contains(load_bytes(b"", "empty.gltf"), &["empty.gltf"]);
    assert_err_contains(load_bytes(b"glTF", "tiny.glb"), &["tiny.glb", "truncated"]);
}

#[test]
fn truncated_glb() {
    let glb = basic().glb();
    let e = assert_err_contains(
        load_bytes(&glb[..glb.len() / 2], "cut.glb"),
        &["cut.glb", "truncated"],
    );
    assert!(matches!(
        e,
        SceneError::Invalid { .. } | SceneError::Gltf { .. }
    ));
    // A header claiming fewer bytes than a header.
    let mut bad = glb.clone();
    bad[8..12].copy_from_slice(&3u32.to_le_bytes());
    assert_err_contains(load_bytes(&bad, "short.glb"), &["short.glb"]);
    // BIN chunk shorter than the buffer's byteLength.
    let mut b = basic();
    b.json["buffers"] = json!([{ "byteLength": 1 }]);
    let mut glb2 = b.glb();
    let n = glb2.len();
    glb2[8..12].copy_from_slice(&((n - 8) as u32).to_le_bytes());
    assert!(load_bytes(&glb2, "odd.glb").is_err());
}

#[test]
fn every_truncation_and_corruption_is_an_error_not_a_panic() {
    let mut b = basic();
    let t = b.floats(&[0.0, 1.0], "SCALAR");
    let v = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0], "VEC3");
    b.animation(json!({ "samplers": [ { "input": t, "output": v } ],
        "channels": [ { "sampler": 0, "target": { "node": 2, "path": "translation" } } ] }));
    let glb = b.glb();
    for cut in 0..glb.len() {
        if let Err(e) = load_bytes(&glb[..cut], "cut.glb") {
            assert!(
                !e.to_string().contains("internal error"),
                "cut at {cut}: {e}"
            );
        }
    }
    for i in 0..glb.len() {
        for x in [0x00u8, 0xff, 0x7f, 0x80] {
            let mut g = glb.clone();
            g[i] ^= x | 1;
            if let Err(e) = load_bytes(&g, "flip.glb") {
                assert!(!e.to_string().contains("internal error"), "byte {i}: {e}");
            }
        }
    }
}

/// Replaces every number of the document, one at a time, by hostile values.
#[test]
fn every_number_replaced_is_an_error_or_a_scene_not_a_panic() {
    fn paths(v: &serde_json::Value, cur: &mut Vec<String>, out: &mut Vec<String>) {
        match v {
            serde_json::Value::Number(_) => out.push(format!("/{}", cur.join("/"))),
            serde_json::Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    cur.push(i.to_string());
                    paths(x, cur, out);
                    cur.pop();
                }
            }
            serde_json::Value::Object(o) => {
                for (k, x) in o {
                    cur.push(k.clone());
                    paths(x, cur, out);
                    cur.pop();
                }
            }
            _ => {}
        }
    }
    let mut b = basic();
    let t = b.floats(&[0.0, 1.0], "SCALAR");
    let v = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0], "VEC3");
    b.animation(
        json!({ "samplers": [ { "input": t, "output": v, "interpolation": "CUBICSPLINE" } ],
        "channels": [ { "sampler": 0, "target": { "node": 0, "path": "scale" } } ] }),
    );
    let base = b.json_with_data_uri();
    let mut all = Vec::new();
    paths(&base, &mut Vec::new(), &mut all);
    let hostile = [
        json!(0),
        json!(1),
        json!(2),
        json!(3),
        json!(7),
        json!(-1),
        json!(4_294_967_295u64),
        json!(u64::MAX),
        json!(1e30),
        json!(0.5),
    ];
    for p in &all {
        for h in &hostile {
            let mut j = base.clone();
            *j.pointer_mut(p).unwrap() = h.clone();
            let bytes = serde_json::to_vec(&j).unwrap();
            if let Err(e) = load_bytes(&bytes, "num.gltf") {
                let msg = e.to_string();
                assert!(!msg.contains("internal error"), "{p} = {h}: {msg}");
                assert!(msg.contains("num.gltf"), "{msg}");
            }
        }
    }
}

#[test]
fn nan_vertex_position() {
    let mut b = basic();
    let m = b.mesh(
        "Broken",
        &[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]],
        None,
        None,
        None,
    );
    b.root_mesh_node("BrokenNode", m);
    let e = assert_err_contains(
        b.load(),
        &[
            FILE,
            "Broken",
            "POSITION",
            "accessor",
            "not finite",
            "vertex 1",
        ],
    );
    assert!(matches!(e, SceneError::Invalid { .. }));
}

#[test]
fn index_out_of_range() {
    let mut b = basic();
    let m = b.mesh(
        "Tri",
        &[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
        Some(&[0, 1, 7]),
        None,
        None,
    );
    b.root_mesh_node("TriNode", m);
    assert_err_contains(
        b.load(),
        &[
            FILE,
            "TriNode/Tri/0",
            "index 7",
            "out of range",
            "3 vertices",
        ],
    );
}

#[test]
fn accessor_outside_its_buffer() {
    let mut b = basic();
    b.json["accessors"][0]["count"] = json!(1_000_000);
    assert_err_contains(b.load(), &[FILE, "accessor 0", "do not fit"]);
    let mut b = basic();
    b.json["accessors"][0]["count"] = json!(u64::MAX);
    assert!(b.load().is_err());
    let mut b = basic();
    b.json["accessors"][0]["count"] = json!(0);
    assert!(b.load().is_err());
    let mut b = basic();
    b.json["bufferViews"][0]["byteLength"] = json!(1 << 30);
    assert_err_contains(b.load(), &[FILE, "outside buffer"]);
    let mut b = basic();
    b.json["bufferViews"][0]["byteStride"] = json!(4);
    assert_err_contains(b.load(), &[FILE, "byteStride"]);
}

#[test]
fn no_static_triangles() {
    let mut b = Builder::new();
    let q = b.quad("Ball", true);
    let n = b.node(json!({ "name": "Ball", "mesh": q, "extras": { "dynamic": true } }));
    b.root(n);
    b.light_node(spot_light(), json!({}));
    let e = assert_err_contains(b.load(), &[FILE, "no static triangles"]);
    assert!(matches!(e, SceneError::Invalid { .. }));
    // Nothing at all.
    let mut b = Builder::new();
    b.light_node(spot_light(), json!({}));
    assert_err_contains(b.load(), &[FILE, "no static triangles"]);
}

#[test]
fn no_light() {
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("F", q);
    let e = assert_err_contains(b.load(), &[FILE, "no KHR_lights_punctual light", "--sun"]);
    assert!(matches!(e, SceneError::Invalid { .. }));
    // Defined but not used by any node.
    b.light(spot_light());
    assert_err_contains(b.load(), &[FILE, "no KHR_lights_punctual", "no node"]);
}

/// A point light alone is the primary light (its maps are cube faces).
#[test]
fn a_point_light_alone_is_the_primary_light() {
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("F", q);
    b.light_node(
        json!({ "name": "Bulb", "type": "point", "intensity": 5.0 }),
        json!({ "name": "BulbNode" }),
    );
    let s = b.load().unwrap();
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.light().name, "Bulb");
    assert_eq!(s.light().kind, LightKind::Point);
    // Picked by name: the same.
    let opts = LoadOptions {
        lights: vec!["Bulb".into()],
        ..Default::default()
    };
    assert_eq!(b.load_with(&opts).unwrap().light().kind, LightKind::Point);
}

fn two_spots() -> Builder {
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("F", q);
    b.light_node(
        json!({ "name": "Alpha", "type": "spot", "spot": {} }),
        json!({ "name": "A", "translation": [0.0, 1.0, 0.0] }),
    );
    b.light_node(
        json!({ "name": "Beta", "type": "directional", "intensity": 2.0 }),
        json!({ "name": "B" }),
    );
    b
}

/// Two lights: both are primary lights, the directional one first.
#[test]
fn two_lights_are_both_kept() {
    let s = two_spots().load().unwrap();
    let names: Vec<&str> = s.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Beta", "Alpha"]);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn light_option_picks_one() {
    let b = two_spots();
    let s = b
        .load_with(&LoadOptions {
            lights: vec!["Beta".into()],
            ..Default::default()
        })
        .unwrap();
    assert_eq!(s.light().name, "Beta");
    assert_eq!(s.light().color, glam::Vec3::splat(2.0));
    assert!(
        s.warnings.iter().any(|w| w.contains("Alpha")),
        "{:?}",
        s.warnings
    );
    // The node name works too.
    let s = b
        .load_with(&LoadOptions {
            lights: vec!["A".into()],
            ..Default::default()
        })
        .unwrap();
    assert_eq!(s.light().name, "Alpha");
    assert_eq!(s.light().position, glam::Vec3::Y);
}

#[test]
fn unknown_light_name() {
    let e = assert_err_contains(
        two_spots().load_with(&LoadOptions {
            lights: vec!["Gamma".into()],
            ..Default::default()
        }),
        &[FILE, "Gamma", "Alpha", "Beta"],
    );
    assert!(matches!(e, SceneError::Invalid { .. }));
}

#[test]
fn missing_external_buffer_file() {
    let b = basic();
    let dir = tempfile::tempdir().unwrap();
    let mut j = b.json.clone();
    j["buffers"] = json!([{ "byteLength": b.bin.len(), "uri": "missing.bin" }]);
    let path = dir.path().join("scene.gltf");
    std::fs::write(&path, serde_json::to_vec(&j).unwrap()).unwrap();
    assert_err_contains(
        gibake_scene::load(&path, &LoadOptions::default()),
        &["scene.gltf", "missing.bin", "buffer 0"],
    );
    // Unsupported scheme.
    j["buffers"] = json!([{ "byteLength": b.bin.len(), "uri": "https://example.com/x.bin" }]);
    std::fs::write(&path, serde_json::to_vec(&j).unwrap()).unwrap();
    let e = assert_err_contains(
        gibake_scene::load(&path, &LoadOptions::default()),
        &["scene.gltf", "https"],
    );
    assert!(matches!(e, SceneError::NotSupported { .. }));
    // Percent escapes that are not UTF-8.
    j["buffers"] = json!([{ "byteLength": b.bin.len(), "uri": "%FF.bin" }]);
    std::fs::write(&path, serde_json::to_vec(&j).unwrap()).unwrap();
    assert_err_contains(
        gibake_scene::load(&path, &LoadOptions::default()),
        &["scene.gltf", "UTF-8"],
    );
}

#[test]
fn missing_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nothere.gltf");
    let e = assert_err_contains(
        gibake_scene::load(&path, &LoadOptions::default()),
        &["nothere.gltf", "cannot read"],
    );
    assert!(matches!(e, SceneError::Io { .. }));
}

#[test]
fn missing_or_broken_image() {
    let mut b = basic();
    let img = b.node(json!({})); // placeholder to keep indices simple
    let _ = img;
    b.json["images"] = json!([{ "uri": "nope.png" }]);
    b.json["textures"] = json!([{ "source": 0 }]);
    let m = b.material(json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }));
    let p = b.vec3s(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    let uv = b.floats(&[0.0; 6], "VEC2");
    let mesh = b.mesh_raw(
        "T",
        json!({ "attributes": { "POSITION": p, "TEXCOORD_0": uv }, "material": m }),
    );
    b.root_mesh_node("TN", mesh);
    assert_err_contains(b.load(), &[FILE, "image 0", "nope.png"]);
    b.json["images"] = json!([{ "uri": "data:image/png;base64,AAAA" }]);
    assert_err_contains(b.load(), &[FILE, "image 0", "decode"]);
}

#[test]
fn animated_light() {
    let mut b = basic();
    let t = b.floats(&[0.0, 1.0], "SCALAR");
    let v = b.floats(&[0.0, 5.0, 0.0, 1.0, 5.0, 0.0], "VEC3");
    // Light node is node 1 in basic().
    b.animation(json!({ "samplers": [ { "input": t, "output": v } ],
        "channels": [ { "sampler": 0, "target": { "node": 1, "path": "translation" } } ] }));
    let e = assert_err_contains(b.load(), &[FILE, "Key", "must not move"]);
    assert!(matches!(e, SceneError::Invalid { .. }));
}

#[test]
fn light_under_dynamic_parent() {
    let mut b = basic();
    let parent = b.node(json!({ "name": "Rig", "extras": { "dynamic": true } }));
    let l = b.light(json!({ "name": "Carried", "type": "directional" }));
    let n = b.node(json!({ "extensions": { "KHR_lights_punctual": { "light": l } } }));
    b.child(parent, n);
    b.root(parent);
    let opts = LoadOptions {
        lights: vec!["Carried".into()],
        ..Default::default()
    };
    assert_err_contains(b.load_with(&opts), &[FILE, "Carried", "must not move"]);
}

#[test]
fn bad_hierarchy_and_transforms() {
    // Cycle.
    let mut b = basic();
    let a = b.node(json!({ "name": "CycA" }));
    let c = b.node(json!({ "name": "CycB" }));
    b.child(a, c);
    b.child(c, a);
    assert_err_contains(b.load(), &[FILE, "cycle"]);
    // Two parents.
    let mut b = basic();
    let a = b.node(json!({ "name": "P1" }));
    let c = b.node(json!({ "name": "P2" }));
    let k = b.node(json!({ "name": "Kid" }));
    b.child(a, k);
    b.child(c, k);
    assert_err_contains(b.load(), &[FILE, "Kid", "P1", "P2"]);
    // Non-finite transform (1e39 overflows f32).
    let mut b = basic();
    b.json["nodes"][0]["scale"] = json!([1e39, 1.0, 1.0]);
    assert_err_contains(b.load(), &[FILE, "FloorNode", "non-finite transform"]);
    let mut b = basic();
    b.json["nodes"][0]["matrix"] = json!([1e39, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);
    assert_err_contains(b.load(), &[FILE, "non-finite transform"]);
}

#[test]
fn bad_animation_data() {
    let mut b = basic();
    let t = b.floats(&[1.0, 0.0], "SCALAR");
    let v = b.floats(&[0.0; 6], "VEC3");
    b.animation(
        json!({ "name": "Back", "samplers": [ { "input": t, "output": v } ],
        "channels": [ { "sampler": 0, "target": { "node": 0, "path": "translation" } } ] }),
    );
    assert_err_contains(b.load(), &[FILE, "Back", "increasing"]);
    let mut b = basic();
    let t = b.floats(&[0.0, 1.0], "SCALAR");
    let v = b.floats(&[0.0; 3], "VEC3");
    b.animation(json!({ "samplers": [ { "input": t, "output": v } ],
        "channels": [ { "sampler": 0, "target": { "node": 0, "path": "translation" } } ] }));
    assert_err_contains(b.load(), &[FILE, "animation #0", "expected 2"]);
}

#[test]
fn unsupported_required_extension_and_no_scene() {
    let mut b = basic();
    b.json["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    b.json["extensionsUsed"] = json!(["KHR_draco_mesh_compression", "KHR_lights_punctual"]);
    let e = assert_err_contains(b.load(), &[FILE, "KHR_draco_mesh_compression"]);
    assert!(matches!(e, SceneError::NotSupported { .. }));
    let j = br#"{ "asset": { "version": "2.0" } }"#;
    assert_err_contains(load_bytes(j, "empty.gltf"), &["empty.gltf", "no scene"]);
}

#[test]
fn bad_light_and_camera_parameters() {
    let mut b = basic();
    b.json["extensions"]["KHR_lights_punctual"]["lights"][0]["spot"]["outerConeAngle"] = json!(2.0);
    assert_err_contains(b.load(), &[FILE, "outerConeAngle"]);
    let mut b = basic();
    b.json["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(-1.0);
    assert_err_contains(b.load(), &[FILE, "Key", "non-negative"]);
    let mut b = basic();
    b.json["cameras"][0]["perspective"]["yfov"] = json!(0.0);
    assert_err_contains(b.load(), &[FILE, "Cam", "yfov"]);
    let mut b = basic();
    b.json["cameras"][0] = json!({ "type": "perspective", "orthographic": { "xmag": 1, "ymag": 1, "znear": 0, "zfar": 1 } });
    assert_err_contains(b.load(), &[FILE, "perspective"]);
}

// ------------------------------------------------- every light

fn every_light() -> LoadOptions {
    LoadOptions::default()
}

/// A spot, a directional and a point light with a range.
fn three_kinds() -> Builder {
    let mut b = two_spots();
    b.light_node(
        json!({ "name": "Bulb", "type": "point", "intensity": 5.0, "range": 3.0 }),
        json!({ "name": "C", "translation": [1.0, 2.0, 3.0] }),
    );
    b
}

#[test]
fn every_light_is_kept_the_sun_first() {
    // The directional light leads (a_directional_light_else_the_first_spot_leads);
    // the others keep their file order.
    let s = three_kinds().load_with(&every_light()).unwrap();
    let names: Vec<&str> = s.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Beta", "Alpha", "Bulb"]);
    assert_eq!(s.lights[0].kind, LightKind::Directional);
    assert!(matches!(s.lights[1].kind, LightKind::Spot { .. }));
    assert_eq!(s.lights[2].kind, LightKind::Point);
    assert_eq!(s.lights[2].color, glam::Vec3::splat(5.0));
    assert_eq!(s.lights[2].position, glam::Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(s.lights[2].range, Some(3.0));
    assert_eq!(s.lights[0].range, None);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn repeated_light_option_restricts_the_set() {
    let opts = LoadOptions {
        lights: vec!["Bulb".into(), "A".into(), "Bulb".into()],
        ..every_light()
    };
    let s = three_kinds().load_with(&opts).unwrap();
    let names: Vec<&str> = s.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Alpha", "Bulb"], "file order, each once");
    assert!(
        s.warnings.iter().any(|w| w.contains("Beta")),
        "{:?}",
        s.warnings
    );
}

/// The first light is the primary one: the first directional light in
/// file order leads (a sun covers the level: full-size maps, cascades),
/// else the first spot; the others keep their order; a file of point
/// lights only keeps its order.
#[test]
fn a_directional_light_else_the_first_spot_leads() {
    // The lights' names in the scene's order after import, for lights of
    // the given names and types in file order.
    let order = |lights: &[(&str, &str)]| -> Vec<String> {
        let mut b = Builder::new();
        let q = b.quad("Floor", true);
        b.root_mesh_node("F", q);
        for &(name, ty) in lights {
            let light = if ty == "spot" {
                json!({ "name": name, "type": ty, "spot": {} })
            } else {
                json!({ "name": name, "type": ty })
            };
            b.light_node(light, json!({ "translation": [0.0, 2.0, 0.0] }));
        }
        let s = b.load_with(&every_light()).unwrap();
        s.lights.iter().map(|l| l.name.clone()).collect()
    };
    assert_eq!(
        order(&[
            ("P1", "point"),
            ("S", "spot"),
            ("P2", "point"),
            ("D", "directional"),
        ]),
        ["D", "P1", "S", "P2"]
    );
    // Without a directional light the first spot leads.
    assert_eq!(
        order(&[("P1", "point"), ("S1", "spot"), ("S2", "spot")]),
        ["S1", "P1", "S2"]
    );
    // Point lights only: file order.
    assert_eq!(order(&[("P1", "point"), ("P2", "point")]), ["P1", "P2"]);
}

#[test]
fn too_many_lights_are_refused() {
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("F", q);
    for i in 0..5 {
        b.light_node(
            json!({ "name": format!("L{i}"), "type": "point" }),
            json!({ "translation": [0.0, 1.0 + i as f32, 0.0] }),
        );
    }
    let mut opts = every_light();
    opts.limits.max_lights = 4;
    let e = assert_err_contains(b.load_with(&opts), &[FILE, "5 lights", "--max-lights"]);
    assert!(matches!(e, SceneError::Invalid { .. }), "{e:?}");
    opts.limits.max_lights = 5;
    assert_eq!(b.load_with(&opts).unwrap().lights.len(), 5);
}

#[test]
fn bad_ranges_are_refused() {
    for range in [json!(0.0), json!(-1.0)] {
        let mut b = Builder::new();
        let q = b.quad("Floor", true);
        b.root_mesh_node("F", q);
        b.light_node(
            json!({ "name": "Bulb", "type": "point", "range": range }),
            json!({}),
        );
        let e = assert_err_contains(b.load_with(&every_light()), &[FILE, "Bulb", "range"]);
        assert!(matches!(e, SceneError::Invalid { .. }), "{e:?}");
    }
    // On a directional light a range means nothing: warned, dropped.
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("F", q);
    b.light_node(
        json!({ "name": "Sun", "type": "directional", "range": 4.0 }),
        json!({}),
    );
    let s = b.load_with(&every_light()).unwrap();
    assert_eq!(s.light().range, None);
    assert!(
        s.warnings.iter().any(|w| w.contains("range")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn only_point_lights_load_in_the_every_light_mode() {
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("F", q);
    b.light_node(
        json!({ "name": "Bulb", "type": "point", "intensity": 5.0 }),
        json!({ "name": "BulbNode" }),
    );
    let s = b.load_with(&every_light()).unwrap();
    assert_eq!(s.lights.len(), 1);
    assert_eq!(s.light().kind, LightKind::Point);
}
