//! Format 4.6: the bounces after the first (`Manifest::later`, appended to
//! the manifest payload after `swept_bounds`; the later VPLs are the last of
//! `vpls.bin`, no light's): round trip in the documented layout, 4.5 assets
//! still read (the first bounce alone), every bad record refused naming the
//! manifest (a hostile bounce count before allocating), the VPL counts
//! adding up, the later VPLs' map origins lifted, `inspect` and `diff`.

use crate::common;

use common::*;
use gibake_asset::*;

/// The later VPLs of [`with_later`]: the last three records.
const LATER: u32 = 3;

fn mkdir(tmp: &std::path::Path, name: &str) -> std::path::PathBuf {
    let d = tmp.join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn record() -> LaterRecord {
    LaterRecord {
        bounces: 0,
        vpl_budget: 0,
        vpls: LATER,
        left_out: false,
        converged: true,
        direct: [2.0, 1.0, 0.5],
        per_bounce: vec![[1.0, 0.5, 0.25], [0.5, 0.25, 0.125]],
        tail: [0.0; 3],
    }
}

/// The sample asset whose last three VPLs are the later bounces' (its
/// second light keeps one of its four).
fn with_later() -> Asset {
    let mut a = sample_asset(true);
    a.manifest.lights[1].vpls -= LATER;
    a.manifest.later = Some(record());
    a
}

#[test]
fn later_round_trips_in_the_documented_layout() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &with_later());
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded, as_written(&with_later(), &loaded));
    assert_eq!(loaded.manifest.later, Some(record()));
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    assert_eq!(FORMAT_MINOR, 8);
    assert_eq!(u16::from_le_bytes([bytes[10], bytes[11]]), 8);
    // The payload ends with the Option tag `01`, then bounces, vpl_budget
    // and vpls (varints), left_out and converged (a byte each), direct
    // (three f32), per_bounce (a varint count, three f32 each) and tail;
    // then (4.7) lower_map_count, one byte here, and (4.8) later_sources,
    // none: `00`.
    let mut tail = vec![1u8, 0, 0, LATER as u8, 0, 1];
    let f32s = |t: &mut Vec<u8>, v: &[f32]| {
        for x in v {
            t.extend_from_slice(&x.to_le_bytes());
        }
    };
    f32s(&mut tail, &[2.0, 1.0, 0.5]);
    tail.push(2);
    f32s(&mut tail, &[1.0, 0.5, 0.25, 0.5, 0.25, 0.125]);
    f32s(&mut tail, &[0.0; 3]);
    tail.push(u8::try_from(loaded.manifest.lower_map_count).unwrap());
    tail.push(0);
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    assert_eq!(&bytes[20 + len - tail.len()..20 + len], &tail[..]);
    // The later VPLs' map origins are lifted by one member's radius, the
    // others' by their own.
    let lift = loaded.manifest.origin_lift_flags();
    assert_eq!(lift.len(), VPLS);
    assert!(lift[..VPLS - LATER as usize].iter().all(|f| !f));
    assert!(lift[VPLS - LATER as usize..].iter().all(|f| *f));
    // The share of the later bounces: (0.875 + 0.125·… ) of all.
    let share = record().later_share();
    assert!(
        (share - 0.875 / (3.5 + 1.75 + 0.875)).abs() < 1e-6,
        "{share}"
    );
}

#[test]
fn a_4_5_manifest_loads_as_the_first_bounce_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = written(tmp.path(), &with_later());
    let current = load(&dir).unwrap();
    // A 4.5 writer could not hold them.
    assert!(testing::manifest_bytes_4_5(&current.manifest).is_err());
    let dir = written(&mkdir(tmp.path(), "one"), &sample_asset(true));
    let current = load(&dir).unwrap();
    let old = testing::manifest_bytes_4_5(&current.manifest).unwrap();
    assert_eq!(u16::from_le_bytes([old[10], old[11]]), 5);
    // One byte shorter than 4.6's: its `later`, none.
    assert_eq!(
        old.len() + 1,
        testing::manifest_bytes_4_6(&current.manifest)
            .unwrap()
            .len()
    );
    std::fs::write(dir.join(FILE_MANIFEST), &old).unwrap();
    let loaded = load(&dir).expect("a 4.5 asset loads");
    assert_eq!(loaded.manifest.later, None);
    assert!(loaded.manifest.origin_lift_flags().iter().all(|f| !f));
}

