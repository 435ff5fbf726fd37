//! Tests of the generated scenes: the committed `data/*.glb` are exactly what
//! the generator writes, scaled variants differ only by the documented
//! scaling, heavy variants have the promised static triangle counts, and the
//! scenes keep the design's contracts (one light in those of `all()`, dynamic
//! nodes marked). The multi-light scenes (`multi_light()`) are held to the
//! same, but for the light count.

use std::path::{Path, PathBuf};

use gibake_scenegen::inspect::{split_glb, triangle_counts};
use gibake_scenegen::{Params, SceneFn, all, multi_light};
use serde_json::Value;

/// Every bundled scene: those of `all()` (one light), then the multi-light ones.
fn bundled() -> Vec<(&'static str, SceneFn)> {
    all().into_iter().chain(multi_light()).collect()
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data")
}

/// The binary writes byte-for-byte the committed files, and the library
/// agrees with both.
#[test]
fn committed_data_is_reproducible() {
    let out = std::env::temp_dir().join(format!("gibake-scenegen-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_gibake-scenegen"))
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .status()
        .expect("run gibake-scenegen");
    assert!(status.success());
    for (name, f) in bundled() {
        let file = format!("{name}.glb");
        let written = std::fs::read(out.join(&file)).expect("generated file");
        let committed = std::fs::read(data_dir().join(&file))
            .unwrap_or_else(|e| panic!("data/{file}: {e} (run `cargo run -p gibake-scenegen`)"));
        assert!(
            written == committed,
            "data/{file} differs from the generator's output: run `cargo run -p gibake-scenegen` and commit"
        );
        assert!(
            f(&Params::default()) == written,
            "{name}: library and binary disagree"
        );
        assert!(
            f(&Params::default()) == written,
            "{name}: not deterministic"
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// Reads accessor `i` of a GLB as `f32` values (float accessors only).
fn floats(j: &Value, bin: &[u8], i: usize) -> Vec<f32> {
    let a = &j["accessors"][i];
    let v = &j["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let off = v["byteOffset"].as_u64().unwrap_or(0) as usize
        + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    let n = match a["type"].as_str().unwrap() {
        "SCALAR" => 1,
        "VEC3" => 3,
        "VEC4" => 4,
        t => panic!("type {t}"),
    };
    let count = a["count"].as_u64().unwrap() as usize * n;
    bin[off..off + 4 * count]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

/// Accessors holding lengths: mesh POSITIONs and translation animation outputs.
fn length_accessors(j: &Value) -> Vec<usize> {
    let mut out = Vec::new();
    for m in j["meshes"].as_array().unwrap() {
        for p in m["primitives"].as_array().unwrap() {
            out.push(p["attributes"]["POSITION"].as_u64().unwrap() as usize);
        }
    }
    for a in j["animations"].as_array().into_iter().flatten() {
        for c in a["channels"].as_array().unwrap() {
            assert_eq!(c["target"]["path"], "translation");
            let s = &a["samplers"][c["sampler"].as_u64().unwrap() as usize];
            out.push(s["output"].as_u64().unwrap() as usize);
        }
    }
    out
}

fn close(expected: f64, got: f64, s: f64) -> bool {
    (expected - got).abs() <= 1e-6 * expected.abs().max(got.abs()) + 1e-12 * s
}

/// Walks two JSON documents in step; every number of `b` must be the number of
/// `a` times the factor `factor(path)` gives; everything else equal.
fn compare(
    a: &Value,
    b: &Value,
    path: &mut Vec<String>,
    factor: &dyn Fn(&[String]) -> f64,
    s: f64,
) {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let f = factor(path);
            if f == 1.0 && (x.is_u64() || x.is_i64()) {
                assert_eq!(x, y, "at {path:?}");
            } else {
                let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
                assert!(close(x * f, y, s), "at {path:?}: {x} × {f} ≠ {y}");
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "at {path:?}");
            for (i, (x, y)) in x.iter().zip(y).enumerate() {
                path.push(i.to_string());
                compare(x, y, path, factor, s);
                path.pop();
            }
        }
        (Value::Object(x), Value::Object(y)) => {
            assert_eq!(
                x.keys().collect::<Vec<_>>(),
                y.keys().collect::<Vec<_>>(),
                "at {path:?}"
            );
            for (k, xv) in x {
                path.push(k.clone());
                compare(xv, &y[k], path, factor, s);
                path.pop();
            }
        }
        _ => assert_eq!(a, b, "at {path:?}"),
    }
}

/// Scaling by `s` multiplies exactly the documented quantities: positions,
/// translations (nodes and animation keys), camera near/far and orthographic
/// magnifications and light ranges by `s`, spot and point intensity by `s²`;
/// nothing else changes.
#[test]
fn scaled_scenes_differ_only_by_the_documented_scaling() {
    for (name, f) in bundled() {
        let base = f(&Params::default());
        let (ja, bin_a) = split_glb(&base).unwrap();
        let lengths = length_accessors(&ja);
        for s in [1000.0f32, 0.001, 3.7] {
            let scaled = f(&Params {
                scale: s,
                ..Params::default()
            });
            let (jb, bin_b) = split_glb(&scaled).unwrap();
            let sd = f64::from(s);
            let lights = ja["extensions"]["KHR_lights_punctual"]["lights"].clone();
            let factor = |p: &[String]| -> f64 {
                let p: Vec<&str> = p.iter().map(String::as_str).collect();
                match p.as_slice() {
                    ["nodes", _, "translation", _] => sd,
                    ["cameras", _, "perspective", "znear" | "zfar"] => sd,
                    [
                        "cameras",
                        _,
                        "orthographic",
                        "xmag" | "ymag" | "znear" | "zfar",
                    ] => sd,
                    [
                        "extensions",
                        "KHR_lights_punctual",
                        "lights",
                        i,
                        "intensity",
                    ] if ["spot", "point"].contains(
                        &lights[i.parse::<usize>().unwrap()]["type"]
                            .as_str()
                            .unwrap(),
                    ) =>
                    {
                        sd * sd
                    }
                    ["extensions", "KHR_lights_punctual", "lights", _, "range"] => sd,
                    ["accessors", i, "min" | "max", _] if lengths.contains(&i.parse().unwrap()) => {
                        sd
                    }
                    _ => 1.0,
                }
            };
            compare(&ja, &jb, &mut Vec::new(), &factor, sd);
            // Binary data: lengths scaled, everything else (normals, indices, times) identical.
            assert_eq!(bin_a.len(), bin_b.len());
            let n_acc = ja["accessors"].as_array().unwrap().len();
            for i in 0..n_acc {
                if lengths.contains(&i) {
                    for (x, y) in floats(&ja, bin_a, i).iter().zip(floats(&jb, bin_b, i)) {
                        assert!(
                            close(f64::from(*x) * sd, f64::from(y), sd),
                            "{name} ×{s}: accessor {i}: {x} vs {y}"
                        );
                    }
                } else {
                    let a = &ja["accessors"][i];
                    let v = &ja["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
                    let (o, l) = (
                        v["byteOffset"].as_u64().unwrap() as usize,
                        v["byteLength"].as_u64().unwrap() as usize,
                    );
                    assert_eq!(
                        bin_a[o..o + l],
                        bin_b[o..o + l],
                        "{name} ×{s}: accessor {i} changed"
                    );
                }
            }
        }
    }
}

/// Spot intensity scales by s², directional irradiance does not; checked on
/// the values themselves.
#[test]
fn light_and_camera_scaling_values() {
    let s = 10.0;
    let p = Params {
        scale: s,
        ..Params::default()
    };
    let (a, _) = split_glb(&gibake_scenegen::corner_bunny(&Params::default())).unwrap();
    let (b, _) = split_glb(&gibake_scenegen::corner_bunny(&p)).unwrap();
    let ia = a["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"]
        .as_f64()
        .unwrap();
    let ib = b["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"]
        .as_f64()
        .unwrap();
    assert!((ib / ia - 100.0).abs() < 1e-4);
    let za = a["cameras"][0]["perspective"]["znear"].as_f64().unwrap();
    let zb = b["cameras"][0]["perspective"]["znear"].as_f64().unwrap();
    assert!((zb / za - 10.0).abs() < 1e-5);
    let (a, _) = split_glb(&gibake_scenegen::sun(&Params::default())).unwrap();
    let (b, _) = split_glb(&gibake_scenegen::sun(&p)).unwrap();
    assert_eq!(a["extensions"], b["extensions"]);
    let ma = a["cameras"][1]["orthographic"]["xmag"].as_f64().unwrap();
    let mb = b["cameras"][1]["orthographic"]["xmag"].as_f64().unwrap();
    assert!((mb / ma - 10.0).abs() < 1e-5);
}

/// `heavy = 20` gives at least 15× the static triangles (and not absurdly
/// more), and leaves the dynamic part alone.
#[test]
fn heavy_multiplies_static_triangles() {
    for (name, f) in bundled() {
        let base = triangle_counts(&f(&Params::default())).unwrap();
        let heavy = triangle_counts(&f(&Params {
            heavy: 20,
            ..Params::default()
        }))
        .unwrap();
        let ratio = heavy.static_tris as f64 / base.static_tris as f64;
        assert!(
            (15.0..=40.0).contains(&ratio),
            "{name}: heavy=20 gives {ratio:.1}× static triangles"
        );
        assert_eq!(base.dynamic_tris, heavy.dynamic_tris, "{name}");
        assert!(base.dynamic_tris > 0 && base.static_tris > 0, "{name}");
    }
}

/// The design's scene contract: exactly one spot or directional light (the
/// scenes of `all()`; the multi-light ones have several), a perspective
/// camera first, every animated node marked dynamic and every node marked
/// dynamic animated, LINEAR loops, metallic 0 everywhere, normals everywhere.
#[test]
fn scenes_keep_the_contract() {
    let one_light: Vec<&str> = all().iter().map(|(n, _)| *n).collect();
    for (name, f) in bundled() {
        let (j, _) = split_glb(&f(&Params::default())).unwrap();
        let lights = j["extensions"]["KHR_lights_punctual"]["lights"]
            .as_array()
            .unwrap();
        if one_light.contains(&name) {
            assert_eq!(lights.len(), 1, "{name}");
            assert!(["spot", "directional"].contains(&lights[0]["type"].as_str().unwrap()));
        } else {
            assert!(lights.len() >= 2, "{name}");
        }
        assert_eq!(j["cameras"][0]["type"], "perspective", "{name}");
        let animated: Vec<u64> = j["animations"][0]["channels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["target"]["node"].as_u64().unwrap())
            .collect();
        for (i, n) in j["nodes"].as_array().unwrap().iter().enumerate() {
            let marked = n["extras"]["dynamic"] == Value::Bool(true);
            assert_eq!(marked, animated.contains(&(i as u64)), "{name}: node {i}");
        }
        for m in j["materials"].as_array().unwrap() {
            assert_eq!(
                m["pbrMetallicRoughness"]["metallicFactor"].as_f64(),
                Some(0.0)
            );
        }
        for m in j["meshes"].as_array().unwrap() {
            for p in m["primitives"].as_array().unwrap() {
                assert!(p["attributes"]["NORMAL"].is_u64() && p["indices"].is_u64());
            }
        }
        // Every loop lasts 4 s.
        for s in j["animations"][0]["samplers"].as_array().unwrap() {
            assert_eq!(s["interpolation"], "LINEAR", "{name}");
            let a = &j["accessors"][s["input"].as_u64().unwrap() as usize];
            assert_eq!(a["min"][0].as_f64(), Some(0.0));
            assert_eq!(a["max"][0].as_f64(), Some(gibake_scenegen::LOOP_SECONDS));
        }
    }
}

/// The Khronos validator reports no errors on the committed scenes. CI
/// runs the validator itself: `scripts/test.sh` installs Node.js, runs
/// `npm ci` in `data/validate` and validates `data/*.glb` before the Rust
/// tests, so this copy of the check is for a manual `--ignored` run (it
/// needs Node.js and `npm ci` in `data/validate` first).
#[test]
#[ignore = "scripts/test.sh validates data/*.glb with the Khronos validator before the Rust tests; run this with --ignored after `cd data/validate && npm ci`"]
fn khronos_validator_accepts_committed_scenes() {
    let dir = data_dir().join("validate");
    assert!(
        dir.join("node_modules/gltf-validator").exists(),
        "run `cd data/validate && npm ci` first"
    );
    let files: Vec<PathBuf> = bundled()
        .iter()
        .map(|(n, _)| data_dir().join(format!("{n}.glb")))
        .collect();
    let out = std::process::Command::new("node")
        .arg("validate.mjs")
        .args(&files)
        .current_dir(&dir)
        .output()
        .expect("run node (is Node.js installed?)");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "validator found errors:\n{text}");
}
