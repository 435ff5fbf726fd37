//! Valid glTF 2.0 that the `gltf` crate refuses (issue 49, item 5), and the
//! rules that stay errors: accessors without `bufferView` (zeros, with
//! `sparse` substitution on top) used and unused, hostile sparse accessors,
//! the other places where gltf-json is stricter than the specification
//! (integral numbers written as `4.0`, scenes without nodes, channels
//! without a target node, primitives without POSITION, enum values glTF
//! does not define, GLB chunks of unknown type), and gltf-json's checks
//! that the Khronos validator shares.
//!
//! The fixtures in `data/gltf-rules/` are written by [`fixtures`]
//! (`fixtures_are_current` checks the committed bytes; the ignored
//! `write_fixtures` writes them again), and
//! `the_khronos_validator_and_gibake_agree` runs the validator
//! (`data/validate`, needs Node.js and `npm ci` there, as
//! `scripts/test.sh` does) on each and checks both verdicts against the
//! table of [`CASES`].

use crate::common;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use common::{Builder, assert_err_contains, basic, png};
use gibake_scene::{LoadOptions, Mesh, Scene, SceneError};
use glam::{Vec2, Vec3};
use serde_json::{Value, json};

/// Appends `a` to the accessors; returns its index.
fn accessor(b: &mut Builder, a: Value) -> usize {
    let list = b.json["accessors"].as_array_mut().expect("accessors");
    list.push(a);
    list.len() - 1
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn u16_bytes(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A sparse object substituting `values` (VEC3) at `indices` (u16).
fn sparse(b: &mut Builder, indices: &[u16], values: &[[f32; 3]]) -> Value {
    let iv = b.view(&u16_bytes(indices));
    let flat: Vec<f32> = values.iter().flatten().copied().collect();
    let vv = b.view(&f32_bytes(&flat));
    json!({ "count": indices.len(),
            "indices": { "bufferView": iv, "componentType": 5123 },
            "values": { "bufferView": vv } })
}

/// The wall's corners: vertex 0 is the origin (left as the zeros of an
/// accessor without `bufferView`), 1–3 come from a sparse substitution.
const WALL: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
];

/// Adds the mesh "Wall" on node "WallNode": POSITION without `bufferView`
/// (zeros, with [`WALL`]'s vertices 1–3 substituted by `sparse`), indices
/// from a buffer view; `edit` may change the POSITION accessor first.
/// Returns the POSITION accessor.
fn wall(b: &mut Builder, edit: impl FnOnce(&mut Builder, &mut Value)) -> usize {
    let s = sparse(b, &[1, 2, 3], &WALL[1..]);
    let mut pos = json!({ "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0], "sparse": s });
    edit(b, &mut pos);
    let p = accessor(b, pos);
    let i = b.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let m = b.mesh_raw(
        "Wall",
        json!({ "attributes": { "POSITION": p }, "indices": i }),
    );
    b.root_mesh_node("WallNode", m);
    p
}

fn mesh<'a>(s: &'a Scene, name: &str) -> &'a Mesh {
    s.static_meshes
        .iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("no static mesh {name}"))
}

/// An accessor of four zero VEC3s: no `bufferView`, no `sparse`.
fn hollow() -> Value {
    json!({ "componentType": 5126, "count": 4, "type": "VEC3" })
}

// ------------------------------------------------------------ accessors without bufferView

#[test]
fn an_unused_accessor_without_buffer_view_changes_nothing() {
    let mut b = basic();
    let before = b.load().unwrap();
    accessor(&mut b, hollow());
    for (bytes, name) in [(b.gltf(), "level.gltf"), (b.glb(), "level.glb")] {
        let s = gibake_scene::load_from_slice(&bytes, Path::new(name), &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.static_meshes, before.static_meshes, "{name}");
        assert_eq!(s.materials, before.materials, "{name}");
        assert!(s.warnings.is_empty(), "{name}: {:?}", s.warnings);
    }
}

