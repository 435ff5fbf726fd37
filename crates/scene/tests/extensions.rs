//! The glTF extensions real exporters write, imported from the files in
//! `data/exports/` (made by gltfpack and gltf-transform, see
//! `tools/exports/run.sh`) and from small synthetic files, each checked
//! against what the file asks for. The images these scenes bake to are
//! judged in `tests/exports.rs`.

use crate::common;

use std::path::{Path, PathBuf};

use common::{Builder, assert_err_contains, basic, png};
use gibake_scene::{AlphaMode, LoadOptions, Scene, SceneError, static_scene_hash};
use glam::{Vec2, Vec3};
use serde_json::{Value, json};

fn exports(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/exports")
        .join(name)
}

fn load(name: &str) -> Scene {
    let p = exports(name);
    gibake_scene::load(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// A GLB's JSON and BIN chunk.
fn split_glb(bytes: &[u8]) -> (Value, Vec<u8>) {
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
    let jlen = word(12);
    let json = serde_json::from_slice(&bytes[20..20 + jlen]).expect("JSON chunk");
    let bin = if bytes.len() > 20 + jlen {
        let blen = word(20 + jlen);
        bytes[28 + jlen..28 + jlen + blen].to_vec()
    } else {
        Vec::new()
    };
    (json, bin)
}

/// A GLB from a JSON document and a BIN chunk (buffers kept as they are).
fn join_glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut js = serde_json::to_vec(json).unwrap();
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + js.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

/// Loads `name` from data/exports after `edit` changed its JSON.
fn load_edited(name: &str, edit: impl FnOnce(&mut Value)) -> Result<Scene, SceneError> {
    load_edited_with(name, &LoadOptions::default(), edit)
}

fn load_edited_with(
    name: &str,
    options: &LoadOptions,
    edit: impl FnOnce(&mut Value),
) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(exports(name)).expect("export");
    let (mut j, bin) = split_glb(&bytes);
    edit(&mut j);
    gibake_scene::load_from_slice(&join_glb(&j, &bin), &exports(name), options)
}

fn static_mesh<'a>(s: &'a Scene, prefix: &str) -> Vec<&'a gibake_scene::Mesh> {
    s.static_meshes
        .iter()
        .filter(|m| m.name.starts_with(prefix))
        .collect()
}

/// Every vertex of `a` lies within `tol` of a vertex of `b`.
fn same_points(a: &[Vec3], b: &[Vec3], tol: f32) -> bool {
    a.iter()
        .all(|p| b.iter().any(|q| (*p - *q).length() <= tol))
}

// ------------------------------------------------------------------ meshopt

#[test]
fn meshopt_exports_decode_to_the_source_geometry() {
    let source = gibake_scene::load(&exports("../corner_bunny.glb"), &LoadOptions::default())
        .expect("source");
    let packed = load("corner_bunny.gt-meshopt.glb");
    let (s, p) = (source.triangle_counts(), packed.triangle_counts());
    assert_eq!(s, p, "triangle counts (static, dynamic)");
    // gltf-transform quantizes positions to 14 bits per mesh: the bunny
    // (0.6 m) moves by under 0.1 mm.
    let bunny = |sc: &Scene| static_mesh(sc, "bunny")[0].positions.clone();
    assert!(same_points(&bunny(&packed), &bunny(&source), 1e-4));
    assert!(packed.warnings.is_empty(), "{:?}", packed.warnings);

    // gltfpack -cc: octahedral normals, exponential animation data.
    let sun = load("sun.pack-cc.glb");
    let src = gibake_scene::load(&exports("../sun.glb"), &LoadOptions::default()).expect("sun");
    assert_eq!(sun.triangle_counts(), src.triangle_counts());
    for m in &sun.static_meshes {
        for n in &m.normals {
            assert!((n.length() - 1.0).abs() < 1e-3, "{}: normal {n}", m.name);
        }
    }
    // The moving box follows the same path (resampled at 30 Hz, keys at 14 bits).
    for t in [0.0f32, 0.7, 1.9, 3.3] {
        let a = sun.dynamic_bounds(0, t).center();
        let b = src.dynamic_bounds(0, t).center();
        assert!((a - b).length() < 2e-3, "t = {t}: {a} vs {b}");
    }
}

