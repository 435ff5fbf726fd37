//! Format 4.1: the other lights' view RSMs (`Manifest::view_rsms`, appended
//! to the manifest payload, and `view_rsms.exr`): round trip, 4.0 assets
//! still read, every refusal naming its file, shards, `diff`, `inspect`, and
//! the spec reader (`tools/spec_reader/read_gibake.py`) reading them too.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::*;
use gibake_asset::*;

/// The error of loading `dir`, checked to be `Invalid` and to name `file`
/// and `what`.
fn refused(dir: &Path, file: &str, what: &str) -> String {
    let e = load(dir).expect_err("a damaged asset must be refused");
    let msg = e.to_string();
    assert!(matches!(e, AssetError::Invalid { .. }), "{e:?}");
    assert!(msg.contains(file), "the message must name {file}: {msg}");
    assert!(msg.contains(what), "the message must say `{what}`: {msg}");
    msg
}

/// The three channels of the view-RSM atlas of `rsms` (a 2 × 2 grid for
/// three tiles; unused tiles empty), laid out by hand as the spec says.
fn atlas_of(rsms: &[RsmData]) -> (usize, usize, Vec<f32>, Vec<u32>, Vec<u32>) {
    let s = RSM as usize;
    let (cols, rows) = atlas_grid(rsms.len() as u32);
    let (w, h) = (cols as usize * s, rows as usize * s);
    let (mut z, mut share, mut vpl) = (
        vec![f32::INFINITY; w * h],
        vec![0u32; w * h],
        vec![u32::MAX; w * h],
    );
    for (k, r) in rsms.iter().enumerate() {
        let (cx, cy) = (k % cols as usize, k / cols as usize);
        for y in 0..s {
            for x in 0..s {
                let i = (cy * s + y) * w + cx * s + x;
                z[i] = r.metric[y * s + x];
                share[i] = r.share[y * s + x];
                vpl[i] = r.vpl[y * s + x];
            }
        }
    }
    (w, h, z, share, vpl)
}

/// A fresh written copy of the sample with view RSMs, and the asset.
fn fresh(tmp: &Path, name: &str) -> (PathBuf, Asset) {
    let asset = sample_asset_with_view_rsms();
    let dir = tmp.join(name);
    write(&asset, &dir).expect("write");
    (dir, asset)
}

/// Stores `rsms` as `view_rsms.exr` of `dir` behind a valid checksum.
fn store(dir: &Path, rsms: &[RsmData], edit: impl FnOnce(&mut [f32], &mut [u32], &mut [u32])) {
    let (w, h, mut z, mut share, mut vpl) = atlas_of(rsms);
    edit(&mut z, &mut share, &mut vpl);
    let bytes = testing::rsm_exr_bytes(w, h, z, share, vpl).unwrap();
    replace_signed(dir, FILE_VIEW_RSMS, &bytes);
}

#[test]
fn view_rsms_round_trip_in_the_documented_layout() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, asset) = fresh(tmp.path(), "a.gibake");
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded, as_written(&asset, &loaded));
    assert_eq!(loaded.manifest.view_rsms, VIEW_RSMS);
    assert_eq!(loaded.view_rsms.len(), VIEW_RSMS.len());
    // The file list: view_rsms.exr last.
    let names: Vec<&str> = loaded
        .manifest
        .files
        .iter()
        .map(|f| f.name.as_str())
        .collect();
    assert_eq!(names.last(), Some(&FILE_VIEW_RSMS));
    // The manifest payload ends with the appended vector: count 3, then
    // the indices (one-byte varints); then (4.3) no ring VPLs (`00`),
    // (4.4) no scene options recorded (`00`), (4.5) no swept bounds
    // (`00`), (4.6) no later bounces (`00`), (4.7) three second maps
    // (`03`) and (4.8) no later sources (`00`).
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    assert_eq!(
        u16::from_le_bytes([bytes[10], bytes[11]]),
        gibake_asset::FORMAT_MINOR
    );
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    assert_eq!(
        &bytes[20 + len - 10..20 + len],
        &[3, 1, 4, 5, 0, 0, 0, 0, 3, 0]
    );
    // The atlas, read back as the spec lays it out.
    let (w, h, z, share, vpl) = atlas_of(&asset.view_rsms);
    assert_eq!((w, h), (2 * RSM as usize, 2 * RSM as usize));
    let expected = testing::rsm_exr_bytes(w, h, z, share, vpl).unwrap();
    assert_eq!(std::fs::read(dir.join(FILE_VIEW_RSMS)).unwrap(), expected);
    // Written twice: the same bytes.
    let again = tmp.path().join("b.gibake");
    write(&loaded, &again).unwrap();
    for f in file_names(&dir) {
        assert_eq!(
            std::fs::read(dir.join(&f)).unwrap(),
            std::fs::read(again.join(&f)).unwrap(),
            "{f}"
        );
    }
    // The budget counts the atlas.
    let without = {
        let mut m = loaded.manifest.clone();
        m.view_rsms.clear();
        decoded_bytes(&m)
    };
    assert!(decoded_bytes(&loaded.manifest) >= without + 12 * 4 * (RSM * RSM) as u64);
}

