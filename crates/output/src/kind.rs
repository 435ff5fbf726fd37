//! What a path is, in words for messages: "a regular file", "a directory",
//! "a symbolic link to ../b.gibake (a directory)", "a symbolic link to
//! x.gibake, which does not exist". A message that refuses an output says
//! what is there, so the user never reads "is not a directory" about a
//! link that, to them, is one.

use std::path::Path;

/// The kind of a file from its own metadata (a link is not followed).
fn kind_of(m: &std::fs::Metadata) -> &'static str {
    let t = m.file_type();
    if t.is_dir() {
        return "a directory";
    }
    if t.is_file() {
        return "a regular file";
    }
    if t.is_symlink() {
        return "a symbolic link";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a named pipe (FIFO)";
        }
        if t.is_socket() {
            return "a socket";
        }
        if t.is_block_device() || t.is_char_device() {
            return "a device";
        }
    }
    "neither a file nor a directory"
}

/// What `path` is (see the module docs): `None` when nothing is there, not
/// even a dangling link.
pub fn describe(path: &Path) -> Option<String> {
    let m = std::fs::symlink_metadata(path).ok()?;
    if !m.file_type().is_symlink() {
        return Some(kind_of(&m).to_string());
    }
    let to = std::fs::read_link(path)
        .map(|t| t.display().to_string())
        .unwrap_or_else(|_| "an unreadable target".into());
    Some(match std::fs::metadata(path) {
        Ok(target) => format!("a symbolic link to {to} ({})", kind_of(&target)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            format!("a symbolic link to {to}, which does not exist")
        }
        Err(e) => format!("a symbolic link to {to}, which cannot be followed ({e})"),
    })
}

/// Whether `path` is a symbolic link (not followed).
pub fn is_symlink(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("f"), b"x").unwrap();
        std::fs::create_dir(d.join("a.gibake")).unwrap();
        assert_eq!(describe(&d.join("f")).unwrap(), "a regular file");
        assert_eq!(describe(&d.join("a.gibake")).unwrap(), "a directory");
        assert_eq!(describe(&d.join("none")), None);
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink("a.gibake", d.join("l.gibake")).unwrap();
            std::os::unix::fs::symlink("gone.gibake", d.join("dangling")).unwrap();
            std::os::unix::fs::symlink("f", d.join("lf")).unwrap();
            assert_eq!(
                describe(&d.join("l.gibake")).unwrap(),
                "a symbolic link to a.gibake (a directory)"
            );
            assert_eq!(
                describe(&d.join("dangling")).unwrap(),
                "a symbolic link to gone.gibake, which does not exist"
            );
            assert_eq!(
                describe(&d.join("lf")).unwrap(),
                "a symbolic link to f (a regular file)"
            );
            assert!(is_symlink(&d.join("dangling")) && !is_symlink(&d.join("f")));
        }
    }
}