#[test]
fn khr_meshopt_compression_reads_like_ext() {
    let ext = load("sun.pack-cc.glb");
    let khr = load_edited("sun.pack-cc.glb", |j| {
        let s = serde_json::to_string(j)
            .unwrap()
            .replace("EXT_meshopt_compression", "KHR_meshopt_compression");
        *j = serde_json::from_str(&s).unwrap();
    })
    .expect("KHR_meshopt_compression loads");
    assert_eq!(static_scene_hash(&ext), static_scene_hash(&khr));
    assert!(khr.warnings.is_empty(), "{:?}", khr.warnings);
}

#[test]
fn meshopt_budgets_and_damage_are_errors() {
    // The element budget covers decoded views before they are allocated.
    let opts = LoadOptions {
        limits: gibake_scene::Limits {
            max_elements: 100,
            ..Default::default()
        },
        ..Default::default()
    };
    let e = load_edited_with("sun.pack-cc.glb", &opts, |_| {}).unwrap_err();
    assert!(
        e.to_string().contains("--max-elements") && e.to_string().contains("meshopt"),
        "{e}"
    );
    // So does the byte budget.
    let opts = LoadOptions {
        limits: gibake_scene::Limits {
            max_input_bytes: 1000,
            ..Default::default()
        },
        ..Default::default()
    };
    let e = gibake_scene::load_from_slice(
        &std::fs::read(exports("sun.pack-cc.glb")).unwrap(),
        Path::new("x.glb"),
        &opts,
    )
    .unwrap_err();
    assert!(e.to_string().contains("--max-input-bytes"), "{e}");
    // A huge declared count: refused by the budget, nothing allocated.
    let e = load_edited("sun.pack-cc.glb", |j| {
        let v = &mut j["bufferViews"][0];
        v["byteLength"] = json!(4_000_000_000u64);
        v["extensions"]["EXT_meshopt_compression"]["count"] = json!(1_000_000_000u64);
        v["extensions"]["EXT_meshopt_compression"]["byteStride"] = json!(4);
    })
    .unwrap_err();
    assert!(e.to_string().contains("bufferView 0"), "{e}");
    // A stride the codec would assert on.
    let e = load_edited("sun.pack-cc.glb", |j| {
        let x = &mut j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"];
        let count = x["count"].as_u64().unwrap();
        x["byteStride"] = json!(6);
        j["bufferViews"][0]["byteLength"] = json!(count * 6);
    })
    .unwrap_err();
    assert!(e.to_string().contains("byteStride 6"), "{e}");
    // Compressed bytes outside their buffer, and garbage bytes.
    let e = load_edited("sun.pack-cc.glb", |j| {
        j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"]["byteOffset"] =
            json!(1u64 << 40);
    })
    .unwrap_err();
    assert!(e.to_string().contains("outside buffer"), "{e}");
    let bytes = std::fs::read(exports("sun.pack-cc.glb")).unwrap();
    let (j, mut bin) = split_glb(&bytes);
    for b in bin.iter_mut().step_by(7) {
        *b ^= 0x5a;
    }
    // Damaged data decodes to an error or to some scene: never a panic.
    let _ =
        gibake_scene::load_from_slice(&join_glb(&j, &bin), Path::new("x.glb"), &Default::default());
    // A view of the fallback buffer read as plain data.
    let e = load_edited("sun.pack-cc.glb", |j| {
        let fallback = j["bufferViews"][0]["buffer"].as_u64().unwrap();
        let _ = fallback;
        let views = j["bufferViews"].as_array_mut().unwrap();
        let v = views
            .iter_mut()
            .find(|v| v.get("extensions").is_some())
            .unwrap();
        v.as_object_mut().unwrap().remove("extensions");
    })
    .unwrap_err();
    assert!(e.to_string().contains("fallback buffer"), "{e}");
}

