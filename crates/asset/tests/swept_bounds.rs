//! Format 4.5: the moving objects' swept bounds a bake used
//! (`Manifest::swept_bounds`, appended to the manifest payload after
//! `scene_options`): round trip in the documented layout, 4.4 assets still
//! read (not recorded: `None`), and every bad list refused naming the
//! manifest, a hostile count before allocating.

use crate::common;

use common::*;
use gibake_asset::*;

const BOX: [f32; 6] = [-1.5, 0.25, -2.0, 3.0, 1.0e3, 0.5];

fn with_sweep() -> Asset {
    let mut a = sample_asset(true);
    a.manifest.swept_bounds = Some(BOX);
    a
}

#[test]
fn swept_bounds_round_trip_in_the_documented_layout() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &with_sweep());
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded, as_written(&with_sweep(), &loaded));
    assert_eq!(loaded.manifest.swept_bounds, Some(BOX));
    // The payload ends with the count 6, then each value's f32 bit
    // pattern as a varint u32 (`FC` and four little-endian bytes for the
    // patterns of these values, all at or above 2^16).
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    assert_eq!(u16::from_le_bytes([bytes[10], bytes[11]]), 8);
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    // (then 4.6's `later`, none: `00`, 4.7's lower_map_count, one byte,
    // and 4.8's later_sources, none: `00`)
    assert_eq!(bytes[20 + len - 3], 0);
    assert_eq!(
        u32::from(bytes[20 + len - 2]),
        loaded.manifest.lower_map_count
    );
    assert_eq!(bytes[20 + len - 1], 0);
    let tail = &bytes[20 + len - 34..20 + len - 3];
    assert_eq!(tail[0], 6);
    for (k, v) in BOX.iter().enumerate() {
        let at = 1 + 5 * k;
        assert_eq!(tail[at], 0xFC, "value {k}");
        assert_eq!(
            &tail[at + 1..at + 5],
            &v.to_bits().to_le_bytes(),
            "value {k}"
        );
    }
    // An empty box (a scene without moving objects) round-trips too.
    let mut a = with_sweep();
    a.manifest.swept_bounds = Some([
        f32::INFINITY,
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ]);
    let dir = tmp.path().join("empty.gibake");
    write(&a, &dir).unwrap();
    assert_eq!(
        load(&dir).unwrap().manifest.swept_bounds,
        a.manifest.swept_bounds
    );
}

#[test]
fn a_4_4_manifest_loads_without_swept_bounds() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &with_sweep());
    let current = load(&dir).unwrap();
    // A 4.4 writer could not hold them.
    assert!(testing::manifest_bytes_4_4(&current.manifest).is_err());
    let mut m = current.manifest.clone();
    m.swept_bounds = None;
    let old = testing::manifest_bytes_4_4(&m).unwrap();
    assert_eq!(u16::from_le_bytes([old[10], old[11]]), 4);
    // One byte for the empty box, one for 4.6's `later` (none).
    assert_eq!(
        old.len() + 2,
        testing::manifest_bytes_4_6(&m).unwrap().len()
    );
    std::fs::write(dir.join(FILE_MANIFEST), &old).unwrap();
    let loaded = load(&dir).expect("a 4.4 asset loads");
    assert_eq!(loaded.manifest.swept_bounds, None);
}

#[test]
fn bad_swept_bounds_are_refused_naming_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &with_sweep());
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    let keep = len - 34;
    let nan = f32::NAN.to_bits();
    let three = vec![3u8, 0, 0, 0];
    let mut with_nan = vec![6u8];
    for v in [0, 0, 0, nan, 0, 0] {
        if v == 0 {
            with_nan.push(0);
        } else {
            with_nan.push(0xFC);
            with_nan.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut hostile = vec![253u8];
    hostile.extend_from_slice(&(1u64 << 40).to_le_bytes());
    for (tail, what) in [
        (three, "swept_bounds holds 3 values"),
        (with_nan, "swept_bounds holds NaN"),
        (
            hostile,
            "damaged manifest payload: swept_bounds holds 1099511627776 entries",
        ),
        (vec![6, 0, 0], "damaged manifest payload: swept_bounds"),
    ] {
        let out = with_payload_tail(&bytes, keep, &tail);
        std::fs::write(dir.join(FILE_MANIFEST), &out).unwrap();
        let msg = load_manifest(&dir).unwrap_err().to_string();
        assert!(
            msg.contains("manifest.bin") && msg.contains(what),
            "{what}: {msg}"
        );
    }
}
