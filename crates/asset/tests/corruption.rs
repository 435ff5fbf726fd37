//! Damaged, truncated, hostile and mismatched assets: every one is a clear
//! error naming the file, and nothing panics.

use crate::common;

use std::path::Path;

use common::*;
use gibake_asset::*;

fn fresh(tmp: &Path) -> std::path::PathBuf {
    written(tmp, &sample_asset(true))
}

fn all_files(dir: &Path) -> Vec<String> {
    file_names(dir)
}

fn expect_err_naming(dir: &Path, name: &str, what: &str) -> AssetError {
    match load(dir) {
        Ok(_) => panic!("{what}: load of a damaged {name} succeeded"),
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.contains(name),
                "{what}: error does not name {name}: {msg}"
            );
            e
        }
    }
}

#[test]
fn every_file_truncated_is_an_error_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    for name in all_files(&dir) {
        let path = dir.join(&name);
        let orig = std::fs::read(&path).unwrap();
        for len in [0, orig.len() / 2, orig.len() - 1] {
            std::fs::write(&path, &orig[..len]).unwrap();
            let e = expect_err_naming(&dir, &name, &format!("truncated to {len}"));
            assert!(matches!(e, AssetError::Invalid { .. }), "{e:?}");
        }
        std::fs::write(&path, &orig).unwrap();
        load(&dir).unwrap();
    }
}

#[test]
fn every_file_with_a_bit_flip_is_an_error_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let mut rng = Rng::new(3);
    for name in all_files(&dir) {
        let path = dir.join(&name);
        let orig = std::fs::read(&path).unwrap();
        let mut positions = vec![0, orig.len() / 2, orig.len() - 1];
        positions.extend((0..5).map(|_| rng.below(orig.len())));
        for pos in positions {
            let mut bad = orig.clone();
            bad[pos] ^= 1 << rng.below(8);
            std::fs::write(&path, &bad).unwrap();
            let e = expect_err_naming(&dir, &name, &format!("bit flip at {pos}"));
            if name != "manifest.bin" {
                assert!(e.to_string().contains("checksum"), "{e}");
            }
        }
        std::fs::write(&path, &orig).unwrap();
    }
    load(&dir).unwrap();
}

#[test]
fn a_missing_file_is_an_io_error_naming_it() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    for name in all_files(&dir) {
        let path = dir.join(&name);
        let orig = std::fs::read(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        let e = expect_err_naming(&dir, &name, "missing");
        if name == "manifest.bin" {
            // A directory without a manifest is said to be no asset.
            assert!(e.to_string().contains("not a baked gibake asset"), "{e}");
        } else {
            assert!(matches!(e, AssetError::Io { .. }), "{e:?}");
        }
        std::fs::write(&path, &orig).unwrap();
    }
}

#[test]
fn another_major_version_is_not_supported_naming_both() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let path = dir.join("manifest.bin");
    let orig = std::fs::read(&path).unwrap();
    for major in [FORMAT_MAJOR + 1, 0] {
        let mut b = orig.clone();
        b[8..10].copy_from_slice(&major.to_le_bytes());
        b[10..12].copy_from_slice(&0u16.to_le_bytes());
        std::fs::write(&path, &b).unwrap();
        for e in [load(&dir).unwrap_err(), load_manifest(&dir).unwrap_err()] {
            let msg = e.to_string();
            assert!(matches!(e, AssetError::NotSupported { .. }), "{e:?}");
            assert!(msg.contains(&format!("asset format {major}.0")), "{msg}");
            assert!(msg.contains(&format!("reads {FORMAT_MAJOR}.x")), "{msg}");
            assert!(msg.contains("manifest.bin"), "{msg}");
        }
    }
}

#[test]
fn a_newer_minor_version_with_additions_is_read() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let path = dir.join("manifest.bin");
    let b = std::fs::read(&path).unwrap();
    let len = u64::from_le_bytes(b[12..20].try_into().unwrap()) as usize;
    // Minor + 1, three more bytes appended to the payload, re-hashed.
    let mut n = b[..20 + len].to_vec();
    n[10..12].copy_from_slice(&(FORMAT_MINOR + 1).to_le_bytes());
    n.extend_from_slice(&[1, 2, 3]);
    n[12..20].copy_from_slice(&(len as u64 + 3).to_le_bytes());
    let h = *blake3::hash(&n).as_bytes();
    n.extend_from_slice(&h);
    std::fs::write(&path, &n).unwrap();
    load(&dir).unwrap();
    // The same trailing bytes without the newer minor are an error.
    n[10..12].copy_from_slice(&FORMAT_MINOR.to_le_bytes());
    let h = *blake3::hash(&n[..20 + len + 3]).as_bytes();
    n[20 + len + 3..].copy_from_slice(&h);
    std::fs::write(&path, &n).unwrap();
    let msg = load(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("manifest.bin") && msg.contains("unexpected bytes"),
        "{msg}"
    );
}

