//! Format 4.7: each VPL's second origin and second map, for the light it
//! sends below its horizon (`vpl_lower.bin`, `vpl_lower_maps.exr`,
//! `Manifest::lower_map_count`): the documented layout, a 4.6 asset loads
//! with none, damaged records are refused naming the file, the writer
//! refuses inconsistent ones, and `diff` sees a changed second map.

use crate::common;

use common::*;
use gibake_asset::*;

#[test]
fn second_origins_round_trip_in_the_documented_layout() {
    let tmp = tempfile::tempdir().unwrap();
    let asset = sample_asset(false);
    let dir = written(tmp.path(), &asset);
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded.vpl_lower, asset.vpl_lower);
    assert_eq!(loaded.vpl_lower_maps, asset.vpl_lower_maps);
    assert_eq!(loaded.manifest.lower_map_count, 3);
    // 16 bytes per VPL: the origin's three f32, then the map (u32), little
    // endian; a VPL without a second origin is zeros and 0xFFFFFFFE.
    let bytes = std::fs::read(dir.join(FILE_VPL_LOWER)).unwrap();
    assert_eq!(bytes.len(), VPLS * LOWER_RECORD_BYTES);
    for (i, l) in asset.vpl_lower.iter().enumerate() {
        let r = &bytes[16 * i..16 * i + 16];
        for k in 0..3 {
            assert_eq!(&r[4 * k..4 * k + 4], &l.origin[k].to_le_bytes());
        }
        assert_eq!(&r[12..16], &l.map.to_le_bytes());
    }
    assert_eq!(
        &bytes[16..32],
        &[0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0xFE, 0xFF, 0xFF, 0xFF]
    );
    assert_eq!(NO_LOWER, 0xFFFF_FFFE);
    // The maps: the atlas of vpl_maps.exr's layout, VPL 4's is tile 1.
    assert_eq!(loaded.vpl_lower_map_of(4), asset.vpl_lower_maps.map(1));
    assert_eq!(
        loaded.vpl_lower_map_of(2),
        None,
        "its second map sees no surface"
    );
    assert_eq!(loaded.vpl_lower_map_of(1), None, "no second origin");
    // The budget counts them.
    let mut without = loaded.manifest.clone();
    without.lower_map_count = 0;
    assert_eq!(
        decoded_bytes(&loaded.manifest),
        decoded_bytes(&without)
            + 4 * 3 * u64::from(VPL_MAP * VPL_MAP)
            + 4 * u64::from(VPL_MAP * VPL_MAP)
    );
}

#[test]
fn a_4_6_manifest_loads_without_second_origins() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &sample_asset(true));
    let current = load(&dir).unwrap();
    let old = testing::manifest_bytes_4_6(&current.manifest).unwrap();
    assert_eq!(u16::from_le_bytes([old[10], old[11]]), 6);
    std::fs::write(dir.join(FILE_MANIFEST), &old).unwrap();
    let loaded = load(&dir).expect("a 4.6 asset loads");
    assert_eq!(loaded, without_4_7(&current));
    assert!(loaded.vpl_lower.is_empty() && loaded.vpl_lower_map_of(0).is_none());
    // Written again, it is a 4.7 asset whose VPLs have none.
    let again = tmp.path().join("again.gibake");
    write(&loaded, &again).unwrap();
    let l = load(&again).unwrap();
    assert_eq!(l.vpl_lower, vec![LowerVpl::NONE; VPLS]);
    assert_eq!(l.manifest.lower_map_count, 0);
    // A 4.6 manifest that lists vpl_lower.bin is refused: the counts say
    // it is not stored.
    let m = load_manifest(&dir.join("../again.gibake")).unwrap();
    let mut bytes = testing::manifest_bytes(&m).unwrap();
    bytes[10..12].copy_from_slice(&6u16.to_le_bytes());
    let bytes = with_payload_tail(
        &bytes,
        u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize - 2,
        &[],
    );
    std::fs::write(again.join(FILE_MANIFEST), &bytes).unwrap();
    let msg = load_manifest(&again).unwrap_err().to_string();
    assert!(
        msg.contains("vpl_lower.bin") && msg.contains("not stored"),
        "{msg}"
    );
}