#[test]
fn bad_later_records_are_refused_naming_the_manifest() {
    let tmp = tempfile::tempdir().unwrap();
    type Edit = Box<dyn Fn(&mut LaterRecord)>;
    let cases: Vec<(Edit, &str)> = vec![
        (Box::new(|l| l.bounces = 1), "bounces = 1"),
        (
            Box::new(|l| l.left_out = true),
            "left out, yet 3 later VPLs",
        ),
        (
            Box::new(|l| l.per_bounce[1][2] = f32::NAN),
            "negative or not finite",
        ),
        (Box::new(|l| l.direct[0] = -1.0), "negative or not finite"),
        (
            Box::new(|l| l.tail[1] = f32::INFINITY),
            "negative or not finite",
        ),
        (
            Box::new(|l| l.per_bounce = vec![[0.1; 3]; MAX_LATER_BOUNCES + 1]),
            "bounces listed",
        ),
    ];
    for (k, (f, what)) in cases.iter().enumerate() {
        let dir = written(&mkdir(tmp.path(), &format!("c{k}")), &with_later());
        edit_manifest(&dir, |m| f(m.later.as_mut().unwrap()));
        let e = load(&dir).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, AssetError::Invalid { .. }), "{e:?}");
        assert!(
            msg.contains("manifest.bin") && msg.contains(what),
            "{what}: {msg}"
        );
        // Nothing is written from such a record either.
        let mut a = with_later();
        f(a.manifest.later.as_mut().unwrap());
        let err = write(&a, &tmp.path().join(format!("w{k}.gibake")))
            .unwrap_err()
            .to_string();
        assert!(err.contains(what), "{what}: {err}");
    }
    // More later VPLs than the asset has, and counts that do not add up
    // with the lights'.
    let dir = written(&mkdir(tmp.path(), "many"), &with_later());
    edit_manifest(&dir, |m| m.later.as_mut().unwrap().vpls = 11);
    let msg = load(&dir).unwrap_err().to_string();
    assert!(msg.contains("11 later VPLs but the asset has 10"), "{msg}");
    let dir = written(&mkdir(tmp.path(), "sum"), &with_later());
    edit_manifest(&dir, |m| m.later.as_mut().unwrap().vpls = 2);
    let msg = load(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("the lights' VPL counts add up to 7 and the later bounces' to 2"),
        "{msg}"
    );
    // A hostile bounce count (2^40) is refused before any allocation.
    let dir = written(&mkdir(tmp.path(), "huge"), &with_later());
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    // The record's last fields: per_bounce (1 + 24 bytes) and tail (12).
    let keep = len - (1 + 24 + 12);
    let mut tail = vec![253u8];
    tail.extend_from_slice(&(1u64 << 40).to_le_bytes());
    std::fs::write(
        dir.join(FILE_MANIFEST),
        with_payload_tail(&bytes, keep, &tail),
    )
    .unwrap();
    let msg = load_manifest(&dir).unwrap_err().to_string();
    assert!(
        msg.contains("manifest.bin") && msg.contains("damaged manifest payload: later"),
        "{msg}"
    );
    // An Option tag that is neither 0 nor 1.
    std::fs::write(
        dir.join(FILE_MANIFEST),
        with_payload_tail(&bytes, len - (1 + 3 + 2 + 12 + 25 + 12), &[2]),
    )
    .unwrap();
    let msg = load_manifest(&dir).unwrap_err().to_string();
    assert!(msg.contains("damaged manifest payload: later"), "{msg}");
}

#[test]
fn inspect_and_diff_say_what_the_later_bounces_carry() {
    let a = with_later();
    let text = inspect(&a).to_string();
    assert!(
        text.contains("bounces: every bounce that matters; the later ones 3 VPLs"),
        "{text}"
    );
    assert!(text.contains("1: 0.500 2: 0.250"), "{text}");
    let one = sample_asset(true);
    let text = inspect(&one).to_string();
    assert!(text.contains("bounces: the first alone"), "{text}");
    // A diff names the change.
    let mut b = with_later();
    b.manifest.later.as_mut().unwrap().per_bounce[1] = [1.0, 0.5, 0.25];
    let r = diff(&a, &b, &Tolerance::same_machine());
    assert!(
        r.later
            .iter()
            .any(|d| d.field.contains("later light per bounce")),
        "{:?}",
        r.later
    );
    let r = diff(&a, &a, &Tolerance::same_machine());
    assert!(r.later.is_empty(), "{:?}", r.later);
    // Their sources (4.8): inspect says how much the named groups carry,
    // a diff names a weight moved, or sources on one side only.
    let mut c = with_later();
    c.manifest.later_sources = Some(sources());
    let text = inspect(&c).to_string();
    assert!(
        text.contains("their sources: the first bounce's VPLs in 2 groups")
            && text.contains("carry 88% of its light"),
        "{text}"
    );
    let mut d = c.clone();
    d.manifest.later_sources.as_mut().unwrap().weights[1].1 = 0.125;
    let r = diff(&c, &d, &Tolerance::same_machine());
    assert!(
        r.later.iter().any(|x| x.field == "later_sources.weights"),
        "{:?}",
        r.later
    );
    let r = diff(&a, &c, &Tolerance::same_machine());
    assert!(
        r.later.iter().any(|x| x.field == "later_sources"),
        "{:?}",
        r.later
    );
}