#[test]
fn wrong_magic_and_bad_payload_length() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let path = dir.join("manifest.bin");
    let orig = std::fs::read(&path).unwrap();

    let mut b = orig.clone();
    b[..8].copy_from_slice(b"PNG\r\n\x1a\n\0");
    std::fs::write(&path, &b).unwrap();
    let e = load(&dir).unwrap_err();
    assert!(matches!(e, AssetError::Invalid { .. }));
    assert!(
        e.to_string().contains("manifest.bin") && e.to_string().contains("magic"),
        "{e}"
    );

    for len in [
        0u64,
        1,
        (orig.len() - 20 - 32 - 1) as u64,
        (orig.len() - 20) as u64,
        u64::MAX,
    ] {
        let mut b = orig.clone();
        b[12..20].copy_from_slice(&len.to_le_bytes());
        std::fs::write(&path, &b).unwrap();
        let e = load(&dir).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("manifest.bin") && msg.contains("payload length"),
            "{msg}"
        );
    }
}

#[test]
fn manifest_and_vpls_never_panic_on_truncation_or_flips() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let mut rng = Rng::new(11);
    for name in ["manifest.bin", "vpls.bin"] {
        let path = dir.join(name);
        let orig = std::fs::read(&path).unwrap();
        for len in 0..orig.len() {
            std::fs::write(&path, &orig[..len]).unwrap();
            assert!(load(&dir).is_err(), "{name} truncated to {len} loaded");
        }
        for _ in 0..300 {
            let mut b = orig.clone();
            let pos = rng.below(b.len());
            b[pos] ^= 1 + rng.below(255) as u8;
            std::fs::write(&path, &b).unwrap();
            assert!(load(&dir).is_err(), "{name} with byte {pos} changed loaded");
        }
        std::fs::write(&path, &orig).unwrap();
    }
    load(&dir).unwrap();
}

#[test]
fn parsers_behind_the_checksums_never_panic() {
    // Re-sign damaged contents so that they reach the decoders.
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let mut rng = Rng::new(5);

    // Manifest payload: every truncation and byte changes, re-hashed.
    let path = dir.join("manifest.bin");
    let orig = std::fs::read(&path).unwrap();
    let len = u64::from_le_bytes(orig[12..20].try_into().unwrap()) as usize;
    let payload = orig[20..20 + len].to_vec();
    let sign = |p: &[u8]| {
        let mut b = orig[..20].to_vec();
        b[12..20].copy_from_slice(&(p.len() as u64).to_le_bytes());
        b.extend_from_slice(p);
        let h = *blake3::hash(&b).as_bytes();
        b.extend_from_slice(&h);
        b
    };
    for l in 0..payload.len() {
        std::fs::write(&path, sign(&payload[..l])).unwrap();
        assert!(load(&dir).is_err(), "payload truncated to {l} loaded");
    }
    for _ in 0..300 {
        let mut p = payload.clone();
        let pos = rng.below(p.len());
        p[pos] = rng.below(256) as u8;
        std::fs::write(&path, sign(&p)).unwrap();
        let _ = load(&dir); // may be valid (e.g. a changed name): must not panic
    }
    std::fs::write(&path, &orig).unwrap();

    // Data files: truncations and flips with valid checksums.
    for name in ["vpls.bin", "primary_depth.exr", "vpl_maps.exr", "rsm.exr"] {
        let good = std::fs::read(dir.join(name)).unwrap();
        let mut tries: Vec<Vec<u8>> = vec![vec![], good[..good.len() / 2].to_vec()];
        tries.push(good[..good.len() - 1].to_vec());
        for _ in 0..40 {
            let mut b = good.clone();
            let pos = rng.below(b.len());
            b[pos] = rng.below(256) as u8;
            tries.push(b);
        }
        for (k, b) in tries.iter().enumerate() {
            replace_signed(&dir, name, b);
            let r = load(&dir);
            if k < 3 {
                let e = r.expect_err("truncated file loaded");
                assert!(e.to_string().contains(name), "{e}");
            }
        }
        replace_signed(&dir, name, &good);
    }
    load(&dir).unwrap();
}

