//! `endoloc dataset`: inspect datasets in endoloc's format v1 (`check`, `info`).

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use endoloc_data::{check_dataset, dataset_info};

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

/// Runs `endoloc dataset …`.
pub fn run(args: Args) -> Result<()> {
    match args.command {
        Command::Check { dir } => {
            let report =
                check_dataset(&dir).with_context(|| format!("cannot check {}", dir.display()))?;
            println!("{report}");
            if !report.is_ok() {
                bail!("{} problem(s) in {}", report.problems.len(), dir.display());
            }
            Ok(())
        }
        Command::Info { dir } => {
            let info = dataset_info(&dir)
                .with_context(|| format!("cannot summarize {}", dir.display()))?;
            print!("{info}");
            Ok(())
        }
    }
}
