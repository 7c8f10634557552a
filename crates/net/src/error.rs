//! The one error type of `endoloc-net`.

use std::path::PathBuf;

/// Errors from zoning, training, saving/loading models and classifying images.
#[derive(Debug, thiserror::Error)]
pub enum NetError {
    /// Reading the dataset failed (file named inside).
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
    /// A model file's content does not follow its format.
    #[error("{}{}: {message}", path.display(), if *line > 0 { format!(":{line}") } else { String::new() })]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line, 0 when the format is not line-based.
        line: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// A configuration value out of range or inconsistent.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// The training sequence cannot be cut into the zones asked for.
    #[error("zoning: {0}")]
    Zoning(String),
    /// Expert zones were asked for but the sequence has no `sections.csv`.
    #[error(
        "{}: no sections.csv; expert zones need one anatomical label per frame (use uniform zones, or add sections.csv with header `frame,section`)",
        dir.display()
    )]
    MissingSections {
        /// The sequence folder.
        dir: PathBuf,
    },
    /// The model does not fit the data (image size, camera, descriptor size).
    #[error("model {} does not fit the data: {message}", model.display())]
    Incompatible {
        /// The model folder.
        model: PathBuf,
        /// What differs, with both values.
        message: String,
    },
    /// The output exists and overwriting was not asked for.
    #[error("{}: already exists (`force` replaces it, or choose another path)", path.display())]
    AlreadyExists {
        /// The existing path.
        path: PathBuf,
    },
    /// An image could not be decoded or has an unusable size.
    #[error("{}: {message}", path.display())]
    Image {
        /// The image file (or a description of the in-memory image).
        path: PathBuf,
        /// What went wrong and what was expected.
        message: String,
    },
    /// Saving or loading network weights failed (burn / burn-store).
    #[error("{}: weights: {message}", path.display())]
    Weights {
        /// The weights file.
        path: PathBuf,
        /// The underlying error.
        message: String,
    },
    /// The compute device named cannot be used in this build.
    #[error("device: {0}")]
    Device(String),
    /// Training diverged (a non-finite loss).
    #[error("training diverged at epoch {epoch}: loss is {loss} (try a lower learning rate)")]
    Diverged {
        /// 1-based epoch.
        epoch: usize,
        /// The loss value.
        loss: f32,
    },
}

impl NetError {
    /// A [`NetError::Io`] for `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        NetError::Io {
            path: path.into(),
            source,
        }
    }

    /// A [`NetError::Parse`] for `path` at 1-based `line` (0: not line-based).
    pub fn parse(path: impl Into<PathBuf>, line: usize, message: impl Into<String>) -> Self {
        NetError::Parse {
            path: path.into(),
            line,
            message: message.into(),
        }
    }

    /// A [`NetError::Weights`] for `path`.
    pub fn weights(path: impl Into<PathBuf>, message: impl std::fmt::Display) -> Self {
        NetError::Weights {
            path: path.into(),
            message: message.to_string(),
        }
    }
}
