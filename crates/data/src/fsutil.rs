//! Small file-system helpers: atomic writes and unique hidden sibling names.

use crate::DataError;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A hidden path next to `path` (same folder, so a rename is atomic), unique within this
/// process and across processes: `.NAME.TAG-PID-N`.
pub(crate) fn hidden_sibling(path: &Path, tag: &str) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".to_string());
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let file = format!(".{name}.{tag}-{}-{n}", std::process::id());
    match path.parent() {
        Some(p) => p.join(file),
        None => PathBuf::from(file),
    }
}

/// The folder a path lives in, `.` for a bare file name.
pub(crate) fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder is written,
/// flushed to disk and renamed over `path`, so readers see either the old or the new file.
///
/// # Errors
/// [`DataError::Io`] naming the file that failed.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), DataError> {
    let tmp = hidden_sibling(path, "tmp");
    let result = (|| {
        // Errors name the destination: the temporary name means nothing to a user.
        let mut f = File::create(&tmp).map_err(|e| DataError::io(path, e))?;
        f.write_all(bytes).map_err(|e| DataError::io(path, e))?;
        f.sync_all().map_err(|e| DataError::io(path, e))?;
        drop(f);
        std::fs::rename(&tmp, path).map_err(|e| DataError::io(path, e))?;
        sync_dir(&parent_dir(path));
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Flushes a folder's entries (new names, renames) to disk; best effort, as not every
/// platform can open a folder for syncing.
pub(crate) fn sync_dir(dir: &Path) {
    if let Ok(f) = File::open(dir) {
        let _ = f.sync_all();
    }
}

/// Reads a whole text file.
///
/// # Errors
/// [`DataError::Io`] when the file cannot be read, [`DataError::Parse`] when it is not UTF-8.
pub(crate) fn read_text(path: &Path) -> Result<String, DataError> {
    let bytes = std::fs::read(path).map_err(|e| DataError::io(path, e))?;
    String::from_utf8(bytes).map_err(|e| {
        let upto = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..upto].iter().filter(|&&b| b == b'\n').count() + 1;
        DataError::parse(path, line, "invalid UTF-8; expected a text file")
    })
}
