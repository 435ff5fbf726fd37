//! Output helpers: output-path safety checks, atomic file writes, stdout
//! that tolerates a closed pipe, and progress bars.
//!
//! Safety rules (docs/robustness.md): an output never names an input of the
//! same command (the same file, or a file inside an input asset directory);
//! `-o` of an image is `.exr` or `.png`, `--stats` is `.json`; the outputs of
//! one command are distinct; every write goes to a uniquely named temporary
//! sibling (`gibake_output::FileWriter`: exclusive, under the output's
//! lock) that is renamed into place, and removed on every failure path.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use gibake_image::Image;
use indicatif::{ProgressBar, ProgressStyle};

/// The lower-case extension of `path`, if any.
fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
}

/// Requires `path` (given to `flag`) to end in one of `allowed` (lower-case,
/// without the dot).
pub fn check_extension(flag: &str, path: &Path, allowed: &[&str]) -> anyhow::Result<()> {
    match extension(path) {
        Some(e) if allowed.contains(&e.as_str()) => Ok(()),
        other => {
            let list = allowed
                .iter()
                .map(|a| format!(".{a}"))
                .collect::<Vec<_>>()
                .join(" or ");
            match other {
                Some(e) => bail!(
                    "{}: {flag} must name a {list} file, not .{e}",
                    path.display()
                ),
                None => bail!(
                    "{}: {flag} must name a {list} file (the name has no extension)",
                    path.display()
                ),
            }
        }
    }
}

/// An absolute, normalised form of `p` for comparisons: the canonical path
/// of its parent directory (symbolic links resolved) joined with its name;
/// `p` itself when it cannot be resolved.
fn normalised(p: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(p) {
        return c;
    }
    let parent = p
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    match (std::fs::canonicalize(parent), p.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => p.to_path_buf(),
    }
}

/// Whether `a` and `b` are the same file (same device and inode when both
/// exist, else the same normalised path).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    normalised(a) == normalised(b)
}