#[test]
fn hostile_counts_are_refused_without_huge_allocations() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    type Edit = Box<dyn Fn(&mut Manifest)>;
    let cases: Vec<(&str, Edit)> = vec![
        ("vpl_count", Box::new(|m| m.vpl_count = u32::MAX)),
        (
            "vpls.bin",
            Box::new(|m| {
                m.vpl_count = u32::MAX;
                m.files[0].size = u32::MAX as u64 * 48;
                m.files[1].size = u32::MAX as u64 * 48 * 84;
                let c = m.files.iter_mut().find(|f| f.name == "vpl_coherence.bin");
                c.expect("listed").size = u32::MAX as u64 * 4 * 64;
                let l = m.files.iter_mut().find(|f| f.name == "vpl_lower.bin");
                l.expect("listed").size = u32::MAX as u64 * 16;
            }),
        ),
        ("map_count", Box::new(|m| m.map_count = m.vpl_count + 1)),
        (
            "lower_map_count",
            Box::new(|m| m.lower_map_count = m.vpl_count + 1),
        ),
        (
            "vpl_lower.bin",
            Box::new(|m| {
                let l = m.files.iter_mut().find(|f| f.name == "vpl_lower.bin");
                l.expect("listed").size += 16;
            }),
        ),
        ("vpl_map_size", Box::new(|m| m.settings.vpl_map_size = 0)),
        (
            "shadow_map_size",
            Box::new(|m| m.settings.shadow_map_size = 1 << 20),
        ),
        ("rsm_size", Box::new(|m| m.settings.rsm_size = u32::MAX)),
        ("light_map_size", Box::new(|m| m.light_map_size = u32::MAX)),
        (
            "views",
            Box::new(|m| {
                let v = m.views[0].clone();
                m.views.extend(std::iter::repeat_n(v, 100_000));
            }),
        ),
        ("tile", Box::new(|m| m.views[0].tile = 1_000_000)),
        ("threshold", Box::new(|m| m.settings.threshold = f32::NAN)),
        (
            "light_view",
            Box::new(|m| m.light_view.origin[1] = f32::INFINITY),
        ),
        ("rsm.exr", Box::new(|m| m.has_dynamic = false)),
        (
            "vpl_maps.exr",
            Box::new(|m| m.files.retain(|f| f.name != "vpl_maps.exr")),
        ),
        (
            "listed twice",
            Box::new(|m| m.files.push(m.files[0].clone())),
        ),
        (
            "unknown file",
            Box::new(|m| {
                let mut f = m.files[0].clone();
                f.name = "../../etc/passwd".into();
                m.files.push(f);
            }),
        ),
        (
            "primary_depth.exr",
            Box::new(|m| {
                let f = m.files.iter_mut().find(|f| f.name == "primary_depth.exr");
                f.expect("listed").size = u64::MAX;
            }),
        ),
    ];
    let orig = std::fs::read(dir.join("manifest.bin")).unwrap();
    for (what, f) in cases {
        edit_manifest(&dir, f);
        let e = load(&dir).expect_err(what);
        let msg = e.to_string();
        assert!(msg.contains(what), "{what}: {msg}");
        std::fs::write(dir.join("manifest.bin"), &orig).unwrap();
    }
    // A shadow map size that agrees with nothing on disk: the EXR check names it.
    edit_manifest(&dir, |m| m.settings.shadow_map_size = 4096);
    let msg = load(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("primary_depth.exr") && msg.contains("16x16"),
        "{msg}"
    );
}

#[test]
fn bad_values_behind_valid_checksums_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let good = std::fs::read(dir.join("vpls.bin")).unwrap();
    // A NaN position, then a map index out of range.
    for (offset, value, what) in [
        (4usize, f32::NAN.to_bits(), "not finite"),
        (44, 7, "hemisphere map 7"),
    ] {
        let mut b = good.clone();
        b[48 * 2 + offset..48 * 2 + offset + 4].copy_from_slice(&value.to_le_bytes());
        replace_signed(&dir, "vpls.bin", &b);
        let msg = load(&dir).unwrap_err().to_string();
        assert!(
            msg.contains("vpls.bin") && msg.contains("VPL 2") && msg.contains(what),
            "{msg}"
        );
    }
    replace_signed(&dir, "vpls.bin", &good);

    // An RSM texel pointing past the VPLs.
    let mut asset = load(&dir).unwrap();
    asset.rsm.as_mut().unwrap().vpl[5] = VPLS as u32;
    let e = write(&asset, &tmp.path().join("x.gibake")).unwrap_err();
    assert!(
        e.to_string().contains("rsm: channel vpl refers to VPL 10"),
        "{e}"
    );
    assert!(!tmp.path().join("x.gibake").exists());
}

