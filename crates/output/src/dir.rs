//! [`DirWriter`]: an output directory (an asset, `NAME.gibake/`) written to
//! a temporary sibling directory and swapped with the old one in one step.
//!
//! The swap, by what is at the target:
//!
//! - nothing, or an empty directory: `rename` (atomic; it replaces an empty
//!   directory);
//! - a directory: its entries the format does not own are hard-linked into
//!   the new directory, then the two are exchanged in one system call
//!   (`renameat2(RENAME_EXCHANGE)` on Linux ≥ 3.15 — ext4, xfs, btrfs,
//!   tmpfs, overlayfs among others — `renamex_np(RENAME_SWAP)` on macOS).
//!   At every instant the path names a complete directory, old or new.
//!   The old one (now at the temporary's name) is then emptied: its owned
//!   files removed, entries that could not be linked moved across, and
//!   removed.
//! - Where the file system cannot exchange (`EINVAL`, `ENOTSUP`, `ENOSYS`),
//!   two renames: old → `.KEY.XXXXXX.old`, new → target. Between them the
//!   path is briefly missing; a crash there is repaired by the next writer
//!   of the output ([`crate::remove_stale`] puts the old directory back).

use std::ffi::OsString;
use std::path::{Path, PathBuf};

use crate::registry::{self, Item};
use crate::{OutputError, OutputLock, names, parent_of};

/// A directory being written to `target` (see the module docs).
pub struct DirWriter {
    target: PathBuf,
    tmp: PathBuf,
    owned: Vec<OsString>,
    registry_id: u64,
    done: bool,
    // Declared last: released after the temporary is gone.
    _lock: OutputLock,
}

/// How the swap went (for tests and messages).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Swap {
    /// The target did not exist (or was an empty directory): one rename.
    Renamed,
    /// Exchanged with the old directory in one step.
    Exchanged,
    /// The file system cannot exchange: two renames.
    TwoRenames,
}

/// Makes a fresh, empty, exclusively created directory named like a
/// temporary of `target` with `suffix` (`.tmp` or `.old`), mode 0777 less
/// the umask.
fn make_temp_dir(target: &Path, suffix: &str) -> Result<PathBuf, OutputError> {
    let prefix = names::temp_prefix(target)?;
    tempfile::Builder::new()
        .prefix(&prefix)
        .suffix(suffix)
        .rand_bytes(names::RANDOM_CHARS)
        .tempdir_in(parent_of(target))
        .map(|d| d.keep())
        .map_err(|e| OutputError::new(target, "cannot create a temporary directory", e))
}

/// Exchanges the directories `a` and `b` in one step. `Ok(false)`: this
/// file system or platform cannot.
fn exchange(a: &Path, b: &Path) -> std::io::Result<bool> {
    #[cfg(any(target_os = "linux", target_os = "android", target_vendor = "apple"))]
    {
        use rustix::fs::{CWD, RenameFlags, renameat_with};
        use rustix::io::Errno;
        match renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE) {
            Ok(()) => Ok(true),
            Err(Errno::INVAL | Errno::NOSYS | Errno::NOTSUP) => Ok(false),
            Err(e) => Err(e.into()),
        }
    }
    #[cfg(not(any(target_os = "linux", target_os = "android", target_vendor = "apple")))]
    {
        let _ = (a, b);
        Ok(false)
    }
}

/// Environment variable that turns the one-step exchange off (tests of the
/// two-rename fallback).
pub const NO_EXCHANGE_ENV: &str = "GIBAKE_NO_RENAME_EXCHANGE";

impl DirWriter {
    /// Locks `target` (calling `on_wait` if another process holds it),
    /// removes stale temporaries of `target` (`owned`: the file names the
    /// format owns; anything else in an old directory is a user's and is
    /// kept), and creates the temporary directory.
    pub fn create(
        target: &Path,
        owned: Vec<OsString>,
        on_wait: &mut dyn FnMut(&Path),
    ) -> Result<Self, OutputError> {
        let lock = OutputLock::acquire(target, on_wait)?;
        crate::remove_stale(target, &owned, &lock);
        let (tmp, registry_id) = registry::with(|r| {
            let tmp = make_temp_dir(target, ".tmp")?;
            let id = r.add(Item::NewDir(tmp.clone()));
            Ok::<_, OutputError>((tmp, id))
        })?;
        Ok(DirWriter {
            target: target.to_owned(),
            tmp,
            owned,
            registry_id,
            done: false,
            _lock: lock,
        })
    }

