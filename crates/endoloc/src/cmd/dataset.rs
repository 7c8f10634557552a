//! `endoloc dataset`: inspect datasets in endoloc's format v1 (`check`, `info`).

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
}

impl From<Args> for DatasetJob {
    fn from(a: Args) -> Self {
        let (action, dir) = match a.command {
            Command::Check { dir } => (DatasetAction::Check, dir),
            Command::Info { dir } => (DatasetAction::Info, dir),
        };
        DatasetJob { action, dir }
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
