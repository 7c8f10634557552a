//! The one error type of every job, with the context a user needs (which file, which stage).

use std::path::PathBuf;

/// What went wrong in a job. Each variant prints its own cause once; [`JobError::Context`]
/// adds what the job was doing and keeps the cause as its [`std::error::Error::source`], so a
/// caller that walks the chain (e.g. `anyhow`'s `{:#}`) prints each cause exactly once.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// A dataset, trajectory, image or mesh could not be read or written.
    #[error(transparent)]
    Data(#[from] endoloc_data::DataError),
    /// Feature extraction failed.
    #[error(transparent)]
    Features(#[from] endoloc_features::FeatureError),
    /// The simulator refused its input.
    #[error(transparent)]
    Sim(#[from] endoloc_sim::SimError),
    /// Zoning, the Siamese network, its training or its database failed.
    #[error(transparent)]
    Net(#[from] endoloc_net::NetError),
    /// Map building or localization failed.
    #[error(transparent)]
    Localize(#[from] endoloc_localize::LocalizeError),
    /// Evaluation or report writing failed.
    #[error(transparent)]
    Eval(#[from] endoloc_eval::EvalError),
    /// The visual-odometry baseline failed.
    #[error(transparent)]
    Vo(#[from] endoloc_vo::VoError),
    /// A file-system operation failed on `path`.
    #[error("{}", io_message(path, source))]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// An output exists and `force` was not given; nothing was written.
    #[error("{path} exists; `force` replaces it{hint}")]
    Exists {
        /// The existing output.
        path: PathBuf,
        /// More advice, starting with its own separator (may be empty).
        hint: String,
    },
    /// A job's settings or inputs are not usable; the message says what is expected.
    #[error("{0}")]
    Invalid(String),
    /// What the job was doing when `source` happened.
    #[error("{context}")]
    Context {
        /// What was being done, e.g. `loading model models/paper50`.
        context: String,
        /// The cause.
        #[source]
        source: Box<JobError>,
    },
}

impl JobError {
    /// The message with every cause after it, `context: cause: …` (each cause once).
    pub fn full_message(&self) -> String {
        let mut text = self.to_string();
        let mut next = std::error::Error::source(self);
        while let Some(cause) = next {
            let line = cause.to_string();
            if !text.ends_with(&line) {
                text.push_str(": ");
                text.push_str(&line);
            }
            next = cause.source();
        }
        text
    }

    /// An [`JobError::Io`] on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        JobError::Io {
            path: path.into(),
            source,
        }
    }
}

fn io_message(path: &std::path::Path, source: &std::io::Error) -> String {
    if path.as_os_str().is_empty() {
        source.to_string()
    } else {
        format!("{}: {source}", path.display())
    }
}

impl From<std::io::Error> for JobError {
    fn from(source: std::io::Error) -> Self {
        JobError::Io {
            path: PathBuf::new(),
            source,
        }
    }
}

impl From<endoloc_geometry::RegistrationError> for JobError {
    fn from(e: endoloc_geometry::RegistrationError) -> Self {
        JobError::Invalid(e.to_string())
    }
}

macro_rules! invalid_from {
    ($($t:ty),*) => {
        $(impl From<$t> for JobError {
            fn from(e: $t) -> Self {
                JobError::Invalid(e.to_string())
            }
        })*
    };
}

invalid_from!(
    std::num::ParseIntError,
    std::num::ParseFloatError,
    toml::de::Error,
    toml::ser::Error,
    serde_json::Error
);

/// The result of a job.
pub type Result<T, E = JobError> = std::result::Result<T, E>;

/// Adds what a job was doing to an error (the library's counterpart of `anyhow::Context`).
pub trait Context<T> {
    /// Wraps the error with a fixed context.
    fn context(self, context: impl Into<String>) -> Result<T>;
    /// Wraps the error with a context built only on failure.
    fn with_context<S: Into<String>>(self, f: impl FnOnce() -> S) -> Result<T>;
}

impl<T, E: Into<JobError>> Context<T> for std::result::Result<T, E> {
    fn context(self, context: impl Into<String>) -> Result<T> {
        self.map_err(|e| JobError::Context {
            context: context.into(),
            source: Box::new(e.into()),
        })
    }
    fn with_context<S: Into<String>>(self, f: impl FnOnce() -> S) -> Result<T> {
        self.map_err(|e| JobError::Context {
            context: f().into(),
            source: Box::new(e.into()),
        })
    }
}

impl<T> Context<T> for Option<T> {
    fn context(self, context: impl Into<String>) -> Result<T> {
        self.ok_or_else(|| JobError::Invalid(context.into()))
    }
    fn with_context<S: Into<String>>(self, f: impl FnOnce() -> S) -> Result<T> {
        self.ok_or_else(|| JobError::Invalid(f().into()))
    }
}

/// Returns early with a [`JobError::Invalid`] built like `format!`.
#[macro_export]
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::JobError::Invalid(format!($($arg)*)))
    };
}

/// Sends a `format!` line to a [`crate::Progress`] sink's `note`.
#[macro_export]
macro_rules! note {
    ($progress:expr, $($arg:tt)*) => {
        $progress.note(&format!($($arg)*))
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn context_keeps_the_cause_once() {
        let err: Result<()> = Err(std::io::Error::other("disk full")).context("writing x.txt");
        let err = err.unwrap_err();
        assert_eq!(err.to_string(), "writing x.txt");
        let cause = std::error::Error::source(&err).map(|s| s.to_string());
        assert_eq!(cause.as_deref(), Some("disk full"));
    }
}