#[test]
fn a_4_0_manifest_loads_without_view_rsms() {
    let tmp = tempfile::tempdir().unwrap();
    let asset = sample_asset(true);
    let dir = written(tmp.path(), &asset);
    let current = load(&dir).unwrap();
    let old = testing::manifest_bytes_4_0(&current.manifest).unwrap();
    // Minor 0, and one byte shorter: no appended vector.
    assert_eq!(u16::from_le_bytes([old[10], old[11]]), 0);
    let now = testing::manifest_bytes_4_1(&current.manifest).unwrap();
    assert_eq!(old.len() + 1, now.len());
    std::fs::write(dir.join(FILE_MANIFEST), &old).unwrap();
    let loaded = load(&dir).expect("a 4.0 asset loads");
    assert!(loaded.manifest.view_rsms.is_empty() && loaded.view_rsms.is_empty());
    // Without the level-3 coherences of format 4.2 (nor the second maps of
    // 4.7): none.
    let mut expected = without_4_7(&current);
    expected.vpl_coherence.clear();
    expected
        .manifest
        .files
        .retain(|f| f.name != "vpl_coherence.bin");
    assert_eq!(loaded, expected);
    // A 4.0 manifest cannot hold view RSMs.
    let with = sample_asset_with_view_rsms();
    assert!(testing::manifest_bytes_4_0(&with.manifest).is_err());
    // A 4.0 manifest listing view_rsms.exr is refused (the counts say it
    // is not stored).
    let (d41, _) = fresh(tmp.path(), "v41.gibake");
    let m = load_manifest(&d41).unwrap();
    let mut m40 = m.clone();
    m40.view_rsms.clear();
    let mut bytes = testing::manifest_bytes_4_0(&m40).unwrap();
    // (re-encoded: `files` still lists view_rsms.exr)
    assert!(bytes.windows(13).any(|w| w == b"view_rsms.exr"));
    std::fs::write(d41.join(FILE_MANIFEST), &bytes).unwrap();
    let msg = load_manifest(&d41).unwrap_err().to_string();
    assert!(
        msg.contains("manifest.bin") && msg.contains("view_rsms.exr") && msg.contains("not stored"),
        "{msg}"
    );
    // Its trailing byte from a 4.1 writer, under minor 0: unexpected.
    bytes = now.clone();
    bytes[10..12].copy_from_slice(&0u16.to_le_bytes());
    let n = bytes.len();
    let h = *blake3::hash(&bytes[..n - 32]).as_bytes();
    bytes[n - 32..].copy_from_slice(&h);
    std::fs::write(dir.join(FILE_MANIFEST), &bytes).unwrap();
    let msg = load_manifest(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("manifest.bin") && msg.contains("unexpected bytes"),
        "{msg}"
    );
}

