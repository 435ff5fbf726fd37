//! `write` replaces only a gibake asset (judged by the magic bytes of its
//! `manifest.bin`), only the files the format owns, and a load refuses
//! non-regular files and maps past its decoding budget.

use crate::common;

use common::*;
use gibake_asset::*;

#[test]
fn a_manifest_without_magic_is_not_an_asset() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("user.gibake");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join(FILE_MANIFEST), b"my own manifest").unwrap();
    std::fs::write(dir.join("thesis.tex"), b"precious").unwrap();
    let e = write(&sample_asset(true), &dir).unwrap_err();
    assert!(e.to_string().contains("magic"), "{e}");
    assert_eq!(file_names(&dir), ["manifest.bin", "thesis.tex"]);
    assert_eq!(
        std::fs::read(dir.join(FILE_MANIFEST)).unwrap(),
        b"my own manifest"
    );
    assert_eq!(file_names(tmp.path()), ["user.gibake"]);
}

#[test]
fn foreign_files_in_an_asset_survive_its_replacement() {
    let tmp = tempfile::tempdir().unwrap();
    // A dynamic asset (with rsm.exr) replaced by a static one (without).
    let dir = written(tmp.path(), &sample_asset(true));
    assert!(dir.join(FILE_RSM).is_file());
    std::fs::write(dir.join("notes.txt"), b"keep me").unwrap();
    let new = sample_asset(false);
    write(&new, &dir).unwrap();
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded, as_written(&new, &loaded));
    assert_eq!(std::fs::read(dir.join("notes.txt")).unwrap(), b"keep me");
    assert!(!dir.join(FILE_RSM).exists(), "a stale owned file stays");
    // Nothing but the asset is left beside it.
    assert_eq!(file_names(tmp.path()).len(), 1);
}

#[test]
fn decoding_budget_and_regular_files() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &sample_asset(true));
    let m = load_manifest(&dir).unwrap();
    let need = decoded_bytes(&m);
    assert!(need > 0);
    let e = load_with_limit(&dir, need - 1).unwrap_err();
    assert!(e.to_string().contains("--max-memory"), "{e}");
    // The files' bytes are held while the maps are decoded: counted too.
    let files: u64 = m.files.iter().map(|f| f.size).sum();
    let e = load_with_limit(&dir, need + files - 1).unwrap_err();
    assert!(e.to_string().contains("its files"), "{e}");
    load_with_limit(&dir, need + files).unwrap();
    // A FIFO in place of a map is refused without blocking.
    let vpls = dir.join(FILE_VPLS);
    std::fs::remove_file(&vpls).unwrap();
    let made = std::process::Command::new("mkfifo").arg(&vpls).status();
    if made.is_ok_and(|s| s.success()) {
        let e = load(&dir).unwrap_err();
        assert!(e.to_string().contains("not a regular file"), "{e}");
    }
}

#[test]
fn a_manifest_promising_gigabytes_of_maps_is_refused_before_any_map_is_read() {
    // Within the format's limits (maps ≤ 16384, ≤ 2³¹ texels per file) but
    // over the default decoding budget: refused from the manifest alone,
    // whatever the (small, highly compressible) EXR files hold.
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &sample_asset(true));
    edit_manifest(&dir, |m| m.settings.vpl_map_size = 8192);
    let m = load_manifest(&dir).unwrap();
    assert!(decoded_bytes(&m) > DEFAULT_MAX_DECODED_BYTES, "{m:?}");
    let e = load(&dir).unwrap_err();
    assert!(
        e.to_string().contains("--max-memory") && e.to_string().contains("manifest.bin"),
        "{e}"
    );
}

#[test]
fn exr_channels_the_reader_does_not_use_count_in_the_budget() {
    use exr::prelude::*;
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &sample_asset(true));
    let m = load_manifest(&dir).unwrap();
    let files: u64 = m.files.iter().map(|f| f.size).sum();
    load_with_limit(&dir, decoded_bytes(&m) + files).expect("the manifest's own estimate fits");
    // The same RSM with 200 extra channels (a few KB on disk, compressed):
    // 200 × RSM² × 4 bytes more when decoded.
    let asset = load(&dir).unwrap();
    let r = asset.rsm.as_ref().unwrap();
    let n = r.size as usize;
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    list.push(AnyChannel::new("Z", FlatSamples::F32(r.metric.clone())));
    list.push(AnyChannel::new("share", FlatSamples::U32(r.share.clone())));
    list.push(AnyChannel::new("vpl", FlatSamples::U32(r.vpl.clone())));
    for k in 0..200 {
        list.push(AnyChannel::new(
            format!("extra{k:03}").as_str(),
            FlatSamples::F32(vec![0.0; n * n]),
        ));
    }
    let layer = Layer::new(
        (n, n),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .to_buffered(&mut bytes)
        .unwrap();
    replace_signed(&dir, "rsm.exr", &bytes.into_inner());
    let m = load_manifest(&dir).unwrap();
    let need = decoded_bytes(&m) + m.files.iter().map(|f| f.size).sum::<u64>();
    let extra = 200 * (n * n * 4) as u64;
    let e = load_with_limit(&dir, need + extra - 1)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("channels this reader does not use") && e.contains("--max-memory"),
        "{e}"
    );
    assert!(e.contains(&format!("does not use {extra}")), "{e}");
    // Within the budget they are read (and ignored), as the spec says.
    load_with_limit(&dir, need + extra).expect("fits");
}
