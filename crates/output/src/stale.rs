//! Temporaries left by processes that died before cleaning up (SIGKILL,
//! power loss, an out-of-memory kill), found and removed by the next writer
//! of the same output while it holds the output's lock — so no live process
//! can own them, whatever its process id.
//!
//! Nothing that might be a user's is deleted: in an old output directory
//! only the names the format owns, and hard links whose twin is in the live
//! directory, are removed; anything else is moved back into the live
//! directory when its name is free there, and otherwise left in place.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use crate::names::{self, TempKind};
use crate::registry;
use crate::{OutputLock, parent_of};

#[cfg(unix)]
fn same_inode(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_inode(_: &std::fs::Metadata, _: &std::fs::Metadata) -> bool {
    false
}

/// Removes what can be removed of the old output directory `old` (see the
/// module docs), then `old` itself if it is then empty. Returns whether
/// `old` is gone.
pub(crate) fn clean_old_dir(old: &Path, live: &Path, owned: &[OsString]) -> bool {
    let Ok(entries) = std::fs::read_dir(old) else {
        return std::fs::symlink_metadata(old).is_err();
    };
    let live_is_dir = std::fs::symlink_metadata(live).is_ok_and(|m| m.is_dir());
    for e in entries.flatten() {
        let name = e.file_name();
        let p = e.path();
        let Ok(meta) = std::fs::symlink_metadata(&p) else {
            continue;
        };
        let twin = live.join(&name);
        let twin_meta = std::fs::symlink_metadata(&twin);
        if owned.contains(&name) && !meta.is_dir() {
            let _ = std::fs::remove_file(&p);
        } else if twin_meta
            .as_ref()
            .is_ok_and(|t| !meta.is_dir() && same_inode(t, &meta))
        {
            // A hard link made before the swap: the live directory has it.
            let _ = std::fs::remove_file(&p);
        } else if live_is_dir && twin_meta.is_err() {
            let _ = std::fs::rename(&p, &twin);
        }
    }
    std::fs::remove_dir(old).is_ok()
}

/// Removes the temporaries of `target` left by dead processes; the caller
/// holds `target`'s lock (`_lock` says so). `owned` names the files the
/// output's format owns (for an asset directory; empty for a file). When
/// `target` is missing and the two-rename fallback had moved the old
/// directory aside (`.KEY.XXXXXX.old`), the old directory is put back first.
/// Returns the temporaries removed (or put back).
pub fn remove_stale(target: &Path, owned: &[OsString], _lock: &OutputLock) -> Vec<PathBuf> {
    let parent = parent_of(target);
    let Ok(entries) = std::fs::read_dir(&parent) else {
        return Vec::new();
    };
    let mut found: Vec<(PathBuf, TempKind)> = entries
        .flatten()
        .filter_map(|e| names::temp_kind(target, &e.file_name()).map(|k| (e.path(), k)))
        .filter(|(p, _)| !registry::with(|r| r.owns(p)))
        .collect();
    // `.old` first: it may be the only complete copy of the output.
    found.sort_by_key(|(_, k)| *k != TempKind::Old);
    let mut removed = Vec::new();
    for (p, kind) in found {
        let Ok(meta) = std::fs::symlink_metadata(&p) else {
            continue;
        };
        if meta.is_dir() {
            if kind == TempKind::Old
                && std::fs::symlink_metadata(target).is_err()
                && std::fs::rename(&p, target).is_ok()
            {
                crate::sync_dir(&parent);
                removed.push(p);
                continue;
            }
            if clean_old_dir(&p, target, owned) {
                removed.push(p);
            }
        } else if std::fs::remove_file(&p).is_ok() {
            removed.push(p);
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_temporaries_go_user_files_stay() {
        let dir = tempfile::tempdir().unwrap();
        let live = dir.path().join("a.gibake");
        std::fs::create_dir(&live).unwrap();
        std::fs::write(live.join("manifest.bin"), b"new").unwrap();
        std::fs::write(live.join("notes.txt"), b"notes").unwrap();
        // A stale file temporary, a stale new directory, an old directory
        // holding an owned file, a hard link of the notes and a user's
        // directory that had not been moved back yet.
        std::fs::write(dir.path().join(".a.gibake.AAAAAA.tmp"), b"x").unwrap();
        let newdir = dir.path().join(".a.gibake.BBBBBB.tmp");
        std::fs::create_dir(&newdir).unwrap();
        std::fs::write(newdir.join("vpls.bin"), b"v").unwrap();
        let old = dir.path().join(".a.gibake.CCCCCC.tmp");
        std::fs::create_dir(&old).unwrap();
        std::fs::write(old.join("manifest.bin"), b"old").unwrap();
        std::fs::hard_link(live.join("notes.txt"), old.join("notes.txt")).unwrap();
        std::fs::create_dir(old.join("sketches")).unwrap();
        std::fs::write(old.join("sketches/s.txt"), b"s").unwrap();
        // Not ours: another output's lock and a user's hidden file.
        std::fs::write(dir.path().join(".a.gibake.notes"), b"keep").unwrap();
        let owned: Vec<OsString> = vec!["manifest.bin".into(), "vpls.bin".into()];
        let lock = OutputLock::acquire(&live, &mut |_| {}).unwrap();
        let removed = remove_stale(&live, &owned, &lock);
        assert_eq!(removed.len(), 3, "{removed:?}");
        let mut left: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, [".a.gibake.lock", ".a.gibake.notes", "a.gibake"]);
        assert_eq!(std::fs::read(live.join("manifest.bin")).unwrap(), b"new");
        assert_eq!(std::fs::read(live.join("notes.txt")).unwrap(), b"notes");
        assert_eq!(std::fs::read(live.join("sketches/s.txt")).unwrap(), b"s");
    }

    #[test]
    fn an_old_directory_is_put_back_when_the_output_is_missing() {
        let dir = tempfile::tempdir().unwrap();
        let live = dir.path().join("a.gibake");
        let old = dir.path().join(".a.gibake.DDDDDD.old");
        std::fs::create_dir(&old).unwrap();
        std::fs::write(old.join("manifest.bin"), b"old").unwrap();
        let newer = dir.path().join(".a.gibake.EEEEEE.tmp");
        std::fs::create_dir(&newer).unwrap();
        std::fs::write(newer.join("manifest.bin"), b"new").unwrap();
        let owned: Vec<OsString> = vec!["manifest.bin".into()];
        let lock = OutputLock::acquire(&live, &mut |_| {}).unwrap();
        remove_stale(&live, &owned, &lock);
        assert_eq!(std::fs::read(live.join("manifest.bin")).unwrap(), b"old");
        assert!(!old.exists() && !newer.exists());
    }
}
