//! End-to-end tests of `gibake` in a content pipeline (docs/pipeline.md):
//! sharded bakes merge into the single bake's bytes, bad parts are refused
//! naming the part, an up-to-date asset is left untouched and a change of
//! setting, scene or baker version re-bakes saying why, and a batch with a
//! broken scene bakes the others and names it.

use crate::common;

use common::{Run, run_command};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Small settings: every bake takes well under a second on lavapipe.
const SMALL: [&str; 8] = [
    "--rsm-size",
    "128",
    "--vpl-map-size",
    "32",
    "--vpls",
    "64",
    "--shadow-map-size",
    "256",
];

fn gibake(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Run {
    let mut c = common::gibake();
    for a in args {
        c.arg(a);
    }
    run_command(c)
}

fn assert_ok(r: &Run) {
    assert_eq!(r.code, Some(0), "{r}");
}

fn assert_bad_input(r: &Run, names: &[&str]) {
    assert_eq!(r.code, Some(2), "expected exit 2\n{r}");
    assert!(!r.stderr.contains("panicked"), "panicked\n{r}");
    for n in names {
        assert!(r.stderr.contains(n), "the message does not name {n}\n{r}");
    }
}

/// Every file of an asset directory, by name.
fn read_all(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    for e in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        out.insert(name, std::fs::read(e.path()).unwrap());
    }
    out
}

fn assert_same_bytes(a: &Path, b: &Path, what: &str) {
    let (fa, fb) = (read_all(a), read_all(b));
    assert_eq!(
        fa.keys().collect::<Vec<_>>(),
        fb.keys().collect::<Vec<_>>(),
        "{what}: different files"
    );
    for (name, bytes) in &fa {
        assert!(
            bytes == &fb[name],
            "{what}: {name} differs ({} against {} bytes)",
            bytes.len(),
            fb[name].len()
        );
    }
}

/// [`SMALL`] without the flags that `extra` sets, then `extra`.
fn settings<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut v: Vec<&str> = SMALL
        .chunks(2)
        .filter(|f| !extra.contains(&f[0]))
        .flatten()
        .copied()
        .collect();
    v.extend_from_slice(extra);
    v
}

fn bake_small(scene: &Path, out: &Path, extra: &[&str]) -> Run {
    let mut c = common::gibake();
    c.arg("bake")
        .arg(scene)
        .arg("-o")
        .arg(out)
        .args(settings(extra));
    run_command(c)
}

fn shard(scene: &Path, part: &Path, k: u32, n: u32) -> Run {
    bake_small(scene, part, &["--shard", &format!("{k}/{n}")])
}

