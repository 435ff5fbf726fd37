//! Output safety: how gibake puts a file or an asset directory at a path so
//! that the path always holds the old output or the new one, complete, at
//! every instant and under every fault (I/O error, full disk, signal, a
//! second writer, a crash), and how readers see old or new during a replace.
//!
//! The rules (docs/robustness.md, "Output safety"):
//!
//! - **One writer per output.** [`OutputLock`] takes an advisory lock
//!   (`flock`, through `std::fs::File::lock`) on a sibling lock file
//!   `.NAME.lock`; a second writer waits (the caller is told, so it can say
//!   so). The lock dies with its process, so a crashed writer never blocks
//!   the next one, and no process id is ever trusted (two containers both
//!   run as PID 1). The lock file is removed on release.
//! - **Temporaries** are siblings named `.NAME.XXXXXX.tmp` (six random
//!   characters; `NAME` shortened with a hash when long, so every name fits
//!   in 255 bytes), created exclusively (`O_EXCL`, `mkdir`), so an existing
//!   file or symbolic link is never followed or reused. Files are created
//!   with mode 0666 and directories 0777, both less the umask.
//! - **Stale temporaries** of `NAME` (of a process that died without
//!   cleaning up) are removed by the next writer of `NAME` while it holds
//!   the lock: no live process can own them then ([`remove_stale`]).
//! - **Files** ([`FileWriter`]) are written to a temporary, `fsync`ed and
//!   renamed over the target.
//! - **Directories** ([`DirWriter`]) are written to a temporary directory and
//!   swapped with the old one in one step (`renameat2(RENAME_EXCHANGE)` on
//!   Linux, `renamex_np(RENAME_SWAP)` on macOS); files in the old directory
//!   that the format does not own (a user's notes) are hard-linked into the
//!   new one first, so they are there at the instant of the swap. Where the
//!   file system cannot exchange, two renames are used; a crash between
//!   them leaves the old directory under a `.old` name, which the next
//!   writer puts back.
//! - **Messages** say what a refused path is ([`describe`]: a file, a
//!   directory, a symbolic link and what it points to).
//! - **Readers** ([`read_stable`]) retry a read that failed while the
//!   directory at the path was swapped under them.
//! - **Signals** (feature `signals`, [`signals::install`]): SIGINT, SIGTERM
//!   and SIGHUP remove what this process created, then end it as the
//!   signal would.

use std::path::{Path, PathBuf};

mod dir;
mod file;
mod kind;
mod lock;
mod names;
mod read;
mod registry;
#[cfg(feature = "signals")]
pub mod signals;
mod stale;

pub use dir::{DirWriter, NO_EXCHANGE_ENV, Swap};
pub use file::FileWriter;
pub use kind::{describe, is_symlink};
pub use lock::OutputLock;
pub use names::{MAX_KEY_BYTES, lock_path};
pub use read::read_stable;
pub use stale::remove_stale;

/// A failed step of writing an output: what was being done, to which path,
/// and the operating system's error.
#[derive(Debug, thiserror::Error)]
#[error("{}: {action}: {source}", path.display())]
pub struct OutputError {
    /// The file or directory concerned.
    pub path: PathBuf,
    /// What was being done ("cannot create a temporary directory", ...).
    pub action: &'static str,
    /// The underlying error.
    #[source]
    pub source: std::io::Error,
}

impl OutputError {
    pub(crate) fn new(path: &Path, action: &'static str, source: std::io::Error) -> Self {
        OutputError {
            path: path.to_owned(),
            action,
            source,
        }
    }
}

/// The directory that holds `target` (`.` for a bare name).
pub(crate) fn parent_of(target: &Path) -> PathBuf {
    target
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// Flushes a directory's entries to disk (a rename is durable only then).
/// Best effort: not every platform lets a directory be opened for this.
pub(crate) fn sync_dir(dir: &Path) {
    if let Ok(f) = std::fs::File::open(dir) {
        let _ = f.sync_all();
    }
}