#[test]
fn scene_hash_mismatch_names_asset_and_scene() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let m = load_manifest(&dir).unwrap();
    let scene = Path::new("data/other_scene.gltf");
    check_scene_hash(&m, &[0xAB; 32], scene).unwrap();
    check_scene_hash_for(&dir, &m, &[0xAB; 32], scene, None).unwrap();
    let e = check_scene_hash(&m, &[0xCD; 32], scene).unwrap_err();
    assert!(matches!(e, AssetError::SceneMismatch { .. }));
    let msg = e.to_string();
    assert!(
        msg.contains("corner.gltf") && msg.contains("other_scene.gltf"),
        "{msg}"
    );
    assert!(
        msg.contains("was baked from a different static scene"),
        "{msg}"
    );
    assert!(
        msg.contains("abababab") && msg.contains("cdcdcdcd"),
        "{msg}"
    );
    let msg = check_scene_hash_for(&dir, &m, &[0; 32], scene, None)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("scene.gibake") && msg.contains("other_scene.gltf"),
        "{msg}"
    );
}

#[test]
fn a_directory_that_is_no_asset_is_an_error() {
    let tmp = tempfile::tempdir().unwrap();
    let e = load(tmp.path()).unwrap_err();
    assert!(matches!(e, AssetError::Invalid { .. }));
    assert!(
        e.to_string()
            .contains("a directory without manifest.bin: not a baked gibake asset"),
        "{e}"
    );
    let e = load(&tmp.path().join("nope.gibake")).unwrap_err();
    assert!(e.to_string().contains("nope.gibake: does not exist"), "{e}");
    // A file given as an asset: a scene, a shard part, anything else.
    let scene = tmp.path().join("level.glb");
    std::fs::write(&scene, b"glTF\x02\0\0\0").unwrap();
    let e = load(&scene).unwrap_err().to_string();
    assert!(e.contains("a scene, not a baked asset"), "{e}");
    let part = tmp.path().join("part.0");
    std::fs::write(&part, gibake_asset::PART_MAGIC).unwrap();
    let e = load(&part).unwrap_err().to_string();
    assert!(
        e.contains("a shard part") && e.contains("gibake merge"),
        "{e}"
    );
    let other = tmp.path().join("notes.txt");
    std::fs::write(&other, b"hello").unwrap();
    let e = load(&other).unwrap_err().to_string();
    assert!(e.contains("a file, not a baked asset"), "{e}");
    assert!(!e.contains("os error"), "{e}");
}

#[test]
fn two_vpls_sharing_a_map_tile_and_bad_nodes_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let asset = load(&dir).unwrap();
    let with_map: Vec<usize> = (0..asset.vpls.len())
        .filter(|&i| asset.vpls[i].map != NO_MAP)
        .collect();
    assert!(with_map.len() >= 2, "the sample stores maps");
    // VPL b points at VPL a's tile (the manifest's checksums re-sealed).
    let (a, b) = (with_map[0], with_map[1]);
    let good = std::fs::read(dir.join("vpls.bin")).unwrap();
    let mut bytes = good.clone();
    let tile = asset.vpls[a].map.to_le_bytes();
    bytes[48 * b + 44..48 * b + 48].copy_from_slice(&tile);
    replace_signed(&dir, "vpls.bin", &bytes);
    let msg = load(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("vpls.bin")
            && msg.contains(&format!("VPL {b} uses hemisphere map tile"))
            && msg.contains(&format!("VPL {a} already uses")),
        "{msg}"
    );
    replace_signed(&dir, "vpls.bin", &good);
    // The writer refuses the same.
    let mut dup = asset.clone();
    dup.vpls[b].map = dup.vpls[a].map;
    let e = write(&dup, &tmp.path().join("dup.gibake")).unwrap_err();
    assert!(e.to_string().contains("already uses"), "{e}");
    // A bad near-field node is named as a node of its VPL, without Rust
    // debug text.
    let nodes = std::fs::read(dir.join("vpl_nodes.bin")).unwrap();
    let mut bytes = nodes.clone();
    let rec = NODES_PER_VPL + 5;
    bytes[48 * rec..48 * rec + 4].copy_from_slice(&f32::INFINITY.to_bits().to_le_bytes());
    replace_signed(&dir, "vpl_nodes.bin", &bytes);
    let msg = load(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("near-field node 5 of VPL 1") && msg.contains("position.x is inf"),
        "{msg}"
    );
    assert!(!msg.contains("VplRecord") && !msg.contains('{'), "{msg}");
}