fn sources() -> LaterSources {
    let first = VPLS - LATER as usize;
    LaterSources {
        first: (0..first as u32).map(|i| (i % 2, 1.0 + i as f32)).collect(),
        weights: (0..LATER as usize * SOURCES_PER_LATER_VPL)
            .map(|k| match k % SOURCES_PER_LATER_VPL {
                0 => (1, 0.625),
                1 => (0, 0.25),
                _ => (0, 0.0),
            })
            .collect(),
    }
}

/// Format 4.8: where the later light came from, appended after
/// `lower_map_count` as an `Option<LaterSources>`; a 4.7 manifest (none)
/// still loads; bad records are refused naming the manifest.
#[test]
fn later_sources_round_trip_and_bad_ones_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let mut a = with_later();
    a.manifest.later_sources = Some(sources());
    let dir = written(&mkdir(tmp.path(), "s"), &a);
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded.manifest.later_sources, Some(sources()));
    // The payload ends with the tag `01`, the groups (count, varints),
    // the pairs (count, then a varint and an f32 each).
    let bytes = std::fs::read(dir.join(FILE_MANIFEST)).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    let first = VPLS - LATER as usize;
    let mut tail = vec![1u8, first as u8];
    for i in 0..first {
        tail.push((i % 2) as u8);
        tail.extend_from_slice(&(1.0 + i as f32).to_le_bytes());
    }
    tail.push((LATER as usize * SOURCES_PER_LATER_VPL) as u8);
    for k in 0..LATER as usize * SOURCES_PER_LATER_VPL {
        let (g, w) = sources().weights[k];
        tail.push(g as u8);
        tail.extend_from_slice(&w.to_le_bytes());
    }
    assert_eq!(&bytes[20 + len - tail.len()..20 + len], &tail[..]);
    // A 4.7 writer leaves them out; such an asset loads without them.
    let old = testing::manifest_bytes_4_7(&loaded.manifest).unwrap();
    assert_eq!(u16::from_le_bytes([old[10], old[11]]), 7);
    std::fs::write(dir.join(FILE_MANIFEST), &old).unwrap();
    let back = load(&dir).expect("a 4.7 asset loads");
    assert_eq!(back.manifest.later_sources, None);
    assert_eq!(back.manifest.later, Some(record()));
    // Bad records.
    type Edit = Box<dyn Fn(&mut Manifest)>;
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|m| {
                m.later_sources
                    .as_mut()
                    .unwrap()
                    .first
                    .pop()
                    .map(drop)
                    .unwrap_or(())
            }),
            "source groups listed",
        ),
        (
            Box::new(|m| m.later_sources.as_mut().unwrap().weights.truncate(3)),
            "source weights listed",
        ),
        (
            Box::new(|m| m.later_sources.as_mut().unwrap().first[0].0 = MAX_SOURCE_GROUPS),
            "source group 256",
        ),
        (
            Box::new(|m| m.later_sources.as_mut().unwrap().weights[2].1 = f32::NAN),
            "not finite",
        ),
        (
            Box::new(|m| m.later_sources.as_mut().unwrap().first[1].1 = -1.0),
            "weight is negative",
        ),
        (
            Box::new(|m| m.later_sources.as_mut().unwrap().weights[1].1 = 0.5),
            "sum to",
        ),
        (Box::new(|m| m.later = None), "no later VPLs"),
    ];
    for (k, (f, what)) in cases.iter().enumerate() {
        let dir = written(&mkdir(tmp.path(), &format!("b{k}")), &a);
        edit_manifest(&dir, |m| f(m));
        let e = load(&dir).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, AssetError::Invalid { .. }), "{e:?}");
        assert!(
            msg.contains("manifest.bin") && msg.contains(what),
            "case {k}: {msg}"
        );
    }
}