#[test]
fn sparse_substitution_makes_geometry_of_zeros() {
    // POSITION without bufferView: zeros, vertices 1-3 substituted.
    let mut b = basic();
    wall(&mut b, |_, _| {});
    let s = b.load().unwrap();
    let w = mesh(&s, "WallNode/Wall/0");
    assert_eq!(w.positions, WALL.map(Vec3::from).to_vec());
    assert_eq!(w.indices, [0, 1, 2, 0, 2, 3]);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);

    // Sparse on an accessor with a bufferView: the floor's vertex 2 moves.
    let mut b = basic();
    let s = sparse(&mut b, &[2], &[[1.0, 0.5, 1.0]]);
    b.json["accessors"][0]["sparse"] = s;
    b.json["accessors"][0]["max"] = json!([1.0, 0.5, 1.0]);
    let s = b.load().unwrap();
    let f = mesh(&s, "FloorNode/Floor/0");
    assert_eq!(f.positions[2], Vec3::new(1.0, 0.5, 1.0));
    assert_eq!(f.positions[1], Vec3::new(-1.0, 0.0, 1.0));

    // Indices without bufferView: zeros, then [0 1 2 0 2 3] by sparse
    // substitution of elements 1, 2, 4, 5.
    let mut b = basic();
    let iv = b.view(&u16_bytes(&[1, 2, 4, 5]));
    let vv = b.view(&u16_bytes(&[1, 2, 2, 3]));
    let ia = accessor(
        &mut b,
        json!({ "componentType": 5123, "count": 6, "type": "SCALAR",
                "sparse": { "count": 4, "indices": { "bufferView": iv, "componentType": 5123 },
                            "values": { "bufferView": vv } } }),
    );
    b.json["meshes"][0]["primitives"][0]["indices"] = json!(ia);
    let s = b.load().unwrap();
    assert_eq!(mesh(&s, "FloorNode/Floor/0").indices, [0, 1, 2, 0, 2, 3]);
}

