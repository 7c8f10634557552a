//! `endoloc dataset`: inspect datasets in endoloc's format v1 (`check`, `info`) and find their
//! image mask (`mask`).

use std::path::PathBuf;

use anyhow::{Result, bail};
use endoloc_jobs::{DatasetAction, DatasetJob, Progress};

/// Inspect a dataset: check it for problems, or summarize it.
///
/// Examples:
///
///   endoloc dataset check data/small
///
///   endoloc dataset info data/small
///
///   endoloc dataset mask data/c3vd-like
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, clap::Subcommand)]
enum Command {
    /// Find every problem in a dataset: counts (images, poses, sections, depth), poses
    /// (finite, unit quaternions, increasing timestamps), images (decodable, camera size),
    /// labels, camera, format version and units. Exits non-zero when any is found.
    Check {
        /// Dataset folder (the one holding dataset.toml).
        dir: PathBuf,
    },
    /// Summarize a dataset: source, camera, and per sequence frames, duration, path length,
    /// speed, anatomical sections and depth.
    Info {
        /// Dataset folder (the one holding dataset.toml).
        dir: PathBuf,
    },
    /// Find the image mask — black border, circular field stop — from frames sampled over
    /// every sequence (lit in some frame = valid; holes filled; a circle or rectangle fitted
    /// when one fits), write it as mask.png and name it in dataset.toml ([camera] mask).
    /// SURF, maps, localization and the VO baseline then keep inside it.
    Mask {
        /// Dataset folder (the one holding dataset.toml).
        dir: PathBuf,
        /// Frames sampled evenly over every sequence.
        #[arg(long, default_value_t = DatasetJob::default().frames)]
        frames: usize,
        /// A pixel whose smoothed maximum over the frames is at or below this (0–255) is
        /// black.
        #[arg(long, default_value_t = DatasetJob::default().detect.threshold)]
        threshold: u8,
        /// Shrink the valid area by this many pixels (the dim ring at a field stop's edge).
        #[arg(long, default_value_t = DatasetJob::default().detect.margin_px)]
        margin_px: f32,
        /// Replace an existing mask.
        #[arg(long)]
        force: bool,
    },
}

impl From<Args> for DatasetJob {
    fn from(a: Args) -> Self {
        let base = DatasetJob::default();
        match a.command {
            Command::Check { dir } => DatasetJob {
                action: DatasetAction::Check,
                dir,
                ..base
            },
            Command::Info { dir } => DatasetJob {
                action: DatasetAction::Info,
                dir,
                ..base
            },
            Command::Mask {
                dir,
                frames,
                threshold,
                margin_px,
                force,
            } => DatasetJob {
                action: DatasetAction::Mask,
                dir,
                frames,
                detect: endoloc_jobs::MaskDetectConfig {
                    threshold,
                    margin_px,
                    ..base.detect
                },
                force,
            },
        }
    }
}

/// Runs `endoloc dataset …`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    let job = DatasetJob::from(args);
    let report = job.run(ui)?;
    crate::ui::print(&report)?;
    if report.problems() > 0 {
        bail!("{} problem(s) in {}", report.problems(), job.dir.display());
    }
    Ok(())
}
