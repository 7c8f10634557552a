//! The one error type of `endoloc-eval`.
//!
//! Every variant that is about a file names it; parse errors also name the 1-based line and
//! say what was expected.

use std::path::PathBuf;

/// Errors from reading evaluation inputs, computing metrics and writing results.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// Reading a TUM trajectory failed (the message names the file and line).
    #[error(transparent)]
    Data(#[from] endoloc_data::DataError),
    /// An operating-system I/O error on `path`.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder the operation was about.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A text file (frames.csv, zones.csv) does not follow its format.
    #[error("{}:{line}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// No estimated pose could be associated with a ground-truth pose by timestamp.
    #[error(
        "no matching timestamps between the ground truth ({gt_poses} poses) and the estimate \
         ({est_poses} poses) with max. time difference {max_diff_s} s and offset {offset_s} s"
    )]
    NoAssociation {
        /// Poses in the ground truth.
        gt_poses: usize,
        /// Poses in the estimate.
        est_poses: usize,
        /// The association tolerance, seconds.
        max_diff_s: f64,
        /// The offset added to the estimate's timestamps, seconds.
        offset_s: f64,
    },
    /// The Umeyama alignment is not defined for these points.
    #[error("Umeyama alignment: {0}")]
    Alignment(String),
    /// Input values that parse but cannot be evaluated (empty inputs, bad settings).
    #[error("{0}")]
    Invalid(String),
    /// An output file exists and overwriting was not asked for.
    #[error("{}: already exists (`force` overwrites it, or choose another output folder)", path.display())]
    AlreadyExists {
        /// The existing file.
        path: PathBuf,
    },
    /// A plot could not be drawn or encoded.
    #[error("{}: plot: {message}", path.display())]
    Plot {
        /// The PNG file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// JSON could not be written or read.
    #[error("{}: JSON: {source}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: serde_json::Error,
    },
}

impl EvalError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        EvalError::Io {
            path: path.into(),
            source,
        }
    }

    pub(crate) fn parse(path: impl Into<PathBuf>, line: usize, message: impl Into<String>) -> Self {
        EvalError::Parse {
            path: path.into(),
            line,
            message: message.into(),
        }
    }
}