#[test]
fn zero_texture_coordinates_and_normals_without_buffer_view() {
    let mut b = basic();
    let t = b.png_texture(&png(1, 1, 3, &[200, 100, 50]));
    let m = b.material(json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": t } } }));
    let uv = accessor(
        &mut b,
        json!({ "componentType": 5126, "count": 4, "type": "VEC2" }),
    );
    let n = accessor(&mut b, hollow());
    let prim = &mut b.json["meshes"][0]["primitives"][0];
    prim["material"] = json!(m);
    prim["attributes"]["TEXCOORD_0"] = json!(uv);
    prim["attributes"]["NORMAL"] = json!(n);
    let s = b.load().unwrap();
    let f = mesh(&s, "FloorNode/Floor/0");
    assert_eq!(f.uvs.as_deref(), Some(&[Vec2::ZERO; 4][..]));
    // Zero normals are recomputed (facing +Y), with the usual warning.
    assert!(f.normals.iter().all(|n| (*n - Vec3::Y).length() < 1e-6));
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("zero or non-finite normals")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn a_used_accessor_of_zeros_gives_degenerate_triangles_not_an_error() {
    let mut b = basic();
    let p = accessor(
        &mut b,
        json!({ "componentType": 5126, "count": 3, "type": "VEC3",
                "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0] }),
    );
    let m = b.mesh_raw("Zeros", json!({ "attributes": { "POSITION": p } }));
    b.root_mesh_node("ZerosNode", m);
    let s = b.load().unwrap();
    assert!(
        s.static_meshes
            .iter()
            .all(|m| m.name != "ZerosNode/Zeros/0")
    );
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("degenerate") && w.contains("ZerosNode/Zeros/0")),
        "{:?}",
        s.warnings
    );
}

/// Each hostile accessor is one clear error naming the file and the
/// accessor, never a panic (the CLI's exit 2: tests/hostile.rs).
#[test]
fn hostile_sparse_accessors_and_accessors_without_buffer_view_are_errors() {
    type Edit = Box<dyn Fn(&mut Builder, &mut Value)>;
    let cases: Vec<(&str, Edit, &[&str])> = vec![
        (
            "decreasing indices",
            Box::new(|b, p| p["sparse"] = sparse(b, &[2, 1, 3], &WALL[1..])),
            &["strictly increase", "index 1 is 1 after 2"],
        ),
        (
            "a repeated index",
            Box::new(|b, p| p["sparse"] = sparse(b, &[1, 1, 3], &WALL[1..])),
            &["strictly increase"],
        ),
        (
            "an index out of range",
            Box::new(|b, p| p["sparse"] = sparse(b, &[1, 2, 9], &WALL[1..])),
            &["sparse index 9 is out of range (count 4)"],
        ),
        (
            "sparse count 0",
            Box::new(|_, p| p["sparse"]["count"] = json!(0)),
            &["sparse count is 0"],
        ),
        (
            "sparse count over the accessor's",
            Box::new(|_, p| p["sparse"]["count"] = json!(5)),
            &["sparse count 5 exceeds the accessor's count 4"],
        ),
        (
            "indices that do not fit their view",
            Box::new(|b, p| {
                let v = b.view(&u16_bytes(&[1, 2]));
                p["sparse"]["indices"]["bufferView"] = json!(v);
            }),
            &["do not fit"],
        ),
        (
            "values that do not fit their view",
            Box::new(|b, p| {
                let v = b.view(&f32_bytes(&[1.0; 6]));
                p["sparse"]["values"]["bufferView"] = json!(v);
            }),
            &["do not fit"],
        ),
        (
            "a strided view of values",
            Box::new(|b, p| {
                let v = b.view(&f32_bytes(&[1.0; 9]));
                b.json["bufferViews"][v]["byteStride"] = json!(12);
                p["sparse"]["values"]["bufferView"] = json!(v);
            }),
            &["sparse values has byteStride 12"],
        ),
        (
            "float sparse indices",
            Box::new(|_, p| p["sparse"]["indices"]["componentType"] = json!(5126)),
            &["invalid sparse index componentType"],
        ),
        (
            "a sparse view that does not exist",
            Box::new(|_, p| p["sparse"]["values"]["bufferView"] = json!(99)),
            &["sparse.values.bufferView: Index out of bounds"],
        ),
        (
            "a non-finite sparse value",
            Box::new(|b, p| {
                p["sparse"] = sparse(
                    b,
                    &[1, 2, 3],
                    &[[1.0, 0.0, 0.0], [f32::NAN, 1.0, 0.0], [0.0, 1.0, 0.0]],
                )
            }),
            &["vertex 2 is not finite"],
        ),
        (
            "byteOffset without bufferView",
            Box::new(|_, p| p["byteOffset"] = json!(0)),
            &["byteOffset 0 without a bufferView"],
        ),
        (
            "more zeros than the element budget",
            Box::new(|_, p| p["count"] = json!(20_000_000)),
            &["--max-elements"],
        ),
    ];
    for (what, edit, needles) in cases {
        let mut b = basic();
        let p = wall(&mut b, |b, p| edit(b, p));
        let r = b.load();
        assert!(r.is_err(), "{what}: loaded");
        let e = assert_err_contains(r, needles).to_string();
        assert!(
            e.starts_with("test_scene.gltf: ")
                && (e.contains(&format!("accessor {p}")) || e.contains(&format!("accessors[{p}]"))),
            "{what}: {e}"
        );
    }

    // Past the element budget too, the zeros are bounded in bytes.
    let mut b = basic();
    wall(&mut b, |_, p| p["count"] = json!(30_000_000));
    let mut options = LoadOptions::default();
    options.limits.max_elements = u64::MAX;
    assert_err_contains(
        b.load_with(&options),
        &["count 30000000 is too large for an accessor without bufferView"],
    );

    // The rules that need no data hold for an accessor nothing uses.
    for (sparse_count, needle) in [(0, "sparse count is 0"), (9, "exceeds")] {
        let mut b = basic();
        let mut a = hollow();
        a["sparse"] = sparse(&mut b, &[0], &[[1.0; 3]]);
        a["sparse"]["count"] = json!(sparse_count);
        accessor(&mut b, a);
        assert_err_contains(b.load(), &[needle]);
    }
}

// ------------------------------------------------------------ the other rules

#[test]
fn integral_numbers_written_as_floats_are_integers() {
    let b = basic();
    let before = b.load().unwrap();
    let mut j = b.json_with_data_uri();
    j["accessors"][0]["count"] = json!(4.0);
    j["accessors"][2]["componentType"] = json!(5123.0);
    j["meshes"][0]["primitives"][0]["indices"] = json!(2.0);
    j["scene"] = json!(0.0);
    let text = serde_json::to_string(&j).unwrap();
    assert!(text.contains("\"count\":4.0"), "{text}");
    let s = load_json(&j).unwrap();
    assert_eq!(s.static_meshes, before.static_meshes);
    // Extras survive the relaxed parse: a moving object stays one.
    let mut moving = j.clone();
    moving["nodes"][0]["extras"] = json!({ "dynamic": true });
    let q = json!({ "name": "GroundNode", "mesh": 0, "translation": [0.0, -1.0, 0.0] });
    moving["nodes"].as_array_mut().unwrap().push(q);
    moving["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!(3));
    let s = load_json(&moving).unwrap();
    assert_eq!(s.dynamic_objects.len(), 1);
    assert_eq!(s.dynamic_objects[0].name, "FloorNode");
    // A fraction where an integer belongs stays an error (without its
    // line and column when other numbers needed the relaxed parse).
    j["accessors"][0]["count"] = json!(4.5);
    assert_err_contains(load_json(&j), &["not a valid glTF 2.0 file", "`4.5`"]);
}

fn load_json(j: &Value) -> Result<Scene, SceneError> {
    gibake_scene::load_from_slice(
        &serde_json::to_vec(j).unwrap(),
        Path::new("test_scene.gltf"),
        &LoadOptions::default(),
    )
}

#[test]
fn a_scene_without_nodes_is_empty() {
    let mut b = basic();
    b.json["scenes"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "name": "Empty" }));
    assert_eq!(b.load().unwrap().triangle_counts(), (2, 0));
    // As the scene to import, it holds nothing: the usual errors.
    b.json["scene"] = json!(1);
    assert_err_contains(b.load(), &["no KHR_lights_punctual light"]);
    let options = LoadOptions {
        sun: Some(gibake_scene::Sun::new(30.0, 45.0)),
        ..Default::default()
    };
    assert_err_contains(b.load_with(&options), &["no static triangles"]);
}

#[test]
fn channels_without_a_node_or_with_an_extensions_path_are_ignored() {
    let mut b = basic();
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let out = b.floats(&[0.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let intensity = b.floats(&[5.0, 10.0], "SCALAR");
    b.json["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_animation_pointer"]);
    b.animation(json!({ "name": "Pointers",
        "samplers": [ { "input": times, "output": intensity }, { "input": times, "output": out } ],
        "channels": [
            { "sampler": 0, "target": { "path": "pointer", "extensions": { "KHR_animation_pointer":
                { "pointer": "/extensions/KHR_lights_punctual/lights/0/intensity" } } } },
            { "sampler": 1, "target": { "path": "translation" } },
            { "sampler": 1, "target": { "node": 0, "path": "shear" } } ] }));
    let s = b.load().unwrap();
    assert!(s.dynamic_objects.is_empty());
    assert_eq!(s.triangle_counts(), (2, 0));
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("animation 'Pointers': channel(s) 0, 1, 2 ignored")),
        "{:?}",
        s.warnings
    );
    // A channel of the same animation that targets a node still moves it.
    b.json["animations"][0]["channels"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "sampler": 1, "target": { "node": 0, "path": "translation" } }));
    let q = b.quad("Ground", true);
    b.root_mesh_node("GroundNode", q);
    let s = b.load().unwrap();
    assert_eq!(s.dynamic_objects.len(), 1);
    assert_eq!(s.dynamic_objects[0].name, "FloorNode");
}

