//! Format 4.4: the scene options a bake applied (`Manifest::scene_options`,
//! appended to the manifest payload after `ring_vpls`): round trip in the
//! documented layout, written in canonical form, 4.3 assets still read
//! (nothing recorded), bad values and damaged bytes refused naming the
//! manifest, the static-scene-hash message naming them (as flags for a
//! tool, in plain words for the runtime), `inspect` and `diff`, and shard
//! parts carrying them (and the ring VPLs, which part version 5 lost).

use crate::common;

use std::path::{Path, PathBuf};

use common::*;
use gibake_asset::*;

/// What `gibake bake room.glb --sun 173,60 --sun-irradiance 2.5
/// --sun-color 1,0.5,0.25 --dynamic 'Cylinder*' --light Key
/// --bake-volume=-1,0,-1,1,2,1 --max-texture-size 1024` records.
fn every_option() -> SceneOptions {
    SceneOptions {
        sun: Some(SunOption {
            azimuth_deg: 173.0,
            elevation_deg: 60.0,
            irradiance: 2.5,
            color: [1.0, 0.5, 0.25],
        }),
        dynamic: vec!["Cylinder*".into()],
        lights: vec!["Key".into()],
        bake_volume: Some([-1.0, 0.0, -1.0, 1.0, 2.0, 1.0]),
        max_texture_size: Some(1024),
    }
}

fn with_options(o: Option<SceneOptions>) -> Asset {
    let mut a = sample_asset(false);
    a.manifest.scene_options = o;
    a
}

fn fresh(tmp: &Path, name: &str, o: Option<SceneOptions>) -> PathBuf {
    let dir = tmp.join(name);
    write(&with_options(o), &dir).expect("write");
    dir
}

fn payload(dir: &Path) -> Vec<u8> {
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    bytes[20..20 + len].to_vec()
}

#[test]
fn scene_options_round_trip_in_the_documented_layout() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path(), "o.gibake", Some(every_option()));
    let loaded = load(&dir).unwrap();
    assert_eq!(
        loaded,
        as_written(&with_options(Some(every_option())), &loaded)
    );
    assert_eq!(loaded.scene_options(), Some(&every_option()));
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    assert_eq!(FORMAT_MINOR, 8);
    assert_eq!(u16::from_le_bytes([bytes[10], bytes[11]]), 8);
    // The payload ends with ring_vpls (none: `00`), then the Option tag
    // `01` and the fields: sun (tag, 6 f32), dynamic (count, strings),
    // lights, bake_volume (tag, 6 f32), max_texture_size (tag, varint:
    // 1024 is `FB 00 04`); then (4.5) swept_bounds, not recorded (`00`),
    // (4.6) later, none (`00`), (4.7) lower_map_count (`03`) and (4.8)
    // later_sources, none (`00`).
    let mut tail = vec![0u8, 1, 1];
    for x in [173.0f32, 60.0, 2.5, 1.0, 0.5, 0.25] {
        tail.extend_from_slice(&x.to_le_bytes());
    }
    tail.extend_from_slice(&[1, 9]);
    tail.extend_from_slice(b"Cylinder*");
    tail.extend_from_slice(&[1, 3]);
    tail.extend_from_slice(b"Key");
    tail.push(1);
    for x in [-1.0f32, 0.0, -1.0, 1.0, 2.0, 1.0] {
        tail.extend_from_slice(&x.to_le_bytes());
    }
    tail.extend_from_slice(&[1, 0xFB, 0x00, 0x04, 0, 0, 3, 0]);
    let p = payload(&dir);
    assert_eq!(&p[p.len() - tail.len()..], &tail[..]);
    // None given: `01` then five empty fields.
    let dir = fresh(tmp.path(), "none.gibake", Some(SceneOptions::default()));
    assert!(payload(&dir).ends_with(&[0, 1, 0, 0, 0, 0, 0, 0, 0, 3, 0]));
    assert_eq!(
        load(&dir).unwrap().scene_options(),
        Some(&SceneOptions::default())
    );
    // Not recorded: `00`.
    let dir = fresh(tmp.path(), "unknown.gibake", None);
    assert!(payload(&dir).ends_with(&[0, 0, 0, 0, 3, 0]));
    assert_eq!(load(&dir).unwrap().scene_options(), None);
}

