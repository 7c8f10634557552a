//! `DatasetJob`: check a dataset in endoloc's format v1 for problems, summarize it, or find
//! its image mask.

use std::fmt;
use std::path::PathBuf;

use endoloc_data::{
    CheckReport, Dataset, DatasetInfo, check_dataset, dataset_info, write_dataset_mask,
};
use endoloc_features::{DetectedMask, MaskDetectConfig, MaskShape, detect_mask};
use serde::{Deserialize, Serialize};

use crate::error::{Context, Result};
use crate::progress::Progress;

/// What a `DatasetJob` does with the dataset.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum DatasetAction {
    /// Find every problem in a dataset: counts (images, poses, sections, depth), poses
    /// (finite, unit quaternions, increasing timestamps), images (decodable, camera size),
    /// labels, camera, format version and units.
    #[default]
    Check,
    /// Summarize a dataset: source, camera, and per sequence frames, duration, path length,
    /// speed, anatomical sections and depth.
    Info,
    /// Find the image mask (black border, circular field stop) from frames sampled over
    /// every sequence (lit in some frame = valid; holes filled; a circle or rectangle fitted
    /// when one fits), write it as mask.png and name it in dataset.toml (`[camera] mask`).
    /// SURF, maps, localization and the VO baseline then keep inside it.
    Mask,
}

/// Checks or summarizes the dataset folder `dir` (the one holding `dataset.toml`), or finds
/// its image mask.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[serde(default, deny_unknown_fields)]
pub struct DatasetJob {
    /// What to do: check, info or mask.
    #[cfg_attr(feature = "cli", arg(value_enum, value_name = "ACTION"))]
    pub action: DatasetAction,
    /// Dataset folder (the one holding dataset.toml).
    #[cfg_attr(feature = "cli", arg(value_name = "DIR"))]
    pub dir: PathBuf,
    /// Mask: frames sampled evenly over every sequence.
    #[cfg_attr(feature = "cli", arg(long, default_value_t = DatasetJob::default().frames))]
    pub frames: usize,
    /// Mask: detection settings.
    #[cfg_attr(feature = "cli", command(flatten))]
    pub detect: MaskDetectConfig,
    /// Mask: replace an existing mask.
    #[cfg_attr(feature = "cli", arg(long))]
    pub force: bool,
}

impl Default for DatasetJob {
    fn default() -> Self {
        DatasetJob {
            action: DatasetAction::default(),
            dir: PathBuf::new(),
            frames: 64,
            detect: MaskDetectConfig::default(),
            force: false,
        }
    }
}

/// What a `DatasetJob` found. A check that found problems is still a report; see
/// [`DatasetReport::problems`].
#[derive(Debug, Clone)]
pub enum DatasetReport {
    /// Every problem found.
    Check(CheckReport),
    /// The summary.
    Info(DatasetInfo),
    /// The mask found, from how many frames, and where it was written.
    Mask {
        /// The mask and its shape.
        found: DetectedMask,
        /// Frames it was found from.
        frames: usize,
        /// The file written.
        path: PathBuf,
    },
}

impl DatasetReport {
    /// Problems found by a check (0 for a summary).
    pub fn problems(&self) -> usize {
        match self {
            DatasetReport::Check(r) => r.problems.len(),
            DatasetReport::Info(_) | DatasetReport::Mask { .. } => 0,
        }
    }
}

impl DatasetJob {
    /// Checks or summarizes the dataset.
    ///
    /// # Errors
    /// A dataset that cannot be read at all (for `Info`, also one with inconsistent counts);
    /// for `Mask`, an existing mask without `force`, or frames that are all black.
    pub fn run(&self, progress: &dyn Progress) -> Result<DatasetReport> {
        let dir = &self.dir;
        Ok(match self.action {
            DatasetAction::Check => DatasetReport::Check(
                check_dataset(dir).with_context(|| format!("cannot check {}", dir.display()))?,
            ),
            DatasetAction::Info => DatasetReport::Info(
                dataset_info(dir).with_context(|| format!("cannot summarize {}", dir.display()))?,
            ),
            DatasetAction::Mask => self.mask(progress)?,
        })
    }

    /// Samples frames evenly over every sequence, detects the mask and writes it.
    fn mask(&self, progress: &dyn Progress) -> Result<DatasetReport> {
        let ds = Dataset::open(&self.dir)?;
        if ds.meta.mask.is_some() && !self.force {
            return Err(crate::JobError::Exists {
                path: ds.mask_path().unwrap_or_default(),
                hint: " (replaces the mask)".into(),
            });
        }
        let mut frames = Vec::new();
        let seqs: Vec<_> = ds
            .sequences
            .iter()
            // The frames as recorded: the mask in place would hide what is found again.
            .map(|name| ds.sequence(name).map(endoloc_data::Sequence::unmasked))
            .collect::<std::result::Result<_, _>>()?;
        let total: usize = seqs.iter().map(|s| s.len()).sum();
        if total == 0 {
            crate::bail!("{}: no frames to find a mask from", self.dir.display());
        }
        let want = self.frames.clamp(1, total);
        let bar = crate::progress::bar(progress, want as u64, "frames");
        for k in 0..want {
            // The k-th of `want` evenly spaced frames over all sequences in order.
            let mut i = k * total / want;
            let seq = seqs
                .iter()
                .find(|s| {
                    if i < s.len() {
                        true
                    } else {
                        i -= s.len();
                        false
                    }
                })
                .expect("i < total");
            frames.push(seq.load_gray(i)?);
            bar.inc(1);
        }
        let found = detect_mask(&frames, &self.detect)
            .with_context(|| format!("finding the mask of {}", self.dir.display()))?;
        let path = write_dataset_mask(&self.dir, &found.mask.to_gray(), self.force)?;
        Ok(DatasetReport::Mask {
            found,
            frames: want,
            path,
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
            DatasetReport::Mask {
                found,
                frames,
                path,
            } => {
                let shape = match found.shape {
                    MaskShape::Circle { cx, cy, radius } => format!(
                        "circular field stop, centre ({cx:.1}, {cy:.1}) px, radius {radius:.1} px"
                    ),
                    MaskShape::Rectangle { x0, y0, x1, y1 } => {
                        format!("black border, valid columns {x0}..={x1}, rows {y0}..={y1}")
                    }
                    MaskShape::Region => {
                        "irregular valid region (no circle or rectangle fits)".into()
                    }
                };
                writeln!(
                    f,
                    "mask      {shape} (IoU {:.3} with the lit region)",
                    found.shape_iou
                )?;
                writeln!(
                    f,
                    "valid     {:.1} % of the image, from {frames} frames",
                    100.0 * found.mask.valid_fraction()
                )?;
                write!(f, "wrote     {} (named in dataset.toml)", path.display())
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
