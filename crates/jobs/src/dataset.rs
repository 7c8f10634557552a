//! `DatasetJob`: check a dataset in endoloc's format v1 for problems, or summarize it.

use std::fmt;
use std::path::PathBuf;

use endoloc_data::{CheckReport, DatasetInfo, check_dataset, dataset_info};
use serde::{Deserialize, Serialize};

use crate::error::{Context, Result};
use crate::progress::Progress;

/// What a `DatasetJob` does with the dataset.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DatasetAction {
    /// Find every problem: counts, poses, images, labels, camera, format version, units.
    #[default]
    Check,
    /// Summarize: source, camera, and per sequence frames, duration, path length, speed,
    /// sections and depth.
    Info,
}

/// Checks or summarizes the dataset folder `dir` (the one holding `dataset.toml`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DatasetJob {
    /// What to do.
    pub action: DatasetAction,
    /// Dataset folder.
    pub dir: PathBuf,
}

/// What a `DatasetJob` found. A check that found problems is still a report; see
/// [`DatasetReport::problems`].
#[derive(Debug, Clone)]
pub enum DatasetReport {
    /// Every problem found.
    Check(CheckReport),
    /// The summary.
    Info(DatasetInfo),
}

impl DatasetReport {
    /// Problems found by a check (0 for a summary).
    pub fn problems(&self) -> usize {
        match self {
            DatasetReport::Check(r) => r.problems.len(),
            DatasetReport::Info(_) => 0,
        }
    }
}

impl DatasetJob {
    /// Checks or summarizes the dataset.
    ///
    /// # Errors
    /// A dataset that cannot be read at all (for `Info`, also one with inconsistent counts).
    pub fn run(&self, _progress: &dyn Progress) -> Result<DatasetReport> {
        let dir = &self.dir;
        Ok(match self.action {
            DatasetAction::Check => DatasetReport::Check(
                check_dataset(dir).with_context(|| format!("cannot check {}", dir.display()))?,
            ),
            DatasetAction::Info => DatasetReport::Info(
                dataset_info(dir).with_context(|| format!("cannot summarize {}", dir.display()))?,
            ),
        })
    }
}

impl fmt::Display for DatasetReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DatasetReport::Check(r) => write!(f, "{r}"),
            DatasetReport::Info(i) => {
                let text = i.to_string();
                write!(f, "{}", text.strip_suffix('\n').unwrap_or(&text))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_from_an_empty_file() {
        let from_toml: DatasetJob = toml::from_str("").unwrap();
        assert_eq!(from_toml, DatasetJob::default());
        let info: DatasetJob = toml::from_str("action = \"info\"\ndir = \"data/small\"").unwrap();
        assert_eq!(info.action, DatasetAction::Info);
    }
}