#[test]
fn bad_view_rsm_lists_are_refused_naming_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    for (k, (list, what)) in [
        (vec![1, 4, 6], "view_rsms[2] = 6 is not a view"),
        (vec![4, 1, 5], "strictly ascending"),
        (vec![1, 1, 5], "strictly ascending"),
        (vec![0, 1, 2, 3, 4, 5, 5], "only 6 views"),
    ]
    .into_iter()
    .enumerate()
    {
        let (dir, _) = fresh(tmp.path(), &format!("l{k}.gibake"));
        edit_manifest(&dir, |m| m.view_rsms = list.clone());
        for e in [load_manifest(&dir).unwrap_err(), load(&dir).unwrap_err()] {
            let msg = e.to_string();
            assert!(matches!(e, AssetError::Invalid { .. }), "{e:?}");
            assert!(
                msg.contains("manifest.bin") && msg.contains(what),
                "{list:?}: {msg}"
            );
        }
    }
    // A hostile count (2^40 entries) is refused before any allocation
    // (the payload ends with view_rsms, 4 bytes, then ring_vpls, 1,
    // scene_options, 1, swept_bounds, 1, later, 1, and lower_map_count, 1).
    let (dir, _) = fresh(tmp.path(), "huge.gibake");
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    let mut tail = vec![253];
    tail.extend_from_slice(&(1u64 << 40).to_le_bytes());
    let out = with_payload_tail(&bytes, len - 10, &tail);
    std::fs::write(dir.join(FILE_MANIFEST), &out).unwrap();
    let msg = load_manifest(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("manifest.bin") && msg.contains("damaged manifest payload"),
        "{msg}"
    );
    // Cut inside the vector: damaged.
    let out = with_payload_tail(&bytes, len - 7, &[]);
    std::fs::write(dir.join(FILE_MANIFEST), &out).unwrap();
    let msg = load_manifest(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("manifest.bin") && msg.contains("damaged manifest payload: view_rsms"),
        "{msg}"
    );
}

#[test]
fn bad_view_rsm_texels_are_refused_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, asset) = fresh(tmp.path(), "a.gibake");
    let rsms = &asset.view_rsms;
    let s = RSM as usize;
    let w = 2 * s;
    // Tile 1 (views[4]) at column 1, row 0: its texel (2, 3).
    let at = 3 * w + s + 2;

    store(&dir, rsms, |_, _, vpl| vpl[at] = 2);
    let msg = refused(&dir, FILE_VIEW_RSMS, "refers to VPL 2");
    assert!(
        msg.contains("tile 1")
            && msg.contains("views[4]")
            && msg.contains("light 1")
            && msg.contains("texel (2, 3)")
            && msg.contains("6..10"),
        "{msg}"
    );

    store(&dir, rsms, |_, _, vpl| vpl[at] = VPLS as u32);
    refused(&dir, FILE_VIEW_RSMS, "refers to VPL 10");

    store(&dir, rsms, |z, _, _| z[at] = f32::NAN);
    refused(&dir, FILE_VIEW_RSMS, "NaN");

    store(&dir, rsms, |_, share, vpl| {
        vpl[at] = FIRST_LIGHT_VPLS as u32;
        share[at] = SHARE_ONE + 1;
    });
    let msg = refused(&dir, FILE_VIEW_RSMS, "channel share holds 16777217");
    assert!(msg.contains("texel (2, 3)"), "{msg}");

    store(&dir, rsms, |_, share, vpl| {
        vpl[at] = u32::MAX;
        share[at] = 5;
    });
    refused(&dir, FILE_VIEW_RSMS, "outside every VPL");

    // The unused tile 3 (column 1, row 1): each channel in turn.
    let unused = (s + 7) * w + s + 7;
    store(&dir, rsms, |z, _, _| z[unused] = 1.5);
    refused(
        &dir,
        FILE_VIEW_RSMS,
        "unused tile 3 (after the 3 view RSMs) holds Z = 1.5 at its texel (7, 7)",
    );
    store(&dir, rsms, |_, share, _| share[unused] = 1);
    refused(&dir, FILE_VIEW_RSMS, "unused tile 3");
    store(&dir, rsms, |_, _, vpl| vpl[unused] = 6);
    refused(&dir, FILE_VIEW_RSMS, "holds vpl = 6");

    // An atlas of the wrong size (one tile).
    let (_, _, z, share, vpl) = atlas_of(&rsms[..1]);
    let bytes = testing::rsm_exr_bytes(s, s, z, share, vpl).unwrap();
    replace_signed(&dir, FILE_VIEW_RSMS, &bytes);
    refused(&dir, FILE_VIEW_RSMS, "16x16");

    // Intact again: loads.
    store(&dir, rsms, |_, _, _| {});
    load(&dir).unwrap();

    // Truncated (the manifest's size no longer matches), then missing.
    let path = dir.join(FILE_VIEW_RSMS);
    let b = std::fs::read(&path).unwrap();
    std::fs::write(&path, &b[..b.len() / 2]).unwrap();
    refused(&dir, FILE_VIEW_RSMS, "truncated or damaged");
    std::fs::remove_file(&path).unwrap();
    let e = load(&dir).unwrap_err();
    assert!(e.to_string().contains(FILE_VIEW_RSMS), "{e}");
    // Not listed though the manifest says view RSMs are stored.
    edit_manifest(&dir, |m| m.files.retain(|f| f.name != FILE_VIEW_RSMS));
    let msg = load_manifest(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("manifest.bin") && msg.contains("`view_rsms.exr` is not listed"),
        "{msg}"
    );
}

