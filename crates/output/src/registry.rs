//! What this process has created and not yet finished with: temporaries
//! and lock files. Writers register an item while holding the registry's
//! mutex, in the same step as the system call that creates, renames or
//! removes it, so the signal handler ([`cleanup_all`]) always sees the
//! true state and never races a half-done step.

use std::ffi::OsString;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, LazyLock, Mutex, MutexGuard};

/// One thing to undo when the process is stopped.
#[derive(Clone, Debug)]
pub(crate) enum Item {
    /// A temporary file (removed).
    File(PathBuf),
    /// A new directory being written; holds only what this process wrote
    /// (removed whole).
    NewDir(PathBuf),
    /// An old output directory moved aside (after an exchange or the first
    /// rename of the fallback): its owned files are removed, anything else
    /// is moved back to `live` or left in place ([`crate::stale::clean_old_dir`]).
    OldDir {
        /// Where it is now.
        old: PathBuf,
        /// The output path.
        live: PathBuf,
        /// Names the format owns (removable).
        owned: Vec<OsString>,
    },
    /// A lock file this process holds (removed when it is still the file locked).
    Lock {
        /// The lock file.
        path: PathBuf,
        /// Its device and inode when locked.
        id: Option<(u64, u64)>,
    },
}

/// The registered items, by id.
#[derive(Default)]
pub(crate) struct Registry {
    next: u64,
    items: Vec<(u64, Item)>,
}

impl Registry {
    /// Registers `item`; returns its id.
    pub(crate) fn add(&mut self, item: Item) -> u64 {
        self.next += 1;
        self.items.push((self.next, item));
        self.next
    }

    /// Replaces item `id` (after a rename changed what it is).
    pub(crate) fn set(&mut self, id: u64, item: Item) {
        if let Some(slot) = self.items.iter_mut().find(|(i, _)| *i == id) {
            slot.1 = item;
        }
    }

    /// Forgets item `id` (done with it).
    pub(crate) fn remove(&mut self, id: u64) {
        self.items.retain(|(i, _)| *i != id);
    }

    /// Whether a temporary at `path` is this process's.
    pub(crate) fn owns(&self, path: &std::path::Path) -> bool {
        self.items.iter().any(|(_, it)| match it {
            Item::File(p) | Item::NewDir(p) => p == path,
            Item::OldDir { old, .. } => old == path,
            Item::Lock { .. } => false,
        })
    }
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry {
    next: 0,
    items: Vec::new(),
});

/// Set in signal context the moment SIGINT, SIGTERM or SIGHUP arrives
/// (`signal_hook::flag`), before the handler thread wakes: a writer that
/// sees it set stops before its next step ([`lock`]).
pub(crate) static SIGNALLED: LazyLock<Arc<AtomicBool>> =
    LazyLock::new(|| Arc::new(AtomicBool::new(false)));

/// The registry, locked (a poisoned lock is recovered: the data is a list
/// of paths, valid whatever panicked).
///
/// Once a signal has arrived, this never returns: the calling thread waits
/// for the handler thread to clean up and end the process. Without that, a
/// writer that got the signal during its last system call could rename its
/// output and return from `main` (exit 0) before the handler thread ran.
pub(crate) fn lock() -> MutexGuard<'static, Registry> {
    let guard = lock_unchecked();
    if SIGNALLED.load(Ordering::SeqCst) {
        drop(guard);
        loop {
            std::thread::park();
        }
    }
    guard
}

/// The registry, locked, whatever signal arrived (for the handler itself).
fn lock_unchecked() -> MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// Runs `f` with the registry locked.
pub(crate) fn with<R>(f: impl FnOnce(&mut Registry) -> R) -> R {
    f(&mut lock())
}

/// Removes everything this process registered, and keeps the registry
/// locked for good (returns the guard to leak), so no writer of this process
/// can start a new step afterwards. For the signal handler, just before the
/// process ends.
#[cfg_attr(not(feature = "signals"), allow(dead_code))]
pub(crate) fn cleanup_all() -> MutexGuard<'static, Registry> {
    let guard = lock_unchecked();
    // Temporaries first, lock files last (another writer may start as soon
    // as a lock file is gone).
    for (_, item) in &guard.items {
        match item {
            Item::File(p) => {
                let _ = std::fs::remove_file(p);
            }
            Item::NewDir(p) => {
                // A writer may still be adding files: try a few times.
                for _ in 0..5 {
                    if std::fs::remove_dir_all(p).is_ok() || std::fs::symlink_metadata(p).is_err() {
                        break;
                    }
                }
            }
            Item::OldDir { old, live, owned } => {
                crate::stale::clean_old_dir(old, live, owned);
            }
            Item::Lock { .. } => {}
        }
    }
    for (_, item) in &guard.items {
        if let Item::Lock { path, id } = item {
            crate::lock::remove_if_same(path, *id);
        }
    }
    guard
}
