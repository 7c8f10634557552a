//! The one error type of `endoloc-data`.
//!
//! Every variant names the file it is about; parse errors also name the 1-based line and say
//! what was expected, so a user can open the file and fix it.

use std::fmt;
use std::path::{Path, PathBuf};

/// Errors from reading or writing datasets, trajectories, meshes and mid-line paths.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// An operating-system I/O error on `path`: `path: the OS's message`.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder the operation was about.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A file's content does not follow its format.
    #[error("{}: {message}", Located(path, *line))]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number, 0 when the format is not line-based (binary files, JSON
        /// values located by index).
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// The output exists and overwriting was not asked for.
    #[error("{}: already exists (ask to overwrite it, or choose another path)", path.display())]
    AlreadyExists {
        /// The existing path.
        path: PathBuf,
    },
    /// An image could not be encoded or decoded, or has the wrong size or pixel type.
    #[error("{}: image: {message}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// What went wrong and what was expected.
        message: String,
    },
    /// Values that parse but do not make sense together (counts that differ, a bad camera,
    /// landmarks out of order, ...).
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file or folder concerned.
        path: PathBuf,
        /// What is wrong and what was expected.
        message: String,
    },
    /// Anatomical landmarks that are missing or out of order (not tied to one file).
    #[error("anatomical landmarks: {message}")]
    Anatomy {
        /// What is missing or wrong and what was expected.
        message: String,
    },
}

impl DataError {
    /// An [`DataError::Io`] for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        DataError::Io {
            path: path.into(),
            source,
        }
    }

    /// A [`DataError::Parse`] for `path` at 1-based `line` (0: not line-based).
    pub fn parse(path: impl Into<PathBuf>, line: usize, message: impl Into<String>) -> Self {
        DataError::Parse {
            path: path.into(),
            line,
            message: message.into(),
        }
    }

    /// An [`DataError::Invalid`] for `path`.
    pub fn invalid(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        DataError::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }

    /// An [`DataError::Image`] for `path`.
    pub fn image(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        DataError::Image {
            path: path.into(),
            message: message.into(),
        }
    }

    /// The same error with a path under `from` moved under `to`: an error about a file
    /// written in a staging folder names the file where the user will look for it.
    pub fn relocated(mut self, from: &Path, to: &Path) -> Self {
        match &mut self {
            DataError::Io { path, .. }
            | DataError::Parse { path, .. }
            | DataError::AlreadyExists { path }
            | DataError::Image { path, .. }
            | DataError::Invalid { path, .. } => {
                if let Ok(rest) = path.strip_prefix(from) {
                    *path = to.join(rest);
                }
            }
            DataError::Anatomy { .. } => {}
        }
        self
    }
}

/// Where a TOML error is and what it says, for one-line messages: the 1-based line of its
/// span (0 when it has none) and the message without the quoted source excerpt.
pub fn toml_error_line(text: &str, e: &toml::de::Error) -> (usize, String) {
    let line = e.span().map_or(0, |s| {
        text[..s.start.min(text.len())].matches('\n').count() + 1
    });
    (line, e.message().trim().to_string())
}

/// `path:line` (or just `path` when the line is 0), the way compilers name a place in a file.
pub(crate) struct Located<'a>(pub &'a Path, pub usize);

impl fmt::Display for Located<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.1 == 0 {
            write!(f, "{}", self.0.display())
        } else {
            write!(f, "{}:{}", self.0.display(), self.1)
        }
    }
}
