//! `endoloc eval`: errors, plots and a report for an estimated trajectory.

use std::path::PathBuf;

use anyhow::Result;
use clap::ValueEnum;
use endoloc_eval::align::AlignmentKind;
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
    /// Ground-truth trajectory of the test sequence (TUM; e.g. the dataset's test/poses.txt).
    #[arg(long)]
    gt: PathBuf,

    /// Estimated trajectory (TUM; a localization run's trajectory.txt).
    #[arg(long)]
    est: PathBuf,

    /// The run's frames.csv (status, zone, ... per frame). Default: frames.csv next to --est,
    /// when it exists.
    #[arg(long)]
    frames: Option<PathBuf>,

    /// True zone of each test frame: CSV with header `frame,zone` (0-based frame and zone
    /// indices). Enables zone_accuracy.
    #[arg(long, value_name = "CSV")]
    gt_zones: Option<PathBuf>,

    /// Output folder. Default: `eval/` next to --est.
    #[arg(short, long)]
    out: Option<PathBuf>,

    /// Replace existing output files.
    #[arg(long)]
    force: bool,

    /// Align the estimate onto the ground truth before computing errors: `none`, `se3`
    /// (rigid Umeyama, evo -a) or `sim3` (with scale, evo -a -s).
    #[arg(long, value_enum, default_value = "none")]
    align: AlignArg,

    /// Largest timestamp difference for associating poses, seconds (evo --t_max_diff).
    #[arg(long, default_value_t = EvalJob::default().t_max_diff)]
    t_max_diff: f64,

    /// Offset added to the estimate's timestamps before associating, seconds (evo --t_offset).
    #[arg(long, default_value_t = EvalJob::default().t_offset, allow_hyphen_values = true)]
    t_offset: f64,

    /// RPE pair distance, in associated poses (evo_rpe --delta N --delta_unit f).
    #[arg(long, default_value_t = EvalJob::default().rpe_delta)]
    rpe_delta: usize,

    /// RPE over every pair (i, i+delta) instead of consecutive pairs (evo_rpe --all_pairs).
    #[arg(long)]
    rpe_all_pairs: bool,

    /// Do not draw the PNG plots.
    #[arg(long)]
    no_plots: bool,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum AlignArg {
    None,
    Se3,
    Sim3,
}

impl From<Args> for EvalJob {
    fn from(a: Args) -> Self {
        EvalJob {
            gt: a.gt,
            est: a.est,
            frames: a.frames,
            gt_zones: a.gt_zones,
            out: a.out.unwrap_or_default(),
            force: a.force,
            align: match a.align {
                AlignArg::None => AlignmentKind::None,
                AlignArg::Se3 => AlignmentKind::Se3,
                AlignArg::Sim3 => AlignmentKind::Sim3,
            },
            t_max_diff: a.t_max_diff,
            t_offset: a.t_offset,
            rpe_delta: a.rpe_delta,
            rpe_all_pairs: a.rpe_all_pairs,
            no_plots: a.no_plots,
        }
    }
}

/// Runs `endoloc eval`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&EvalJob::from(args).run(ui)?)?;
    Ok(())
}
