//! Replays every input kept by the fuzzer (`fuzz/regressions/<target>/`,
//! see scripts/fuzz.sh) and the seed asset (`fuzz/seeds/asset`) through the
//! asset loader's manifest and EXR decoding and `diff`'s tolerance parsing:
//! errors are fine, panics are not, and a parsed tolerance is always a
//! finite number in [0, 1].

use std::path::{Path, PathBuf};

use gibake_asset::testing::{decode_exr_bytes, decode_manifest_bytes};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    v.retain(|p| p.is_file());
    v.sort();
    v
}

#[test]
fn the_seed_asset_decodes() {
    let seeds = root().join("fuzz/seeds/asset");
    let m = std::fs::read(seeds.join("manifest.bin")).expect("seed manifest");
    decode_manifest_bytes(&m).expect("the seed manifest is valid");
    for exr in ["primary_depth.exr", "vpl_maps.exr"] {
        let b = std::fs::read(seeds.join(exr)).expect("seed exr");
        // A depth map decodes as `D`; the RSM channel set is missing there.
        let _ = decode_exr_bytes(&b);
    }
    let dir = tempfile::tempdir().expect("tempdir");
    for f in files(&seeds) {
        std::fs::copy(&f, dir.path().join(f.file_name().expect("name"))).expect("copy");
    }
    gibake_asset::load(dir.path()).expect("the seed asset loads");
}

#[test]
fn kept_manifest_inputs_do_not_panic() {
    for f in files(&root().join("fuzz/regressions/asset_manifest")) {
        let _ = decode_manifest_bytes(&std::fs::read(&f).expect("read"));
    }
}

#[test]
fn kept_exr_inputs_do_not_panic() {
    for f in files(&root().join("fuzz/regressions/asset_exr")) {
        let _ = decode_exr_bytes(&std::fs::read(&f).expect("read"));
    }
}

#[test]
fn kept_tolerance_inputs_give_errors_or_sane_values() {
    let mut inputs: Vec<PathBuf> = files(&root().join("fuzz/regressions/diff_tolerance"));
    inputs.extend(files(&root().join("fuzz/seeds/diff_tolerance")));
    for f in inputs {
        let bytes = std::fs::read(&f).expect("read");
        let Ok(text) = std::str::from_utf8(&bytes) else {
            continue;
        };
        if let Ok(v) = gibake_asset::parse_tolerance("--map-rel", text) {
            assert!(v.is_finite() && (0.0..=1.0).contains(&v), "{text:?} → {v}");
        }
    }
}