/// A finite value in an atlas tile past the last map (vpl_maps.exr holds 7
/// maps in a 3 × 3 grid here) is refused at write and at load, naming the
/// file and the tile.
#[test]
fn a_finite_value_in_an_unused_atlas_tile_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path());
    let asset = load(&dir).unwrap();
    let (cols, rows) = asset.vpl_maps.grid();
    let count = asset.vpl_maps.count();
    assert!(cols * rows > count, "the sample leaves a tile unused");
    // The last texel of the atlas lies in the last, unused tile.
    let mut bad = asset.clone();
    *bad.vpl_maps.texels_mut().last_mut().unwrap() = 1.5;
    let out = tmp.path().join("bad.gibake");
    let e = write(&bad, &out).unwrap_err().to_string();
    assert!(e.contains("vpl_maps") && e.contains("unused tile"), "{e}");
    assert!(!out.exists(), "nothing left behind");
    // The same atlas on disk behind a valid checksum (written by hand).
    let exr = dir.join("vpl_maps.exr");
    let good = std::fs::read(&exr).unwrap();
    let s = asset.vpl_maps.tile_size();
    let (w, h) = (cols * s, rows * s);
    let mut texels = asset.vpl_maps.texels().to_vec();
    *texels.last_mut().unwrap() = 1.5;
    let bytes = testing::z_exr_bytes(w as usize, h as usize, texels).unwrap();
    replace_signed(&dir, "vpl_maps.exr", &bytes);
    let msg = load(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("vpl_maps.exr") && msg.contains(&format!("unused tile {}", cols * rows - 1)),
        "{msg}"
    );
    replace_signed(&dir, "vpl_maps.exr", &good);
    load(&dir).expect("the original loads again");
}

#[test]
fn damaged_level3_coherences_are_named_and_a_4_1_asset_has_none() {
    let tmp = tempfile::tempdir().unwrap();
    let mut asset = sample_asset(true);
    // VPL 0's first level-3 node lit, its texels' coherence 0.5.
    asset.vpl_nodes[NODES_PER_VPL - LEVEL3_NODES] = asset.vpl_nodes[0];
    asset.vpl_coherence[0] = 0.5;
    let dir = written(tmp.path(), &asset);
    assert_eq!(load(&dir).unwrap().vpl_coherence, asset.vpl_coherence);
    let good = std::fs::read(dir.join(FILE_VPL_COHERENCE)).unwrap();
    let cases = [
        (
            0,
            1.5f32,
            "VPL 0 level-3 node 0: coherence 1.5 is not in [0, 1]",
        ),
        (0, f32::NAN, "coherence NaN is not in [0, 1]"),
        (
            1,
            0.5,
            "VPL 0 level-3 node 1 is empty but its coherence is 0.5, not 1",
        ),
    ];
    for (at, v, says) in cases {
        let mut bytes = good.clone();
        bytes[4 * at..4 * at + 4].copy_from_slice(&v.to_le_bytes());
        replace_signed(&dir, FILE_VPL_COHERENCE, &bytes);
        let msg = expect_err_naming(&dir, FILE_VPL_COHERENCE, says).to_string();
        assert!(msg.contains(says), "{msg}");
    }
    // The writer refuses a count that is neither none nor 64 per VPL.
    let mut short = asset.clone();
    short.vpl_coherence.pop();
    let e = write(&short, &tmp.path().join("short.gibake")).unwrap_err();
    assert!(e.to_string().contains("vpl_coherence holds"), "{e}");
    // A 4.1 manifest (which does not list the file) loads with none: every
    // level-3 node one cosine lobe, its tree as stored.
    replace_signed(&dir, FILE_VPL_COHERENCE, &good);
    let m = load_manifest(&dir).unwrap();
    std::fs::write(
        dir.join(FILE_MANIFEST),
        testing::manifest_bytes_4_1(&m).unwrap(),
    )
    .unwrap();
    let old = load(&dir).unwrap();
    assert!(old.vpl_coherence.is_empty() && old.level3_coherence(0).is_empty());
    assert_eq!(old.texel_tree(0), old.vpl_nodes[..NODES_PER_VPL].to_vec());
    // Written again, it is a 4.2 asset with coherence 1 everywhere.
    let again = tmp.path().join("again.gibake");
    write(&old, &again).unwrap();
    let c = load(&again).unwrap().vpl_coherence;
    assert_eq!(c.len(), old.vpls.len() * LEVEL3_NODES);
    assert!(c.iter().all(|&c| c == 1.0));
}
