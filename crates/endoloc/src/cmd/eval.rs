//! `endoloc eval`: errors, plots and a report for an estimated trajectory.

use anyhow::Result;
use endoloc_jobs::{EvalJob, Progress};

/// Evaluate an estimated trajectory against the ground truth: position / orientation errors
/// (evo-compatible APE, optional Umeyama alignment), relative pose error, localized fraction,
/// zone accuracy, per-zone and per-status tables, plots and a markdown report.
///
/// Trajectories are TUM files (timestamp tx ty tz qx qy qz qw; T_wc, mm) associated by
/// timestamp as evo does; a ground-truth pose's frame index is its line order. The numbers
/// equal `evo_ape tum GT EST` (-r trans_part / angle_deg) and `evo_rpe` to 1e-6.
///
/// Writes into --out: metrics.json, errors.csv (one row per test frame), report.md and
/// trajectory_xy.png, errors_along.png, error_cdf.png. Existing files are kept unless --force.
///
/// Examples:
///
///   endoloc eval --gt data/small/test/poses.txt --est runs/a/trajectory.txt
///
///   endoloc eval --gt poses.txt --est runs/a/trajectory.txt --frames runs/a/frames.csv \
///       --gt-zones runs/a/test_zones.csv --out runs/a/eval --force
///
///   endoloc eval --gt poses.txt --est slam.txt --align se3 --no-plots
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: EvalJob,
}

/// Runs `endoloc eval`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
