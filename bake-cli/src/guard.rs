//! The command line's side of output safety (docs/robustness.md): every
//! output checked before any work (so a bad `-o`, `--stats` or frame name
//! fails in milliseconds, not after a bake), the per-output lock taken with
//! a message when another process holds it, and paths shown lossily (a file
//! name need not be UTF-8; JSON gets the same lossy text).
//!
//! The machinery itself (locks, temporaries, the one-step swap, signals)
//! is `gibake-output`.

use std::path::{Path, PathBuf};

use anyhow::bail;

/// `path` as text for messages and JSON (invalid UTF-8 replaced by U+FFFD).
pub fn lossy(path: &Path) -> String {
    path.to_string_lossy().into_owned()
}

/// The `on_wait` of `gibake_output`'s lock: one line saying who waits for what.
pub fn say_waiting(target: &Path) -> impl FnMut(&Path) + '_ {
    move |lock| {
        eprintln!(
            "{}: another gibake process is writing it; waiting for it to finish (lock {})",
            target.display(),
            lock.display()
        );
    }
}

/// Locks the output `target` for the rest of the command (a second writer
/// of the same output waits, then sees the first one's result).
pub fn lock_output(target: &Path) -> anyhow::Result<gibake_output::OutputLock> {
    Ok(gibake_output::OutputLock::acquire(
        target,
        &mut say_waiting(target),
    )?)
}

/// The directory `path` is written into must exist and be a directory.
fn check_parent(flag: &str, path: &Path) -> anyhow::Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if !dir.is_dir() {
        bail!(
            "{}: {flag}: the directory {} does not exist (create it first)",
            path.display(),
            dir.display()
        );
    }
    Ok(())
}

/// An output file (`-o` of an image, `--stats`, one frame of a sequence):
/// its directory exists, and it is not a directory or anything but a
/// regular file (a rename would fail after the work, or replace a link).
pub fn check_file_output(flag: &str, path: &Path) -> anyhow::Result<()> {
    check_parent(flag, path)?;
    if let Ok(m) = std::fs::metadata(path) {
        if m.is_dir() {
            bail!(
                "{}: {flag} names a directory; give a file name",
                path.display()
            );
        }
        if !m.is_file() {
            bail!(
                "{}: {flag} names something that is not a regular file (a pipe, device or socket)",
                path.display()
            );
        }
    }
    Ok(())
}

/// `bake -o` / `merge -o` of an asset: the name ends in `.gibake` (an asset
/// is a directory; `-o new.png` would make a directory named `.png`), its
/// directory exists, and what is there may be replaced (absent, empty, or
/// a gibake asset). Returns the directory to write: `path`, or where it
/// points when it is a symbolic link to a directory ([`asset_target`]).
pub fn check_asset_output(flag: &str, path: &Path) -> anyhow::Result<PathBuf> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase());
    if ext.as_deref() != Some("gibake") {
        bail!(
            "{}: {flag} names the asset directory, which must end in .gibake (for example {}.gibake)",
            path.display(),
            path.file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "scene".into())
        );
    }
    check_parent(flag, path)?;
    let target = asset_target(flag, path)?;
    gibake_asset::check_output(&target)?;
    Ok(target)
}

/// Where the asset output `path` is written. Itself, unless it is a
/// symbolic link: to a user a link to an asset directory is that
/// directory, so the asset is written (swapped in one step) where the link
/// points, the link is kept, and a note says so. A link to anything but a
/// directory, a dangling link or a loop is refused with a message that
/// says it is a link and to what.
pub fn asset_target(flag: &str, path: &Path) -> anyhow::Result<PathBuf> {
    if !gibake_output::is_symlink(path) {
        return Ok(path.to_owned());
    }
    let what = gibake_output::describe(path).unwrap_or_else(|| "a symbolic link".into());
    match std::fs::canonicalize(path) {
        Ok(real) if real.is_dir() => {
            eprintln!(
                "{}: {flag} is {what}: the asset is written there ({}); the link is kept",
                path.display(),
                real.display()
            );
            Ok(real)
        }
        Ok(_) => bail!(
            "{}: {flag} is {what}, and an asset is a directory; refusing to replace it (give another -o, or remove the link)",
            path.display()
        ),
        Err(_) => bail!(
            "{}: {flag} is {what}; give the asset directory itself, or make the link point to one",
            path.display()
        ),
    }
}

/// An output directory (`diff --images DIR`): absent (created) or a
/// directory (a link to one is followed); anything else is refused, saying
/// what it is.
pub fn check_dir_output(flag: &str, dir: &Path) -> anyhow::Result<()> {
    if std::fs::symlink_metadata(dir).is_err() || dir.is_dir() {
        return Ok(());
    }
    let what = gibake_output::describe(dir).unwrap_or_default();
    bail!(
        "{}: {flag} names a directory to write into, but it is {what}",
        dir.display()
    )
}

/// `bake --shard K/N -o PART`: a file, not named like an asset or an image,
/// whose directory exists; an existing file there must be a part.
pub fn check_part_output(path: &Path) -> anyhow::Result<()> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase());
    if let Some(e @ ("gibake" | "png" | "exr" | "json" | "gltf" | "glb")) = ext.as_deref() {
        bail!(
            "{}: with --shard, -o names the shard's part file (for example part.0), not a .{e}",
            path.display()
        );
    }
    check_file_output("-o", path)?;
    if std::fs::metadata(path).is_ok() {
        let mut head = [0u8; 8];
        let is_part = std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
            .is_ok()
            && head == gibake_asset::PART_MAGIC;
        if !is_part {
            bail!(
                "{}: exists and is not a gibake shard part; refusing to replace it",
                path.display()
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outputs_are_checked_before_work() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("frames")).unwrap();
        assert!(check_file_output("--stats", &d.join("frames")).is_err());
        assert!(check_file_output("-o", &d.join("no/such/f.exr")).is_err());
        assert!(check_file_output("-o", &d.join("f.exr")).is_ok());
        assert!(check_asset_output("-o", &d.join("new.png")).is_err());
        assert!(check_asset_output("-o", &d.join("new.gibake")).is_ok());
        std::fs::write(d.join("x.gibake"), b"file").unwrap();
        assert!(check_asset_output("-o", &d.join("x.gibake")).is_err());
        assert!(check_part_output(&d.join("p.gibake")).is_err());
        std::fs::write(d.join("thesis.tex"), b"mine").unwrap();
        assert!(check_part_output(&d.join("thesis.tex")).is_err());
        assert!(check_part_output(&d.join("part.0")).is_ok());
    }
}