#[test]
fn inconsistent_view_rsms_are_not_written() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("x.gibake");
    type Case = (&'static str, fn(&mut Asset));
    let cases: [Case; 5] = [
        ("light 1 owns VPLs 6..10", |a| a.view_rsms[0].vpl[0] = 0),
        ("NaN", |a| a.view_rsms[2].metric[9] = f32::NAN),
        ("channel share", |a| a.view_rsms[1].share[0] = SHARE_ONE + 7),
        ("2 view RSMs but view_rsms lists 3", |a| {
            a.view_rsms.pop();
        }),
        ("strictly ascending", |a| {
            a.manifest.view_rsms = vec![5, 4, 1]
        }),
    ];
    for (what, edit) in cases {
        let mut a = sample_asset_with_view_rsms();
        if what == "channel share" {
            a.view_rsms[1].vpl[0] = FIRST_LIGHT_VPLS as u32;
        }
        edit(&mut a);
        let e = write(&a, &out).unwrap_err().to_string();
        assert!(
            e.contains("cannot write: view_rsms") && e.contains(what),
            "{what}: {e}"
        );
        assert!(!out.exists());
    }
}

/// The parts of `asset`'s bake split into `n` shards, as the shards write
/// them (front data without hemisphere maps, each shard its VPLs' maps).
fn parts(asset: &Asset, n: u32) -> Vec<ShardPart> {
    let mut front = asset.clone();
    front.manifest.map_count = 0;
    front.vpl_maps = MapAtlas::empty(VPL_MAP);
    for v in &mut front.vpls {
        v.map = NO_MAP;
    }
    front.manifest.lower_map_count = 0;
    front.vpl_lower_maps = MapAtlas::empty(VPL_MAP);
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

#[test]
fn shards_carry_view_rsms_and_merge_to_the_unsharded_asset() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, _) = fresh(tmp.path(), "single.gibake");
    let single = load(&dir).unwrap();
    let mut loaded = Vec::new();
    for part in parts(&single, 3) {
        let path = tmp.path().join(format!("p{}", part.shard));
        write_part(&part, &path).unwrap();
        let back = load_part(&path).unwrap();
        assert_eq!(back, part, "a part round-trips with its view RSMs");
        loaded.push((path, back));
    }
    loaded.reverse();
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
    // A part whose view RSM differs does not merge.
    let (path, mut odd) = loaded[0].clone();
    odd.front.view_rsms[2].metric[0] += 1.0;
    let mut m = Merger::default();
    m.add(loaded[1].0.clone(), loaded[1].1.clone()).unwrap();
    let e = m.add(path, odd).unwrap_err().to_string();
    assert!(e.contains("view RSMs") && e.contains("differs"), "{e}");
    // A part with a view RSM of the wrong size is refused, naming it.
    let mut bad = loaded[0].1.clone();
    bad.front.view_rsms[0].metric.pop();
    let path = tmp.path().join("bad.part");
    let e = write_part(&bad, &path).unwrap_err().to_string();
    assert!(
        e.contains("bad.part") && e.contains("view RSMs") && e.contains("tile 0"),
        "{e}"
    );
}