#[test]
fn a_primitive_without_position_is_skipped() {
    let mut b = basic();
    let n = b.vec3s(&[[0.0, 1.0, 0.0]; 3]);
    let m = b.mesh_raw("NoPos", json!({ "attributes": { "NORMAL": n } }));
    b.root_mesh_node("NoPosNode", m);
    let s = b.load().unwrap();
    assert_eq!(s.triangle_counts(), (2, 0));
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("NoPosNode/NoPos/0: primitive has no POSITION")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn enum_values_gltf_does_not_define_matter_only_where_used() {
    // Unused: a sampler, a buffer view target, an accessor, a camera, a
    // light, an animation sampler.
    let mut b = basic();
    b.json["samplers"] = json!([{ "wrapS": 1234, "magFilter": 1 }]);
    b.json["bufferViews"][0]["target"] = json!(1);
    accessor(
        &mut b,
        json!({ "componentType": 5130, "count": 1, "type": "VEC5" }),
    );
    b.camera(json!({ "type": "fisheye", "perspective": { "yfov": 1.0, "znear": 0.1 } }));
    b.json["extensions"]["KHR_lights_punctual"]["lights"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "type": "area" }));
    let t = b.floats(&[0.0, 1.0], "SCALAR");
    b.animation(
        json!({ "samplers": [ { "input": t, "output": t, "interpolation": "BEZIER" } ],
                        "channels": [] }),
    );
    let s = b.load().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.camera.as_ref().unwrap().name, "Cam");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);

    // Used: a camera of unknown type is passed over (the next one is
    // used), a material's alphaMode is OPAQUE with a warning, a primitive
    // mode is skipped, an interpolation cannot be sampled.
    let mut b = basic();
    let c = b.camera(
        json!({ "name": "Fish", "type": "fisheye", "perspective": { "yfov": 1.0, "znear": 0.1 } }),
    );
    let n = b.node(json!({ "name": "FishNode", "camera": c }));
    b.json["scenes"][0]["nodes"]
        .as_array_mut()
        .unwrap()
        .insert(0, json!(n));
    let m = b.material(json!({ "alphaMode": "DITHER" }));
    b.json["meshes"][0]["primitives"][0]["material"] = json!(m);
    let q = b.quad("Strip", true);
    b.json["meshes"][q]["primitives"][0]["mode"] = json!(9);
    b.root_mesh_node("StripNode", q);
    let s = b.load().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.camera.as_ref().unwrap().name, "Cam");
    assert_eq!(s.triangle_counts(), (2, 0));
    for needle in [
        "camera 'Fish' ignored",
        "alphaMode is not one glTF 2.0 defines",
        "StripNode/Strip/0: invalid primitive mode, skipped",
    ] {
        assert!(
            s.warnings.iter().any(|w| w.contains(needle)),
            "{needle}: {:?}",
            s.warnings
        );
    }
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let out = b.floats(&[0.0; 6], "VEC3");
    b.animation(json!({ "samplers": [ { "input": times, "output": out, "interpolation": "BEZIER" } ],
                        "channels": [ { "sampler": 0, "target": { "node": 0, "path": "translation" } } ] }));
    assert!(matches!(
        assert_err_contains(b.load(), &["interpolation glTF 2.0 does not define"]),
        SceneError::NotSupported { .. }
    ));
}

