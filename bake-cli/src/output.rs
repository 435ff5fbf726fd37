//! Output helpers: atomic file writes and progress bars.

use std::path::{Path, PathBuf};

use anyhow::Context;
use gibake_image::Image;
use indicatif::{ProgressBar, ProgressStyle};

/// Writes `img` (EXR or PNG by extension) through a temporary file in the
/// same directory and a rename, so a failure never leaves a half-written
/// file that looks valid.
pub fn write_image_atomic(img: &Image, path: &Path) -> anyhow::Result<()> {
    let tmp = temp_sibling(path);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("exr")
        .to_ascii_lowercase();
    let tmp = tmp.with_extension(format!("tmp.{ext}"));
    let r = if ext == "png" {
        img.write_png(&tmp, None)
    } else {
        img.write_exr(&tmp)
    };
    if let Err(e) = r {
        let _ = std::fs::remove_file(&tmp);
        return Err(e).with_context(|| format!("writing {}", path.display()));
    }
    std::fs::rename(&tmp, path).with_context(|| {
        format!(
            "{}: cannot move the finished file into place",
            path.display()
        )
    })
}

/// Writes bytes through a temporary sibling and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    let tmp = temp_sibling(path);
    if let Err(e) = std::fs::write(&tmp, bytes) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e).with_context(|| format!("{}: cannot write", path.display()));
    }
    std::fs::rename(&tmp, path).with_context(|| {
        format!(
            "{}: cannot move the finished file into place",
            path.display()
        )
    })
}

fn temp_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.{}", std::process::id()))
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
