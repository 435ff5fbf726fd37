//! Names of the lock file and the temporaries of an output: `.KEY.lock`,
//! `.KEY.XXXXXX.tmp` and `.KEY.XXXXXX.old`, where `KEY` is the output's
//! file name, or, when that is longer than [`MAX_KEY_BYTES`], its first
//! bytes, `~` and a hash of the whole name (so every name fits in the
//! 255-byte limit of common file systems, and two long names that share a
//! beginning still get different keys). Names need not be UTF-8.

use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};

use crate::{OutputError, parent_of};

/// Longest key kept as is: 200 bytes (`.KEY.XXXXXX.tmp` is then 212).
pub const MAX_KEY_BYTES: usize = 200;
/// Bytes of the name kept before the hash in a shortened key.
const SHORT_PREFIX: usize = 160;
/// Random characters in a temporary's name.
pub(crate) const RANDOM_CHARS: usize = 6;

#[cfg(unix)]
fn bytes(s: &OsStr) -> Vec<u8> {
    use std::os::unix::ffi::OsStrExt;
    s.as_bytes().to_vec()
}

#[cfg(not(unix))]
fn bytes(s: &OsStr) -> Vec<u8> {
    s.to_string_lossy().into_owned().into_bytes()
}

#[cfg(unix)]
fn from_bytes(b: Vec<u8>) -> OsString {
    use std::os::unix::ffi::OsStringExt;
    OsString::from_vec(b)
}

#[cfg(not(unix))]
fn from_bytes(b: Vec<u8>) -> OsString {
    OsString::from(String::from_utf8_lossy(&b).into_owned())
}

/// The key of `target` (see the module docs).
pub(crate) fn key(target: &Path) -> Result<Vec<u8>, OutputError> {
    let name = target.file_name().ok_or_else(|| {
        OutputError::new(
            target,
            "an output needs a file name",
            std::io::Error::from(std::io::ErrorKind::InvalidInput),
        )
    })?;
    let b = bytes(name);
    if b.len() <= MAX_KEY_BYTES {
        return Ok(b);
    }
    let hash = blake3::hash(&b);
    let mut k = b[..SHORT_PREFIX].to_vec();
    k.push(b'~');
    k.extend(
        hash.as_bytes()[..8]
            .iter()
            .flat_map(|x| format!("{x:02x}").into_bytes()),
    );
    Ok(k)
}

/// `.KEY` followed by `suffix`, in the target's directory.
fn sibling(target: &Path, suffix: &str) -> Result<PathBuf, OutputError> {
    let mut n = vec![b'.'];
    n.extend(key(target)?);
    n.extend_from_slice(suffix.as_bytes());
    Ok(parent_of(target).join(from_bytes(n)))
}

/// The lock file of `target`: `.KEY.lock` beside it.
pub fn lock_path(target: &Path) -> Result<PathBuf, OutputError> {
    sibling(target, ".lock")
}

/// The prefix of every temporary of `target`: `.KEY.`.
pub(crate) fn temp_prefix(target: &Path) -> Result<OsString, OutputError> {
    let mut n = vec![b'.'];
    n.extend(key(target)?);
    n.push(b'.');
    Ok(from_bytes(n))
}

/// What kind of temporary of `target` `name` is, if it is one: `.KEY.` then
/// exactly [`RANDOM_CHARS`] ASCII letters or digits, then `.tmp` or `.old`.
pub(crate) fn temp_kind(target: &Path, name: &OsStr) -> Option<TempKind> {
    let prefix = bytes(&temp_prefix(target).ok()?);
    let n = bytes(name);
    let rest = n.strip_prefix(prefix.as_slice())?;
    if rest.len() != RANDOM_CHARS + 4 || !rest[..RANDOM_CHARS].iter().all(u8::is_ascii_alphanumeric)
    {
        return None;
    }
    match &rest[RANDOM_CHARS..] {
        b".tmp" => Some(TempKind::Tmp),
        b".old" => Some(TempKind::Old),
        _ => None,
    }
}

/// The two kinds of temporaries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum TempKind {
    /// A new output being written, or (after an exchange) the old one being
    /// removed.
    Tmp,
    /// The old directory moved aside by the two-rename fallback.
    Old,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_fit_and_temporaries_are_recognised() {
        let t = Path::new("out/x.gibake");
        assert_eq!(lock_path(t).unwrap(), Path::new("out/.x.gibake.lock"));
        assert_eq!(
            temp_kind(t, OsStr::new(".x.gibake.Ab12Cd.tmp")),
            Some(TempKind::Tmp)
        );
        assert_eq!(
            temp_kind(t, OsStr::new(".x.gibake.Ab12Cd.old")),
            Some(TempKind::Old)
        );
        // Another output's temporaries and look-alikes are not ours.
        for n in [
            ".x.gibake.Ab12Cd.Zz99Yy.tmp",
            ".x.gibake.Ab1.tmp",
            ".x.gibake.Ab12C-.tmp",
            "x.gibake.Ab12Cd.tmp",
            ".x.gibake.lock",
        ] {
            assert_eq!(temp_kind(t, OsStr::new(n)), None, "{n}");
        }
        let long = "a".repeat(255);
        let lp = lock_path(Path::new(&long)).unwrap();
        let len = lp.file_name().unwrap().len();
        assert!(len <= 255 - 12, "{len}");
        let other = format!("{}b", "a".repeat(254));
        assert_ne!(lp, lock_path(Path::new(&other)).unwrap());
    }

    #[cfg(unix)]
    #[test]
    fn non_utf8_names_work() {
        use std::os::unix::ffi::OsStrExt;
        let t = Path::new(OsStr::from_bytes(b"f\xff.exr"));
        let lp = lock_path(t).unwrap();
        assert_eq!(lp.file_name().unwrap().as_bytes(), b".f\xff.exr.lock");
        let tmp = OsStr::from_bytes(b".f\xff.exr.abcDEF.tmp");
        assert_eq!(temp_kind(t, tmp), Some(TempKind::Tmp));
    }
}
