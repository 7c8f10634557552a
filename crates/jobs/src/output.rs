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

/// Result files written together: each goes first into a hidden staging folder next to the
/// output folder (`.OUT.staging-PID-N`, written and flushed there, which is what takes
/// time), then [`StagedFiles::publish`] renames them into the output folder one after the
/// other (microseconds). A run killed before `publish` leaves the earlier results as they
/// were; its staging folder is removed by the next run into the same folder.
#[derive(Debug)]
pub struct StagedFiles {
    staging: std::path::PathBuf,
    dest: std::path::PathBuf,
    published: bool,
}

impl StagedFiles {
    /// A staging folder for files that will go into `dest`.
    ///
    /// # Errors
    /// [`JobError::Io`] when the staging folder cannot be made (its parent is not writable).
    pub fn new(dest: &Path) -> Result<Self> {
        let dest = if dest.file_name().is_some() {
            dest.to_path_buf()
        } else {
            std::path::absolute(dest).map_err(|e| JobError::io(dest, e))?
        };
        endoloc_data::fsutil::remove_stale_siblings(&dest, "staging");
        let staging = endoloc_data::fsutil::hidden_sibling(&dest, "staging");
        if let Some(parent) = staging.parent() {
            if parent.exists() && !parent.is_dir() {
                return Err(JobError::Invalid(format!(
                    "{}: is a file, not a folder; expected the folder to hold {}",
                    parent.display(),
                    dest.display()
                )));
            }
            create_dir(parent)?;
        }
        std::fs::create_dir(&staging).map_err(|e| JobError::io(&dest, e))?;
        Ok(StagedFiles {
            staging,
            dest,
            published: false,
        })
    }

    /// The staging folder (write the files here).
    pub fn dir(&self) -> &Path {
        &self.staging
    }

    /// Where to write file `name` now.
    pub fn path(&self, name: &str) -> std::path::PathBuf {
        self.staging.join(name)
    }

    /// Moves every staged file into the output folder (created if needed), replacing files
    /// of the same name; other files there are left alone.
    ///
    /// # Errors
    /// [`JobError::Io`] naming the output folder.
    pub fn publish(mut self) -> Result<()> {
        create_dir(&self.dest)?;
        let entries = std::fs::read_dir(&self.staging).map_err(|e| JobError::io(&self.dest, e))?;
        for entry in entries {
            let entry = entry.map_err(|e| JobError::io(&self.dest, e))?;
            let to = self.dest.join(entry.file_name());
            std::fs::rename(entry.path(), &to).map_err(|e| JobError::io(&to, e))?;
        }
        endoloc_data::fsutil::sync_dir(&self.dest);
        self.published = true;
        let _ = std::fs::remove_dir_all(&self.staging);
        Ok(())
    }
}

impl Drop for StagedFiles {
    /// An error before [`StagedFiles::publish`] leaves nothing behind.
    fn drop(&mut self) {
        if !self.published {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// Creates `path` and its parents.
///
/// # Errors
/// [`JobError::Io`] naming the folder.
pub fn create_dir(path: &Path) -> Result<()> {
    std::fs::create_dir_all(path).map_err(|e| JobError::io(path, e))
}