#[test]
fn damaged_second_origins_are_refused_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &sample_asset(false));
    let good = std::fs::read(dir.join(FILE_VPL_LOWER)).unwrap();
    let set = |bytes: &mut Vec<u8>, vpl: usize, word: usize, v: u32| {
        bytes[16 * vpl + 4 * word..16 * vpl + 4 * word + 4].copy_from_slice(&v.to_le_bytes());
    };
    type Edit = Box<dyn Fn(&mut Vec<u8>)>;
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(move |b| set(b, 0, 1, f32::NAN.to_bits())),
            "VPL 0's second origin holds NaN",
        ),
        (
            Box::new(move |b| set(b, 1, 0, 1.0f32.to_bits())),
            "VPL 1 has no second origin",
        ),
        (
            Box::new(move |b| set(b, 4, 3, 7)),
            "refers to second hemisphere map 7 but only 3 are stored",
        ),
        (
            Box::new(move |b| {
                set(b, 0, 3, 1);
                set(b, 4, 3, 0);
            }),
            "must use tiles 0, 1, 2",
        ),
        (
            Box::new(move |b| set(b, 8, 3, NO_MAP)),
            "2 VPLs use a second hemisphere map but lower_map_count is 3",
        ),
    ];
    for (edit, says) in cases {
        let mut bytes = good.clone();
        edit(&mut bytes);
        replace_signed(&dir, FILE_VPL_LOWER, &bytes);
        let msg = load(&dir).unwrap_err().to_string();
        assert!(
            msg.contains(FILE_VPL_LOWER) && msg.contains(says),
            "{says}: {msg}"
        );
    }
    replace_signed(&dir, FILE_VPL_LOWER, &good);
    load(&dir).expect("the original loads again");
    // The writer refuses records that are neither none nor one per VPL,
    // and tiles the maps do not hold.
    let mut a = sample_asset(false);
    a.vpl_lower.pop();
    let e = write(&a, &tmp.path().join("short.gibake")).unwrap_err();
    assert!(e.to_string().contains("vpl_lower holds 9 records"), "{e}");
    let mut a = sample_asset(false);
    a.vpl_lower[4].map = 5;
    let e = write(&a, &tmp.path().join("tile.gibake")).unwrap_err();
    assert!(e.to_string().contains("cannot write"), "{e}");
    assert!(!tmp.path().join("tile.gibake").exists());
}

#[test]
fn diff_compares_the_second_maps() {
    let a = sample_asset(false);
    let mut b = a.clone();
    let tile = VPL_MAP as usize;
    let mut texels: Vec<f32> = b.vpl_lower_maps.texels().to_vec();
    // A finite texel of tile 0 moved by a tenth of its distance.
    let k = (0..tile * tile)
        .map(|i| (i / tile) * b.vpl_lower_maps.width() as usize + i % tile)
        .find(|&i| texels[i].is_finite())
        .expect("a finite texel");
    texels[k] *= 1.1;
    b.vpl_lower_maps = MapAtlas::from_texels(VPL_MAP, 3, texels).expect("the same atlas");
    let r = diff(&a, &b, &Tolerance::same_machine());
    assert!(!r.equal(), "{r}");
    let m = r
        .maps
        .iter()
        .find(|m| m.name == "vpl_lower_maps")
        .expect("compared");
    assert_eq!((m.over, m.worst_vpl), (1, Some(0)), "{m:?}");
    assert!(
        r.differences.iter().any(|d| d.contains("vpl_lower_maps")),
        "{r}"
    );
    assert!(diff(&a, &a, &Tolerance::same_machine()).equal());
}
