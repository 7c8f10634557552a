//! File-system helpers: [`write_atomic`], the one atomic file write of endoloc's crates.

use crate::DataError;
use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// A hidden path next to `path` (same folder, so a rename is atomic), unique within this
/// process and across processes: `.NAME.TAG-PID-N`.
pub fn hidden_sibling(path: &Path, tag: &str) -> PathBuf {
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

/// Removes the hidden `.NAME.TAG-PID-N` siblings of `path` ([`hidden_sibling`]) left by
/// processes that no longer run (a killed `simulate`, say). Processes are looked up in
/// `/proc`; where there is none (not Linux) nothing is removed. Errors are ignored: this is
/// tidying, not part of the job.
pub fn remove_stale_siblings(path: &Path, tag: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Some(name) = path.file_name().map(|n| n.to_string_lossy().into_owned()) else {
        return;
    };
    let prefix = format!(".{name}.{tag}-");
    let Ok(entries) = std::fs::read_dir(parent_dir(path)) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let Some(rest) = file.strip_prefix(&prefix) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_dir_all(entry.path());
        }
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
/// flushed to disk and renamed over `path`, then the folder is flushed, so readers (and a
/// crash) see either the old or the new file, never half of one.
///
/// On any error the temporary file is removed and an existing file at `path` is left as it
/// was.
///
/// # Errors
/// [`DataError::Io`] naming `path` (not the temporary file).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), DataError> {
    write_atomic_with(path, |w| {
        w.write_all(bytes).map_err(|e| DataError::io(path, e))
    })
}

/// Writes `path` atomically as [`write_atomic`] does, with the content produced by `fill`
/// through a buffered writer: for files too large to build in memory first.
///
/// # Errors
/// [`DataError::Io`] naming `path` when writing fails; whatever `fill` returns (the
/// temporary file is removed either way).
pub fn write_atomic_with<E: From<DataError>>(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> Result<(), E>,
) -> Result<(), E> {
    let tmp = hidden_sibling(path, "tmp");
    let result = (|| {
        let f = File::create(&tmp).map_err(|e| DataError::io(path, e))?;
        let mut w = std::io::BufWriter::with_capacity(1 << 16, f);
        fill(&mut w)?;
        let f = w
            .into_inner()
            .map_err(|e| DataError::io(path, e.into_error()))?;
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
pub fn sync_dir(dir: &Path) {
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
    text_from_bytes(path, bytes)
}

/// The lines of a text stream, read one at a time (memory independent of the file's length):
/// yields `(line number, line)` with the number 1-based and the line break removed, and an
/// error naming `path` and the line at the first byte that is not UTF-8 or a read failure.
pub struct TextLines<R> {
    reader: R,
    path: PathBuf,
    line: usize,
    buf: Vec<u8>,
    done: bool,
}

impl<R: std::io::BufRead> TextLines<R> {
    /// Lines of `reader`; `path` names the source in errors.
    pub fn new(path: &Path, reader: R) -> Self {
        Self {
            reader,
            path: path.to_path_buf(),
            line: 0,
            buf: Vec::new(),
            done: false,
        }
    }
}

impl TextLines<std::io::BufReader<File>> {
    /// Lines of the file at `path`.
    ///
    /// # Errors
    /// [`DataError::Io`] naming `path` when it cannot be opened.
    pub fn open(path: &Path) -> Result<Self, DataError> {
        let file = File::open(path).map_err(|e| DataError::io(path, e))?;
        Ok(Self::new(path, std::io::BufReader::new(file)))
    }
}

impl<R: std::io::BufRead> Iterator for TextLines<R> {
    type Item = Result<(usize, String), DataError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        self.buf.clear();
        match self.reader.read_until(b'\n', &mut self.buf) {
            Ok(0) => {
                self.done = true;
                None
            }
            Ok(_) => {
                self.line += 1;
                if self.buf.last() == Some(&b'\n') {
                    self.buf.pop();
                    if self.buf.last() == Some(&b'\r') {
                        self.buf.pop();
                    }
                }
                match std::str::from_utf8(&self.buf) {
                    Ok(s) => Some(Ok((self.line, s.to_string()))),
                    Err(_) => {
                        self.done = true;
                        Some(Err(DataError::parse(
                            &self.path,
                            self.line,
                            "invalid UTF-8; expected a text file",
                        )))
                    }
                }
            }
            Err(e) => {
                self.done = true;
                Some(Err(DataError::io(&self.path, e)))
            }
        }
    }
}

/// A text file's bytes as a `String`; `path` names the file in the error.
///
/// # Errors
/// [`DataError::Parse`] at the line of the first byte that is not UTF-8.
pub(crate) fn text_from_bytes(path: &Path, bytes: Vec<u8>) -> Result<String, DataError> {
    String::from_utf8(bytes).map_err(|e| {
        let upto = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..upto].iter().filter(|&&b| b == b'\n').count() + 1;
        DataError::parse(path, line, "invalid UTF-8; expected a text file")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn staging_folders_of_dead_processes_are_removed_and_live_ones_kept() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("data");
        // No process has a number above the kernel's pid_max (at most 4194304).
        let dead = dir.path().join(".data.staging-4294967-0");
        let live = dir
            .path()
            .join(format!(".data.staging-{}-3", std::process::id()));
        let other = dir.path().join(".other.staging-4294967-0");
        for d in [&dead, &live, &other] {
            std::fs::create_dir_all(d.join("train")).unwrap();
        }
        remove_stale_siblings(&out, "staging");
        assert!(!dead.exists());
        assert!(live.exists() && other.exists());
    }

    #[test]
    fn write_atomic_replaces_the_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        write_atomic(&path, b"old").unwrap();
        write_atomic(&path, b"new").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"new");
        assert_eq!(names(dir.path()), vec!["a.txt".to_string()]);
    }

    #[test]
    fn failed_write_leaves_no_temporary_and_the_previous_file_intact() {
        let dir = tempfile::tempdir().unwrap();
        // The destination is a non-empty folder: the temporary file is written, the rename
        // fails, and the temporary must be removed.
        let target = dir.path().join("out");
        std::fs::create_dir(&target).unwrap();
        std::fs::write(target.join("keep.txt"), b"previous").unwrap();
        let err = write_atomic(&target, b"new").unwrap_err();
        assert!(
            matches!(&err, DataError::Io { path, .. } if path == &target),
            "{err}"
        );
        assert_eq!(names(dir.path()), vec!["out".to_string()]);
        assert_eq!(std::fs::read(target.join("keep.txt")).unwrap(), b"previous");

        // A missing folder: nothing is created at all.
        let missing = dir.path().join("no-such-folder").join("a.txt");
        assert!(write_atomic(&missing, b"x").is_err());
        assert_eq!(names(dir.path()), vec!["out".to_string()]);
    }
}
