//! Hot reload's trigger: the asset's manifest, polled (size and
//! modification time) at most once a second. `gibake bake` and
//! `gibake-output` replace an asset directory atomically (the manifest is
//! written last and the directory swapped by a rename), and
//! `gibake_asset::load` retries across a swap, so a change seen here is a
//! complete asset or one being swapped in: the load that follows gets the
//! whole new one or fails cleanly (the viewer then keeps the old one).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

/// How often the manifest is looked at.
pub const POLL_INTERVAL: Duration = Duration::from_secs(1);

/// What identifies one version of the manifest.
type Stamp = Option<(u64, SystemTime)>;

fn stamp(path: &Path) -> Stamp {
    let m = std::fs::metadata(path).ok()?;
    Some((m.len(), m.modified().ok()?))
}

/// Watches one asset directory's manifest.
#[derive(Debug)]
pub struct AssetWatch {
    manifest: PathBuf,
    seen: Stamp,
    next: Instant,
}

impl AssetWatch {
    /// Watches `asset_dir` (its manifest as it is now counts as seen).
    pub fn new(asset_dir: &Path) -> AssetWatch {
        let manifest = asset_dir.join(gibake_asset::FILE_MANIFEST);
        AssetWatch {
            seen: stamp(&manifest),
            manifest,
            next: Instant::now() + POLL_INTERVAL,
        }
    }

    /// True once after the manifest changed (size or time; a manifest that
    /// disappears is no change: the asset is being swapped or was deleted,
    /// and the viewer keeps what it has). Looks at the file only when
    /// [`POLL_INTERVAL`] has passed since the last look (`now`).
    pub fn poll(&mut self, now: Instant) -> bool {
        if now < self.next {
            return false;
        }
        self.next = now + POLL_INTERVAL;
        let s = stamp(&self.manifest);
        if s.is_none() || s == self.seen {
            return false;
        }
        self.seen = s;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rewritten_manifest_is_seen_once_and_only_after_the_interval() {
        let dir = tempfile::tempdir().unwrap();
        let m = dir.path().join(gibake_asset::FILE_MANIFEST);
        std::fs::write(&m, b"one").unwrap();
        let mut w = AssetWatch::new(dir.path());
        let t0 = Instant::now();
        assert!(!w.poll(t0 + 2 * POLL_INTERVAL), "unchanged");
        std::fs::write(&m, b"a longer one").unwrap();
        assert!(!w.poll(t0 + 2 * POLL_INTERVAL), "looked too soon");
        assert!(w.poll(t0 + 4 * POLL_INTERVAL), "changed size");
        assert!(!w.poll(t0 + 6 * POLL_INTERVAL), "seen already");
        std::fs::remove_file(&m).unwrap();
        assert!(!w.poll(t0 + 8 * POLL_INTERVAL), "gone is no change");
        std::fs::write(&m, b"a longer one, again").unwrap();
        assert!(w.poll(t0 + 10 * POLL_INTERVAL), "back");
    }
}
