//! What a path given as an asset really is, when it has no readable
//! `manifest.bin`: missing, a shard part, a glTF scene, another file, or a
//! directory that is not an asset. One message that says so and what to do,
//! in place of the operating system's "Not a directory (os error 20)".

use std::io::Read;
use std::path::Path;

use crate::{AssetError, FILE_MANIFEST, PART_MAGIC};

/// `err` (reading `dir/manifest.bin` failed) in words that say what `dir` is.
pub(crate) fn explain(dir: &Path, err: AssetError) -> AssetError {
    let Ok(meta) = std::fs::metadata(dir) else {
        return AssetError::invalid(
            dir,
            "does not exist: no baked asset here (bake one with `gibake bake SCENE -o OUT.gibake`)",
        );
    };
    if meta.is_dir() {
        if std::fs::symlink_metadata(dir.join(FILE_MANIFEST)).is_err() {
            return AssetError::invalid(
                dir,
                format!("a directory without {FILE_MANIFEST}: not a baked gibake asset"),
            );
        }
        return err;
    }
    if !meta.is_file() {
        return AssetError::invalid(
            dir,
            "not a regular file or directory (a pipe, device or socket): not a baked asset",
        );
    }
    let mut head = [0u8; 8];
    let n = std::fs::File::open(dir)
        .and_then(|mut f| f.read(&mut head))
        .unwrap_or(0);
    let head = &head[..n];
    let ext = dir
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    if head == PART_MAGIC {
        AssetError::invalid(
            dir,
            "a shard part (written by `gibake bake --shard K/N`), not an asset: merge the parts first with `gibake merge PART... -o OUT.gibake`",
        )
    } else if head.starts_with(b"glTF") || matches!(ext.as_deref(), Some("gltf" | "glb")) {
        AssetError::invalid(
            dir,
            "a scene, not a baked asset: bake it first with `gibake bake SCENE -o OUT.gibake` and give OUT.gibake",
        )
    } else {
        AssetError::invalid(
            dir,
            "a file, not a baked asset (an asset is a directory NAME.gibake/ holding manifest.bin)",
        )
    }
}