    /// The temporary directory: write the new output's files here.
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// Puts the finished directory at the target (see the module docs).
    /// The target must be absent, an empty directory or a directory the
    /// caller has decided may be replaced.
    pub fn commit(self) -> Result<Swap, OutputError> {
        let allow = std::env::var_os(NO_EXCHANGE_ENV).is_none();
        self.commit_with(allow)
    }

    /// [`DirWriter::commit`]; `allow_exchange: false` forces the fallback.
    fn commit_with(mut self, allow_exchange: bool) -> Result<Swap, OutputError> {
        let target = self.target.clone();
        let tmp = self.tmp.clone();
        let id = self.registry_id;
        crate::sync_dir(&tmp);
        let old_meta = std::fs::symlink_metadata(&target);
        let non_empty = match &old_meta {
            Ok(m) if m.is_dir() => std::fs::read_dir(&target)
                .map_err(|e| OutputError::new(&target, "cannot list the old directory", e))?
                .next()
                .is_some(),
            Ok(_) => {
                return Err(OutputError::new(
                    &target,
                    "cannot replace it with a directory",
                    std::io::Error::other(format!(
                        "it is {}, not a directory",
                        crate::describe(&target).unwrap_or_else(|| "gone".into())
                    )),
                ));
            }
            Err(_) => false,
        };
        if !non_empty {
            registry::with(|r| {
                std::fs::rename(&tmp, &target).map_err(|e| {
                    OutputError::new(&target, "cannot move the new directory in", e)
                })?;
                r.remove(id);
                Ok::<_, OutputError>(())
            })?;
            self.done = true;
            crate::sync_dir(&parent_of(&target));
            return Ok(Swap::Renamed);
        }
        self.link_foreign();
        let owned = self.owned.clone();
        let exchanged = registry::with(|r| {
            let ok = allow_exchange
                && exchange(&tmp, &target).map_err(|e| {
                    OutputError::new(&target, "cannot swap in the new directory", e)
                })?;
            if ok {
                r.set(
                    id,
                    Item::OldDir {
                        old: tmp.clone(),
                        live: target.clone(),
                        owned: owned.clone(),
                    },
                );
            }
            Ok::<_, OutputError>(ok)
        })?;
        let swap = if exchanged {
            crate::sync_dir(&parent_of(&target));
            crate::stale::clean_old_dir(&tmp, &target, &owned);
            registry::with(|r| r.remove(id));
            Swap::Exchanged
        } else {
            self.two_renames()?;
            Swap::TwoRenames
        };
        self.done = true;
        Ok(swap)
    }

    /// Hard-links the old directory's entries the format does not own into
    /// the new one, so they are at the target at the instant of the swap.
    /// What cannot be linked (a directory, a file system without hard
    /// links) is moved across after the swap.
    fn link_foreign(&self) {
        let Ok(entries) = std::fs::read_dir(&self.target) else {
            return;
        };
        for e in entries.flatten() {
            let name = e.file_name();
            let to = self.tmp.join(&name);
            if self.owned.contains(&name) || std::fs::symlink_metadata(&to).is_ok() {
                continue;
            }
            if e.file_type().is_ok_and(|t| !t.is_dir()) {
                let _ = std::fs::hard_link(e.path(), &to);
            }
        }
    }