#[test]
fn diff_and_inspect_see_the_view_rsms() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, _) = fresh(tmp.path(), "a.gibake");
    let a = load(&dir).unwrap();
    let tol = Tolerance::same_machine();
    assert!(diff(&a, &a, &tol).equal());
    let names: Vec<String> = diff(&a, &a, &tol)
        .maps
        .iter()
        .map(|m| m.name.clone())
        .collect();
    for n in ["view_rsms.Z", "view_rsms.share", "view_rsms.vpl"] {
        assert!(names.iter().any(|x| x == n), "{names:?}");
    }

    // One texel of the RSM of views[4] (tile 1).
    let mut b = a.clone();
    let i = b.view_rsms[1]
        .metric
        .iter()
        .position(|m| m.is_finite())
        .unwrap();
    b.view_rsms[1].metric[i] += 0.25;
    let r = diff(&a, &b, &tol);
    assert!(!r.equal());
    let z = r.maps.iter().find(|m| m.name == "view_rsms.Z").unwrap();
    assert_eq!((z.over, z.texels), (1, 3 * (RSM * RSM) as u64));
    assert!((z.max_abs - 0.25).abs() < 1e-3, "{}", z.max_abs);
    assert!(
        r.differences
            .iter()
            .any(|d| d.contains("view_rsms.Z") && d.contains("1 of 3 views differ: [4]")),
        "{:?}",
        r.differences
    );
    // A texel's VPL.
    let mut c = a.clone();
    let i = c.view_rsms[2].vpl.iter().position(|&v| v == 7).unwrap();
    c.view_rsms[2].vpl[i] = 8;
    let r = diff(&a, &c, &tol);
    assert!(
        r.differences
            .iter()
            .any(|d| d.contains("view_rsms.vpl") && d.contains("[5]")),
        "{:?}",
        r.differences
    );
    // One side only, or other views.
    let mut d = a.clone();
    d.manifest.view_rsms.clear();
    d.view_rsms.clear();
    let r = diff(&a, &d, &tol);
    assert!(
        r.differences
            .iter()
            .any(|x| x.contains("view_rsms") && x.contains("stored in A only")),
        "{:?}",
        r.differences
    );
    let r = diff(&d, &a, &tol);
    assert!(r.differences.iter().any(|x| x.contains("stored in B only")));
    let mut e = a.clone();
    e.manifest.view_rsms = vec![0, 4, 5];
    let r = diff(&a, &e, &tol);
    assert!(
        r.differences
            .iter()
            .any(|x| x.contains("A stores the RSMs of views [1, 4, 5], B of views [0, 4, 5]")),
        "{:?}",
        r.differences
    );

    let i = inspect(&a);
    let size = std::fs::metadata(dir.join(FILE_VIEW_RSMS)).unwrap().len();
    assert_eq!(
        (i.view_rsms, i.view_rsm_size, i.view_rsms_bytes),
        (3, RSM, size)
    );
    assert_eq!(i.view_rsm_metric.as_ref().map(|m| m.layers), Some(3));
    let text = i.to_string();
    assert!(
        text.contains("3 views store a static RSM") && text.contains("view RSMs"),
        "{text}"
    );
    let json = serde_json::to_value(&i).unwrap();
    assert_eq!(json["view_rsms"], 3);
    assert_eq!(json["view_rsms_bytes"], size);
    let none = inspect(&sample_asset(true));
    assert_eq!((none.view_rsms, none.view_rsms_bytes), (0, 0));
    assert!(none.to_string().contains("view RSMs      none stored"));
}

/// The interpreter of the spec reader: `GIBAKE_PYTHON`, else the venv of
/// `scripts/ensure-deps.sh --python` (`target/pyenv`), else `python3`.
fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("GIBAKE_PYTHON") {
        return PathBuf::from(p);
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target"));
    let venv = target.join("pyenv").join("bin").join("python");
    if venv.is_file() {
        venv
    } else {
        PathBuf::from("python3")
    }
}

