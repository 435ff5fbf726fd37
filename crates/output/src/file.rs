//! [`FileWriter`]: one output file, written to a temporary sibling and
//! renamed over the target, under the output's lock.

use std::fs::File;
use std::path::{Path, PathBuf};

use crate::registry::{self, Item};
use crate::{OutputError, OutputLock, names, parent_of};

/// A file being written to `target`: [`FileWriter::path`] / [`FileWriter::file`]
/// is the temporary; [`FileWriter::commit`] puts it in place. Dropped
/// without a commit, the temporary is removed and `target` is untouched.
pub struct FileWriter {
    target: PathBuf,
    tmp: Option<tempfile::NamedTempFile>,
    registry_id: u64,
    // Declared last: released after the temporary is gone.
    _lock: OutputLock,
}

impl FileWriter {
    /// Locks `target` (calling `on_wait` if another process holds it), removes
    /// stale temporaries of `target`, and creates the temporary (mode 0666
    /// less the umask, exclusively: never an existing file or link).
    pub fn create(target: &Path, on_wait: &mut dyn FnMut(&Path)) -> Result<Self, OutputError> {
        let lock = OutputLock::acquire(target, on_wait)?;
        crate::remove_stale(target, &[], &lock);
        let prefix = names::temp_prefix(target)?;
        let dir = parent_of(target);
        let (tmp, registry_id) = registry::with(|r| {
            let mut b = tempfile::Builder::new();
            b.prefix(&prefix)
                .suffix(".tmp")
                .rand_bytes(names::RANDOM_CHARS);
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                b.permissions(std::fs::Permissions::from_mode(0o666));
            }
            let tmp = b
                .tempfile_in(&dir)
                .map_err(|e| OutputError::new(target, "cannot create a temporary file", e))?;
            let id = r.add(Item::File(tmp.path().to_owned()));
            Ok::<_, OutputError>((tmp, id))
        })?;
        Ok(FileWriter {
            target: target.to_owned(),
            tmp: Some(tmp),
            registry_id,
            _lock: lock,
        })
    }

    /// The temporary file's path (write here, or through [`FileWriter::file`]).
    pub fn path(&self) -> &Path {
        self.tmp.as_ref().map_or(&self.target, |t| t.path())
    }

    /// The temporary file, open for writing.
    pub fn file(&mut self) -> &mut File {
        self.tmp
            .as_mut()
            .map(|t| t.as_file_mut())
            .expect("FileWriter holds its temporary until commit or drop")
    }

    /// Flushes the temporary to disk and renames it over the target.
    pub fn commit(mut self) -> Result<(), OutputError> {
        let Some(tmp) = self.tmp.take() else {
            return Ok(());
        };
        // Data on disk before the name points at it. The file may have been
        // rewritten through its path: open it again to flush that too.
        File::open(tmp.path())
            .and_then(|f| f.sync_all())
            .map_err(|e| OutputError::new(&self.target, "cannot flush the finished file", e))?;
        let id = self.registry_id;
        let r = registry::with(|r| {
            let res = tmp.persist(&self.target).map(|_| ());
            if res.is_ok() {
                r.remove(id);
            }
            res
        });
        match r {
            Ok(()) => {
                crate::sync_dir(&parent_of(&self.target));
                Ok(())
            }
            Err(e) => {
                let err = e.error;
                registry::with(|r| {
                    drop(e.file);
                    r.remove(id);
                });
                Err(OutputError::new(
                    &self.target,
                    "cannot move the finished file into place",
                    err,
                ))
            }
        }
    }
}

impl Drop for FileWriter {
    fn drop(&mut self) {
        if let Some(tmp) = self.tmp.take() {
            let id = self.registry_id;
            registry::with(|r| {
                drop(tmp);
                r.remove(id);
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names_in(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn commit_replaces_and_drop_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("f.json");
        std::fs::write(&t, b"old").unwrap();
        let mut w = FileWriter::create(&t, &mut |_| {}).unwrap();
        std::io::Write::write_all(w.file(), b"new").unwrap();
        assert_eq!(std::fs::read(&t).unwrap(), b"old", "not before commit");
        w.commit().unwrap();
        assert_eq!(std::fs::read(&t).unwrap(), b"new");
        let w = FileWriter::create(&t, &mut |_| {}).unwrap();
        drop(w);
        assert_eq!(names_in(dir.path()), ["f.json"]);
    }

    #[cfg(unix)]
    #[test]
    fn modes_follow_the_umask_not_0600() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("g.exr");
        let w = FileWriter::create(&t, &mut |_| {}).unwrap();
        w.commit().unwrap();
        let mode = std::fs::metadata(&t).unwrap().permissions().mode() & 0o777;
        // A plain file created now gets 0666 less the umask: the same mode.
        let probe = dir.path().join("probe");
        std::fs::write(&probe, b"").unwrap();
        let want = std::fs::metadata(&probe).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, want, "{mode:o} vs {want:o}");
    }

    #[test]
    fn a_255_byte_name_works() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join(format!("{}.exr", "n".repeat(251)));
        let w = FileWriter::create(&t, &mut |_| {}).unwrap();
        w.commit().unwrap();
        assert!(t.exists());
    }

    #[test]
    fn a_failed_rename_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let t = dir.path().join("x.json");
        std::fs::create_dir(&t).unwrap();
        std::fs::write(t.join("keep"), b"k").unwrap();
        let w = FileWriter::create(&t, &mut |_| {}).unwrap();
        assert!(w.commit().is_err());
        assert_eq!(names_in(dir.path()), ["x.json"]);
    }
}