/// `bytes` (a GLB) with `chunks` appended, its total length updated.
fn with_chunks(mut bytes: Vec<u8>, chunks: &[(&[u8; 4], &[u8])]) -> Vec<u8> {
    for (kind, data) in chunks {
        assert!(data.len().is_multiple_of(4));
        bytes.extend_from_slice(&(data.len() as u32).to_le_bytes());
        bytes.extend_from_slice(*kind);
        bytes.extend_from_slice(data);
    }
    let n = bytes.len() as u32;
    bytes[8..12].copy_from_slice(&n.to_le_bytes());
    bytes
}

#[test]
fn glb_chunks_of_unknown_type_are_ignored() {
    let b = basic();
    let before = b.load().unwrap();
    // After the BIN chunk, and as the second chunk of a GLB without one.
    let after_bin = with_chunks(b.glb(), &[(b"XTRA", b"abcd")]);
    let mut no_bin = Builder::new();
    no_bin.json = b.json_with_data_uri();
    let no_bin = with_chunks(
        no_bin.glb(),
        &[(b"XTRA", b"abcd"), (b"\x01\x02\x03\x04", b"")],
    );
    for bytes in [after_bin, no_bin] {
        let s = gibake_scene::load_from_slice(&bytes, Path::new("x.glb"), &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.static_meshes, before.static_meshes);
    }
}

#[test]
fn gltf_rules_the_validator_shares_stay_errors() {
    type Edit = fn(&mut Value);
    let cases: [(Edit, &str); 6] = [
        (
            |j| {
                j["accessors"][0].as_object_mut().unwrap().remove("min");
            },
            "attributes[\"POSITION\"].min: Missing data",
        ),
        (
            |j| j["meshes"][0]["primitives"][0]["attributes"]["CUSTOM"] = json!(1),
            "<invalid semantic name>",
        ),
        (
            |j| {
                j["extensions"]["KHR_lights_punctual"]["lights"][0]
                    .as_object_mut()
                    .unwrap()
                    .remove("spot");
            },
            "lights[0].spot: Missing data",
        ),
        (
            |j| {
                j["cameras"][0]
                    .as_object_mut()
                    .unwrap()
                    .remove("perspective");
            },
            "cameras[0]: Missing data",
        ),
        (
            |j| j["bufferViews"][0]["byteStride"] = json!(2),
            "bufferViews[0].byteStride: Invalid value",
        ),
        (
            |j| j["meshes"][0]["primitives"][0]["indices"] = json!(40),
            "meshes[0].primitives[0].indices: Index out of bounds",
        ),
    ];
    for (edit, needle) in cases {
        let mut j = basic().json_with_data_uri();
        edit(&mut j);
        assert_err_contains(load_json(&j), &["not a valid glTF 2.0 file", needle]);
    }
}

