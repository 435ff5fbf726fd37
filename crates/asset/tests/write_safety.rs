//! `write` never destroys what it should not and never leaves a half-written
//! asset.

use crate::common;

use common::*;
use gibake_asset::*;

#[test]
fn a_directory_that_is_not_an_asset_is_not_replaced() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("photos.gibake");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join("holiday.jpg"), b"precious").unwrap();
    let e = write(&sample_asset(false), &dir).unwrap_err();
    assert!(matches!(e, AssetError::Invalid { .. }));
    assert!(
        e.to_string().contains("photos.gibake") && e.to_string().contains("refusing"),
        "{e}"
    );
    assert_eq!(std::fs::read(dir.join("holiday.jpg")).unwrap(), b"precious");
    assert_eq!(file_names(&dir), ["holiday.jpg"]);
    assert_eq!(file_names(tmp.path()), ["photos.gibake"]);
}

#[test]
fn a_file_in_the_way_is_not_replaced() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("out.gibake");
    std::fs::write(&path, b"not a directory").unwrap();
    let e = write(&sample_asset(false), &path).unwrap_err();
    assert!(e.to_string().contains("not a directory"), "{e}");
    assert_eq!(std::fs::read(&path).unwrap(), b"not a directory");
    assert_eq!(file_names(tmp.path()), ["out.gibake"]);
    // A parent that is a file: the temporary directory cannot be created.
    let e = write(&sample_asset(false), &path.join("inner.gibake")).unwrap_err();
    assert!(matches!(e, AssetError::Io { .. }), "{e:?}");
    assert_eq!(file_names(tmp.path()), ["out.gibake"]);
    // No usable directory name at all.
    let e = write(&sample_asset(false), std::path::Path::new("/")).unwrap_err();
    assert!(matches!(e, AssetError::Invalid { .. }) || matches!(e, AssetError::Io { .. }));
}

#[test]
fn an_empty_directory_or_an_old_asset_is_replaced() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene.gibake");
    std::fs::create_dir(&dir).unwrap();
    let a = sample_asset(true);
    write(&a, &dir).unwrap();
    let mut b = sample_asset(false);
    b.manifest.settings.threshold = 0.5;
    write(&b, &dir).unwrap();
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded, as_written(&b, &loaded));
    // The old rsm.exr is gone with the old asset; no hidden leftovers.
    assert!(!dir.join("rsm.exr").exists());
    assert_eq!(file_names(tmp.path()), ["scene.gibake"]);
}

#[test]
fn a_failure_at_any_step_leaves_no_asset_and_no_temporary() {
    let steps = [
        "vpls.bin",
        "primary_depth.exr",
        "vpl_maps.exr",
        "rsm.exr",
        "manifest.bin",
        "rename",
    ];
    let asset = sample_asset(true);
    for step in steps {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("scene.gibake");
        let e = testing::write_failing_before(&asset, &dir, step).unwrap_err();
        assert!(matches!(e, AssetError::Io { .. }), "{step}: {e:?}");
        assert!(e.to_string().contains("injected"), "{e}");
        assert!(!dir.exists(), "{step}: an asset was left");
        assert!(
            file_names(tmp.path()).is_empty(),
            "{step}: {:?}",
            file_names(tmp.path())
        );
    }
}

#[test]
fn a_failure_while_replacing_keeps_the_old_asset() {
    let old = sample_asset(false);
    let mut new = sample_asset(true);
    new.manifest.settings.threshold = 0.25;
    for step in ["vpls.bin", "rsm.exr", "manifest.bin", "rename"] {
        let tmp = tempfile::tempdir().unwrap();
        let dir = written(tmp.path(), &old);
        testing::write_failing_before(&new, &dir, step).unwrap_err();
        let loaded = load(&dir).unwrap();
        assert_eq!(loaded, as_written(&old, &loaded), "{step}");
        assert_eq!(file_names(tmp.path()), ["scene.gibake"], "{step}");
    }
}

#[test]
fn an_inconsistent_asset_is_refused_before_writing_anything() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene.gibake");
    type Edit = Box<dyn Fn(&mut Asset)>;
    let cases: Vec<(&str, Edit)> = vec![
        (
            "primary_depth",
            Box::new(|a| a.primary_depth.data.pop().map(|_| ()).unwrap()),
        ),
        (
            "shadow_map_size",
            Box::new(|a| a.manifest.settings.shadow_map_size = 32),
        ),
        (
            "vpl_map_size",
            Box::new(|a| a.vpl_maps = MapAtlas::from_maps(1, [[1.0f32].as_slice()]).unwrap()),
        ),
        (
            "rsm",
            Box::new(|a| a.rsm.as_mut().unwrap().share.truncate(3)),
        ),
        (
            "share",
            Box::new(|a| a.rsm.as_mut().unwrap().share[0] = SHARE_ONE + 1),
        ),
        ("not finite", Box::new(|a| a.vpls[4].flux[1] = f32::NAN)),
        ("hemisphere map 7", Box::new(|a| a.vpls[4].map = 7)),
        ("NaN", Box::new(|a| a.vpl_maps.texels_mut()[3] = f32::NAN)),
        ("NaN", Box::new(|a| a.primary_depth.data[3] = f32::NAN)),
    ];
    for (what, f) in cases {
        let mut a = sample_asset(true);
        f(&mut a);
        let e = write(&a, &dir).unwrap_err();
        assert!(e.to_string().contains(what), "{what}: {e}");
        assert!(file_names(tmp.path()).is_empty(), "{what}");
    }
}

#[test]
fn a_read_only_parent_fails_cleanly() {
    use std::os::unix::fs::PermissionsExt;
    let tmp = tempfile::tempdir().unwrap();
    let parent = tmp.path().join("ro");
    std::fs::create_dir(&parent).unwrap();
    std::fs::set_permissions(&parent, std::fs::Permissions::from_mode(0o555)).unwrap();
    // Root ignores permissions: then there is nothing to test here (the
    // injected failures above cover the same code).
    if std::fs::write(parent.join("probe"), b"").is_ok() {
        std::fs::set_permissions(&parent, std::fs::Permissions::from_mode(0o755)).unwrap();
        return;
    }
    let e = write(&sample_asset(false), &parent.join("scene.gibake")).unwrap_err();
    assert!(matches!(e, AssetError::Io { .. }), "{e:?}");
    assert!(file_names(&parent).is_empty());
    std::fs::set_permissions(&parent, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn a_stale_temporary_directory_is_cleaned_up() {
    let tmp = tempfile::tempdir().unwrap();
    // Left by a process killed while writing (no one holds the lock): the
    // next writer of the same output removes it. Another output's temporary
    // and a look-alike name are left alone.
    let stale = tmp.path().join(".scene.gibake.k1Ll3d.tmp");
    std::fs::create_dir(&stale).unwrap();
    std::fs::write(stale.join("manifest.bin"), b"half").unwrap();
    std::fs::write(tmp.path().join(".other.gibake.k1Ll3d.tmp"), b"x").unwrap();
    std::fs::write(tmp.path().join(".scene.gibake.notes"), b"x").unwrap();
    let dir = written(tmp.path(), &sample_asset(false));
    load(&dir).unwrap();
    assert_eq!(
        file_names(tmp.path()),
        [
            ".other.gibake.k1Ll3d.tmp",
            ".scene.gibake.notes",
            "scene.gibake"
        ]
    );
}