#[test]
fn the_writer_records_the_canonical_form() {
    let tmp = tempfile::tempdir().unwrap();
    let canonical = SceneOptions {
        dynamic: vec!["a*".into(), "b?".into()],
        lights: vec!["x".into(), "y".into()],
        ..Default::default()
    };
    let given = SceneOptions {
        dynamic: vec!["b?".into(), "a*".into(), "b?".into()],
        lights: vec!["y".into(), "x".into()],
        max_texture_size: Some(DEFAULT_MAX_TEXTURE_SIZE),
        ..Default::default()
    };
    let a = fresh(tmp.path(), "a.gibake", Some(canonical.clone()));
    let b = fresh(tmp.path(), "b.gibake", Some(given));
    assert_eq!(
        std::fs::read(a.join(FILE_MANIFEST)).unwrap(),
        std::fs::read(b.join(FILE_MANIFEST)).unwrap(),
        "the same options in another order give other manifest bytes"
    );
    assert_eq!(load(&b).unwrap().scene_options(), Some(&canonical));
}

#[test]
fn a_4_3_manifest_loads_with_nothing_recorded() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path(), "o.gibake", Some(every_option()));
    let current = load(&dir).unwrap();
    // A 4.3 writer could not hold the options.
    assert!(testing::manifest_bytes_4_3(&current.manifest).is_err());
    let mut m = current.manifest.clone();
    m.scene_options = None;
    let old = testing::manifest_bytes_4_3(&m).unwrap();
    assert_eq!(u16::from_le_bytes([old[10], old[11]]), 3);
    // One byte shorter than the same manifest at 4.4 (its `None` tag).
    assert_eq!(
        old.len() + 1,
        testing::manifest_bytes_4_4(&m).unwrap().len()
    );
    std::fs::write(dir.join(FILE_MANIFEST), &old).unwrap();
    let loaded = load(&dir).expect("a 4.3 asset loads");
    assert_eq!(loaded.scene_options(), None);
    let mut expected = without_4_7(&current);
    expected.manifest.scene_options = None;
    assert_eq!(loaded, expected);
    // The 4.3 payload with a 4.4 tail appended, still minor 3: refused.
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    std::fs::write(
        dir.join(FILE_MANIFEST),
        with_payload_tail(&bytes, len, &[0]),
    )
    .unwrap();
    let msg = load_manifest(&dir).unwrap_err().to_string();
    assert!(msg.contains("1 unexpected bytes"), "{msg}");
}

#[test]
fn bad_values_and_damaged_bytes_are_refused_naming_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    type Case = (&'static str, fn(&mut SceneOptions));
    let cases: [Case; 4] = [
        ("scene_options: sun elevation 0 is not in (0, 90]", |o| {
            o.sun.as_mut().unwrap().elevation_deg = 0.0
        }),
        ("scene_options: sun irradiance NaN", |o| {
            o.sun.as_mut().unwrap().irradiance = f32::NAN
        }),
        (
            "scene_options: bake volume -1,0,-1,-2,2,1 is not a finite box",
            |o| o.bake_volume = Some([-1.0, 0.0, -1.0, -2.0, 2.0, 1.0]),
        ),
        (
            "scene_options: largest texture side 0 is not in 1..=65536",
            |o| o.max_texture_size = Some(0),
        ),
    ];
    for (k, (what, edit)) in cases.into_iter().enumerate() {
        let dir = fresh(tmp.path(), &format!("b{k}.gibake"), Some(every_option()));
        edit_manifest(&dir, |m| edit(m.scene_options.as_mut().unwrap()));
        for e in [load_manifest(&dir).unwrap_err(), load(&dir).unwrap_err()] {
            let msg = e.to_string();
            assert!(matches!(e, AssetError::Invalid { .. }), "{e:?}");
            assert!(
                msg.contains("manifest.bin") && msg.contains(what),
                "{what}: {msg}"
            );
        }
        // Nothing is written from such a manifest either.
        let mut o = every_option();
        edit(&mut o);
        let out = tmp.path().join(format!("w{k}.gibake"));
        let err = write(&with_options(Some(o)), &out).unwrap_err().to_string();
        assert!(err.contains("cannot write") && err.contains(what), "{err}");
        assert!(!out.exists());
    }
    // Damaged bytes behind a valid checksum (in place of the `None` tag and
    // what 4.5 to 4.8 append after it): an Option tag of 2, a string claiming 2^40
    // bytes, a pattern that is not UTF-8, a cut field.
    let dir = fresh(tmp.path(), "d.gibake", None);
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    let mut huge = vec![1u8, 0, 1, 253];
    huge.extend_from_slice(&(1u64 << 40).to_le_bytes());
    for tail in [
        vec![2u8],
        huge,
        vec![1, 0, 1, 2, 0xC3, 0x28, 0, 0, 0],
        vec![1, 1, 0, 0],
    ] {
        std::fs::write(
            dir.join(FILE_MANIFEST),
            with_payload_tail(&bytes, len - 5, &tail),
        )
        .unwrap();
        let msg = load_manifest(&dir).unwrap_err().to_string();
        assert!(
            msg.contains("manifest.bin") && msg.contains("damaged manifest payload: scene_options"),
            "{tail:?}: {msg}"
        );
    }
}