// ------------------------------------------------------------ fixtures and the validator

/// What one tool says of a fixture.
#[derive(Clone, Copy, Debug)]
enum Verdict {
    /// No error.
    Valid,
    /// An error; for the validator its issue code, for gibake a part of
    /// its message.
    Error(&'static str),
}

/// Every fixture of `data/gltf-rules/` (and one real export): the
/// validator's verdict, then gibake's. They agree except where gibake
/// refuses a file it cannot decode (Draco), by name.
const CASES: &[(&str, Verdict, Verdict)] = &[
    (
        "gltf-rules/accessor-without-buffer-view.gltf",
        Verdict::Valid,
        Verdict::Valid,
    ),
    (
        "gltf-rules/sparse-without-buffer-view.gltf",
        Verdict::Valid,
        Verdict::Valid,
    ),
    (
        "gltf-rules/integral-numbers.gltf",
        Verdict::Valid,
        Verdict::Valid,
    ),
    (
        "gltf-rules/scene-without-nodes.gltf",
        Verdict::Valid,
        Verdict::Valid,
    ),
    (
        "gltf-rules/channel-without-node.gltf",
        Verdict::Valid,
        Verdict::Valid,
    ),
    (
        "gltf-rules/primitive-without-position.gltf",
        Verdict::Valid,
        Verdict::Valid,
    ),
    (
        "gltf-rules/undefined-enum-values.gltf",
        Verdict::Valid,
        Verdict::Valid,
    ),
    (
        "gltf-rules/unknown-glb-chunk.glb",
        Verdict::Valid,
        Verdict::Valid,
    ),
    (
        "gltf-rules/invalid-sparse-indices-not-increasing.gltf",
        Verdict::Error("ACCESSOR_SPARSE_INDICES_NON_INCREASING"),
        Verdict::Error("sparse indices must strictly increase"),
    ),
    (
        "gltf-rules/invalid-sparse-index-out-of-range.gltf",
        Verdict::Error("ACCESSOR_SPARSE_INDEX_OOB"),
        Verdict::Error("sparse index 7 is out of range"),
    ),
    (
        "gltf-rules/invalid-sparse-count-over.gltf",
        Verdict::Error("ACCESSOR_SPARSE_COUNT_OUT_OF_RANGE"),
        Verdict::Error("exceeds the accessor's count"),
    ),
    (
        "gltf-rules/invalid-sparse-strided-indices.gltf",
        Verdict::Error("BUFFER_VIEW_INVALID_BYTE_STRIDE"),
        Verdict::Error("sparse indices has byteStride"),
    ),
    (
        "gltf-rules/invalid-byte-offset-without-buffer-view.gltf",
        Verdict::Error("UNSATISFIED_DEPENDENCY"),
        Verdict::Error("without a bufferView"),
    ),
    (
        "gltf-rules/invalid-position-without-bounds.gltf",
        Verdict::Error("MESH_PRIMITIVE_POSITION_ACCESSOR_WITHOUT_BOUNDS"),
        Verdict::Error("POSITION\"].min: Missing data"),
    ),
    (
        "gltf-rules/invalid-glb-bin-not-second.glb",
        Verdict::Error("GLB_UNEXPECTED_BIN_CHUNK"),
        Verdict::Error("it must be the second chunk"),
    ),
    // The exception: valid, but its geometry exists only Draco-compressed.
    (
        "exports/refused/foliage.gt-draco.glb",
        Verdict::Valid,
        Verdict::Error("KHR_draco_mesh_compression"),
    ),
];

/// The fixtures of `data/gltf-rules/`: file name and bytes.
fn fixtures() -> Vec<(&'static str, Vec<u8>)> {
    let mut out = Vec::new();
    let text = |b: &Builder| b.gltf();

    // An unused accessor of zeros (as tools that decode Draco leave).
    let mut b = basic();
    accessor(&mut b, hollow());
    out.push(("accessor-without-buffer-view.gltf", text(&b)));

    // The wall: POSITION of zeros with three vertices substituted, and
    // zero texture coordinates under a texture.
    let mut b = basic();
    wall(&mut b, |_, _| {});
    let t = b.png_texture(&png(1, 1, 3, &[200, 100, 50]));
    let m = b.material(json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": t } } }));
    let uv = accessor(
        &mut b,
        json!({ "componentType": 5126, "count": 4, "type": "VEC2" }),
    );
    let w = b.json["meshes"].as_array().unwrap().len() - 1;
    b.json["meshes"][w]["primitives"][0]["material"] = json!(m);
    b.json["meshes"][w]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(uv);
    out.push(("sparse-without-buffer-view.gltf", text(&b)));

    let mut j = basic().json_with_data_uri();
    j["accessors"][0]["count"] = json!(4.0);
    j["accessors"][2]["componentType"] = json!(5123.0);
    j["scene"] = json!(0.0);
    out.push((
        "integral-numbers.gltf",
        serde_json::to_vec_pretty(&j).unwrap(),
    ));

    let mut b = basic();
    b.json["scenes"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "name": "Empty" }));
    out.push(("scene-without-nodes.gltf", text(&b)));