/// Refuses an output `out` (given to `flag`) that is one of the command's
/// `inputs` or lies inside one of them (an input asset directory).
pub fn check_not_input(flag: &str, out: &Path, inputs: &[&Path]) -> anyhow::Result<()> {
    let n_out = normalised(out);
    for input in inputs {
        if same_file(out, input) {
            bail!(
                "{}: {flag} names an input of this command ({}); refusing to overwrite it",
                out.display(),
                input.display()
            );
        }
        let n_in = normalised(input);
        if n_in.is_dir() && n_out.starts_with(&n_in) {
            bail!(
                "{}: {flag} lies inside the input {}; refusing to write into it",
                out.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// Refuses two outputs of one command that name the same file (same
/// device and inode when it exists, else the same normalised path).
pub fn check_distinct(outputs: &[(&str, &Path)]) -> anyhow::Result<()> {
    let mut seen: std::collections::HashMap<FileKey, &str> = std::collections::HashMap::new();
    for (flag, p) in outputs {
        if let Some(first) = seen.insert(file_key(p), flag) {
            bail!(
                "{}: {first} and {flag} name the same file; give them different paths",
                p.display()
            );
        }
    }
    Ok(())
}

/// What identifies a file for [`check_distinct`].
#[derive(PartialEq, Eq, Hash)]
enum FileKey {
    Inode(u64, u64),
    Path(PathBuf),
}

fn file_key(p: &Path) -> FileKey {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let Ok(m) = std::fs::metadata(p) {
            return FileKey::Inode(m.dev(), m.ino());
        }
    }
    FileKey::Path(normalised(p))
}

/// Opens the writer of the output file `path`: its lock (saying so when
/// another gibake process holds it) and an exclusive temporary sibling.
fn writer(path: &Path) -> anyhow::Result<gibake_output::FileWriter> {
    Ok(gibake_output::FileWriter::create(
        path,
        &mut crate::guard::say_waiting(path),
    )?)
}

/// Writes `img` (EXR or PNG by extension; anything else is refused) through
/// a temporary file in the same directory and a rename, so a failure never
/// leaves a half-written file that looks valid, nor a temporary file. PNG
/// previews use `exposure` (`None`: the image's own automatic exposure).
pub fn write_image_atomic(img: &Image, path: &Path, exposure: Option<f32>) -> anyhow::Result<()> {
    check_extension("-o", path, &["exr", "png"])?;
    let ext = extension(path).unwrap_or_default();
    let out = writer(path)?;
    let r = if ext == "png" {
        img.write_png(out.path(), exposure)
    } else {
        img.write_exr(out.path())
    };
    r.with_context(|| format!("writing {}", path.display()))?;
    out.commit()?;
    Ok(())
}

/// Writes 8-bit RGB pixels as a PNG through a temporary sibling and a rename.
pub fn write_rgb8_png_atomic(
    path: &Path,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> anyhow::Result<()> {
    check_extension("--presented", path, &["png"])?;
    let out = writer(path)?;
    gibake_image::write_rgb8_png(out.path(), width, height, rgb)
        .with_context(|| format!("writing {}", path.display()))?;
    out.commit()?;
    Ok(())
}

/// Writes bytes through a temporary sibling and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let mut out = writer(path)?;
    out.file()
        .write_all(bytes)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    out.commit()?;
    Ok(())
}

/// Prints `text` and a newline on stdout. A reader that closed the pipe
/// early (`gibake inspect A | head -1`) is not an error: the rest is
/// dropped quietly.
pub fn print_stdout(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(anyhow::Error::new(e).context("cannot write to standard output")),
    }
}

/// `println!` through [`print_stdout`]: a closed pipe ends the output
/// quietly instead of panicking (other write errors are ignored too, as a
/// report on stdout is not the command's result).
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {{
        let _ = $crate::output::print_stdout(&format!($($arg)*));
    }};
}

/// A progress bar on stderr (hidden when stderr is not a terminal).
pub fn bar(len: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(len);
    pb.set_style(
        ProgressStyle::with_template(
            "{prefix:>10} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    pb.set_prefix(what.to_string());
    pb
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions_inputs_and_distinct_outputs() {
        let dir = tempfile::tempdir().expect("tempdir");
        let scene = dir.path().join("s.glb");
        std::fs::write(&scene, b"x").expect("write");
        assert!(check_extension("-o", Path::new("a.EXR"), &["exr", "png"]).is_ok());
        assert!(check_extension("-o", Path::new("a.glb"), &["exr", "png"]).is_err());
        assert!(check_extension("-o", Path::new("a"), &["exr", "png"]).is_err());
        assert!(check_not_input("-o", &scene, &[&scene]).is_err());
        let dotted = dir.path().join(".").join("s.glb");
        assert!(check_not_input("-o", &dotted, &[&scene]).is_err());
        assert!(check_not_input("-o", &dir.path().join("f.exr"), &[&scene]).is_ok());
        assert!(check_not_input("-o", &dir.path().join("f.exr"), &[dir.path()]).is_err());
        let f = dir.path().join("f.exr");
        assert!(check_distinct(&[("-o", &f), ("--stats", &f)]).is_err());
    }

    #[test]
    fn a_long_valid_name_and_a_failed_rename_leave_nothing_behind() {
        let dir = tempfile::tempdir().expect("tempdir");
        let long = format!("{}.json", "a".repeat(250));
        write_atomic(&dir.path().join(&long), b"{}").expect("247+ byte names work");
        // Renaming onto a non-empty directory fails: no temporary is left.
        let blocker = dir.path().join("x.json");
        std::fs::create_dir(&blocker).expect("mkdir");
        std::fs::write(blocker.join("keep"), b"k").expect("write");
        assert!(write_atomic(&blocker, b"{}").is_err());
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .expect("read_dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, vec![long, "x.json".to_string()]);
    }
}
