//! Output files: atomic writes and the no-overwrite rule.
//!
//! Every file is written to a hidden temporary sibling, flushed, then renamed over its final
//! name ([`write_atomic`]), so a reader (or a crash) never sees half a file. An output
//! folder's existing files are only replaced when the caller asks (`--force`); the check
//! covers every file of a run before the first one is written.

use std::path::{Path, PathBuf};

use crate::EvalError;

/// Writes `bytes` to `path` atomically through [`endoloc_data::write_atomic`] (temporary file
/// in the same folder, flushed, renamed, folder flushed; the temporary is removed on error).
///
/// # Errors
/// [`EvalError::Io`] naming the file that failed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), EvalError> {
    endoloc_data::write_atomic(path, bytes).map_err(|e| match e {
        endoloc_data::DataError::Io { path, source } => EvalError::Io { path, source },
        other => EvalError::Data(other),
    })
}

/// Refuses to replace any of `paths` that already exists, unless `force`: call it for every
/// file a command will write before doing the work, so a long run never ends by refusing.
///
/// # Errors
/// [`EvalError::AlreadyExists`] for the first path that exists when `force` is false.
pub fn refuse_existing<P: AsRef<Path>>(paths: &[P], force: bool) -> Result<(), EvalError> {
    if force {
        return Ok(());
    }
    match paths.iter().map(AsRef::as_ref).find(|p| p.exists()) {
        Some(p) => Err(EvalError::AlreadyExists {
            path: p.to_path_buf(),
        }),
        None => Ok(()),
    }
}

/// An output folder whose files may be written: created if missing; refuses when one of the
/// files a run will write already exists, unless `force`.
#[derive(Debug, Clone)]
pub struct OutputDir {
    dir: PathBuf,
}

impl OutputDir {
    /// Prepares `dir` for writing the files `names` (relative to `dir`).
    ///
    /// # Errors
    /// [`EvalError::AlreadyExists`] for the first of `names` that exists when `force` is
    /// false (nothing is written); [`EvalError::Io`] if the folder cannot be created or
    /// `dir` is a file.
    pub fn prepare(dir: &Path, names: &[&str], force: bool) -> Result<Self, EvalError> {
        if dir.exists() && !dir.is_dir() {
            return Err(EvalError::io(
                dir,
                std::io::Error::other("exists and is not a folder; expected an output folder"),
            ));
        }
        if !force {
            for name in names {
                let p = dir.join(name);
                if p.exists() {
                    return Err(EvalError::AlreadyExists { path: p });
                }
            }
        }
        std::fs::create_dir_all(dir).map_err(|e| EvalError::io(dir, e))?;
        Ok(Self {
            dir: dir.to_path_buf(),
        })
    }

    /// The path of `name` inside the folder.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Writes `name` atomically.
    ///
    /// # Errors
    /// [`EvalError::Io`] as [`write_atomic`].
    pub fn write(&self, name: &str, bytes: &[u8]) -> Result<(), EvalError> {
        write_atomic(&self.path(name), bytes)
    }
}

impl OutputDir {
    /// Writes `name` atomically with the content `fill` produces through a buffered writer.
    ///
    /// # Errors
    /// [`EvalError::Io`] naming the file; whatever `fill` returns.
    pub fn write_with(
        &self,
        name: &str,
        fill: impl FnOnce(&mut dyn std::io::Write) -> Result<(), EvalError>,
    ) -> Result<(), EvalError> {
        let path = self.path(name);
        endoloc_data::fsutil::write_atomic_with(&path, fill).map_err(|e| match e {
            EvalError::Data(endoloc_data::DataError::Io { path, source }) => {
                EvalError::Io { path, source }
            }
            other => other,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn existing_files_are_refused_unless_forced_and_kept_intact() {
        let dir = tempfile::tempdir().unwrap();
        let old = dir.path().join("zones.csv");
        std::fs::write(&old, "user's results").unwrap();
        let new = dir.path().join("scores.csv");

        let err = refuse_existing(&[&new, &old], false).unwrap_err();
        assert!(
            matches!(&err, EvalError::AlreadyExists { path } if path == &old),
            "{err}"
        );
        assert!(err.to_string().contains("`force`"), "{err}");
        assert_eq!(std::fs::read_to_string(&old).unwrap(), "user's results");

        refuse_existing(&[&new], false).unwrap();
        refuse_existing(&[&new, &old], true).unwrap();
        write_atomic(&old, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&old).unwrap(), "new");
        // No temporary file is left beside it.
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
        assert_eq!(names.len(), 1);
    }
}
