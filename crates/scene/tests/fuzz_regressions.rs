//! Replays every input kept by the fuzzer (`fuzz/regressions/gltf_import/`,
//! `meshopt_decode/`, `webp_decode/`, see scripts/fuzz.sh) and the bundled
//! scenes and real exports (`data/exports/`), truncated and bit-flipped,
//! through the glTF import and the decoders: each gives a scene or an
//! error, never a panic (not even one caught by the import's last-resort
//! `catch_unwind`).

use std::path::{Path, PathBuf};

use gibake_scene::{LoadOptions, load_from_slice};

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

fn check(bytes: &[u8], what: &str) {
    let path = Path::new("/nonexistent-fuzz-dir/fuzz.glb");
    if let Err(e) = load_from_slice(bytes, path, &LoadOptions::default()) {
        let msg = e.to_string();
        assert!(
            !msg.contains("internal error"),
            "{what}: the import panicked inside: {msg}"
        );
    }
}

#[test]
fn kept_fuzz_inputs_do_not_panic() {
    for f in files(&root().join("fuzz/regressions/gltf_import")) {
        let bytes = std::fs::read(&f).expect("read regression input");
        check(&bytes, &f.display().to_string());
    }
}

#[test]
fn kept_decoder_fuzz_inputs_do_not_panic() {
    let mut inputs = files(&root().join("fuzz/regressions/meshopt_decode"));
    inputs.extend(files(&root().join("fuzz/seeds/meshopt")));
    for f in inputs {
        let bytes = std::fs::read(&f).expect("read regression input");
        gibake_scene::decode::meshopt_fuzz_input(&bytes);
    }
    let mut inputs = files(&root().join("fuzz/regressions/webp_decode"));
    inputs.extend(files(&root().join("fuzz/seeds/webp")));
    for f in inputs {
        let bytes = std::fs::read(&f).expect("read regression input");
        let _ = gibake_scene::decode::webp(&bytes, 1 << 22);
    }
}

#[test]
fn bundled_scenes_damaged_do_not_panic() {
    let mut scenes = files(&root().join("data"));
    scenes.extend(files(&root().join("data/exports")));
    scenes.extend(files(&root().join("data/exports/refused")));
    for f in scenes {
        if f.extension().is_none_or(|e| e != "glb") {
            continue;
        }
        let bytes = std::fs::read(&f).expect("read");
        let n = bytes.len();
        for cut in [n / 2, n - 1, 100, 20] {
            check(
                &bytes[..cut.min(n)],
                &format!("{} cut at {cut}", f.display()),
            );
        }
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for k in 0..64 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let mut b = bytes.clone();
            let i = (state as usize) % n;
            b[i] ^= 1 << (k % 8);
            check(&b, &format!("{} bit flip at {i}", f.display()));
        }
    }
}
