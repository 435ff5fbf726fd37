//! Format 4.3: the VPLs on a sun's outer rings (`Manifest::ring_vpls`,
//! appended to the manifest payload after `view_rsms`): round trip in the
//! documented layout, 4.2 assets still read (no ring VPLs), and every bad
//! list refused naming the manifest, a hostile count before allocating.

use crate::common;

use std::path::{Path, PathBuf};

use common::*;
use gibake_asset::*;

/// The sample asset with a directional first light whose last two VPLs lie
/// on its outer rings.
fn with_rings() -> Asset {
    let mut a = sample_asset(false);
    a.manifest.lights[0].kind = LIGHT_DIRECTIONAL;
    a.manifest.ring_vpls = vec![2, 0];
    a
}

fn fresh(tmp: &Path, name: &str) -> PathBuf {
    let dir = tmp.join(name);
    write(&with_rings(), &dir).expect("write");
    dir
}

#[test]
fn ring_vpls_round_trip_in_the_documented_layout() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path(), "r.gibake");
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded, as_written(&with_rings(), &loaded));
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    assert_eq!(u16::from_le_bytes([bytes[10], bytes[11]]), FORMAT_MINOR);
    assert_eq!(FORMAT_MINOR, 8);
    // The payload ends with view_rsms (none: `00`), then ring_vpls `02 02
    // 00`, then (4.4) scene_options, not recorded: `00`, then (4.5)
    // swept_bounds, not recorded: `00`, then (4.6) later: `00`, then (4.7)
    // lower_map_count `03`, then (4.8) later_sources: `00`.
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    assert_eq!(&bytes[20 + len - 9..20 + len], &[0, 2, 2, 0, 0, 0, 0, 3, 0]);
    // The flags: light 0's last two records.
    let flags = loaded.manifest.ring_flags();
    let first = FIRST_LIGHT_VPLS;
    assert_eq!(flags.len(), VPLS);
    assert!(flags[..first - 2].iter().all(|f| !f));
    assert!(flags[first - 2..first].iter().all(|f| *f));
    assert!(flags[first..].iter().all(|f| !f));
    // `inspect` says so.
    let text = inspect(&loaded).to_string();
    assert!(text.contains("6 VPLs (2 on its outer rings)"), "{text}");
    assert_eq!(inspect(&loaded).ring_vpls, vec![2, 0]);
    // Their map origins are one texel's radius off their surface.
    let v = loaded.vpls[first - 1];
    assert_eq!(v.map_origin_area(true), v.area / v.texels.max(1) as f32);
    assert_eq!(v.map_origin_area(false), v.area);
}

#[test]
fn a_4_2_manifest_loads_without_ring_vpls() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = fresh(tmp.path(), "r.gibake");
    let current = load(&dir).unwrap();
    // A 4.2 writer could not hold ring VPLs.
    assert!(testing::manifest_bytes_4_2(&current.manifest).is_err());
    let mut m = current.manifest.clone();
    m.ring_vpls.clear();
    let old = testing::manifest_bytes_4_2(&m).unwrap();
    assert_eq!(u16::from_le_bytes([old[10], old[11]]), 2);
    // One byte shorter than the same manifest at 4.3 (its empty vector).
    assert_eq!(
        old.len() + 1,
        testing::manifest_bytes_4_3(&m).unwrap().len()
    );
    std::fs::write(dir.join(FILE_MANIFEST), &old).unwrap();
    let loaded = load(&dir).expect("a 4.2 asset loads");
    assert!(loaded.manifest.ring_vpls.is_empty());
    assert!(loaded.manifest.ring_flags().iter().all(|f| !f));
    let mut expected = without_4_7(&current);
    expected.manifest.ring_vpls.clear();
    assert_eq!(loaded, expected);
}

#[test]
fn bad_ring_vpl_lists_are_refused_naming_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    let first = FIRST_LIGHT_VPLS as u32;
    for (k, (list, what)) in [
        (
            vec![first + 1, 0],
            "ring_vpls[0] = 7 but light 0 has only 6 VPLs",
        ),
        (vec![0, 1], "ring_vpls[1] = 1 but light 1 is a point light"),
        (vec![1], "ring_vpls holds 1 entries for 2 lights"),
    ]
    .into_iter()
    .enumerate()
    {
        let dir = fresh(tmp.path(), &format!("b{k}.gibake"));
        edit_manifest(&dir, |m| m.ring_vpls = list.clone());
        let e = load(&dir).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, AssetError::Invalid { .. }), "{e:?}");
        assert!(
            msg.contains("manifest.bin") && msg.contains(what),
            "{list:?}: {msg}"
        );
        // Nothing is written from such a manifest either.
        let mut a = with_rings();
        a.manifest.ring_vpls = list.clone();
        let err = write(&a, &tmp.path().join(format!("w{k}.gibake")))
            .unwrap_err()
            .to_string();
        assert!(err.contains(what), "{err}");
    }
    // A spot first with ring VPLs: refused (only a sun has outer rings).
    let dir = fresh(tmp.path(), "spot.gibake");
    edit_manifest(&dir, |m| m.lights[0].kind = LIGHT_SPOT);
    let msg = load(&dir).unwrap_err().to_string();
    assert!(msg.contains("light 0 is a spot light"), "{msg}");
    // A hostile count (2^40 entries) is refused before any allocation.
    let dir = fresh(tmp.path(), "huge.gibake");
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    let mut tail = vec![253];
    tail.extend_from_slice(&(1u64 << 40).to_le_bytes());
    let out = with_payload_tail(&bytes, len - 8, &tail);
    std::fs::write(dir.join(FILE_MANIFEST), &out).unwrap();
    let msg = load_manifest(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("manifest.bin")
            && msg.contains("damaged manifest payload: ring_vpls holds 1099511627776 entries"),
        "{msg}"
    );
}
