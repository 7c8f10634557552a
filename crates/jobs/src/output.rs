//! Output folders: refuse to replace a user's results without `force`, checked before any work.

use std::path::Path;

use crate::error::{JobError, Result};

/// Fails with [`JobError::Exists`] when `path` exists and `force` is false; with `force`, an
/// existing folder is left in place for the job to overwrite file by file (each file atomically).
///
/// # Errors
/// [`JobError::Exists`] naming `path`.
pub fn refuse_existing(path: &Path, force: bool, hint: &str) -> Result<()> {
    if path.exists() && !force {
        return Err(JobError::Exists {
            path: path.to_path_buf(),
            hint: hint.to_string(),
        });
    }
    Ok(())
}

/// Like [`refuse_existing`], but with `force` the folder is removed first, so that no file of
/// the earlier result survives.
///
/// # Errors
/// [`JobError::Exists`] without `force`; [`JobError::Io`] when the folder cannot be removed.
pub fn replace_folder(path: &Path, force: bool, hint: &str) -> Result<()> {
    refuse_existing(path, force, hint)?;
    if path.exists() {
        std::fs::remove_dir_all(path).map_err(|e| JobError::io(path, e))?;
    }
    Ok(())
}

/// Creates `path` and its parents.
///
/// # Errors
/// [`JobError::Io`] naming the folder.
pub fn create_dir(path: &Path) -> Result<()> {
    std::fs::create_dir_all(path).map_err(|e| JobError::io(path, e))
}