    let mut b = basic();
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let intensity = b.floats(&[5.0, 10.0], "SCALAR");
    b.json["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_animation_pointer"]);
    b.animation(json!({ "samplers": [ { "input": times, "output": intensity } ],
        "channels": [ { "sampler": 0, "target": { "path": "pointer", "extensions": { "KHR_animation_pointer":
            { "pointer": "/extensions/KHR_lights_punctual/lights/0/intensity" } } } } ] }));
    out.push(("channel-without-node.gltf", text(&b)));

    let mut b = basic();
    let n = b.vec3s(&[[0.0, 1.0, 0.0]; 3]);
    let m = b.mesh_raw("NoPos", json!({ "attributes": { "NORMAL": n } }));
    b.root_mesh_node("NoPosNode", m);
    out.push(("primitive-without-position.gltf", text(&b)));

    let mut b = basic();
    b.json["samplers"] = json!([{ "wrapS": 1234 }]);
    b.json["bufferViews"][0]["target"] = json!(1);
    b.camera(json!({ "type": "fisheye", "perspective": { "yfov": 1.0, "znear": 0.1 } }));
    accessor(
        &mut b,
        json!({ "componentType": 5130, "count": 1, "type": "VEC3" }),
    );
    out.push(("undefined-enum-values.gltf", text(&b)));

    out.push((
        "unknown-glb-chunk.glb",
        with_chunks(basic().glb(), &[(b"XTRA", b"abcd")]),
    ));

    let mut b = basic();
    wall(&mut b, |b, p| {
        p["sparse"] = sparse(b, &[1, 3, 2], &WALL[1..])
    });
    out.push(("invalid-sparse-indices-not-increasing.gltf", text(&b)));

    let mut b = basic();
    wall(&mut b, |b, p| {
        p["sparse"] = sparse(b, &[1, 2, 7], &WALL[1..])
    });
    out.push(("invalid-sparse-index-out-of-range.gltf", text(&b)));

    let mut b = basic();
    let mut a = hollow();
    a["sparse"] = sparse(&mut b, &[0, 1, 2, 3, 4], &[[0.0; 3]; 5]);
    accessor(&mut b, a);
    out.push(("invalid-sparse-count-over.gltf", text(&b)));

    let mut b = basic();
    wall(&mut b, |b, p| {
        let bytes: Vec<u8> = [1u16, 2, 3]
            .iter()
            .flat_map(|i| [i.to_le_bytes().as_slice(), &[0, 0]].concat())
            .collect();
        let nv = b.view(&bytes);
        b.json["bufferViews"][nv]["byteStride"] = json!(4);
        p["sparse"]["indices"]["bufferView"] = json!(nv);
    });
    out.push(("invalid-sparse-strided-indices.gltf", text(&b)));

    let mut b = basic();
    let mut a = hollow();
    a["byteOffset"] = json!(0);
    accessor(&mut b, a);
    out.push(("invalid-byte-offset-without-buffer-view.gltf", text(&b)));

    let mut b = basic();
    let a = b.json["accessors"][0].as_object_mut().unwrap();
    a.remove("min");
    a.remove("max");
    out.push(("invalid-position-without-bounds.gltf", text(&b)));

    // JSON, an unknown chunk, then BIN.
    let b = basic();
    let glb = b.glb();
    let jlen = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let (head, bin) = glb.split_at(20 + jlen);
    let mut moved = with_chunks(head.to_vec(), &[(b"XTRA", b"abcd")]);
    moved.extend_from_slice(bin);
    let n = moved.len() as u32;
    moved[8..12].copy_from_slice(&n.to_le_bytes());
    out.push(("invalid-glb-bin-not-second.glb", moved));
    out
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data")
}

