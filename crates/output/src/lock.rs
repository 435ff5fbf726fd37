//! [`OutputLock`]: one writer per output, across processes and containers
//! that share the file system.
//!
//! The lock is an exclusive advisory lock (`flock` on Unix, `LockFileEx` on
//! Windows, through `std::fs::File::lock`) on the sibling file `.KEY.lock`,
//! opened without following a symbolic link. It is released when its holder
//! ends, however it ends, so a crash never leaves an output locked, and no
//! process id is involved. On release the holder removes the lock file;
//! a waiter that then gets the lock on the removed file notices (the path
//! no longer names the file it locked) and locks the new file instead, so
//! two processes never both believe they hold the lock.
//!
//! Within one process the lock is re-entrant: the CLI takes it for the
//! whole of a bake (so a second bake of the same output waits, then finds
//! the asset up to date), and the asset writer it calls takes it again.

use std::collections::HashMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::registry::{self, Item};
use crate::{OutputError, names};

/// Locks held by this process: lock file → (open file, holders, registry id).
static HELD: Mutex<Option<HashMap<PathBuf, Held>>> = Mutex::new(None);

struct Held {
    _file: File,
    count: usize,
    id: Option<(u64, u64)>,
    registry_id: u64,
}

/// An exclusive lock on one output path (see the module docs). Released
/// (and its lock file removed) when the last guard of this process drops.
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
}

/// Device and inode of an open file or a path.
#[cfg(unix)]
fn file_id(m: &std::fs::Metadata) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    Some((m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn file_id(_: &std::fs::Metadata) -> Option<(u64, u64)> {
    None
}

fn open_lock_file(path: &Path) -> std::io::Result<File> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true).write(true).create(true).truncate(false);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(rustix::fs::OFlags::NOFOLLOW.bits() as i32);
    }
    o.open(path)
}

/// Removes the lock file `path` if it is still the file with `id`.
pub(crate) fn remove_if_same(path: &Path, id: Option<(u64, u64)>) {
    let same = match (std::fs::symlink_metadata(path), id) {
        (Ok(m), Some(id)) => file_id(&m) == Some(id),
        (Ok(_), None) => true,
        (Err(_), _) => false,
    };
    if same {
        let _ = std::fs::remove_file(path);
    }
}

impl OutputLock {
    /// Locks the output `target`. When another process holds it,
    /// `on_wait(lock file)` is called once and this blocks until it is free.
    pub fn acquire(target: &Path, on_wait: &mut dyn FnMut(&Path)) -> Result<Self, OutputError> {
        let path = names::lock_path(target)?;
        {
            let mut held = HELD.lock().unwrap_or_else(|e| e.into_inner());
            if let Some(h) = held.get_or_insert_with(HashMap::new).get_mut(&path) {
                h.count += 1;
                return Ok(OutputLock { path });
            }
        }
        let mut told = false;
        let (file, id) = loop {
            let file = open_lock_file(&path)
                .map_err(|e| OutputError::new(&path, "cannot open the output's lock file", e))?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    if !told {
                        on_wait(&path);
                        told = true;
                    }
                    file.lock().map_err(|e| {
                        OutputError::new(&path, "cannot lock the output's lock file", e)
                    })?;
                }
                Err(std::fs::TryLockError::Error(e)) => {
                    return Err(OutputError::new(
                        &path,
                        "cannot lock the output's lock file",
                        e,
                    ));
                }
            }
            let mine = file.metadata().ok().and_then(|m| file_id(&m));
            let now = std::fs::symlink_metadata(&path)
                .ok()
                .and_then(|m| file_id(&m));
            if cfg!(not(unix)) || (mine.is_some() && mine == now) {
                break (file, mine);
            }
            // The holder removed the file we waited on: lock the new one.
        };
        let registry_id = registry::with(|r| {
            r.add(Item::Lock {
                path: path.clone(),
                id,
            })
        });
        let mut held = HELD.lock().unwrap_or_else(|e| e.into_inner());
        held.get_or_insert_with(HashMap::new).insert(
            path.clone(),
            Held {
                _file: file,
                count: 1,
                id,
                registry_id,
            },
        );
        Ok(OutputLock { path })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        let mut held = HELD.lock().unwrap_or_else(|e| e.into_inner());
        let Some(map) = held.as_mut() else { return };
        let Some(h) = map.get_mut(&self.path) else {
            return;
        };
        h.count -= 1;
        if h.count > 0 {
            return;
        }
        if let Some(h) = map.remove(&self.path) {
            // Remove the file while still holding the lock, then unlock (drop).
            registry::with(|r| {
                remove_if_same(&self.path, h.id);
                r.remove(h.registry_id);
            });
            drop(h);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reentrant_and_removed_on_release() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("a.gibake");
        let a = OutputLock::acquire(&t, &mut |_| panic!("no wait")).unwrap();
        let b = OutputLock::acquire(&t, &mut |_| panic!("re-entrant")).unwrap();
        assert!(a.path().exists());
        drop(a);
        assert!(b.path().exists(), "still held by b");
        let p = b.path().to_owned();
        drop(b);
        assert!(!p.exists(), "lock file removed on release");
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_in_place_of_the_lock_file_is_not_followed() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("b.exr");
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, b"keep").unwrap();
        std::os::unix::fs::symlink(&victim, names::lock_path(&t).unwrap()).unwrap();
        let e = OutputLock::acquire(&t, &mut |_| {}).unwrap_err();
        assert!(e.to_string().contains("lock file"), "{e}");
        assert_eq!(std::fs::read(&victim).unwrap(), b"keep");
    }
}