// ------------------------------------------------------------------ WebP

#[test]
fn webp_textures_decode_close_to_the_png_source() {
    let png_scene = load("foliage.glb");
    let webp_scene = load("foliage.gt-webp.glb");
    assert_eq!(png_scene.textures.len(), webp_scene.textures.len());
    for (a, b) in png_scene.textures.iter().zip(&webp_scene.textures) {
        assert_eq!((a.width, a.height), (b.width, b.height));
        // Lossy WebP: the mean absolute difference is a few sRGB steps; the
        // alpha masks survive.
        let diff: f64 = a
            .rgba8_srgb
            .iter()
            .zip(&b.rgba8_srgb)
            .map(|(x, y)| (*x as f64 - *y as f64).abs())
            .sum::<f64>()
            / a.rgba8_srgb.len() as f64;
        assert!(diff < 4.0, "mean |PNG − WebP| = {diff}");
        let holes = |t: &gibake_scene::Texture| {
            t.rgba8_srgb
                .iter()
                .skip(3)
                .step_by(4)
                .filter(|&&x| x < 128)
                .count()
        };
        assert_eq!(holes(a), holes(b));
    }
    assert!(webp_scene.warnings.is_empty(), "{:?}", webp_scene.warnings);
}

/// The WebP bytes of the first image of foliage.gt-webp.glb.
fn a_webp() -> Vec<u8> {
    let bytes = std::fs::read(exports("foliage.gt-webp.glb")).unwrap();
    let (j, bin) = split_glb(&bytes);
    let v = &j["bufferViews"][j["images"][0]["bufferView"].as_u64().unwrap() as usize];
    let off = v["byteOffset"].as_u64().unwrap_or(0) as usize;
    let len = v["byteLength"].as_u64().unwrap() as usize;
    bin[off..off + len].to_vec()
}