#[test]
fn the_scene_hash_message_names_the_options_the_asset_was_baked_with() {
    let room = SceneOptions {
        sun: Some(SunOption {
            azimuth_deg: 173.0,
            elevation_deg: 60.0,
            irradiance: 1.0,
            color: [1.0; 3],
        }),
        dynamic: vec!["Cylinder*".into()],
        ..Default::default()
    };
    let mut m = with_options(Some(room.clone())).manifest;
    let dir = Path::new("room.gibake");
    let scene = Path::new("room.glb");
    let other = [0xCD; 32];
    let tool = |m: &Manifest, loaded: Option<&SceneOptions>| {
        check_scene_hash_for(dir, m, &other, scene, loaded)
            .unwrap_err()
            .to_string()
    };
    // A tool that loaded the scene without them (or does not say).
    let msg = tool(&m, None);
    assert!(
        msg.contains("room.gibake (baked from `corner.gltf`) was baked from a different static scene than room.glb")
            && msg.ends_with(
                "; it was baked with --sun 173,60 --dynamic 'Cylinder*': give the same flags, or re-bake it"
            ),
        "{msg}"
    );
    assert_eq!(tool(&m, Some(&SceneOptions::default())), msg);
    // A tool that loaded it with them: the level itself changed.
    let msg = tool(&m, Some(&room));
    assert!(
        msg.ends_with(
            "it was baked with --sun 173,60 --dynamic 'Cylinder*', the same flags as here: the level's static part changed since; re-bake it"
        ),
        "{msg}"
    );
    // The runtime's message: plain words, no command line.
    let msg = check_scene_hash(&m, &other, scene).unwrap_err().to_string();
    assert!(
        msg.contains("it was baked with the scene options sun at azimuth 173°, elevation 60°")
            && msg.contains("moving objects 'Cylinder*'")
            && msg.ends_with("load the scene with them, or re-bake it")
            && !msg.contains("--"),
        "{msg}"
    );
    // Baked with none of them.
    m.scene_options = Some(SceneOptions::default());
    let msg = tool(&m, None);
    assert!(
        msg.ends_with(
            "; it was baked with none of --sun, --dynamic, --light, --bake-volume or --max-texture-size: give none of them, or re-bake it"
        ),
        "{msg}"
    );
    assert!(tool(&m, Some(&SceneOptions::default())).ends_with("); re-bake it"));
    let msg = check_scene_hash(&m, &other, scene).unwrap_err().to_string();
    assert!(msg.ends_with("); re-bake it"), "{msg}");
    // Not recorded (format 4.3 or older): both ways out are named.
    m.scene_options = None;
    let msg = tool(&m, None);
    assert!(
        msg.ends_with(
            "; re-bake it, or, if it was baked with --sun, --dynamic, --light, --bake-volume or --max-texture-size, give the same ones (an asset before format 4.4 does not record them)"
        ),
        "{msg}"
    );
    let msg = check_scene_hash(&m, &other, scene).unwrap_err().to_string();
    assert!(msg.ends_with("); re-bake it"), "{msg}");
    // The same hash passes whatever is recorded.
    let same = m.static_scene_hash;
    assert!(check_scene_hash_for(dir, &m, &same, scene, None).is_ok());
}

#[test]
fn inspect_shows_and_diff_compares_the_options() {
    let tmp = tempfile::tempdir().unwrap();
    let a = load(&fresh(tmp.path(), "a.gibake", Some(every_option()))).unwrap();
    let text = inspect(&a).to_string();
    assert!(
        text.contains(
            "  scene flags: --sun 173,60 --sun-irradiance 2.5 --sun-color 1,0.5,0.25 --dynamic 'Cylinder*' --light Key --bake-volume=-1,0,-1,1,2,1 --max-texture-size 1024 (render and view apply them when given none)"
        ),
        "{text}"
    );
    let json = serde_json::to_value(inspect(&a)).unwrap();
    assert_eq!(json["scene_options"]["sun"]["azimuth_deg"], 173.0);
    assert_eq!(json["scene_options"]["dynamic"][0], "Cylinder*");
    assert!(
        json["scene_flags"]
            .as_str()
            .unwrap()
            .starts_with("--sun 173,60")
    );
    let none = load(&fresh(
        tmp.path(),
        "n.gibake",
        Some(SceneOptions::default()),
    ))
    .unwrap();
    assert!(
        inspect(&none)
            .to_string()
            .contains("  scene flags: none (the level as exported")
    );
    let unknown = load(&fresh(tmp.path(), "u.gibake", None)).unwrap();
    assert!(
        inspect(&unknown)
            .to_string()
            .contains("  scene flags: not recorded")
    );
    assert!(serde_json::to_value(inspect(&unknown)).unwrap()["scene_flags"].is_null());

    let tol = Tolerance::same_machine();
    assert!(diff(&a, &a, &tol).equal());
    // Both recorded and different: a difference that counts.
    let r = diff(&a, &none, &tol);
    assert!(!r.equal());
    assert!(
        r.differences.iter().any(|d| d
            .starts_with("scene flags: A was baked with --sun 173,60 --sun-irradiance 2.5")
            && d.ends_with(
                "B with none of --sun, --dynamic, --light, --bake-volume or --max-texture-size"
            )),
        "{r}"
    );
    assert!(r.to_string().contains("scene flags: --sun 173,60"), "{r}");
    // One not recorded: reported, not counted (the maps are the same).
    let r = diff(&none, &unknown, &tol);
    assert!(r.equal(), "{r}");
    let d = r.scene_options.as_ref().expect("reported");
    assert_eq!(d.b, "not recorded");
    assert!(diff(&a, &a.clone(), &tol).scene_options.is_none());
}

