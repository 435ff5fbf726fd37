//! [`read_stable`]: readers of an output directory that a writer may swap
//! while they read.
//!
//! A reader opens the manifest, then the files it lists, each by path. If a
//! writer swaps the directory in between, the later files come from the new
//! asset and fail their checksums against the old manifest. The swap
//! changes which directory the path names (its device and inode), so a read
//! that failed while that changed is simply done again; a read that
//! succeeded is consistent whatever happened (every file matched the
//! manifest read first). A failure with the same directory before and after
//! is a real one and is returned.

use std::path::Path;
use std::time::Duration;

/// Attempts of one read before its last error is returned.
const ATTEMPTS: usize = 8;

#[cfg(unix)]
fn identity(p: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn identity(p: &Path) -> Option<(u64, u64)> {
    std::fs::metadata(p).ok().map(|_| (0, 0))
}

/// Runs `read` (which reads the output directory `dir`) until it succeeds,
/// or fails while `dir` stayed the same directory (see the module docs).
/// When `dir` vanished during the read (the two-rename fallback's moment
/// without a directory), waits briefly for it to return.
pub fn read_stable<T, E>(dir: &Path, mut read: impl FnMut() -> Result<T, E>) -> Result<T, E> {
    let mut attempt = 0;
    loop {
        let before = identity(dir);
        let r = read();
        if r.is_ok() {
            return r;
        }
        attempt += 1;
        let after = identity(dir);
        let swapped = before != after;
        if !swapped || attempt >= ATTEMPTS {
            return r;
        }
        if after.is_none() {
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failure_on_a_steady_directory_is_returned_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let mut calls = 0;
        let r: Result<(), &str> = read_stable(dir.path(), || {
            calls += 1;
            Err("damaged")
        });
        assert_eq!(r, Err("damaged"));
        assert_eq!(calls, 1);
    }

    #[test]
    fn a_failure_during_a_swap_is_retried() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a");
        let b = dir.path().join("b");
        std::fs::create_dir(&a).unwrap();
        std::fs::create_dir(&b).unwrap();
        let mut calls = 0;
        let r: Result<u32, &str> = read_stable(&a, || {
            calls += 1;
            if calls == 1 {
                // A writer swaps the directory mid-read.
                std::fs::remove_dir(&a).unwrap();
                std::fs::rename(&b, &a).unwrap();
                Err("checksum mismatch")
            } else {
                Ok(7)
            }
        });
        assert_eq!(r, Ok(7));
        assert_eq!(calls, 2);
    }
}