/// A textured triangle whose image is `image` (JSON), with a texture
/// `texture` (JSON, `source` filled in when absent).
fn textured(image: Value, texture: Value) -> Builder {
    let mut b = basic();
    b.json["images"] = json!([image]);
    let mut t = texture;
    if t.get("source").is_none() && t.get("extensions").is_none() {
        t["source"] = json!(0);
    }
    b.json["textures"] = json!([t]);
    let m = b.material(
        json!({ "name": "Leafy", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }),
    );
    let p = b.vec3s(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    let uv = b.floats(&[0.0, 0.0, 0.0, 1.0, 1.0, 0.0], "VEC2");
    let mesh = b.mesh_raw(
        "T",
        json!({ "attributes": { "POSITION": p, "TEXCOORD_0": uv }, "material": m }),
    );
    b.root_mesh_node("TN", mesh);
    b
}

#[test]
fn webp_as_a_plain_image_and_its_texel_budget() {
    let webp = a_webp();
    let uri = format!("data:image/webp;base64,{}", common::base64(&webp));
    // A WebP named as the texture's own source (no extension): decoded.
    let s = textured(json!({ "uri": uri.clone() }), json!({}))
        .load()
        .expect("plain WebP");
    assert_eq!(s.textures.len(), 1);
    assert_eq!(s.textures[0].width, 96);
    // EXT_texture_webp with no `source` (glTF 2.0 makes it optional).
    let mut b = textured(
        json!({ "uri": uri.clone() }),
        json!({ "extensions": { "EXT_texture_webp": { "source": 0 } } }),
    );
    b.json["extensionsUsed"] = json!(["EXT_texture_webp"]);
    b.json["extensionsRequired"] = json!(["EXT_texture_webp"]);
    let s = b.load().expect("EXT_texture_webp");
    assert_eq!(s.textures[0].width, 96);
    assert!(
        s.warnings.iter().all(|w| !w.contains("EXT_texture_webp")),
        "{:?}",
        s.warnings
    );
    // The texel budget is charged from the WebP header, before decoding.
    let opts = LoadOptions {
        limits: gibake_scene::Limits {
            max_texels: 1000,
            ..Default::default()
        },
        ..Default::default()
    };
    assert_err_contains(b.load_with(&opts), &["image 0", "--max-texels"]);
    // A source index out of range.
    let mut b = textured(
        json!({ "uri": uri }),
        json!({ "extensions": { "EXT_texture_webp": { "source": 7 } } }),
    );
    b.json["extensionsUsed"] = json!(["EXT_texture_webp"]);
    assert_err_contains(b.load(), &["texture 0", "EXT_texture_webp", "7"]);
    // Damaged WebP data: an error naming the image, not a panic.
    let mut bad = webp.clone();
    for x in bad.iter_mut().skip(30) {
        *x = 0x33;
    }
    let uri = format!("data:image/webp;base64,{}", common::base64(&bad));
    assert_err_contains(
        textured(json!({ "uri": uri }), json!({})).load(),
        &["image 0"],
    );
}

// ------------------------------------------------------------------ KTX2, AVIF, Draco

#[test]
fn ktx2_is_refused_with_the_command_or_its_fallback_is_used() {
    let mut ktx = b"\xabKTX 20\xbb\r\n\x1a\n".to_vec();
    ktx.extend_from_slice(&[0; 64]);
    let ktx_uri = format!("data:image/ktx2;base64,{}", common::base64(&ktx));
    // Only a KTX2 image: refused, naming the extension and the command.
    let mut b = textured(
        json!({ "uri": ktx_uri.clone() }),
        json!({ "extensions": { "KHR_texture_basisu": { "source": 0 } } }),
    );
    b.json["extensionsUsed"] = json!(["KHR_texture_basisu"]);
    b.json["extensionsRequired"] = json!(["KHR_texture_basisu"]);
    let e = assert_err_contains(
        b.load(),
        &["KHR_texture_basisu", "gltf-transform", "ktxdecompress"],
    );
    assert!(matches!(e, SceneError::NotSupported { .. }));
    // A KTX2 image named as a plain source: the same refusal.
    assert_err_contains(
        textured(json!({ "uri": ktx_uri.clone() }), json!({})).load(),
        &["KTX2", "KHR_texture_basisu", "ktxdecompress"],
    );
    // With a PNG fallback `source`: the fallback is used, with a warning
    // naming the extension and the material.
    let mut b = textured(
        json!({ "uri": format!("data:image/png;base64,{}", common::base64(&png(1, 1, 4, &[200, 10, 10, 255]))) }),
        json!({ "source": 0, "extensions": { "KHR_texture_basisu": { "source": 1 } } }),
    );
    b.json["images"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "uri": ktx_uri }));
    b.json["extensionsUsed"] = json!(["KHR_texture_basisu"]);
    let s = b.load().expect("fallback used");
    assert_eq!(s.textures[0].rgba8_srgb, vec![200, 10, 10, 255]);
    assert!(
        s.warnings.iter().any(|w| w.contains("KHR_texture_basisu")
            && w.contains("'Leafy'")
            && w.contains("fallback")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn draco_and_avif_exports_are_refused_with_the_command_that_converts_them() {
    let e = gibake_scene::load(
        &exports("refused/foliage.gt-draco.glb"),
        &Default::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("KHR_draco_mesh_compression") && e.contains("gltf-transform/cli meshopt"),
        "{e}"
    );
    let e = gibake_scene::load(&exports("refused/foliage.gt-avif.glb"), &Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("EXT_texture_avif") && e.contains("gltf-transform/cli webp"),
        "{e}"
    );
    // The commands' outputs are committed too and load without warnings
    // (their images are judged in tests/exports.rs).
    for f in ["foliage.gt-draco-meshopt.glb", "foliage.gt-avif-webp.glb"] {
        let s = load(f);
        assert!(s.warnings.is_empty(), "{f}: {:?}", s.warnings);
    }
    // A Draco primitive whose extension is not required and whose
    // accessors hold no fallback data: refused, not read as zeros.
    let mut b = basic();
    let p = b.vec3s(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    b.json["accessors"][p]
        .as_object_mut()
        .unwrap()
        .remove("bufferView");
    let mesh = b.mesh_raw(
        "Squashed",
        json!({ "attributes": { "POSITION": p }, "extensions": { "KHR_draco_mesh_compression": { "bufferView": 0, "attributes": { "POSITION": 0 } } } }),
    );
    b.root_mesh_node("SquashedNode", mesh);
    b.json["extensionsUsed"] = json!(["KHR_lights_punctual", "KHR_draco_mesh_compression"]);
    assert_err_contains(
        b.load(),
        &["Squashed", "KHR_draco_mesh_compression", "meshopt"],
    );
}

// ------------------------------------------------------------------ texture transform, spec-gloss

#[test]
fn texture_transform_moves_the_coordinates_and_the_hash() {
    let with = load("foliage.glb");
    let without = load_edited("foliage.glb", |j| {
        j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]
            .as_object_mut()
            .unwrap()
            .remove("extensions");
    })
    .unwrap();
    let floor = |s: &Scene| {
        let m = s
            .static_meshes
            .iter()
            .find(|m| s.materials[m.material].name == "Floor")
            .expect("floor");
        m.uvs.clone().expect("uvs")
    };
    for (a, b) in floor(&with).iter().zip(&floor(&without)) {
        assert!(
            (*a - *b - Vec2::new(1.0 / 12.0, 0.0)).length() < 1e-6,
            "{a} vs {b}"
        );
    }
    assert_ne!(static_scene_hash(&with), static_scene_hash(&without));
    // gltfpack composes its own dequantization with the file's transform.
    let packed = load("foliage.pack-cc.glb");
    let p = floor(&packed);
    let q = floor(&with);
    assert!(
        p.iter()
            .all(|a| q.iter().any(|b| (*a - *b).length() < 1e-3)),
        "{p:?} vs {q:?}"
    );
}

#[test]
fn spec_gloss_diffuse_is_the_albedo() {
    let s = load("foliage.glb");
    let wall = &s.materials[static_mesh(&s, "Wall")[0].material];
    assert_eq!(wall.base_color, Vec3::new(0.9, 0.1, 0.1));
    let metal_rough = load_edited("foliage.glb", |j| {
        j["materials"][1]
            .as_object_mut()
            .unwrap()
            .remove("extensions");
    })
    .unwrap();
    let wall2 = &metal_rough.materials[static_mesh(&metal_rough, "Wall")[0].material];
    assert_eq!(wall2.base_color, Vec3::ONE);
    assert_ne!(static_scene_hash(&s), static_scene_hash(&metal_rough));
}

// ------------------------------------------------------------------ instancing

#[test]
fn instancing_expands_to_the_source_meshes_within_the_budget() {
    let source = load("foliage.glb");
    let inst = load("foliage.gt-instance.glb");
    let leaves = |s: &Scene| -> Vec<Vec3> {
        s.static_meshes
            .iter()
            .filter(|m| s.materials[m.material].name == "Leaf")
            .flat_map(|m| m.positions.iter().copied())
            .collect()
    };
    let (a, b) = (leaves(&source), leaves(&inst));
    assert_eq!(a.len(), 8, "two static leaf cards of four vertices");
    assert_eq!(b.len(), 8);
    assert!(same_points(&a, &b, 1e-6) && same_points(&b, &a, 1e-6));
    assert_eq!(static_scene_hash(&source).len(), 32);
    // The copies count against --max-elements.
    let opts = LoadOptions {
        limits: gibake_scene::Limits {
            max_elements: 60,
            ..Default::default()
        },
        ..Default::default()
    };
    let e = gibake_scene::load(&exports("foliage.gt-instance.glb"), &opts).unwrap_err();
    assert!(e.to_string().contains("--max-elements"), "{e}");
    // An instance with a non-finite transform.
    let e = load_edited("foliage.gt-instance.glb", |j| {
        let n = j["nodes"]
            .as_array_mut()
            .unwrap()
            .iter_mut()
            .find(|n| {
                n.get("extensions")
                    .is_some_and(|e| e.get("EXT_mesh_gpu_instancing").is_some())
            })
            .unwrap();
        n["extensions"]["EXT_mesh_gpu_instancing"]["attributes"] = json!({});
    })
    .unwrap_err();
    assert!(e.to_string().contains("EXT_mesh_gpu_instancing"), "{e}");
}

// ------------------------------------------------------------------ alpha

#[test]
fn alpha_modes_cutoffs_and_blend() {
    let s = load("foliage.glb");
    let leaf = s.materials.iter().find(|m| m.name == "Leaf").unwrap();
    assert_eq!(leaf.alpha_mode, AlphaMode::Mask { cutoff: 0.5 });
    // The leaf texture is a checker of opaque and transparent 8-texel squares.
    let mesh = static_mesh(&s, "LeafA")[0];
    let m = mesh.material;
    assert!(s.alpha_keeps(m, Some(Vec2::new(4.0 / 64.0, 4.0 / 64.0))));
    assert!(!s.alpha_keeps(m, Some(Vec2::new(12.0 / 64.0, 4.0 / 64.0))));
    // The floor is opaque whatever its alpha.
    let floor = static_mesh(&s, "Floor")[0].material;
    assert!(s.alpha_keeps(floor, Some(Vec2::new(0.3, 0.3))));

    // BLEND: a mask at 0.5, with a warning naming the material.
    let blend = load_edited("foliage.glb", |j| {
        j["materials"][3]["alphaMode"] = json!("BLEND");
        j["materials"][3]
            .as_object_mut()
            .unwrap()
            .remove("alphaCutoff");
    })
    .unwrap();
    let leaf = blend.materials.iter().find(|m| m.name == "Leaf").unwrap();
    assert_eq!(leaf.alpha_mode, AlphaMode::Mask { cutoff: 0.5 });
    let w: Vec<_> = blend
        .warnings
        .iter()
        .filter(|w| w.contains("BLEND"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", blend.warnings);
    assert!(w[0].contains("'Leaf'"), "{w:?}");

    // The factor's alpha counts; a mask changes the hash, OPAQUE keeps the
    // old one.
    let faded = load_edited("foliage.glb", |j| {
        j["materials"][3]["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 1.0, 1.0, 0.4]);
    })
    .unwrap();
    let mf = faded
        .materials
        .iter()
        .position(|m| m.name == "Leaf")
        .unwrap();
    assert!(!faded.alpha_keeps(mf, Some(Vec2::new(4.0 / 64.0, 4.0 / 64.0))));
    assert_ne!(static_scene_hash(&faded), static_scene_hash(&s));
    let opaque = load_edited("foliage.glb", |j| {
        for m in [2, 3] {
            j["materials"][m]["alphaMode"] = json!("OPAQUE");
        }
    })
    .unwrap();
    assert_ne!(static_scene_hash(&opaque), static_scene_hash(&s));
    // Bad cutoffs and alphas are errors naming the material.
    assert_err_contains(
        load_edited("foliage.glb", |j| {
            j["materials"][3]["alphaCutoff"] = json!(-1.0)
        }),
        &["'Leaf'", "alphaCutoff"],
    );
    assert_err_contains(
        load_edited("foliage.glb", |j| {
            j["materials"][3]["pbrMetallicRoughness"]["baseColorFactor"] =
                json!([1.0, 1.0, 1.0, 2.0]);
        }),
        &["'Leaf'", "alpha"],
    );
}

// ------------------------------------------------------------------ warnings

#[test]
fn every_unapplied_extension_is_named_with_what_carries_it() {
    let mut b = basic();
    let m = b.material(
        json!({ "name": "CarPaint", "pbrMetallicRoughness": { "metallicFactor": 0.0 },
        "extensions": { "KHR_materials_clearcoat": { "clearcoatFactor": 1.0 },
                        "KHR_materials_emissive_strength": { "emissiveStrength": 5.0 } },
        "emissiveFactor": [1.0, 0.5, 0.0], "normalTexture": { "index": 0 } }),
    );
    b.json["images"] = json!([{ "uri": format!("data:image/png;base64,{}", common::base64(&png(1, 1, 3, &[1, 2, 3]))) }]);
    b.json["textures"] =
        json!([{ "source": 0, "extensions": { "EXT_texture_avif": { "source": 0 } } }]);
    let p = b.vec3s(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
    let mesh = b.mesh_raw(
        "Car",
        json!({ "attributes": { "POSITION": p }, "material": m,
        "extensions": { "KHR_materials_variants": { "mappings": [] } } }),
    );
    b.root_mesh_node("CarNode", mesh);
    b.json["extensionsUsed"] = json!([
        "KHR_lights_punctual",
        "KHR_materials_clearcoat",
        "KHR_materials_emissive_strength",
        "KHR_materials_variants",
        "EXT_texture_avif",
        "KHR_xmp_json_ld"
    ]);
    b.json["extensionsRequired"] = json!(["KHR_materials_clearcoat"]);
    let s = b.load().expect("material extensions may be required");
    let one = |ext: &str| -> String {
        let w: Vec<&String> = s.warnings.iter().filter(|w| w.contains(ext)).collect();
        assert_eq!(w.len(), 1, "{ext}: {:?}", s.warnings);
        w[0].clone()
    };
    assert!(one("KHR_materials_clearcoat").contains("material 'CarPaint'"));
    assert!(one("KHR_materials_emissive_strength").contains("material 'CarPaint'"));
    assert!(one("KHR_materials_variants").contains("mesh 'Car'"));
    // A texture extension names the materials using the texture.
    assert!(one("EXT_texture_avif").contains("material 'CarPaint'"));
    assert!(one("KHR_xmp_json_ld").contains("extensionsUsed"));
    // Applied extensions are not warned about.
    assert!(
        s.warnings
            .iter()
            .all(|w| !w.contains("KHR_lights_punctual")),
        "{:?}",
        s.warnings
    );
    // The material's ignored inputs, by name, in one warning.
    let w: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("'CarPaint'") && w.contains("input"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", s.warnings);
    assert!(
        w[0].contains("normalTexture") && w[0].contains("emissiveFactor"),
        "{w:?}"
    );

    // An extension gibake neither applies nor may ignore, required: refused
    // with its name.
    let mut b = basic();
    b.json["extensionsUsed"] = json!(["KHR_lights_punctual", "EXT_lights_image_based"]);
    b.json["extensionsRequired"] = json!(["EXT_lights_image_based"]);
    assert_err_contains(b.load(), &["EXT_lights_image_based", "not supported"]);
}

#[test]
fn committed_exports_import_without_unexpected_warnings() {
    for f in std::fs::read_dir(exports("")).unwrap() {
        let p = f.unwrap().path();
        if p.extension().is_some_and(|x| x == "glb") {
            let s = gibake_scene::load(&p, &Default::default())
                .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            assert!(s.warnings.is_empty(), "{}: {:?}", p.display(), s.warnings);
        }
    }
}
