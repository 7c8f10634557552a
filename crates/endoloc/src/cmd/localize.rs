//! `endoloc map` and `endoloc localize`: the geometric half of the method.

use anyhow::Result;
use endoloc_jobs::{LocalizeJob, MapJob, Progress};

/// Build the per-zone 3-D maps of a trained model: SURF tracks over `m` images of each zone,
/// triangulated with the known training poses; points reprojecting farther than δr are
/// dropped. Writes map.toml and map.bin into the model folder, one PLY per zone
/// (map_ply/zone_NNN.ply) and a COLMAP text model (map_colmap/).
///
/// Example:
///
///   endoloc map --model models/small --data data/small
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct MapArgs {
    #[command(flatten)]
    job: MapJob,
}

/// Runs `endoloc map`.
pub fn run_map(args: MapArgs, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}

/// Localize every frame of a sequence: zone (Siamese classifier) → initial pose = zone median
/// → SURF matched to the zone's map points → Gauss-Newton on SE(3) → validity check.
/// Writes trajectory.txt (TUM, T_wc, mm; one line per frame that has a pose) and frames.csv
/// (frame, zone, zone score, status refined|init_only|rejected, reason, inliers,
/// reprojection RMS, time) into --out. Then `endoloc eval --gt SEQ/poses.txt --est
/// OUT/trajectory.txt` gives the errors.
///
/// Examples:
///
///   endoloc localize --model models/small --seq data/small/test --out runs/small
///
///   endoloc localize --model models/small --seq data/small/test --out runs/live --live
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct LocalizeArgs {
    #[command(flatten)]
    job: LocalizeJob,
    #[command(flatten)]
    confirm: ConfirmArgs,
}

/// Runs `endoloc localize`.
pub fn run_localize(args: LocalizeArgs, ui: &dyn Progress) -> Result<()> {
    let mut job = args.job;
    args.confirm.apply(&mut job.confirm);
    crate::ui::print(&job.run(ui)?)?;
    Ok(())
}

/// `--confirm`, the explicit pair of the jobs' `--no-confirm` (shared by `localize` and
/// `bench live`): the last of the two on the command line wins.
#[derive(Debug, clap::Args)]
pub struct ConfirmArgs {
    /// Confirm registrations against the map (the default; see --no-confirm).
    #[arg(long = "confirm", overrides_with = "confirm")]
    confirm_on: bool,
}

impl ConfirmArgs {
    /// Turns `confirm` on when `--confirm` came after any `--no-confirm`.
    pub fn apply(&self, confirm: &mut bool) {
        if self.confirm_on {
            *confirm = true;
        }
    }
}