    /// The fallback swap: old → `.KEY.XXXXXX.old`, new → target.
    fn two_renames(&self) -> Result<(), OutputError> {
        let (target, tmp, id) = (&self.target, &self.tmp, self.registry_id);
        let old = make_temp_dir(target, ".old")?;
        registry::with(|r| {
            // `old` is an empty directory: rename replaces it.
            if let Err(e) = std::fs::rename(target, &old) {
                let _ = std::fs::remove_dir(&old);
                return Err(OutputError::new(
                    target,
                    "cannot move the old directory aside",
                    e,
                ));
            }
            let old_id = r.add(Item::OldDir {
                old: old.clone(),
                live: target.clone(),
                owned: self.owned.clone(),
            });
            if let Err(e) = std::fs::rename(tmp, target) {
                let _ = std::fs::rename(&old, target);
                r.remove(old_id);
                return Err(OutputError::new(
                    target,
                    "cannot move the new directory in",
                    e,
                ));
            }
            r.remove(id);
            Ok(old_id)
        })
        .map(|old_id| {
            crate::sync_dir(&parent_of(target));
            crate::stale::clean_old_dir(&old, target, &self.owned);
            registry::with(|r| r.remove(old_id));
        })
    }
}

impl Drop for DirWriter {
    fn drop(&mut self) {
        if self.done {
            return;
        }
        let (tmp, id) = (self.tmp.clone(), self.registry_id);
        registry::with(|r| {
            let _ = std::fs::remove_dir_all(&tmp);
            r.remove(id);
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn owned() -> Vec<OsString> {
        vec!["manifest.bin".into(), "data.bin".into()]
    }

    fn write_asset(target: &Path, tag: &str) -> Swap {
        write_asset_with(target, tag, true)
    }

    fn write_asset_with(target: &Path, tag: &str, allow_exchange: bool) -> Swap {
        let w = DirWriter::create(target, owned(), &mut |_| {}).unwrap();
        std::fs::write(w.path().join("data.bin"), tag).unwrap();
        std::fs::write(w.path().join("manifest.bin"), tag).unwrap();
        w.commit_with(allow_exchange).unwrap()
    }

    fn listing(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn new_then_replace_keeps_foreign_files_and_leaves_no_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("a.gibake");
        assert_eq!(write_asset(&t, "1"), Swap::Renamed);
        std::fs::write(t.join("notes.txt"), "mine").unwrap();
        std::fs::create_dir(t.join("sketches")).unwrap();
        let swap = write_asset(&t, "2");
        assert!(matches!(swap, Swap::Exchanged | Swap::TwoRenames));
        assert_eq!(
            std::fs::read_to_string(t.join("manifest.bin")).unwrap(),
            "2"
        );
        assert_eq!(
            std::fs::read_to_string(t.join("notes.txt")).unwrap(),
            "mine"
        );
        assert!(t.join("sketches").is_dir());
        assert_eq!(listing(dir.path()), ["a.gibake"]);
    }

    #[test]
    fn a_dropped_writer_leaves_the_old_directory_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("b.gibake");
        write_asset(&t, "1");
        let w = DirWriter::create(&t, owned(), &mut |_| {}).unwrap();
        std::fs::write(w.path().join("data.bin"), "half").unwrap();
        drop(w);
        assert_eq!(std::fs::read_to_string(t.join("data.bin")).unwrap(), "1");
        assert_eq!(listing(dir.path()), ["b.gibake"]);
    }

    #[test]
    fn the_two_rename_fallback_keeps_foreign_files_too() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("d.gibake");
        write_asset(&t, "1");
        std::fs::write(t.join("notes.txt"), "mine").unwrap();
        std::fs::create_dir(t.join("sketches")).unwrap();
        assert_eq!(write_asset_with(&t, "2", false), Swap::TwoRenames);
        assert_eq!(
            std::fs::read_to_string(t.join("manifest.bin")).unwrap(),
            "2"
        );
        assert_eq!(
            std::fs::read_to_string(t.join("notes.txt")).unwrap(),
            "mine"
        );
        assert!(t.join("sketches").is_dir());
        assert_eq!(listing(dir.path()), ["d.gibake"]);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn exchange_is_used_on_this_file_system() {
        // ext4 and tmpfs (this machine, CI) support RENAME_EXCHANGE.
        if std::env::var_os(NO_EXCHANGE_ENV).is_some() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("c.gibake");
        write_asset(&t, "1");
        assert_eq!(write_asset(&t, "2"), Swap::Exchanged);
    }
}