/// The parts of `asset` split into `n` shards, as the shards write them.
fn parts(asset: &Asset, n: u32) -> Vec<ShardPart> {
    let mut front = asset.clone();
    front.manifest.map_count = 0;
    front.vpl_maps = MapAtlas::empty(asset.manifest.settings.vpl_map_size);
    for v in &mut front.vpls {
        v.map = NO_MAP;
    }
    front.manifest.lower_map_count = 0;
    front.vpl_lower_maps = MapAtlas::empty(asset.manifest.settings.vpl_map_size);
    for l in front.vpl_lower.iter_mut().filter(|l| l.is_some()) {
        l.map = NO_MAP;
    }
    (0..n)
        .map(|k| ShardPart {
            shard: k,
            shards: n,
            front: front.clone(),
            maps: shard_range(asset.vpls.len(), k, n)
                .map(|i| asset.vpl_map_of(i))
                .collect(),
            lower_maps: shard_range(asset.vpls.len(), k, n)
                .map(|i| asset.vpl_lower_map_of(i))
                .collect(),
        })
        .collect()
}

/// Part version 6 carries the manifest's `scene_options` and its
/// `ring_vpls`, version 7 its `swept_bounds` (format 4.5), version 8 its
/// `later` (format 4.6), version 9 the second origins and maps (format
/// 4.7), version 10 its `later_sources` (format 4.8): a sharded bake of a sun with outer rings merged into the single
/// bake's bytes (version 5 dropped both: the merge had no ring VPLs).
#[test]
fn shard_parts_carry_the_options_and_the_ring_vpls() {
    assert_eq!(PART_VERSION, 10);
    let tmp = tempfile::tempdir().unwrap();
    let mut a = with_options(Some(every_option()));
    a.manifest.lights[0].kind = LIGHT_DIRECTIONAL;
    a.manifest.ring_vpls = vec![2, 0];
    a.manifest.swept_bounds = Some([-1.0, 0.0, -1.0, 1.0, 2.0, 1.0]);
    let dir = tmp.path().join("single.gibake");
    write(&a, &dir).unwrap();
    let single = load(&dir).unwrap();
    let mut loaded = Vec::new();
    for part in parts(&single, 2) {
        let path = tmp.path().join(format!("p{}", part.shard));
        write_part(&part, &path).unwrap();
        let back = load_part(&path).unwrap();
        assert_eq!(back.front.manifest.ring_vpls, vec![2, 0]);
        assert_eq!(back.front.manifest.scene_options, Some(every_option()));
        assert_eq!(back.front.manifest.swept_bounds, a.manifest.swept_bounds);
        assert_eq!(back, part);
        loaded.push((path, back));
    }
    let merged = merge(loaded.clone()).unwrap();
    let out = tmp.path().join("merged.gibake");
    write(&merged, &out).unwrap();
    for f in file_names(&dir) {
        assert_eq!(
            std::fs::read(dir.join(&f)).unwrap(),
            std::fs::read(out.join(&f)).unwrap(),
            "{f} of the merge differs from the single bake's"
        );
    }
    // A part baked with other flags does not merge, saying which.
    let (path, mut odd) = loaded[1].clone();
    odd.front.manifest.scene_options = Some(SceneOptions::default());
    let mut m = Merger::default();
    m.add(loaded[0].0.clone(), loaded[0].1.clone()).unwrap();
    let e = m.add(path, odd).unwrap_err().to_string();
    assert!(
        e.contains("baked with other scene flags (none of --sun")
            && e.contains("against --sun 173,60"),
        "{e}"
    );
}
