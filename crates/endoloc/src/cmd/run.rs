//! `endoloc run --config experiment.toml`: the whole chain from one config file.

use std::path::PathBuf;

use anyhow::{Context, Result};
use endoloc_jobs::{Progress, RunJob};

/// Run simulate (or use an existing dataset), train, map, localize and eval from one TOML file.
/// Each table holds the options of its command (`endoloc train --help` for [train], and so
/// on, with `-` written `_`); paths between the stages are filled in. The file is copied to
/// OUT/experiment.toml so the run can be repeated from its own outputs; the wall time of every
/// stage is printed at the end and written to OUT/timings.csv.
///
/// Example experiment.toml (every table but `out` is optional):
///
///   out = "experiments/paper50"        # required
///   data = "data/paper"                # an existing dataset; or a [simulate] table:
///   [simulate]
///   preset = "paper"                   # small | paper
///   seed = 0
///   [train]
///   zones = "50"                       # a number, or "expert" / "expert:N"
///   schedule = "fast"                  # fast | paper
///   # epochs = 150                     # default: the schedule's; 0 with pretrained: index only
///   pretrained = "builtin-joint"       # optional start weights: a file, builtin, builtin-track, builtin-joint, builtin-changes
///   pairs = "zone"                     # zone (the paper's) | track
///   [map]
///   images_per_zone = 8
///   threshold = 25.0                   # map; test frames keep a budget above 0.4 × it
///   [localize]
///   live = false
///   candidate_zones = 3
///   neighbours = 1
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Experiment file (TOML).
    #[arg(long, value_name = "TOML")]
    config: PathBuf,
    /// Replace an existing output folder.
    #[arg(long)]
    force: bool,
}

/// Runs `endoloc run`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    let text = std::fs::read_to_string(&args.config)
        .with_context(|| format!("reading {}", args.config.display()))?;
    let job = RunJob::from_toml(&text).with_context(|| args.config.display().to_string())?;
    let timings = job.run(&text, args.force, ui)?;
    eprintln!("\n{timings}");
    eprintln!("wrote {}", job.out.join("timings.csv").display());
    Ok(())
}