#[test]
fn fixtures_are_current() {
    let dir = data_dir().join("gltf-rules");
    let made = fixtures();
    for (name, bytes) in &made {
        let committed = std::fs::read(dir.join(name)).unwrap_or_else(|e| {
            panic!("data/gltf-rules/{name}: {e} (run the ignored test write_fixtures)")
        });
        assert!(
            committed == *bytes,
            "data/gltf-rules/{name} differs from what the test makes: run \
             `cargo test --release -p gibake-scene --test integration valid_gltf::write_fixtures -- --ignored`"
        );
    }
    // Every fixture is judged, and every judged file is a fixture.
    let judged: Vec<&str> = CASES
        .iter()
        .filter_map(|c| c.0.strip_prefix("gltf-rules/"))
        .collect();
    let mut names: Vec<&str> = made.iter().map(|f| f.0).collect();
    let mut sorted = judged.clone();
    names.sort_unstable();
    sorted.sort_unstable();
    assert_eq!(names, sorted);
}

#[test]
#[ignore = "writes data/gltf-rules/ (then commit it)"]
fn write_fixtures() {
    let dir = data_dir().join("gltf-rules");
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bytes) in fixtures() {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
}

/// Runs the Khronos validator (`data/validate/validate.mjs`) on `files`:
/// the error codes it reports for each (none: valid).
fn khronos_validator(files: &[PathBuf]) -> HashMap<PathBuf, Vec<String>> {
    let dir = data_dir().join("validate");
    assert!(
        dir.join("node_modules/gltf-validator").is_dir(),
        "the Khronos validator is not installed: run `cd data/validate && npm ci` \
         (Node.js and npm: scripts/ensure-deps.sh --node; scripts/test.sh does both)"
    );
    let out = std::process::Command::new("node")
        .arg("validate.mjs")
        .args(files)
        .current_dir(&dir)
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run node ({e}): install Node.js with scripts/ensure-deps.sh --node")
        });
    let text = String::from_utf8_lossy(&out.stdout);
    let mut codes: HashMap<PathBuf, Vec<String>> = HashMap::new();
    let mut current: Option<PathBuf> = None;
    for line in text.lines() {
        if let Some(f) = files
            .iter()
            .find(|f| line.starts_with(&format!("{}: ", f.display())))
        {
            assert!(!line.contains("could not be validated"), "{line}");
            codes.insert(f.clone(), Vec::new());
            current = Some(f.clone());
        } else if let (Some(rest), Some(f)) = (line.strip_prefix("  error "), &current) {
            let code = rest.split_whitespace().next().unwrap_or_default();
            codes.get_mut(f).unwrap().push(code.to_string());
        }
    }
    for f in files {
        assert!(
            codes.contains_key(f),
            "no verdict for {} in the validator's output:\n{text}\n{}",
            f.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    codes
}

#[test]
fn the_khronos_validator_and_gibake_agree() {
    let files: Vec<PathBuf> = CASES.iter().map(|c| data_dir().join(c.0)).collect();
    let codes = khronos_validator(&files);
    let mut wrong = Vec::new();
    for ((name, validator, gibake), file) in CASES.iter().zip(&files) {
        let got = &codes[file];
        match validator {
            Verdict::Valid if !got.is_empty() => {
                wrong.push(format!("{name}: the validator found errors {got:?}"))
            }
            Verdict::Error(code) if !got.iter().any(|c| c == code) => wrong.push(format!(
                "{name}: the validator's errors {got:?} lack {code}"
            )),
            _ => {}
        }
        let r = gibake_scene::load(file, &LoadOptions::default());
        match (gibake, r) {
            (Verdict::Valid, Err(e)) => wrong.push(format!("{name}: gibake refused it: {e}")),
            (Verdict::Error(_), Ok(_)) => wrong.push(format!("{name}: gibake loaded it")),
            (Verdict::Error(needle), Err(e)) if !e.to_string().contains(needle) => {
                wrong.push(format!("{name}: gibake's error lacks {needle:?}: {e}"))
            }
            _ => {}
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