/// Runs the spec reader's manifest, file and view-RSM checks (not the
/// geometric ones: the sample is synthetic) on `asset`: `Ok(summary)` or
/// `Err(the reader's message)`.
fn spec_read(asset: &Path) -> Result<String, String> {
    let reader = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/spec_reader");
    let script = "import sys\n\
        sys.path.insert(0, sys.argv[1])\n\
        import read_gibake as r\n\
        a = sys.argv[2]\n\
        try:\n    \
            m = r.read_manifest(a)\n    \
            r.check_manifest_values(m)\n    \
            r.check_files(a, m)\n    \
            print(r.check_view_rsms(a, m, r.light_vpl_ranges(m)))\n\
        except r.AssetError as e:\n    \
            print(f'INVALID: {e}')\n    \
            sys.exit(1)\n";
    let out = Command::new(python())
        .arg("-c")
        .arg(script)
        .arg(&reader)
        .arg(asset)
        .output()
        .expect("python3 runs (scripts/ensure-deps.sh --python, or GIBAKE_PYTHON)");
    let text = String::from_utf8_lossy(&out.stdout).trim().to_string();
    match out.status.code() {
        Some(0) => Ok(text),
        Some(1) if text.starts_with("INVALID") => Err(text),
        _ => panic!(
            "the spec reader failed oddly (needs numpy, OpenEXR and blake3: run \
             `bash scripts/ensure-deps.sh --python` or set GIBAKE_PYTHON)\n{text}\n{}",
            String::from_utf8_lossy(&out.stderr)
        ),
    }
}

#[test]
fn the_spec_reader_reads_and_checks_view_rsms() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, asset) = fresh(tmp.path(), "a.gibake");
    let ok = spec_read(&dir).expect("the reader accepts the 4.1 asset");
    assert!(
        ok.contains("3 view RSMs of 8²") && ok.contains("views [1, 4, 5]"),
        "{ok}"
    );

    // A 4.0 asset: no view RSMs.
    std::fs::create_dir(tmp.path().join("plain")).unwrap();
    let plain = written(&tmp.path().join("plain"), &sample_asset(true));
    let m = load_manifest(&plain).unwrap();
    std::fs::write(
        plain.join(FILE_MANIFEST),
        testing::manifest_bytes_4_0(&m).unwrap(),
    )
    .unwrap();
    let ok = spec_read(&plain).expect("the reader accepts a 4.0 asset");
    assert!(ok.contains("no view_rsms.exr"), "{ok}");

    let rsms = &asset.view_rsms;
    let s = RSM as usize;
    let at = 3 * 2 * s + s + 2;
    let unused = (s + 7) * 2 * s + s + 7;
    type Edit = fn(&mut [f32], &mut [u32], &mut [u32], usize, usize);
    let cases: [(&str, Edit); 5] = [
        (
            "names VPL 2, not one of its light's VPLs 6..10",
            |_, _, v, at, _| v[at] = 2,
        ),
        ("holds NaN", |z, _, _, at, _| z[at] = f32::NAN),
        ("has share 16777217", |_, sh, v, at, _| {
            v[at] = 6;
            sh[at] = SHARE_ONE + 1;
        }),
        ("has share 3", |_, sh, v, at, _| {
            v[at] = u32::MAX;
            sh[at] = 3;
        }),
        ("unused tile 3 is not empty", |z, _, _, _, u| z[u] = 2.0),
    ];
    for (k, (what, edit)) in cases.into_iter().enumerate() {
        let (copy, _) = fresh(tmp.path(), &format!("bad{k}.gibake"));
        store(&copy, rsms, |z, sh, v| edit(z, sh, v, at, unused));
        let e = spec_read(&copy).expect_err(what);
        assert!(
            e.contains("view_rsms.exr") && e.contains(what),
            "{what}: {e}"
        );
        // ... and by the reference reader.
        assert!(
            load(&copy)
                .unwrap_err()
                .to_string()
                .contains(FILE_VIEW_RSMS)
        );
    }
    for (k, (list, what)) in [
        (vec![1, 4, 6], "view_rsms[2] = 6 is not a view"),
        (vec![4, 1, 5], "strictly ascending"),
        (vec![0, 1, 2, 3, 4, 5, 5], "only 6 views"),
    ]
    .into_iter()
    .enumerate()
    {
        let (copy, _) = fresh(tmp.path(), &format!("list{k}.gibake"));
        edit_manifest(&copy, |m| m.view_rsms = list.clone());
        let e = spec_read(&copy).expect_err(what);
        assert!(
            e.contains("manifest.bin") && e.contains(what),
            "{what}: {e}"
        );
    }
    // Listed but missing.
    let (copy, _) = fresh(tmp.path(), "missing.gibake");
    std::fs::remove_file(copy.join(FILE_VIEW_RSMS)).unwrap();
    let e = spec_read(&copy).expect_err("missing");
    assert!(e.contains("view_rsms.exr") && e.contains("missing"), "{e}");
}