fn bundled_scenes() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(common::root().join("data"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    v.sort();
    assert!(v.len() >= 3, "expected the bundled scenes in data/: {v:?}");
    v
}

#[test]
fn sharded_and_merged_equals_single_bake_for_every_bundled_scene() {
    let work = tempfile::tempdir().unwrap();
    for scene in bundled_scenes() {
        let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let single = work.path().join(format!("{stem}.gibake"));
        assert_ok(&bake_small(&scene, &single, &[]));
        for n in [1u32, 2, 3, 4, 7] {
            let parts: Vec<PathBuf> = (0..n)
                .map(|k| work.path().join(format!("{stem}.{k}of{n}.part")))
                .collect();
            for (k, p) in parts.iter().enumerate() {
                assert_ok(&shard(&scene, p, k as u32, n));
            }
            // Any order of arguments: reversed, and rotated by one.
            let mut reversed = parts.clone();
            reversed.reverse();
            let mut rotated = parts.clone();
            rotated.rotate_left(1);
            for (i, order) in [reversed, rotated].iter().enumerate() {
                let merged = work.path().join(format!("{stem}.merged{n}.{i}.gibake"));
                let mut c = common::gibake();
                c.arg("merge").args(order).arg("-o").arg(&merged);
                assert_ok(&run_command(c));
                assert_same_bytes(&single, &merged, &format!("{stem}, {n} shards, order {i}"));
            }
        }
    }
}

#[test]
fn a_merge_keeps_the_manifests_appended_fields_ring_vpls_and_swept_bounds() {
    // The town under a sun has VPLs on its outer rings (format 4.3's
    // `ring_vpls`), and the corner its balls' swept box (4.5's
    // `swept_bounds`): both are appended to the manifest by hand, outside
    // its serde fields, so the part must carry them (part versions 6 and
    // 7; a merge of version-5 parts lost the ring VPLs).
    let work = tempfile::tempdir().unwrap();
    let town = common::root().join("data/levels/town/town_model.gltf");
    let cases: [(&Path, &[&str]); 2] = [
        (&town, &["--sun", "173,60"]),
        (&common::data("corner_bunny.glb"), &[]),
    ];
    for (i, (scene, extra)) in cases.iter().enumerate() {
        let single = work.path().join(format!("single{i}.gibake"));
        assert_ok(&bake_small(scene, &single, extra));
        let parts: Vec<PathBuf> = (0..2)
            .map(|k| work.path().join(format!("p{i}.{k}")))
            .collect();
        for (k, p) in parts.iter().enumerate() {
            let mut e = extra.to_vec();
            let s = format!("{k}/2");
            e.extend(["--shard", &s]);
            assert_ok(&bake_small(scene, p, &e));
        }
        let merged = work.path().join(format!("merged{i}.gibake"));
        let mut c = common::gibake();
        c.arg("merge").args(&parts).arg("-o").arg(&merged);
        assert_ok(&run_command(c));
        let m = gibake_asset::load_manifest(&merged).unwrap();
        if i == 0 {
            assert!(m.ring_vpls.iter().any(|&n| n > 0), "{:?}", m.ring_vpls);
        } else {
            assert!(m.swept_bounds.is_some_and(|b| b[0] < b[3]), "{m:?}");
        }
        assert_same_bytes(&single, &merged, &format!("case {i}"));
    }
}

#[test]
fn merge_refuses_bad_parts_naming_them() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    let scene = common::data("occluded.glb");
    let p: Vec<PathBuf> = (0..3).map(|k| w.join(format!("p{k}.part"))).collect();
    for (k, part) in p.iter().enumerate() {
        assert_ok(&shard(&scene, part, k as u32, 3));
    }
    let out = w.join("out.gibake");
    let merge = |parts: &[&Path]| {
        let mut c = common::gibake();
        c.arg("merge").args(parts).arg("-o").arg(&out);
        run_command(c)
    };
    let name = |p: &Path| p.file_name().unwrap().to_string_lossy().into_owned();

    // A missing shard.
    let r = merge(&[&p[0], &p[2]]);
    assert_bad_input(&r, &["missing", "[1]"]);
    // A repeated shard: names both parts.
    let copy = w.join("p1-copy.part");
    std::fs::copy(&p[1], &copy).unwrap();
    let r = merge(&[&p[0], &p[1], &copy, &p[2]]);
    assert_bad_input(&r, &[&name(&p[1]), &name(&copy), "both shard 1/3"]);
    // Another shard count.
    let other_n = w.join("q0of2.part");
    assert_ok(&shard(&scene, &other_n, 0, 2));
    let r = merge(&[&p[0], &p[1], &p[2], &other_n]);
    assert_bad_input(&r, &[&name(&other_n), "2 shards"]);
    // Another setting.
    let other_s = w.join("other-setting.part");
    assert_ok(&bake_small(
        &scene,
        &other_s,
        &["--shard", "1/3", "--vpl-map-size", "16"],
    ));
    let r = merge(&[&p[0], &other_s, &p[2]]);
    assert_bad_input(&r, &[&name(&other_s), "settings"]);
    // Another scene.
    let other_scene = w.join("other-scene.part");
    assert_ok(&shard(&common::data("sun.glb"), &other_scene, 1, 3));
    let r = merge(&[&p[0], &other_scene, &p[2]]);
    assert_bad_input(&r, &[&name(&other_scene), "scene"]);
    // Not a part, a damaged part, a truncated part, an asset directory.
    let junk = w.join("junk.part");
    std::fs::write(&junk, b"hello, world: not a part at all").unwrap();
    let r = merge(&[&p[0], &junk, &p[2]]);
    assert_bad_input(&r, &[&name(&junk), "not a gibake shard part"]);
    let mut bytes = std::fs::read(&p[1]).unwrap();
    let damaged = w.join("damaged.part");
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    std::fs::write(&damaged, &bytes).unwrap();
    let r = merge(&[&p[0], &damaged, &p[2]]);
    assert_bad_input(&r, &[&name(&damaged), "damaged"]);
    let truncated = w.join("truncated.part");
    std::fs::write(&truncated, &bytes[..mid]).unwrap();
    let r = merge(&[&p[0], &truncated, &p[2]]);
    assert_bad_input(&r, &[&name(&truncated), "truncated"]);
    let asset = w.join("single.gibake");
    assert_ok(&bake_small(&scene, &asset, &[]));
    let r = merge(&[&p[0], &asset, &p[2]]);
    assert_bad_input(&r, &["single.gibake"]);
    // Nothing was written by any refused merge.
    assert!(!out.exists(), "a refused merge left {}", out.display());
    // Bad --shard values are usage errors.
    for bad in ["3/3", "0/0", "1", "a/b", "4/3", "1/5000"] {
        let r = bake_small(&scene, &w.join("x.part"), &["--shard", bad]);
        assert_bad_input(&r, &["--shard"]);
    }
    // And the good set still merges.
    assert_ok(&merge(&[&p[2], &p[0], &p[1]]));
}

