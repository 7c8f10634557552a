//! `endoloc view`: one self-contained HTML page to explore a localization run.

use anyhow::Result;
use endoloc_jobs::{Progress, ViewJob};

/// Write one self-contained HTML page that shows a localization run: a 3-D view (drag to
/// orbit, wheel to zoom) of the colon's wall (when the dataset was simulated), the training
/// pass, the per-zone map points, the true and the
/// estimated trajectories (dots by status: refined green, init_only orange, rejected red, or
/// by position error) and the scope at the current frame; a frame scrubber and play button
/// with the frame's thumbnail, its zone's map points reprojected with the estimated pose, its
/// status, reason, inliers, RMS and time, and its errors; the position error along the pass
/// (click to jump to a frame).
///
/// RUN is a folder written by `endoloc localize` (trajectory.txt, frames.csv, localize.toml);
/// the sequence and model named in localize.toml give the images, the ground truth
/// (SEQ/poses.txt; without it only poses and status are shown), the camera, the training pass
/// and the map. The page needs no network and no other file; opens from disk in any browser.
///
/// Examples:
///
///   endoloc view runs/small
///
///   endoloc view runs/live --out live.html --thumb-width 120 --force
#[derive(Debug, clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    job: ViewJob,
}

/// Runs `endoloc view`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&args.job.run(ui)?)?;
    Ok(())
}
