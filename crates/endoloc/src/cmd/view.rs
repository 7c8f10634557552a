//! `endoloc view`: one self-contained HTML page to explore a localization run.

use std::path::PathBuf;

use anyhow::Result;
use endoloc_jobs::{Progress, ViewJob};

/// Write one self-contained HTML page that shows a localization run: a 3-D view (drag to
/// orbit, wheel to zoom) of the training pass, the per-zone map points, the true and the
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
    /// Run folder written by `endoloc localize --out`.
    #[arg(value_name = "RUN_DIR")]
    run: PathBuf,
    /// Output page. Default: RUN_DIR/view.html.
    #[arg(long, value_name = "FILE.html")]
    out: Option<PathBuf>,
    /// Replace an existing page.
    #[arg(long)]
    force: bool,
    /// Width of the frame thumbnails embedded in the page, pixels.
    #[arg(long, default_value_t = ViewJob::default().thumb_width)]
    thumb_width: u32,
    /// JPEG quality of the thumbnails (1–100).
    #[arg(long, default_value_t = ViewJob::default().jpeg_quality)]
    jpeg_quality: u8,
    /// At most this many map points in the page, all zones together (subsampled evenly).
    #[arg(long, default_value_t = ViewJob::default().max_points)]
    max_points: usize,
    /// Show no errors even when the sequence has poses.txt.
    #[arg(long)]
    no_gt: bool,
    /// Test sequence folder. Default: the one in RUN_DIR/localize.toml.
    #[arg(long, value_name = "DIR")]
    seq: Option<PathBuf>,
    /// Model folder (training pass, zones, map). Default: the one in RUN_DIR/localize.toml.
    #[arg(long, value_name = "DIR")]
    model: Option<PathBuf>,
}

impl From<Args> for ViewJob {
    fn from(a: Args) -> Self {
        ViewJob {
            run: a.run,
            out: a.out,
            force: a.force,
            thumb_width: a.thumb_width,
            max_points: a.max_points,
            no_gt: a.no_gt,
            seq: a.seq,
            model: a.model,
            jpeg_quality: a.jpeg_quality,
        }
    }
}

/// Runs `endoloc view`.
pub fn run(args: Args, ui: &dyn Progress) -> Result<()> {
    crate::ui::print(&ViewJob::from(args).run(ui)?)?;
    Ok(())
}