/// The manifest's modification time and bytes: "left untouched" evidence.
fn snapshot(asset: &Path) -> (std::time::SystemTime, BTreeMap<String, Vec<u8>>) {
    let m = std::fs::metadata(asset.join("manifest.bin")).unwrap();
    (m.modified().unwrap(), read_all(asset))
}

fn bake_json(
    scene: &Path,
    out: &Path,
    extra: &[&str],
    env: Option<(&str, &str)>,
) -> serde_json::Value {
    let mut c = common::gibake();
    c.arg("bake")
        .arg(scene)
        .arg("-o")
        .arg(out)
        .args(settings(extra))
        .arg("--json");
    if let Some((k, v)) = env {
        c.env(k, v);
    }
    let r = run_command(c);
    assert_ok(&r);
    serde_json::from_str(&r.stdout).unwrap_or_else(|e| panic!("not JSON: {e}\n{r}"))
}

fn reasons(j: &serde_json::Value) -> String {
    j["reasons"]
        .as_array()
        .unwrap_or(&Vec::new())
        .iter()
        .map(|r| r.as_str().unwrap_or_default().to_string())
        .collect::<Vec<_>>()
        .join("; ")
}

/// `data/corner_bunny.glb` with the first vertex of the floor (a static
/// mesh) moved 1% of the way towards the second.
fn with_one_vertex_moved() -> Vec<u8> {
    let glb = std::fs::read(common::data("corner_bunny.glb")).unwrap();
    let u32_at = |o: usize| u32::from_le_bytes(glb[o..o + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin = 20 + json_len + 8;
    let node = &json["nodes"][0];
    assert_eq!(
        node["name"], "floor",
        "the test expects node 0 to be the static floor"
    );
    assert!(node["extras"]["dynamic"].is_null());
    let mesh = node["mesh"].as_u64().unwrap() as usize;
    let acc = json["meshes"][mesh]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap() as usize;
    let acc = &json["accessors"][acc];
    let view = &json["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let stride = view["byteStride"].as_u64().unwrap_or(12) as usize;
    let start = bin
        + view["byteOffset"].as_u64().unwrap_or(0) as usize
        + acc["byteOffset"].as_u64().unwrap_or(0) as usize;
    let mut out = glb.clone();
    for c in 0..3 {
        let f = |o: usize| f32::from_le_bytes(glb[o..o + 4].try_into().unwrap());
        let (v0, v1) = (f(start + 4 * c), f(start + stride + 4 * c));
        let moved = v0 + 0.01 * (v1 - v0);
        out[start + 4 * c..start + 4 * c + 4].copy_from_slice(&moved.to_le_bytes());
    }
    assert_ne!(out, glb, "the first two floor vertices are equal");
    out
}

#[test]
fn up_to_date_is_left_untouched_and_changes_rebake_saying_why() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    let scene = w.join("level.glb");
    std::fs::copy(common::data("corner_bunny.glb"), &scene).unwrap();
    let out = w.join("level.gibake");

    let j = bake_json(&scene, &out, &[], None);
    assert_eq!(j["decision"], "baked", "{j}");
    assert!(reasons(&j).contains("no asset"), "{j}");
    let before = snapshot(&out);
    std::thread::sleep(std::time::Duration::from_millis(20));

    // Same inputs: up to date, untouched; said in text and in JSON.
    let r = bake_small(&scene, &out, &[]);
    assert_ok(&r);
    assert!(r.stderr.contains("up to date"), "{r}");
    let j = bake_json(&scene, &out, &[], None);
    assert_eq!(j["decision"], "up_to_date", "{j}");
    assert_eq!(snapshot(&out), before, "an up-to-date asset was rewritten");

    // --force re-bakes (same bytes: the bake is deterministic).
    let j = bake_json(&scene, &out, &["--force"], None);
    assert_eq!(j["decision"], "baked", "{j}");
    assert!(reasons(&j).contains("--force"), "{j}");
    assert_eq!(snapshot(&out).1, before.1);

    // One setting.
    let j = bake_json(&scene, &out, &["--vpl-map-size", "16"], None);
    assert_eq!(j["decision"], "baked", "{j}");
    assert!(
        reasons(&j).contains("--vpl-map-size changed (32 → 16)"),
        "{j}"
    );
    let j = bake_json(&scene, &out, &["--vpl-map-size", "16"], None);
    assert_eq!(j["decision"], "up_to_date", "{j}");
    let j = bake_json(&scene, &out, &[], None);
    assert_eq!(j["decision"], "baked", "{j}");

    // One vertex of a static mesh.
    std::fs::write(&scene, with_one_vertex_moved()).unwrap();
    let r = bake_small(&scene, &out, &[]);
    assert_ok(&r);
    assert!(r.stderr.contains("scene changed"), "{r}");
    let j = bake_json(&scene, &out, &[], None);
    assert_eq!(j["decision"], "up_to_date", "{j}");

    // The baker version (GIBAKE_BAKER_VERSION overrides the recorded one).
    let j = bake_json(
        &scene,
        &out,
        &[],
        Some(("GIBAKE_BAKER_VERSION", "99.0.0-test")),
    );
    assert_eq!(j["decision"], "baked", "{j}");
    assert!(reasons(&j).contains("baker version changed"), "{j}");
    assert!(reasons(&j).contains("99.0.0-test"), "{j}");
    let j = bake_json(
        &scene,
        &out,
        &[],
        Some(("GIBAKE_BAKER_VERSION", "99.0.0-test")),
    );
    assert_eq!(j["decision"], "up_to_date", "{j}");
    let j = bake_json(&scene, &out, &[], None);
    assert!(reasons(&j).contains("baker version changed"), "{j}");

    // A damaged asset is re-baked, not trusted.
    let vpls = out.join("vpls.bin");
    let mut b = std::fs::read(&vpls).unwrap();
    b[0] ^= 1;
    std::fs::write(&vpls, &b).unwrap();
    let j = bake_json(&scene, &out, &[], None);
    assert_eq!(j["decision"], "baked", "{j}");
    assert!(reasons(&j).contains("damaged"), "{j}");
}

#[test]
fn batch_bakes_good_scenes_and_names_the_broken_one() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    let broken = w.join("broken_level.glb");
    std::fs::write(&broken, b"glTF\x02\0\0\0 this is not a real glb").unwrap();
    let dir = w.join("assets");
    let good = [common::data("corner_bunny.glb"), common::data("sun.glb")];
    let run = |json: bool| {
        let mut c = common::gibake();
        c.arg("bake")
            .arg(&good[0])
            .arg(&broken)
            .arg(&good[1])
            .arg("--out-dir")
            .arg(&dir)
            .args(SMALL);
        if json {
            c.arg("--json");
        }
        run_command(c)
    };
    let r = run(false);
    assert_bad_input(&r, &["broken_level.glb", "1 of 3 scenes failed"]);
    for name in ["corner_bunny.gibake", "sun.gibake"] {
        let asset = dir.join(name);
        let mut c = common::gibake();
        c.arg("inspect").arg(&asset);
        assert_ok(&run_command(c));
    }
    assert!(!dir.join("broken_level.gibake").exists());
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names.len(),
        2,
        "only the two assets, no temporaries: {names:?}"
    );

    // Again, as JSON: the good ones are up to date, the broken one failed.
    let r = run(true);
    assert_eq!(r.code, Some(2), "{r}");
    let j: serde_json::Value =
        serde_json::from_str(&r.stdout).unwrap_or_else(|e| panic!("{e}\n{r}"));
    assert_eq!(j["up_to_date"], 2, "{j}");
    assert_eq!(j["baked"], 0, "{j}");
    let failed = j["failed"].as_array().unwrap();
    assert_eq!(failed.len(), 1, "{j}");
    assert!(
        failed[0].as_str().unwrap().contains("broken_level.glb"),
        "{j}"
    );
    let scenes = j["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 3);
    assert_eq!(scenes[1]["decision"], "failed", "{j}");
    assert!(
        scenes[1]["error"]
            .as_str()
            .unwrap()
            .contains("broken_level.glb"),
        "{j}"
    );

    // All good: exit 0 and the assets equal single bakes.
    let mut c = common::gibake();
    c.arg("bake")
        .args(&good)
        .arg("--out-dir")
        .arg(&dir)
        .args(SMALL)
        .arg("--force");
    assert_ok(&run_command(c));
    let single = w.join("sun_single.gibake");
    assert_ok(&bake_small(&good[1], &single, &[]));
    assert_same_bytes(
        &single,
        &dir.join("sun.gibake"),
        "batch against single bake",
    );
}

#[test]
fn bake_usage_errors() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    let a = common::data("corner_bunny.glb");
    // -o with several scenes.
    let r = gibake(&[&"bake", &a, &a, &"-o", &w.join("x.gibake")]);
    assert_bad_input(&r, &["--out-dir"]);
    // Two scenes with one stem in a batch.
    let other = w.join("corner_bunny.glb");
    std::fs::copy(&a, &other).unwrap();
    let r = gibake(&[&"bake", &a, &other, &"--out-dir", &w.join("out")]);
    assert_bad_input(&r, &["corner_bunny.gibake"]);
    // Neither -o nor --out-dir; both; --shard with --out-dir.
    let r = gibake(&[&"bake", &a]);
    assert_eq!(r.code, Some(2), "{r}");
    let r = gibake(&[&"bake", &a, &"-o", &w.join("x"), &"--out-dir", &w]);
    assert_eq!(r.code, Some(2), "{r}");
    let r = gibake(&[&"bake", &a, &"--out-dir", &w, &"--shard", &"0/2"]);
    assert_eq!(r.code, Some(2), "{r}");
    // merge with no parts, or a missing file.
    let r = gibake(&[&"merge", &"-o", &w.join("m.gibake")]);
    assert_eq!(r.code, Some(2), "{r}");
    let r = gibake(&[&"merge", &w.join("nope.part"), &"-o", &w.join("m.gibake")]);
    assert_bad_input(&r, &["nope.part"]);
}

#[test]
fn bench_pipeline_reports_the_check_against_the_bake() {
    let dir = tempfile::tempdir().unwrap();
    let r = gibake(&[&"bench", &"pipeline", &"--quick", &"--out", &dir.path()]);
    assert_ok(&r);
    assert!(r.stdout.contains("| scene | bake (s) |"), "no table\n{r}");
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("pipeline.json")).unwrap()).unwrap();
    let scenes = j["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 3, "{j}");
    for s in scenes {
        let (bake, check) = (
            s["median_bake_seconds"].as_f64().unwrap(),
            s["median_check_seconds"].as_f64().unwrap(),
        );
        assert!(
            bake.is_finite() && bake > 0.0 && check.is_finite() && check > 0.0,
            "{s}"
        );
        // The target is < 10 % (docs/pipeline.md: about 1 % measured); this
        // loose bound only catches a check that started doing real work.
        assert!(
            check < 0.25 * bake,
            "the up-to-date check costs {check} s against a {bake} s bake: {s}"
        );
    }
}
